"""The part read from a top model file → :class:`~switching.model.hybrid_model.HybridModel`.

:class:`LoadedModel` holds what one read of a file gives (the bond graph, the
automata, signals, parameters with their values, inputs, initial state and
settings) and builds a fresh :class:`~switching.model.hybrid_model.HybridModel` for each
set of parameter values (:meth:`LoadedModel.build`), sharing the bond graph
and its derived equations.  It also checks what only the whole model shows:
every declared parameter is used, every used one has a value.

A guard keeps the text it was written with when the model's own parser reads
that text to the same condition (the text is what messages and reports
show); otherwise — a name known to the file but not to the model's parser, a
guard of a sub-model renamed into its instance — the parsed condition itself
is given to the model.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, field

import sympy as sp

from bondgraph import t as TIME
from bondgraph.errors import HybridBondGraphError, UnknownParameterError

from ..model.automaton import Automaton
from ..errors import GuardSyntaxError
from ..model.expression_input import ExpressionInput
from ..model.hybrid_model import HybridModel, InMode, Tolerance
from .errors import ModelFileError
from .read import InModeSpec, Part
from .source import did_you_mean
from ..language.parsing import parse_condition

__all__ = ["LoadedModel", "FileInfo", "file_info", "keep_file_info", "used_parameters"]


@dataclass
class FileInfo:
    """What a model file says beyond the model itself, kept with a loaded model
    so that saving it again keeps it: the file, its description, the unit and
    description of each parameter, and the default run."""

    path: str | None
    description: str | None = None
    units: dict = field(default_factory=dict)
    descriptions: dict = field(default_factory=dict)
    run: dict = field(default_factory=dict)


_FILE_INFO: "weakref.WeakKeyDictionary[HybridModel, FileInfo]" = weakref.WeakKeyDictionary()


def file_info(model: HybridModel) -> FileInfo | None:
    """The :class:`FileInfo` of a model loaded from a model file (None otherwise)."""
    return _FILE_INFO.get(model)


def keep_file_info(model: HybridModel, info: FileInfo) -> HybridModel:
    """``model`` with ``info`` kept as its :func:`file_info` (a file of another form, read by its form:
    :mod:`switching.files.forms`)."""
    _FILE_INFO[model] = info
    return model


def _free_names(expr) -> set:
    return {s.name for s in expr.free_symbols}


def used_parameters(part: Part) -> set:
    """The parameters the hybrid model uses (as :class:`HybridModel` collects
    them): free names of the element laws, signals, guards, restitution
    coefficients and mode constants that are not time, states, inputs, bond
    variables, mode constants or cross-mode signals."""
    graph = part.graph
    used = {s.name for s in graph.parameters}
    for signal in part.signals.values():
        used |= _free_names(signal.expression if isinstance(signal, InModeSpec) else signal)
    for automaton in part.automata:
        for tr in automaton.transitions:
            used |= _free_names(tr.condition)
        for e in automaton.restitution.values():
            used |= _free_names(e)
        for table in automaton.values.values():
            for v in table.values():
                used |= _free_names(v)
    reserved = {"t"} | {s.name for s in graph.states} | set(graph.inputs) | {s.name for s in graph.bond_symbols()}
    reserved |= part.constants | {n for n, s in part.signals.items() if isinstance(s, InModeSpec)}
    return used - reserved


class LoadedModel:
    """A model read from a file, ready to build :class:`HybridModel` objects."""

    def __init__(self, part: Part):
        self.part = part
        self.source = part.source
        self.settings = part.settings
        self._check_parameters()
        self._check_run_signals()
        self._guard_texts = self._guard_texts_kept()

    # ------------------------------------------------------------ checks

    def _check_parameters(self) -> None:
        part, src = self.part, self.source
        self.model_parameters = used_parameters(part)
        by_inputs = set().union(*(_free_names(e) for e in part.inputs.values())) - {"t"}
        by_initial = set().union(*(_free_names(e) for e in part.initial.values()))
        needed = self.model_parameters | by_inputs | by_initial
        self._initial_only = by_initial - self.model_parameters  # kept with the model, out of its code
        own = {name for name, p in part.parameters.items() if p.where and p.where[0] is src}
        for name in sorted(own - needed):
            raise src.error("declared but used by no law, guard, signal, restitution, mode constant, input or "
                            "initial value; remove it (or use it)", part.parameters[name].where[1],
                            f"parameter {name!r}")
        missing = sorted(needed - set(part.parameters))
        if missing:
            raise src.error(
                f"{len(missing)} parameter(s) have no value: {', '.join(missing)}; give each a value in "
                f"[parameters] (e.g. \"{missing[0]}\" = 1.0) or in the sub-model instance's parameters = {{...}}",
                ("parameters",) if "parameters" in src.data else ())

    def _check_run_signals(self) -> None:
        graph = self.part.graph
        known = set(self.part.signals) | {s.name for s in graph.states} | {s.name for s in graph.bond_symbols()}
        for name in self.settings["run"].get("signals", ()):
            if name not in known:
                raise self.source.error(
                    f"signals names {name!r}, which is no signal, state or bond variable of the model"
                    f"{did_you_mean(name, known)}", ("run", "signals"), "[run]")

    def _hybrid_model_names(self) -> dict:
        """The names :class:`HybridModel` parses guards with (its base names and the signals)."""
        graph = self.part.graph
        names = {"t": TIME}
        names.update({s.name: s for s in graph.states})
        names.update({s.name: s for s in graph.bond_symbols()})
        for p in graph.parameters:
            names.setdefault(p.name, p)
        names.update(graph.inputs)
        for name, signal in self.part.signals.items():
            names[name] = sp.Symbol(name) if isinstance(signal, InModeSpec) else signal
        return names

    def _guard_texts_kept(self) -> set:
        names = self._hybrid_model_names()
        kept = set()
        for automaton in self.part.automata:
            for k, tr in enumerate(automaton.transitions):
                if tr.text is None:
                    continue
                try:
                    same = parse_condition(tr.text, names) == tr.condition
                except GuardSyntaxError:
                    same = False
                if same:
                    kept.add((automaton.name, k))
        return kept

    # ------------------------------------------------------------ values

    @property
    def signal_names(self) -> tuple:
        """The names of the file's signals, in order."""
        return tuple(self.part.signals)

    @property
    def defaults(self) -> dict:
        """Parameter name → value, as the file gives them."""
        return {name: p.value for name, p in self.part.parameters.items()}

    def _values(self, overrides: dict) -> dict:
        parameters = self.part.parameters
        unknown = set(overrides) - set(parameters)
        if unknown:
            raise UnknownParameterError(unknown, parameters)
        values = self.defaults
        for name, value in overrides.items():
            try:
                number = float(value)
            except (TypeError, ValueError):
                raise ModelFileError(f"parameter {name!r} needs a number, got {value!r}", self.source.display) from None
            if math.isnan(number) or (math.isinf(number) and not parameters[name].allow_infinite):
                raise ModelFileError(f"parameter {name!r} is {number}: it needs a finite number", self.source.display)
            values[name] = number
        return values

    def _initial_state(self, values: dict) -> dict:
        numbers = {sp.Symbol(k): sp.Float(v) for k, v in values.items()}
        out = {}
        for name, expr in self.part.initial.items():
            value = sp.sympify(expr.xreplace(numbers).evalf()) if expr.free_symbols else sp.sympify(expr)
            if not (value.is_real and value.is_finite):
                why = "not a real number" if value.is_finite else "not finite"
                given = ", ".join(f"{s} = {float(numbers[s]):g}" for s in sorted(expr.free_symbols, key=str)
                                  if s in numbers)
                message = (f"it is {value}" + (f" with {given}" if given else "") + f", {why}; give parameter "
                           "values for which it is a finite real number, or another expression")
                if name in self.part.initial_where:
                    src, keys = self.part.initial_where[name]
                    raise src.error(message, keys, f"initial value of {name!r}")
                raise ModelFileError(message, self.source.display, culprit=f"initial value of {name!r}")
            out[name] = expr if expr.free_symbols else float(value)
        return out

    # ------------------------------------------------------------ build

    def build(self, **overrides) -> HybridModel:
        """A :class:`HybridModel` with the file's parameter values overridden by ``overrides``."""
        part, settings = self.part, self.settings
        values = self._values(overrides)
        automata = []
        try:
            for spec in part.automata:
                automaton = Automaton(spec.name, spec.states, spec.initial, spec.restitution, spec.values,
                                      aliases=spec.aliases)
                for k, tr in enumerate(spec.transitions):
                    guard = tr.text if (spec.name, k) in self._guard_texts else tr.condition
                    automaton.add_transition(tr.source, tr.target, guard, tr.when, pulses=tr.pulses)
                automata.append(automaton)
        except HybridBondGraphError as exc:
            raise self._located(exc) from None
        inputs = {name: ExpressionInput(expr, {p: values[p] for p in _free_names(expr) - {"t"}})
                  for name, expr in part.inputs.items()}
        signals = {name: (InMode(s.expression, **s.states) if isinstance(s, InModeSpec) else s)
                   for name, s in part.signals.items()}
        kept = self.model_parameters | self._initial_only  # the parameters the model holds
        try:
            model = HybridModel(
                part.graph,
                automata,
                {name: values[name] for name in sorted(self.model_parameters | self._initial_only)},
                initial_state=self._initial_state(values),
                signals=signals,
                inputs=inputs,
                name=settings["name"],
                tolerance=Tolerance(**settings["tolerance"]),
                max_steps_per_instant=settings["max_steps_per_instant"],
                jump_law=settings["jump_law"],
                allow_infinite={n for n, p in part.parameters.items() if p.allow_infinite},
                units={**{n: p.unit for n, p in part.parameters.items() if p.unit and n in kept},
                       **settings.get("units", {})},
                descriptions={n: p.description for n, p in part.parameters.items() if p.description and n in kept},
            )
        except ModelFileError:
            raise
        except HybridBondGraphError as exc:
            raise self._located(exc) from None
        _FILE_INFO[model] = FileInfo(
            str(self.source.path) if self.source.path is not None else None,
            settings.get("description"),
            {n: p.unit for n, p in part.parameters.items() if p.unit},
            {n: p.description for n, p in part.parameters.items() if p.description},
            dict(settings.get("run", {})),
        )
        return model

    def _located(self, exc: HybridBondGraphError) -> ModelFileError:
        """The toolkit's error, placed at the line of the first culprit it names."""
        src = self.source
        names = [str(n) for n in getattr(exc, "elements", ())] + [str(getattr(exc, "name", "") or "")]
        for name in names:
            for section in ("automata", "elements", "signals", "parameters", "units"):
                line = src.lines.first((section, name)) if name else None
                if line is not None:
                    return ModelFileError(str(exc), src.display, line, f"{section[:-1]} {name!r}")
        return ModelFileError(str(exc), src.display)
