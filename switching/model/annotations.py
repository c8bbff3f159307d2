"""Units and descriptions of a model's names: what plots, tables and model files show beside the numbers.

A unit is short text (``"V"``, ``"N·s"``, ``"rad/s"``, ``"m^3"``); the
toolkit never computes with it: the equations hold numbers in whatever
units the parameters were given in.  Units are given by name for
parameters, states, signals and inputs (``HybridModel(..., units={"theta":
"rad"})``, a model file's ``unit`` fields and ``[units]`` table, the
circuit and machine builders); a signal defined as one state or parameter
(``theta = "rod/theta"``) takes that name's unit when it has none of its own.
A description is one line of text about a name (``"the rod's mass"``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import sympy as sp

from bondgraph.errors import UnknownNameError, did_you_mean

from ..errors import ModelDefinitionError

__all__ = ["Annotations", "annotations"]


@dataclass(frozen=True)
class Annotations:
    """name → unit and name → description of a model's parameters, states, signals and inputs."""

    units: Mapping = field(default_factory=dict)
    descriptions: Mapping = field(default_factory=dict)

    def unit(self, name: str) -> str | None:
        """The unit of ``name`` (None if it has none)."""
        return self.units.get(name)

    def label(self, name: str) -> str:
        """``"name [unit]"``, or ``name`` alone without a unit: an axis or column label."""
        unit = self.units.get(name)
        return f"{name} [{' '.join(unit.split())}]" if unit else name  # (on one line)


def _text(value, what: str, name: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise ModelDefinitionError(f"the {what} of {name!r} must be a non-empty text, got {value!r}", [name])
    return value


def annotations(model, units: Mapping | None, descriptions: Mapping | None) -> Annotations:
    """The checked :class:`Annotations` of ``model``: every name must be one
    of its parameters, states, signals or inputs (:class:`UnknownNameError`
    with the closest names otherwise), every unit and description a
    non-empty text (kept as given: it is shown, never run).
    Signals defined as a single state or parameter inherit its unit."""
    known = ({s.name for s in model.parameter_symbols} | {s.name for s in model.initial_parameters}
             | set(model.signal_names) | {s.name for s in model.states} | set(model.graph.inputs))
    checked = {}
    for kind, table in (("unit", units), ("description", descriptions)):
        out = {}
        for name, value in dict(table or {}).items():
            name = name.name if isinstance(name, sp.Symbol) else str(name)
            if name not in known:
                raise UnknownNameError(f"{kind} given for {name!r}, which is no parameter, state, signal or input "
                                       f"of model {model.name!r}{did_you_mean(name, known)}", name)
            out[name] = _text(value, kind, name)
        checked[kind] = out
    for name, expr in model.signal_definitions.items():
        if name not in checked["unit"] and isinstance(expr, sp.Symbol) and expr.name in checked["unit"]:
            checked["unit"][name] = checked["unit"][expr.name]
    return Annotations(MappingProxyType(checked["unit"]), MappingProxyType(checked["description"]))
