"""Model files in a form a layer above :mod:`switching` writes and reads.

A model file (:mod:`switching.files.modelfile`) holds a model as its bond graph.  A layer that
builds models from something else — :mod:`models` builds them from the netlists of
:class:`~models.circuits.Circuit` and :class:`~models.mechanics.Mechanism` — registers a
:class:`FileForm`: the top-level tables that mark a file of that form, a writer for the models it
built and a reader for its files.  Then

* :func:`~switching.files.modelfile.save_model` (``model.save``) writes a model in the first
  registered form whose writer takes it, else as its bond graph;
* :class:`~switching.files.modelfile.ModelFile`, :func:`~switching.files.modelfile.load_model` and
  :func:`~switching.files.modelfile.loads_model` read a file that holds one of a form's tables with
  that form's reader (the file's size, encoding, TOML and ``hbg_model_format`` are checked first, as
  for every model file).

:mod:`switching` imports nothing of the layer (DESIGN §2: the dependencies run one way): the layer
registers its form when it is imported (``import models`` registers the netlist form), as the wings
of :mod:`switching` register the model's services (:mod:`switching.model.services`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

__all__ = ["FileForm", "register_form", "form_of", "dumps_in_form", "UNREGISTERED"]

#: the tables of the forms the toolkit's own layers register → what to do when a file holds one and no
#: form is registered for it (the layer was not imported)
UNREGISTERED = {
    "circuit": "a Circuit's netlist, which the models package reads: load it with models.load(path) (or "
               "switching.load_model(path) once models is imported)",
    "mechanism": "a Mechanism's netlist, which the models package reads: load it with models.load(path) (or "
                 "switching.load_model(path) once models is imported)",
}


@dataclass(frozen=True)
class FileForm:
    """One form of model file.

    ``name`` names it (``"netlist"``; registering a form of a registered name replaces it);
    ``tables``: the top-level tables that mark a file of this form (``("circuit", "mechanism")``);
    ``dumps(model, *, run, description, display) -> str | None``: the text of ``model`` in this
    form, ``None`` when the model is not one this form holds (raising
    :class:`~switching.files.errors.ModelFileError` when it is, but cannot be written);
    ``load(source) -> loaded``: a file of this form (a :class:`~switching.files.source.Source`, its
    TOML read) as an object with what :class:`~switching.files.build.LoadedModel` gives a
    :class:`~switching.files.modelfile.ModelFile`: ``settings`` (``name``, ``description``, ``run``),
    ``defaults`` (parameter → value), ``signal_names`` and ``build(**parameters)``.  ``module``: the
    module whose import registers the form, imported by a process that unpickles a
    :class:`~switching.files.modelfile.ModelFile` of this form before it reads the file again (a sweep's
    worker)."""

    name: str
    tables: tuple
    dumps: Callable
    load: Callable
    module: str = ""


_FORMS: dict[str, FileForm] = {}


def register_form(form: FileForm) -> None:
    """Register ``form`` (replacing a form of the same name)."""
    _FORMS[form.name] = form


def form_of(data: Mapping) -> FileForm | None:
    """The registered form whose table the file's top-level ``data`` holds (None: a bond graph's file)."""
    for form in _FORMS.values():
        if any(table in data for table in form.tables):
            return form
    return None


def dumps_in_form(model, **options) -> str | None:
    """The text of ``model`` in the first registered form that holds it (``options``: ``run``,
    ``description``, ``display``), or ``None`` when none does."""
    for form in _FORMS.values():
        text = form.dumps(model, **options)
        if text is not None:
            return text
    return None
