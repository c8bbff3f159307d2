"""The library of ready models and reusable sub-models.

Every model is a module ``models.<name>`` with

* a module docstring: the bond graph drawn in text, the automata and their
  guards (a priori / a posteriori, and why), the sign conventions, the
  signals it exposes;
* ``DEFAULTS`` — parameter name → default value (a meaningful run);
* ``build(**parameters) -> switching.HybridModel`` — unknown names are an error;
* ``RUN`` — the default run: ``t_end`` and the step options (and a ``method`` where the model needs one: ``hbg run`` takes ``auto`` otherwise);
* ``SIGNALS`` — the named signals worth plotting;
* ``UNITS`` — the unit of each parameter, state and signal (plots label their
  axes with them, model files keep them).

A shipped model writes its initial state with parameters (``theta0``,
``m*v0``), so ``hbg save`` keeps them: ``--set theta0=…`` moves a saved
model's start as it moves the shipped one's.

Also: :mod:`models.circuits` (electrical netlists: ``Circuit`` builds the hybrid
model of components between named nodes), :mod:`models.mechanics` (1-D machines,
translational and rotational: ``Mechanism`` does the same with masses, springs,
gears, motors, clutches, stops and backlash), :mod:`models.components` (sub-models with ports), :mod:`models.graphs`
(plain bond graphs), :mod:`models.cli` (the ``hbg`` command), ``models/examples``
(model files written by hand; see :mod:`switching.files.modelfile` for the format).

A model file is loaded with :func:`load` (``models.load("relay.toml")``), its
sub-model instances may place the components of :mod:`models.components` by
name (``component = "msd_cell"``).  A model built by ``Circuit`` or ``Mechanism`` saves
as its netlist (one line a component: :mod:`models.netlist_files`), a form
``import models`` registers with :mod:`switching.files.forms`.
"""

from __future__ import annotations

import importlib
import os
import types
from pathlib import Path

#: name → module of every shipped hybrid model
MODELS = (
    "bouncing_ball",
    "diode_circuit",
    "falling_rod",
    "colliding_balls",
    "ball_chain",
    "parallel_capacitors",
    "boost_converter",
    "two_tanks",
    "vibrating_table",
    "current_mode_converter",
    "rimless_wheel",
)


#: the directory of the model files written by hand (``relay.toml``, …)
EXAMPLES = Path(__file__).resolve().parent / "examples"


def component_library() -> dict:
    """name → function of :mod:`models.components` returning a sub-model bond
    graph: the components a model file places with ``component = "name"``."""
    library = importlib.import_module("models.components")
    return {name: getattr(library, name) for name in library.__all__}


def resolve(reference: str | os.PathLike):
    """What ``hbg`` runs for ``reference``: the module of a shipped model
    (by name), a :class:`switching.files.modelfile.ModelFile` for a path to a
    model file, or a :class:`models.spice.SpiceNetlist` for a SPICE netlist (``.cir``, ``.sp``, …).
    All have ``DEFAULTS``, ``RUN``, ``SIGNALS`` and ``build(**parameters)``."""
    from switching.files.modelfile import ModelFile, is_model_path

    from .spice import SUFFIXES, read

    if str(reference).lower().endswith(SUFFIXES):  # a SPICE netlist: its .tran is the run
        return read(os.fspath(reference))
    if is_model_path(reference):
        return ModelFile(reference, component_library())
    key = str(reference).replace("-", "_")
    if key not in MODELS:
        from bondgraph.errors import UnknownNameError

        raise UnknownNameError(
            f"unknown model {reference!r}; shipped models: {', '.join(MODELS)} (a model file is a path ending "
            "in .toml)", str(reference))
    return importlib.import_module(f"models.{key}")


def _register_netlist_form() -> None:
    """Model files of netlists (``[circuit]``, ``[mechanism]``: :mod:`models.netlist_files`), written by
    ``model.save`` for a model built by ``Circuit`` or ``Mechanism`` and read wherever model files are
    (:mod:`switching.files.forms`); the module is imported when a file of the form is first met."""
    from switching.files.forms import FileForm, register_form

    def dumps(model, **options):
        if getattr(model, "built_from", None) is None:
            return None
        from .netlist_files import dumps_netlist

        return dumps_netlist(model, **options)

    def load(source):
        from .netlist_files import NetlistFile

        return NetlistFile(source)

    register_form(FileForm("netlist", ("circuit", "mechanism"), dumps, load, module=__name__))


_register_netlist_form()


def load(name: str | os.PathLike, **parameters):
    """The module of a shipped model by name (``-`` and ``_`` are
    interchangeable), or — for a path to a model file (``.toml``) or a SPICE netlist (``.cir``, …) — the
    :class:`~switching.model.hybrid_model.HybridModel` it holds, with its parameter values
    overridden by ``parameters``.  A bad file raises
    :class:`switching.files.modelfile.ModelFileError` naming the file, line and culprit."""
    source = resolve(name)
    if not isinstance(source, types.ModuleType):  # a model file
        return source.build(**parameters)
    if parameters:
        raise TypeError(f"parameters are given to a shipped model by models.load({str(name)!r}).build(**parameters)")
    return source
