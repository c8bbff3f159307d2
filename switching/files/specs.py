"""What a model file defines, read and checked but not yet built into a model:
a :class:`Part` (its bond graph with the sub-model instances placed, and the
specs of its parameters, automata, signals, inputs and initial values), all
sympy, nothing executed."""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from bondgraph import BondGraph

from .source import Source

__all__ = ["Part", "Parameter", "TransitionSpec", "AutomatonSpec", "InModeSpec", "LAW_NAMES", "SIGNAL_NAMES"]

#: what the names of an element law may be
LAW_NAMES = "t, a parameter, state, input, bond variable or mode constant"
#: what the names of a signal or guard may be
SIGNAL_NAMES = "t, a parameter, state, input, bond variable, mode constant or signal"


@dataclass
class Parameter:
    """A declared parameter: its value [in ``unit``] and what it is."""

    value: float
    unit: str | None = None
    description: str | None = None
    allow_infinite: bool = False
    where: tuple = ()  # (source, keys) of the declaration


@dataclass
class TransitionSpec:
    source: str
    target: str
    condition: object  # sympy Boolean, signals substituted
    text: str | None  # the guard as written (None for a renamed sub-model guard)
    when: str
    pulses: bool
    where: tuple = ()


@dataclass
class AutomatonSpec:
    name: str
    states: dict
    initial: str
    restitution: dict
    values: dict
    transitions: list
    where: tuple = ()
    aliases: dict = field(default_factory=dict)  # other name → state (old names still read)


@dataclass
class InModeSpec:
    expression: sp.Expr
    states: dict


@dataclass
class Part:
    """Everything one file defines, its sub-model instances placed."""

    source: Source
    graph: BondGraph
    parameters: dict = field(default_factory=dict)  # name → Parameter
    inputs: dict = field(default_factory=dict)  # name → sympy expression of t and parameters
    automata: list = field(default_factory=list)  # AutomatonSpec
    signals: dict = field(default_factory=dict)  # name → sympy expression or InModeSpec
    initial: dict = field(default_factory=dict)  # state name → sympy expression of parameters
    initial_where: dict = field(default_factory=dict)  # state name → (Source, keys) of its initial value
    constants: set = field(default_factory=set)  # mode-constant names
    settings: dict = field(default_factory=dict)  # name, description, jump_law, … (used for the top file)
