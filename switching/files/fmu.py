"""FMUs: a model packaged as an FMI 2.0 co-simulation FMU that runs this toolkit.

:func:`to_fmu` (``hbg fmu MODEL -o model.fmu``) writes a ``.fmu`` (a zip, as
FMI 2.0 lays it out) built with pythonfmu, which packages Python code as an FMU
behind a small C++ library of the FMI functions:

* ``resources/model.toml`` — the model as a model file (:mod:`.modelfile`; read
  with the toolkit's own loader, no text of it ever runs), its ``[run]`` section
  holding the method and tolerances the FMU integrates with, fixed at export;
* ``resources/hbg_<name>_<digest>.py`` — the slave: one generated class, a
  subclass of :class:`switching.files.fmu_slave.ModelSlave` with no code of its
  own (its name is the FMU's ``modelIdentifier``, made of the model's name);
* ``resources/requirements.txt`` — what the Python that runs it needs
  (``pythonfmu deploy -f model.fmu`` installs it), ``resources/pythonfmu/`` and
  ``binaries/`` — pythonfmu's wrapper.

The FMU's variables (:func:`fmu_variables`), in the order of their value references:

* every parameter of the model as a *parameter*: ``tunable`` where the
  equations read it (set between communication steps, it holds from the next
  step on), ``fixed`` where only the initial state reads it (``theta0``, ``y0``:
  set before initialization); its start value is the model's.  A parameter whose
  value is infinite (``allow_infinite``) keeps it and is no variable;
* every declared input (``model.graph.inputs``) as an *input*, its start value
  the model's own input at ``t = 0``.  The FMU holds an input's value over each
  communication step (a zero-order hold: its rate is 0 inside the step), so
  what the model's own function of time said is replaced by what the master
  sets; a faster input needs a shorter communication step;
* the states, then the signals (``model.signal_names``), as *outputs*: their
  values at the communication point — after any instant there (right-continuous,
  as ``simulate(t_eval=...)`` samples), a signal's finite part;
* each automaton's state as an Integer output ``mode.<automaton>``: the index of
  the state in the automaton's order (its description lists them,
  ``0 = conducting, 1 = blocking``).

Units are the model's (its annotations: ``unit`` of parameters, ``[units]`` of
states, signals and inputs), declared in the ``UnitDefinitions`` as names without
base units (FMI 2.0 allows that; the toolkit never computes with a unit).
Names are FMI ``flat`` names, written as the toolkit writes them (``rod/theta``).

At ``fmi2DoStep(t, h)`` the FMU runs ``model.simulate(t + h, method, t0=t,
x0=x, mode=mode, ...)`` from the state and mode it kept
(:class:`CoSimulation`), so it passes every instant inside the step as a run
does, resolving the instant at ``t`` first (a parameter or input changed at the
communication point takes effect there).  A run restarted at every
communication point differs from one run over the whole time by the
integration error of the method (about ``rtol``), not more.
"""

from __future__ import annotations

import hashlib
import keyword
import math
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bondgraph.errors import MissingDependencyError

from ..errors import OptionValueError
from ..model.expression_input import ExpressionInput
from ..model.hybrid_model import HybridModel
from ..simulate.methods import METHOD_CLASSES, canonical_method
from .errors import ModelFileError
from .write import dumps_model

__all__ = ["to_fmu", "export_settings", "fmu_variables", "FmuVariable", "CoSimulation", "HeldInput", "fmu_settings",
           "fmu_identifier", "MODEL_FILE", "FMU_EXTRA"]

#: the model file inside the FMU's ``resources``
MODEL_FILE = "model.toml"
#: the run options an FMU keeps (in its model file's ``[run]``), besides ``method``
RUN_OPTIONS = ("rtol", "atol", "dt", "max_step")
#: what installs the FMU's tools
FMU_EXTRA = "pip install 'hybrid-bondgraph[fmu]' (pythonfmu builds FMUs, fmpy runs and checks them)"


@dataclass(frozen=True)
class FmuVariable:
    """One variable of the FMU: its ``name``, its ``causality`` (``parameter``,
    ``input``, ``output``), its FMI ``variability`` (``tunable``, ``fixed``,
    ``continuous``, ``discrete``), ``kind`` (``real``, or ``mode``: an Integer,
    the automaton's state), unit, description and start value."""

    name: str
    causality: str
    variability: str
    kind: str = "real"
    unit: str | None = None
    description: str | None = None
    start: float | None = None


def fmu_variables(model: HybridModel) -> list[FmuVariable]:
    """The FMU's variables of ``model``, in the order of their value references (see the module's
    documentation): parameters, inputs, states, signals, then the automata's states."""
    notes = model.annotations

    def real(name, causality, variability, start=None, description=None):
        return FmuVariable(name, causality, variability, "real", notes.unit(name),
                           description or notes.descriptions.get(name), start)

    found = [real(s.name, "parameter", "tunable", float(v)) for s, v in model.parameter_values.items()
             if math.isfinite(v)]
    found.sort(key=lambda v: v.name)
    found += sorted((real(s.name, "parameter", "fixed", float(v)) for s, v in model.initial_parameters.items()
                     if math.isfinite(v)), key=lambda v: v.name)
    found += [real(name, "input", "continuous", input_start(model, name)) for name in model.graph.inputs]
    outputs = dict.fromkeys([*model.state_names, *model.signal_names])
    found += [real(name, "output", "continuous") for name in outputs]
    found += [FmuVariable(f"mode.{a.name}", "output", "discrete", "mode", None,
                          f"automaton {a.name}: " + ", ".join(f"{k} = {s}" for k, s in enumerate(a.states)))
              for a in model.automata]
    names = [v.name for v in found]
    if len(set(names)) != len(names):
        twice = sorted({n for n in names if names.count(n) > 1})
        raise ModelFileError(f"the FMU would have two variables named {', '.join(twice)}", model.name)
    return found


def input_start(model: HybridModel, name: str) -> float:
    """The start value of input ``name``: the model's own input at ``t = 0``."""
    value = float(model.input_signals.functions[name](0.0))
    if not math.isfinite(value):
        raise ModelFileError(f"input {name!r} is {value} at t = 0: an FMU input needs a finite start value",
                             model.name)
    return value


# ------------------------------------------------------------------ the co-simulation


class HeldInput:
    """An input held at :attr:`value` (a zero-order hold: its rate is 0)."""

    def __init__(self, value: float):
        self.value = float(value)

    def __call__(self, t: float) -> float:
        """The value held, whatever ``t``."""
        return self.value

    def derivative(self, t: float) -> float:
        """The rate of a held value: 0."""
        return 0.0

    def __repr__(self) -> str:
        return f"HeldInput({self.value!r})"


def fmu_settings(model: HybridModel) -> tuple[str, dict]:
    """``(method, options)`` an FMU of ``model`` integrates with: its model file's ``[run]``."""
    from .build import file_info

    info = file_info(model)
    run = dict(info.run) if info is not None else {}
    return run.get("method", "RK45"), {k: run[k] for k in RUN_OPTIONS if k in run}


class CoSimulation:
    """``model`` run from communication point to communication point, as its FMU runs it: the time,
    state and mode kept between the steps, each step a run of ``model.simulate`` from them.

    The model's inputs are replaced by :class:`HeldInput` values (:meth:`set_input`) — the model
    is the FMU's own, read from its file, so nothing else sees that."""

    def __init__(self, model: HybridModel, method: str | None = None, options: dict | None = None):
        self.model = model
        given_method, given_options = fmu_settings(model)
        self.method = method or given_method
        self.options = dict(given_options if options is None else options)
        self.inputs = {name: HeldInput(input_start(model, name)) for name in model.graph.inputs}
        model.input_signals.functions.update(self.inputs)
        self.values = {s.name: v for s, v in model.parameter_values.items()}
        self.initial_values = {s.name: v for s, v in model.initial_parameters.items()}
        self.changed = False
        self.signal_names = tuple(n for n in model.signal_names if n not in model.state_names)
        self.t, self.x, self.mode = 0.0, None, None
        self._outputs = None

    # ---------------------------------------------------------------- values set by the master

    def set_parameter(self, name: str, value: float) -> None:
        """Give parameter ``name`` a new value, used from the next start or step on."""
        table = self.values if name in self.values else self.initial_values
        table[name] = float(value)
        self.changed, self._outputs = True, None

    def parameter(self, name: str) -> float:
        """The value of parameter ``name`` (the one set last)."""
        return self.values[name] if name in self.values else self.initial_values[name]

    def set_input(self, name: str, value: float) -> None:
        """Hold input ``name`` at ``value`` from now on (over the next step)."""
        self.inputs[name].value = float(value)
        self._outputs = None

    def _apply_parameters(self) -> None:
        """The values set since the last start or step given to the model (its code reads them at every call)."""
        if self.changed:
            self.model.set_parameter_values(self.values, self.initial_values)
            self.changed = False

    # ---------------------------------------------------------------- time

    def start(self, t0: float = 0.0) -> None:
        """The initial state and mode at ``t0`` (the model's, its parameters applied), the instant at
        ``t0`` resolved as a run resolves it."""
        self._apply_parameters()
        model = self.model
        x = model.initial_state()
        instant = model.resolve(x, model.starting_mode(x, t0), t0)
        self.t, self.x, self.mode = float(t0), np.array(instant.x_after, dtype=float), instant.mode_after
        self._outputs = None

    def step(self, t: float, h: float) -> None:
        """Advance from the communication point ``t`` by ``h`` (a run of ``simulate`` from the state
        and mode kept); a failed run raises its error, the state kept where the step began."""
        if self.x is None:
            self.start(t)
        if h <= 0:
            return
        self._apply_parameters()
        run = self.model.simulate(t + h, self.method, t0=t, x0=self.x, mode=self.mode, output="events",
                                  **self.options)
        self.t, self.x, self.mode = float(run.t[-1]), np.array(run.x[-1], dtype=float), run.modes[-1]
        self._outputs = None

    # ---------------------------------------------------------------- outputs

    def outputs(self) -> dict:
        """name → value of every output at the current point: states, signals (finite parts) and
        ``mode.<automaton>`` (the index of the automaton's state)."""
        if self._outputs is None:
            if self.x is None:
                self.start(self.t)
            self._outputs = self._evaluate()
        return self._outputs

    def _evaluate(self) -> dict:
        """The outputs at ``(t, x, mode)``: the signals by one generated call in the mode."""
        model, x, t = self.model, self.x, self.t
        out = dict(zip(model.state_names, x.tolist()))
        if self.signal_names:
            values = np.empty(len(self.signal_names))
            try:
                model.signal_function(self.mode, self.signal_names)(x, t, model.parameter_array,
                                                                      model.input_values(t), values)
            except (ArithmeticError, ValueError):  # a signal with no value here (a 0/0): NaN, the run goes on
                values[:] = np.nan
            out.update(zip(self.signal_names, values.tolist()))
        for automaton, state in zip(model.automata, self.mode.states):
            out[f"mode.{automaton.name}"] = list(automaton.states).index(state)
        return out


# ------------------------------------------------------------------ export


def export_settings(model: HybridModel, method: str = "RK45", rtol=None, atol=None, dt=None, max_step=None) -> dict:
    """The ``[run]`` of the FMU's model file, ``{"method": ..., option: value}``: the method and its options
    checked as ``simulate`` checks them (``rtol`` 1e-6, ``atol`` 1e-9 unless given; see :func:`to_fmu`)."""
    from ..simulate.driver import option_defaults
    from ..simulate.run_options import check_each, check_method

    method = canonical_method(method)
    if method == "auto" or method not in METHOD_CLASSES:
        raise OptionValueError(f"an FMU runs one method: choose one of {', '.join(m for m in METHOD_CLASSES if m != 'auto')}"
                               f", got {method!r}", "method", method)
    cls = METHOD_CLASSES[method]
    if cls.compiled and model.graph.inputs:
        raise OptionValueError(f"method {method!r} compiles the inputs as expressions of t, but an FMU holds its inputs "
                               f"({', '.join(model.graph.inputs)}) at the values the master sets: choose a Python method "
                               f"({'euler, rk4' if cls.fixed_step else 'RK45, Radau, ...'})", "method", method)
    options = {"dt": dt} if cls.fixed_step else {"rtol": 1e-6 if rtol is None else rtol}
    if atol is not None and not cls.fixed_step:  # (without: each state's own, as simulate's default)
        options["atol"] = atol
    if max_step is not None and not cls.fixed_step:
        options["max_step"] = max_step
    if cls.fixed_step and (rtol, atol, max_step) != (None, None, None):
        raise OptionValueError(f"method {method!r} is fixed-step: give dt, not rtol, atol or max_step", "rtol", rtol)
    check_method(method, options.get("dt"))
    check_each({**option_defaults(), **options})
    return {"method": method, **{k: float(v) for k, v in options.items()}}


def fmu_identifier(name: str) -> str:
    """The FMU's ``modelIdentifier`` (and its slave class's name) for a model named ``name``:
    an ASCII identifier (its binaries are named after it)."""
    text = re.sub(r"[^A-Za-z0-9_]", "_", name).strip("_")[:64] or "model"
    text = text if text[0].isalpha() else f"model_{text}"
    return f"{text}_" if keyword.iskeyword(text) or text == "fmu_slave" else text  # (the slave's own names)


SLAVE_TEMPLATE = '''"""The FMI 2.0 co-simulation slave of the model in resources/{model_file}, written by hbg
{version} (switching.files.fmu): the toolkit's switching.files.fmu_slave.ModelSlave runs it; this
file holds no other code."""

from switching.files import fmu_slave

fmu_slave.keep(globals())  # (pythonfmu 0.7 releases this namespace once each time it reads this file)


class {identifier}(fmu_slave.ModelSlave):
    """The model of resources/{model_file}."""
'''


def _slave_source(identifier: str) -> str:
    """The slave module's text: nothing of the model's but ``identifier`` (:func:`fmu_identifier`)."""
    from bondgraph import __version__

    return SLAVE_TEMPLATE.format(identifier=identifier, version=__version__, model_file=MODEL_FILE)


def _requirements() -> str:
    from bondgraph import __version__

    return ("# what the Python that runs this FMU needs (pythonfmu deploy -f FILE.fmu installs it there)\n"
            f"hybrid-bondgraph>={__version__}\n")


def _model_text(model: HybridModel, settings: dict, t_end, description) -> str:
    """The FMU's model file: ``model`` with its inputs written as their start values and ``settings``
    (and ``t_end``) as its ``[run]``."""
    inputs = {name: ExpressionInput(input_start(model, name)) for name in model.graph.inputs}
    run = dict(settings) if t_end is None else {"t_end": float(t_end), **settings}
    return dumps_model(model, run=run, description=description, inputs=inputs, display=f"the FMU of {model.name}")


def _builder():
    try:
        from pythonfmu.builder import FmuBuilder
    except ImportError:
        raise MissingDependencyError(f"writing an FMU needs pythonfmu, which is not installed here: {FMU_EXTRA}") from None
    return FmuBuilder


def to_fmu(model: HybridModel, path, *, method: str = "RK45", rtol: float | None = None, atol: float | None = None,
           dt: float | None = None, max_step: float | None = None, t_end: float | None = None,
           description: str | None = None) -> Path:
    """Write ``model`` as an FMI 2.0 co-simulation FMU to ``path`` (``.fmu``); returns the path.

    ``method`` and its options (``rtol``, ``atol``, ``max_step``; ``dt`` for euler and rk4:
    checked as :meth:`~switching.model.hybrid_model.HybridModel.simulate` checks them; ``rtol``
    1e-6 and ``atol`` 1e-9 unless given) are how the FMU integrates, fixed at export; ``"auto"`` is
    refused (a method chosen anew at every step), and so are the compiled methods for a model with
    inputs (they compile the inputs as expressions of time).  ``t_end`` [s] is the FMU's default
    stop time, ``rtol`` its default tolerance.  The variables, what the FMU does at a step and what
    it needs at run time: see :mod:`switching.files.fmu`.  Needs pythonfmu (``pip install
    'hybrid-bondgraph[fmu]'``); a model a model file cannot hold (a law outside the text grammar)
    raises :class:`~switching.files.errors.ModelFileError`.  Also ``switching.to_fmu``, ``hbg fmu``."""
    if not isinstance(model, HybridModel):
        raise ModelFileError(f"expected a HybridModel, got {type(model).__name__}", str(path))
    path = Path(path)
    if path.suffix.lower() != ".fmu":
        raise ModelFileError("an FMU's file name ends in .fmu", str(path))
    settings = export_settings(model, method, rtol, atol, dt, max_step)
    builder = _builder()
    text = _model_text(model, settings, t_end, description)
    identifier = fmu_identifier(model.name)
    module = f"hbg_{identifier}_{hashlib.sha256(text.encode()).hexdigest()[:12]}"
    with tempfile.TemporaryDirectory(prefix="hbg-fmu-") as folder:
        folder = Path(folder)
        (folder / MODEL_FILE).write_text(text, encoding="utf-8")
        (folder / "requirements.txt").write_text(_requirements(), encoding="utf-8")
        script = folder / "script" / f"{module}.py"
        script.parent.mkdir()
        script.write_text(_slave_source(identifier), encoding="utf-8")
        path.parent.mkdir(parents=True, exist_ok=True)
        _build(builder, script, path, [folder / MODEL_FILE, folder / "requirements.txt"], module)
    return path


def _build(builder, script: Path, path: Path, files: list, module: str) -> None:
    """pythonfmu's build of ``script`` with ``files`` into ``path``; the slave module it imported is
    forgotten after (another FMU of the same name must not find it)."""
    import sys

    try:
        builder.build_FMU(script, dest=path, project_files=files)
    finally:
        sys.modules.pop(module, None)
        while str(script.parent) in sys.path:
            sys.path.remove(str(script.parent))
