'''Model files: a whole hybrid bond graph model as safe, shareable TOML text.

A model file holds everything :class:`~switching.model.hybrid_model.HybridModel` needs —
elements with their laws, bonds, controlled junctions, sub-model instances,
automata with their guards, signals, parameters, inputs, the initial state,
tolerances and the jump law — as data.  Reading one executes nothing: every
expression is parsed by the toolkit's own parser (:mod:`switching.language.parsing`)
into sympy, every name is checked, sizes are limited
(:mod:`switching.files.errors`).  ``models.load("relay.toml")`` reads a
file (with the shipped components available), ``model.save("relay.toml")``
writes one, ``hbg run relay.toml`` runs it.

    >>> from switching.files.modelfile import loads_model, dumps_model
    >>> model = loads_model(EXAMPLE)
    >>> model.mode_equations("open").f[model.state("q_C")]
    0
    >>> loads_model(dumps_model(model)).fingerprint == model.fingerprint
    True

Format, version 1
=================

A model file is TOML (https://toml.io).  Keys and tables, in any order:

``hbg_model_format = 1`` (required)
    The format version.  A file of another version is refused with a message.
``name``, ``description``
    The model's name (default: the file name without ``.toml``) and a text.
``jump_law``, ``max_steps_per_instant``
    As :class:`~switching.model.hybrid_model.HybridModel` takes them (``"conservation"``
    or ``"impulse balance"``; default 1000).

``[parameters]``
    ``name = value`` or ``name = { value = 1e-3, unit = "F", description =
    "...", allow_infinite = false }``.  Every name an expression uses that is
    not a state, input, bond variable, mode constant, signal or ``t`` must be
    declared here (a mistyped name is an error, never a new parameter), and
    every declared parameter must be used.  ``allow_infinite = true`` lets the
    value (or a ``--set``) be ``inf``.
``[inputs]``
    ``u = "V0*sin(2*pi*f*t)"``: every input an element uses, as an
    expression of ``t`` and parameters (see
    :class:`~switching.model.expression_input.ExpressionInput`).
``[elements]``
    One entry per element, in the order that fixes the state vector::

        V     = { type = "Se", value = "V0" }           # value: number or expression
        D     = { type = "Sf", value = "I0*sin(w*t)" }
        C1    = { type = "C", capacitance = "C" }        # e = q_C1/C; state q_C1
        k     = { type = "C", effort_law = "k3*q_k**3", state = "q_k" }
        L     = { type = "I", inertance = "L" }          # f = p_L/L;  state p_L
        m     = { type = "I", flow_law = "p_m/m" }
        R1    = { type = "R", resistance = "R" }         # e = R f, either causality
        valve = { type = "R", flow_law = "Cv*sqrt(abs(e_valve))*sign(e_valve)" }
        lever = { type = "TF", modulus = "l*sin(theta)" }
        motor = { type = "GY", modulus = "K" }
        j     = { type = "1" }                           # or "0"
        sw    = { type = "1", controlled = true }

    A storage law is written in its state (``q_<name>``, ``p_<name>``, or
    ``state = "..."``); an R law in the variable of *its own bond*: an
    ``effort_law`` in the bond's flow ``f_<bond>``, a ``flow_law`` in its
    effort ``e_<bond>``.  Laws may use ``t``, parameters, inputs, states,
    displacements, other bonds' variables and mode constants.
    A sub-model instance is an entry with ``component`` (a shipped component:
    ``msd_cell``, ``rlc_cell``, ``rigid_planar_body``) or ``file`` (another
    model file, by a path relative to this one that stays inside the
    directory of the file first loaded)::

        cell1 = { component = "msd_cell", share = ["m", "k", "c"] }
        rod   = { component = "rigid_planar_body", args = { gravity = true }, share = ["g"] }
        tank2 = { file = "parts/tank.toml", bind = { A = "A2" }, parameters = { h0 = 0.5 } }

    As :meth:`bondgraph.BondGraph.add_submodel`: inner names become
    ``<instance>/<name>`` except those in ``share`` (kept, shared with this
    model) and ``bind`` (replaced by an expression of this model's names);
    ``parameters`` gives values to inner parameters, ``args`` are a
    component's keyword arguments.  A file placed as a sub-model brings its
    automata (``<instance>/<automaton>``), signals (``<instance>/<signal>``),
    parameter values (defaults this file's ``[parameters]`` overrides under
    the full name), inputs and initial values; its ``[run]``, tolerances and
    jump law are ignored.  The automata of instances come first in the mode,
    in the order of the instances, then this file's own.
``[bonds]``
    ``name = "tail -> head"`` (positive power from tail to head).  An end is
    an element, or ``instance.port`` — a port of a sub-model instance.
``[displacements]``
    ``theta = { of = "omega", sign = 1 }``: an integrated displacement (as
    :meth:`~bondgraph.BondGraph.displacement`: ``of`` an element, a
    1-junction or a bond), or ``{ bond = "b3", sign = -1 }`` for the flow of a
    bond in its drawn direction.
``[ports]``
    ``name = "element"`` — for a file used as a sub-model.
``[automata.<name>]``
    ``initial = "state"``, optionally ``aliases = { on = "conducting" }`` (other
    names the states are read by wherever a state is named — ``in_mode``, a
    mode's text —, never shown: the old names of renamed states, as a
    circuit's diode writes them), then::

        [automata.diode.states]          # state → controlled junctions on/off
        off = { D = false }
        on  = { D = true }
        [automata.diode.restitution]     # optional: state → e (pinnacle contacts)
        [automata.diode.values]          # optional: state → mode constants
        [[automata.diode.transitions]]   # tried in the order written
        from = "off"
        to = "on"
        guard = "v_D >= V_th"
        when = "a posteriori"            # default "a priori"
        pulses = true                    # default; false: see Automaton.add_transition
``[signals]``
    ``v = "q_C/C"`` (over states, bond variables, parameters, inputs, ``t``,
    mode constants and earlier signals), or an :class:`~switching.model.hybrid_model.InMode`
    signal ``F_stick = { expression = "-e_tangent", in_mode = { friction =
    "stuck" } }``.
``[initial_state]``
    ``q_C = 0.0`` (a number or an expression of parameters, ``q_C =
    "C*v0"``: the model keeps it so, and ``--set v0=…`` moves the start);
    states not given start at 0.
``[units]``
    ``theta = "rad"``: the unit of a state, signal or input, shown on plots
    (a parameter's unit is in its own entry in ``[parameters]``).
``[tolerance]``
    ``rtol``, ``atol``, ``jump_rtol``, ``jump_atol`` (:class:`~switching.model.hybrid_model.Tolerance`).
``[run]``
    The default run of ``hbg run FILE``: ``t_end``, ``method``, ``rtol``,
    ``atol``, ``max_step``, ``first_step``, ``dt``, and ``signals`` (the
    names to plot and save).

Expressions are text in the grammar of :mod:`switching.language.parsing` (``+ - * /
**``, ``abs sign sqrt exp log sin cos tan asin acos atan atan2 sinh cosh tanh
min max``, ``pi``); numbers may be TOML numbers.  Floats are doubles.

Errors
======

A file that cannot be read raises :class:`ModelFileError` (a
:class:`~bondgraph.errors.HybridBondGraphError` and ``ValueError``) whose
message starts with ``file:line:``, names the element, bond, automaton,
transition, signal or parameter at fault and says what is expected.  TOML
readers give no positions for values; the line is found by scanning the text
for the table header and key (:mod:`switching.files.tomllines`); a value inside an
inline table or a multi-line array is reported at the line of its key.

Writing
=======

:func:`save_model` (``model.save(path)``) writes the flattened model
(sub-model instances as their elements with hierarchical names) and checks
that the text reads back to the same fingerprint.  Inputs given as Python
functions cannot be written (use :class:`~switching.model.expression_input.ExpressionInput`),
nor laws with functions outside the grammar: both raise :class:`ModelFileError`.

Other forms
===========

A layer above :mod:`switching` may register another form of model file
(:mod:`switching.files.forms`): :mod:`models` saves a model built by
``Circuit`` or ``Mechanism`` as its netlist — a ``[circuit]`` or
``[mechanism]`` table, one line a component (:mod:`models.netlist_files`).
:func:`save_model` writes a model in its own form when a registered form holds
it; :class:`ModelFile`, :func:`load_model` and :func:`loads_model` read a file
of a registered form with that form's reader.  :func:`dumps_model` always
writes the bond graph (what an FMU carries).
'''

from __future__ import annotations

import importlib
import os
from collections.abc import Callable, Mapping
from pathlib import Path

from ..model.expression_input import ExpressionInput
from .build import FileInfo, LoadedModel, file_info
from .forms import dumps_in_form, form_of
from .errors import (
    MAX_DEPTH,
    MAX_ELEMENTS,
    MAX_EXPRESSION_CHARS,
    MAX_EXPRESSION_TOKENS,
    MAX_FILE_BYTES,
    MAX_FILES,
    MAX_PARSE_WORK,
    ModelFileError,
)
from .read import FORMAT_KEY, FORMAT_VERSION, Reader
from .write import dumps_model

__all__ = [
    "ModelFile",
    "ModelFileError",
    "ExpressionInput",
    "FileInfo",
    "load_model",
    "loads_model",
    "save_model",
    "dumps_model",
    "file_info",
    "is_model_path",
    "FORMAT_KEY",
    "FORMAT_VERSION",
    "MAX_FILE_BYTES",
    "MAX_EXPRESSION_CHARS",
    "MAX_EXPRESSION_TOKENS",
    "MAX_PARSE_WORK",
    "MAX_ELEMENTS",
    "MAX_DEPTH",
    "MAX_FILES",
]

#: The relay circuit of the README as a model file (used by the example above).
EXAMPLE = """
hbg_model_format = 1
name = "rc"

[parameters]
V0 = 1.0
R = 1.0
C = 1e-3

[elements]
V = { type = "Se", value = "V0" }
sw = { type = "1", controlled = true }
R = { type = "R", resistance = "R" }
C = { type = "C", capacitance = "C" }

[bonds]
V = "V -> sw"
R = "sw -> R"
C = "sw -> C"

[automata.switch]
initial = "closed"
states = { closed = { sw = true }, open = { sw = false } }
[[automata.switch.transitions]]
from = "closed"
to = "open"
guard = "q_C >= 0.5*C*V0"
"""


def is_model_path(reference) -> bool:
    """True when ``reference`` names a model file rather than a shipped model:
    a path object, or a text ending in ``.toml`` or holding a path separator."""
    if isinstance(reference, os.PathLike):
        return True
    return isinstance(reference, str) and (reference.endswith(".toml") or os.sep in reference
                                           or (os.altsep is not None and os.altsep in reference))


class ModelFile:
    """A model file seen as the shipped model modules are: ``DEFAULTS``
    (parameter values), ``RUN`` (the default run: the file's ``[run]``, with
    ``t_end = 1`` s and ``RK45`` unless it says otherwise), ``SIGNALS`` (the
    names to plot: ``[run] signals``, else every signal), ``build(**parameters)
    -> HybridModel`` — what ``hbg`` uses.

    The file is read once, when the object is made (every error is raised
    then); each :meth:`build` makes a new model from it.  ``components``:
    name → function returning a sub-model bond graph (``models.load`` gives
    the shipped ones).  A ModelFile pickles (by its path), so a sweep's
    worker processes read the file again."""

    def __init__(self, path, components: Mapping[str, Callable] | None = None):
        self.path = Path(path)
        self.components = dict(components or {})
        self._loaded, form = _loaded(Reader(self.components), lambda reader: reader.top_source(self.path))
        #: the module that registers the file's form (:mod:`switching.files.forms`; "" for a bond graph's file)
        self.form_module = form.module if form is not None else ""
        settings = self._loaded.settings
        self.name = settings["name"]
        self.__doc__ = settings["description"] or f"model file {self.path}"
        self.DEFAULTS = self._loaded.defaults
        run = dict(settings["run"])
        #: why the run's ``t_end`` is what it is when the file gives none (else None): the command line says it
        self.t_end_chosen = None
        signals = run.pop("signals", None)
        if "t_end" not in run:  # (a file without a run: its time scales choose, and say how)
            from .run_defaults import suggested_t_end

            t_end, self.t_end_chosen = suggested_t_end(self.build())
            run["t_end"] = float(f"{t_end:.6g}")
        self.RUN = run  # (a method only if the file names one: hbg run chooses, else)
        self.SIGNALS = tuple(signals) if signals is not None else self._loaded.signal_names

    def build(self, **parameters):
        """A :class:`~switching.model.hybrid_model.HybridModel` with the file's values overridden by ``parameters``."""
        return self._loaded.build(**parameters)

    def __getstate__(self):
        return {"path": self.path.resolve(), "components": self.components, "form_module": self.form_module}

    def __setstate__(self, state):
        if state.get("form_module"):  # (a file of another form: its layer registers the form when imported)
            importlib.import_module(state["form_module"])
        self.__init__(state["path"], state["components"])

    def __repr__(self) -> str:
        return f"ModelFile({str(self.path)!r})"


def load_model(path, components: Mapping[str, Callable] | None = None, **parameters):
    """The :class:`~switching.model.hybrid_model.HybridModel` of the model file at ``path``,
    its parameter values overridden by ``parameters``."""
    return ModelFile(path, components).build(**parameters)


def loads_model(text: str, components: Mapping[str, Callable] | None = None, directory=None,
                name: str = "<text>", **parameters):
    """The model of a model file given as ``text`` (sub-model files are looked
    for in ``directory``; ``name`` is shown in error messages)."""
    loaded, _ = _loaded(Reader(components), lambda reader: reader.text_source(text, name, directory))
    return loaded.build(**parameters)


def _loaded(reader: Reader, source) -> tuple:
    """``(loaded, form)`` of the top file ``source(reader)``: a :class:`LoadedModel` (form None), or what
    its form's reader gives for a file of a registered form (:mod:`switching.files.forms`)."""
    src = source(reader)
    form = form_of(src.data)
    return (form.load(src) if form is not None else LoadedModel(reader.read_top(src))), form


def save_model(model, path, *, run: dict | None = None, description: str | None = None) -> None:
    """Write ``model`` to the model file ``path`` (see :func:`dumps_model`
    for ``run`` and ``description``): in its own form when a registered form
    holds it (a model built by ``Circuit`` or ``Mechanism``: its netlist,
    :mod:`switching.files.forms`), else as its bond graph; the text is checked to read back to the
    same model before the file is written.  ``models.load(path)`` reads it back.
    Also ``model.save(path, ...)``.  Without ``run`` (and not read from a file that has one) the file's
    ``[run]`` is the model's last run, else a ``t_end`` its time scales suggest
    (:func:`switching.files.run_defaults.default_run`): never a file without a run."""
    from .build import file_info
    from .run_defaults import default_run

    if run is None and (file_info(model) is None or not file_info(model).run):
        run = default_run(model)[0]
    text = dumps_in_form(model, run=run, description=description, display=str(path))
    if text is None:  # (no registered form holds it: its bond graph)
        text = dumps_model(model, run=run, description=description, display=str(path))
    Path(path).write_text(text, encoding="utf-8")

