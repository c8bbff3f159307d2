"""Bond graph elements: sources, storage, dissipation, two-ports and junctions.

Every element is a small immutable record.  Sign and causality conventions
(power flows along a bond from its *tail* to its *head*; ``e`` effort, ``f``
flow; SI units of the domain, e.g. V and A, N and m/s, Pa and m³/s):

=========  ===============================================================
Se         imposes ``e = value`` on its one bond (power normally out of it)
Sf         imposes ``f = value`` on its one bond
C          state ``q`` (charge, displacement, volume) with ``dq/dt = f``;
           constitutive law ``e = Φ(q)``, linear ``Φ(q) = q / C``
I          state ``p`` (flux linkage, momentum) with ``dp/dt = e``;
           law ``f = Φ(p)``, linear ``Φ(p) = p / I``
R          ``e = φ(f)`` (linear ``e = R f``) or ``f = ψ(e)``
TF         bond 1 in, bond 2 out, modulus ``m``: ``e1 = m e2``, ``f2 = m f1``
GY         bond 1 in, bond 2 out, modulus ``r``: ``e1 = r f2``, ``e2 = r f1``
Zero       common effort; Σ flows in − Σ flows out = 0
One        common flow;   Σ efforts in − Σ efforts out = 0
=========  ===============================================================

A *controlled* junction (``controlled=True``) is switched on/off per
configuration: an off 0-junction imposes zero effort on all its bonds, an off
1-junction zero flow.  Values, moduli and laws may be numbers, parameter names
(strings) or sympy expressions of time ``t``, parameters, inputs, states
(e.g. a modulus ``l*sin(theta)`` of an integrated displacement) and bond
variables of other elements (modulated sources).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from typing import ClassVar

import sympy as sp

from . import budget
from .errors import DerivationError, InvalidGraphError
from .inverse import branch_on_the_line, computes_accurately, monotonic_sense, numeric_inverse, within_range
from .solving import SolveFailure, solve
from .symbols import as_expr, check_name

__all__ = [
    "Element",
    "OnePort",
    "Source",
    "Se",
    "Sf",
    "Storage",
    "C",
    "I",
    "R",
    "TwoPort",
    "TF",
    "GY",
    "Junction",
    "Zero",
    "One",
    "OpenPort",
]

SymbolMap = Mapping[sp.Symbol, sp.Expr]


def _rename_expr(expr: sp.Expr, mapping: SymbolMap) -> sp.Expr:
    return expr.xreplace(dict(mapping)) if mapping else expr


def copy_with(element: "Element", **changes) -> "Element":
    """A copy of a (frozen) element with some fields changed, bypassing the
    user-facing constructors (which take parameters, not laws)."""
    new = object.__new__(type(element))
    for f in fields(element):
        object.__setattr__(new, f.name, changes.get(f.name, getattr(element, f.name)))
    return new


@dataclass(frozen=True)
class Element:
    """Base of all elements: a unique (hierarchical) ``name``."""

    name: str
    kind: ClassVar[str] = "element"
    #: number of bonds the element takes (``None``: any number ≥ 1)
    ports: ClassVar[int | None] = None

    def __post_init__(self):
        check_name(self.name, f"{self.kind} name")

    def expressions(self) -> tuple[sp.Expr, ...]:
        """Every sympy expression the element holds (to collect its symbols)."""
        return ()

    def renamed(self, name: str, mapping: SymbolMap) -> "Element":
        """A copy called ``name`` with symbols replaced per ``mapping`` (sub-model instances)."""
        return copy_with(self, name=name)

    def __str__(self) -> str:
        kind = f"{self.kind}-junction" if self.kind in ("0", "1") else self.kind
        return f"{kind} {self.name!r}"


@dataclass(frozen=True)
class OnePort(Element):
    ports: ClassVar[int | None] = 1


# ---------------------------------------------------------------- sources


@dataclass(frozen=True)
class Source(OnePort):
    """A source of effort or flow whose ``value`` is any expression of ``t``,
    parameters, inputs, states or other bonds' variables (modulated source)."""

    value: sp.Expr = sp.S.Zero

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "value", as_expr(self.value, f"value of {self.kind} {self.name!r}"))

    def expressions(self):
        return (self.value,)

    def renamed(self, name, mapping):
        return copy_with(self, name=name, value=_rename_expr(self.value, mapping))


@dataclass(frozen=True)
class Se(Source):
    """Effort source: ``e = value`` (voltage [V], force [N], pressure [Pa])."""

    kind: ClassVar[str] = "Se"


@dataclass(frozen=True)
class Sf(Source):
    """Flow source: pushes the flow ``value`` out of itself (current [A],
    velocity [m/s], volume flow [m³/s]) whatever the drawn direction of its
    bond: drawn out of the source (``g.connect(Sf(...), j)``) the bond's flow
    is ``value``; drawn into it (``g.connect(j, Sf(...))``) the bond's flow is
    ``−value``.  Either way the junction receives ``value`` (a flow source
    feeding a 0-junction with one C gives ``dq/dt = value``)."""

    kind: ClassVar[str] = "Sf"


# ---------------------------------------------------------------- storage


def _law_from(law, placeholder: sp.Symbol, what: str) -> sp.Expr:
    """Turn a user law (callable of one symbol, or an expression in
    ``placeholder``) into an expression of ``placeholder``."""
    if isinstance(law, sp.Lambda) or (callable(law) and not isinstance(law, sp.Basic)):
        law = law(placeholder)
    return as_expr(law, what)


#: the budget of sympy's search for a closed-form inverse of a law (at most the budget as set): past it, a
#: monotonic law gets its numeric inverse
INVERSE_SECONDS = 2.0


@functools.lru_cache(maxsize=4096)
def _inverse(expr: sp.Expr, var: sp.Symbol, element: str, what: str) -> tuple:
    """``(y, inverse, failure)``: ``var`` as an expression of ``y`` (a dummy)
    with ``expr(var) = y`` — sympy's closed form when it has a real branch
    on the whole line that keeps its digits in floating point, else the
    numeric inverse of a monotonic law
    (:mod:`bondgraph.inverse`) — or ``(y, None, reason)``.  Cached, failures
    too: each mode with the element in that causality asks again."""
    y = sp.Dummy("y")
    slope = sp.diff(expr, var)
    if slope != 0 and not slope.has(var) and expr.xreplace({var: 0}) == 0:  # linear: no solver needed
        return y, y / slope, None
    try:
        step = f"inverting {expr} for {var}"
        solutions = [s[var] for s in solve([expr - y], [var], step, INVERSE_SECONDS) if var in s]
        failure = None
    except SolveFailure as exc:
        solutions, failure = [], exc
    branch = branch_on_the_line(expr, var, y, solutions) if solutions else None
    if branch is not None and computes_accurately(expr, var, y, branch):
        return y, within_range(expr, var, y, branch), None
    try:
        monotonic, unchecked = monotonic_sense(expr, var), False
    except budget.OverBudget:
        monotonic, unchecked = None, True
    if branch is not None and monotonic is None:  # (inaccurate in places, but the only inverse there is)
        return y, within_range(expr, var, y, branch), None
    if monotonic is not None:
        return y, numeric_inverse(expr, var, element, what, *monotonic)(y, *_others(expr, var)), None
    if len(solutions) == 1:  # sympy's one solution, unchecked on part of the line: as before
        return y, solutions[0], None
    if failure is not None:
        found = failure.reason + ", "
    elif solutions:
        found = f"sympy gives {len(solutions)} solutions, none of them the inverse on the whole line, "
    else:
        found = "sympy gives no solution, "
    why = ("its monotonicity could not be checked within the budget (its slope far from 0 is beyond reach), so it "
           "gets no numeric inverse either" if unchecked else
           "the law is not monotonic on the whole line (its slope changes sign or is not a finite real number "
           "somewhere), so it has no numeric inverse either")
    return y, None, SolveFailure(found + "and " + why, (failure is not None and failure.over_budget) or unchecked)


def _others(expr: sp.Expr, var: sp.Symbol) -> tuple:
    """The other symbols of a law, in the order of :attr:`bondgraph.inverse.InverseLaw.others`."""
    return tuple(sorted(expr.free_symbols - {var}, key=lambda s: (s.name, sp.srepr(s))))


def _invert(expr: sp.Expr, var: sp.Symbol, value: sp.Expr, element: str, what: str) -> sp.Expr:
    """Solve ``expr(var) = value`` for ``var`` (see :func:`_inverse`), within
    the budget of :mod:`bondgraph.budget`."""
    y, inverse, failure = _inverse(expr, var, element, what)
    if inverse is None:
        shown = expr.xreplace({var: sp.Symbol(var.name)})
        other = {"R flow": "effort_law=", "R effort": "flow_law="}.get(what)
        advice = (f"Give the law in the causality the graph needs ({other}...), " if other
                  else "Give the law in the other causality, ")
        if failure.over_budget:
            advice += ("give its numbers as parameters (symbols, with their values among the model's "
                       "parameters: sympy inverts those far faster), or raise the budget "
                       f"({budget.ENVIRONMENT_VARIABLE}); ")
        raise DerivationError(
            f"cannot invert the {what} law of {element!r} ({shown} = y) for {var.name}: {failure.reason}. "
            f"The graph forces the other causality on {element!r}. {advice}"
            "or change the graph so the element keeps its preferred causality.",
            [element],
        )
    return inverse.xreplace({y: value})


@dataclass(frozen=True)
class Storage(OnePort):
    """An energy-storing element with a state of its own (C or I).

    ``law`` is the constitutive output as an expression of the element's state
    symbol ``state`` (C: ``e = law(q)``; I: ``f = law(p)``).
    """

    law: sp.Expr = None
    state: sp.Symbol = None
    state_prefix: ClassVar[str] = "x"

    def default_state_name(self, name: str | None = None) -> str:
        return f"{self.state_prefix}_{name or self.name}"

    def __post_init__(self):
        super().__post_init__()
        state = self.state
        if state is None:
            state = sp.Symbol(self.default_state_name())
        elif isinstance(state, str):
            state = sp.Symbol(check_name(state, f"state name of {self.name!r}"))
        object.__setattr__(self, "state", state)

    def output(self, state_value: sp.Expr) -> sp.Expr:
        """The integral-causality output (C: effort, I: flow) for a state value."""
        if state_value is self._placeholder:  # the element's own state: the law as it stands
            return self.law
        return self.law.xreplace({self._placeholder: state_value})

    def state_for(self, input_value: sp.Expr) -> sp.Expr:
        """The state fixed by an imposed input (derivative causality): ``Φ⁻¹``."""
        return _invert(self.law, self._placeholder, input_value, self.name, self.kind)

    @property
    def _placeholder(self) -> sp.Symbol:
        return self.state

    def is_linear(self) -> bool:
        """True when the law is linear in the state (and passes through zero)."""
        q = self._placeholder
        return sp.diff(self.law, q, 2) == 0 and self.law.xreplace({q: 0}) == 0

    def expressions(self):
        return (self.law,)

    def renamed(self, name, mapping):
        if self.state.name == self.default_state_name():
            new_state = sp.Symbol(self.default_state_name(name))
        else:
            new_state = mapping.get(self.state, self.state)
        law = self.law.xreplace({**dict(mapping), self.state: new_state})
        return copy_with(self, name=name, law=law, state=new_state)


def _storage_law(kind, name, parameter, law, placeholder, default_param):
    if law is not None and parameter is not None:
        raise InvalidGraphError(f"{kind} {name!r}: give either a linear parameter or a law, not both", [name])
    if law is not None:
        return _law_from(law, placeholder, f"law of {kind} {name!r}")
    what = f"{'capacitance' if kind == 'C' else 'inertance'} of {kind} {name!r}"
    param = as_expr(default_param if parameter is None else parameter, what)
    return placeholder / param


class C(Storage):
    """Capacitor / spring / tank: ``dq/dt = f``, ``e = Φ(q)``.

    ``C("C1", "C")`` is linear with capacitance parameter ``C`` (``e = q/C``);
    ``C("C1")`` uses a parameter named after the element; ``effort_law=lambda q: k*q**3``
    gives a nonlinear law.  The state is ``q_<name>`` unless ``state=`` names it.
    Units: ``q`` [C], [m], [m³]; ``e`` [V], [N], [Pa].
    """

    kind: ClassVar[str] = "C"
    state_prefix: ClassVar[str] = "q"

    def __init__(self, name: str, capacitance=None, *, effort_law: Callable | sp.Expr | None = None, state=None):
        state_sym = sp.Symbol(check_name(state, "state name")) if isinstance(state, str) else state
        if state_sym is None:
            state_sym = sp.Symbol(f"q_{check_name(name, 'C name')}")
        law = _storage_law("C", name, capacitance, effort_law, state_sym, name)
        Storage.__init__(self, name=name, law=law, state=state_sym)


class I(Storage):
    """Inductor / mass / fluid inertia: ``dp/dt = e``, ``f = Φ(p)``.

    ``I("L", "L")`` is linear (``f = p/L``); ``flow_law=`` gives a nonlinear
    law.  The state is ``p_<name>`` unless ``state=`` names it.
    Units: ``p`` [V·s], [N·s], [Pa·s]; ``f`` [A], [m/s], [m³/s].
    """

    kind: ClassVar[str] = "I"
    state_prefix: ClassVar[str] = "p"

    def __init__(self, name: str, inertance=None, *, flow_law: Callable | sp.Expr | None = None, state=None):
        state_sym = sp.Symbol(check_name(state, "state name")) if isinstance(state, str) else state
        if state_sym is None:
            state_sym = sp.Symbol(f"p_{check_name(name, 'I name')}")
        law = _storage_law("I", name, inertance, flow_law, state_sym, name)
        Storage.__init__(self, name=name, law=law, state=state_sym)


# ---------------------------------------------------------------- dissipation


#: the placeholders of an R's laws: its effort law is an expression of LAW_FLOW, its flow law of LAW_EFFORT
LAW_FLOW = sp.Dummy("f")
LAW_EFFORT = sp.Dummy("e")


@dataclass(frozen=True)
class R(OnePort):
    """Resistor / damper / valve: ``e = φ(f)`` or ``f = ψ(e)``.

    ``R("R1", "R")`` is linear (``e = R f``, either causality);
    ``effort_law=lambda f: R0*f**3`` prefers resistance causality (flow in,
    effort out); ``flow_law=lambda e: Is*(exp(e/VT) - 1)`` (a diode curve)
    prefers conductance causality.  The other causality inverts the law
    (:mod:`bondgraph.inverse`): sympy's closed form when it has one that is
    real on the whole line and keeps its digits, else the numeric inverse of
    a monotonic law; a law that is neither is a
    :class:`~bondgraph.errors.DerivationError` naming the element.
    """

    kind: ClassVar[str] = "R"
    effort_law: sp.Expr = None  # expression of LAW_FLOW
    flow_law: sp.Expr = None  # expression of LAW_EFFORT

    def __init__(self, name: str, resistance=None, *, effort_law=None, flow_law=None):
        given = sum(x is not None for x in (resistance, effort_law, flow_law))
        if given > 1:
            raise InvalidGraphError(f"R {name!r}: give one of resistance, effort_law, flow_law", [name])
        e_law = f_law = None
        if effort_law is not None:
            e_law = _law_from(effort_law, LAW_FLOW, f"effort_law of R {name!r}")
        elif flow_law is not None:
            f_law = _law_from(flow_law, LAW_EFFORT, f"flow_law of R {name!r}")
        else:
            res = as_expr(name if resistance is None else resistance, f"resistance of R {name!r}")
            e_law = res * LAW_FLOW
            f_law = LAW_EFFORT / res
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "effort_law", e_law)
        object.__setattr__(self, "flow_law", f_law)
        self.__post_init__()

    @property
    def prefers_resistance(self) -> bool:
        """True if the law is given as ``e = φ(f)`` (flow in, effort out)."""
        return self.effort_law is not None

    def effort(self, flow: sp.Expr) -> sp.Expr:
        """``e = φ(f)`` (inverting ``ψ`` if only that is known)."""
        if self.effort_law is not None:
            return self.effort_law.xreplace({LAW_FLOW: flow})
        return _invert(self.flow_law, LAW_EFFORT, flow, self.name, "R flow")

    def flow(self, effort: sp.Expr) -> sp.Expr:
        """``f = ψ(e)`` (inverting ``φ`` if only that is known)."""
        if self.flow_law is not None:
            return self.flow_law.xreplace({LAW_EFFORT: effort})
        return _invert(self.effort_law, LAW_FLOW, effort, self.name, "R effort")

    def expressions(self):
        return tuple(x for x in (self.effort_law, self.flow_law) if x is not None)

    def renamed(self, name, mapping):
        return copy_with(
            self,
            name=name,
            effort_law=None if self.effort_law is None else _rename_expr(self.effort_law, mapping),
            flow_law=None if self.flow_law is None else _rename_expr(self.flow_law, mapping),
        )


# ---------------------------------------------------------------- two-ports


@dataclass(frozen=True)
class TwoPort(Element):
    """A power-conserving two-port with one bond in (1) and one out (2)."""

    modulus: sp.Expr = sp.S.One
    ports: ClassVar[int | None] = 2

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "modulus", as_expr(self.modulus, f"modulus of {self.kind} {self.name!r}"))

    @property
    def modulated(self) -> bool:
        return bool(self.modulus.free_symbols)

    def expressions(self):
        return (self.modulus,)

    def renamed(self, name, mapping):
        return copy_with(self, name=name, modulus=_rename_expr(self.modulus, mapping))


@dataclass(frozen=True)
class TF(TwoPort):
    """Transformer (lever, gear, pulley, ideal transformer), bond 1 in, bond 2
    out: ``e1 = m e2`` and ``f2 = m f1``.  ``m`` may be modulated by states
    (e.g. ``l*sin(theta)`` of an integrated displacement ``theta``)."""

    kind: ClassVar[str] = "TF"


@dataclass(frozen=True)
class GY(TwoPort):
    """Gyrator (DC motor, gyroscope), bond 1 in, bond 2 out: ``e1 = r f2``, ``e2 = r f1``."""

    kind: ClassVar[str] = "GY"


# ---------------------------------------------------------------- junctions


@dataclass(frozen=True)
class Junction(Element):
    """A 0- or 1-junction; ``controlled=True`` makes it switchable per configuration."""

    controlled: bool = False
    ports: ClassVar[int | None] = None


@dataclass(frozen=True)
class Zero(Junction):
    """0-junction: one common effort; the flows balance (Σ in = Σ out).
    Switched off it imposes zero effort on every bond."""

    kind: ClassVar[str] = "0"


@dataclass(frozen=True)
class One(Junction):
    """1-junction: one common flow; the efforts balance (Σ in = Σ out).
    Switched off it imposes zero flow on every bond."""

    kind: ClassVar[str] = "1"


@dataclass(frozen=True)
class OpenPort(OnePort):
    """The outside world at an open port, seen when a graph with ports is
    derived on its own (never part of a user's graph).

    It contributes no equation: whichever of its bond's variables the rest of
    the graph does not fix stays a free symbol, an *input* of the equations,
    and the other is an *output*.  ``imposes`` fixes which variable the
    outside imposes (``"effort"`` or ``"flow"``); ``None`` lets the causality
    of the rest of the graph decide.
    """

    port: str = ""
    imposes: str | None = None
    kind: ClassVar[str] = "port"
