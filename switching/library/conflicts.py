"""The guards of a conflicting mode, decided in the limit of vanishing resistances.

A candidate mode met at an instant may be over-determined: the automata
each stepped locally (a PWM switch closes) into a configuration whose
sources conflict (the freewheeling diode still conducts, so the switch and
the diode short the source).  Such a mode cannot be real — it has no
equations — but it can be *mythical* (DESIGN.md §6a): it is passed without
its jump, and its guards say where the instant goes.  They are judged on
the configuration with a vanishing resistance ``ε`` in series with every
conducting ideal switch and diode (:mod:`bondgraph.regularize`): a signal
of order ``1/ε`` is an impulse of that sign (the diode's current driven
backwards by the shorted source: ``i_D → −∞``, so ``i_D < 0`` holds and the
diode turns off), a signal of order 1 its finite limit, compared with the
model's band at an instant.  Where the impulse's coefficient vanishes at the
instant itself (a bridge's source crossing zero while the load's inductor
keeps its current: the diodes of the other diagonal turn on into a short of
a source that is 0 V just then) the impulse just after it decides: the sign
of the coefficient's time derivative.  A coefficient vanishes when it lies
within the model's band ``rtol·R(c)`` of zero, ``R(c)`` its round-off scale
(:mod:`codegen.roundoff`), so that units decide nothing.

:class:`ConflictGuards` holds, for one mode, each guard's comparisons as
leading coefficients in ``ε`` (numerical functions of the state), derived
once and kept in the mode library.
"""

from __future__ import annotations

import math

import numpy as np
import sympy as sp
from sympy.core.relational import Relational
from sympy.logic.boolalg import And, BooleanFalse, BooleanTrue, Not, Or

from bondgraph.errors import CausalityConflictError, HybridBondGraphError
from bondgraph.regularize import EPSILON, leading_term, regularized_equations
from bondgraph.symbols import rate_symbol
from codegen import vector_function
from codegen.roundoff import roundoff_scale
from codegen.runtime import Comparison, Hyper

__all__ = ["ConflictGuards"]

_RELATIONS = {sp.StrictLessThan: "<", sp.LessThan: "<=", sp.StrictGreaterThan: ">", sp.GreaterThan: ">=",
              sp.Equality: "==", sp.Unequality: "!="}


class ConflictGuards:
    """The guards of the conflicting ``mode`` of ``model`` in the limit ``ε → 0⁺``.

    ``error`` is the conflict the mode's own derivation raised; it is raised
    again (with the instant and mode named by the caller) when the
    resistances do not settle the conflict or a guard cannot be judged so
    (a signal taken in another mode, a law that is no rational function of ``ε``)."""

    def __init__(self, model, mode, error: CausalityConflictError):
        self.model, self.mode, self.error = model, mode, error
        try:
            equations = regularized_equations(model.derivation_graph, dict(model.configuration_of(mode)))
        except HybridBondGraphError:
            raise error from None
        values = model.mode_values(mode)
        bonds = {}
        for bond in model.derivation_graph.bonds.values():
            bonds[bond.effort] = equations.resolve(equations.efforts[bond.name])
            bonds[bond.flow] = equations.resolve(equations.flows[bond.name])
        self._coefficients: list[sp.Expr] = []
        self.guards = []  # (automaton, transition, text, tree of comparisons)
        self._substitute = lambda expr: expr.xreplace(bonds).xreplace(values)
        for automaton, transition, condition, text in model.guards_from(mode):
            self.guards.append((automaton, transition, text, self._tree(condition)))
        self._function = vector_function(self._coefficients or [sp.Integer(0)], model.states, model.time,
                                         model.parameter_symbols, model.input_symbols)

    def _tree(self, condition):
        """The condition as nested ``("and" | "or" | "not", ...)`` of comparisons ``(op, left, right, text)``,
        each side ``(numerator coefficient indices, denominator coefficient indices)``."""
        if isinstance(condition, (BooleanTrue, BooleanFalse)):
            return ("constant", bool(condition))
        if isinstance(condition, (And, Or)):
            return ("and" if isinstance(condition, And) else "or", [self._tree(a) for a in condition.args])
        if isinstance(condition, Not):
            return ("not", [self._tree(condition.args[0])])
        if isinstance(condition, Relational) and type(condition) in _RELATIONS:
            return (_RELATIONS[type(condition)], self._side(condition.lhs), self._side(condition.rhs),
                    str(condition))
        raise self.error

    def _side(self, expr):
        expr = self._substitute(expr)
        free = expr.free_symbols - {*self.model.states, self.model.time, *self.model.parameter_symbols,
                                    *self.model.input_symbols, EPSILON}
        if free:  # a signal taken in another mode, a rate: not judged here
            raise self.error
        try:
            numerator, denominator = leading_term(expr)
        except (sp.PolynomialError, sp.GeneratorsNeeded, ValueError):
            raise self.error from None
        t = self.model.time
        scales = [roundoff_scale(c) for c in numerator]
        # d/dt at fixed state: explicitly and through the inputs (whose rates the model evaluates with them)
        inputs = tuple(self.model.graph.inputs.values())
        slopes = [sp.diff(c, t) + sum((sp.diff(c, u) * rate_symbol(u) for u in inputs if c.has(u)), sp.Integer(0))
                  for c in numerator]
        indices = []
        for coefficients in (numerator, denominator, scales, slopes):
            start = len(self._coefficients)
            self._coefficients.extend(coefficients)
            indices.append(range(start, len(self._coefficients)))
        return tuple(indices)

    def fired(self, x: np.ndarray, t: float) -> list:
        """``[(automaton, transition, text, comparisons), ...]``: the first holding transition of each
        automaton, every comparison in the limit ``ε → 0⁺`` at the state ``x`` (before the instant: the
        mode is passed without its jump) and decided as an instant decides (:func:`codegen.runtime.decide`:
        a side of order ``1/ε`` is an impulse of its sign), with the figures of the comparisons."""
        values = self._function(x, t, self.model.parameter_array, self.model.input_values(t))
        rtol, atol = self.model.tolerance.rtol, self.model.tolerance.atol
        done, fired = set(), []
        for automaton, transition, text, tree in self.guards:
            if automaton in done:
                continue
            comparisons: list = []
            if _decide(tree, values, rtol, atol, comparisons):
                done.add(automaton)
                fired.append((automaton, transition, text, tuple(comparisons)))
        return fired


def _limit(side, values, rtol: float) -> tuple[Hyper, float]:
    """The limit of one side as ``ε → 0⁺`` from its coefficients' values, as a :class:`Hyper`, with its
    round-off scale: a side of order ``1/ε`` (or beyond) an impulse of the sign of its leading
    coefficient — or, where that coefficient vanishes at the instant, of its time derivative's (the
    impulse just after) — one of order 1 its finite value, one of higher order 0; NaN where the
    denominator vanishes.  A numerator coefficient vanishes within ``rtol`` of its round-off scale."""
    numerator, denominator, scales, slopes = ([float(values[k]) for k in part] for part in side)
    d_order = next((order for order, c in enumerate(denominator) if c != 0.0), None)
    if d_order is None:
        return Hyper(0.0, math.nan), 0.0
    d = denominator[d_order]
    for order, (c, scale, slope) in enumerate(zip(numerator, scales, slopes)):
        if order > d_order:
            break
        if order == d_order:
            return Hyper(0.0, c / d), abs(scale / d)
        if abs(c) > rtol * scale:
            return Hyper(c / d, 0.0), 0.0
        if slope != 0.0:
            return Hyper(slope / d, 0.0), 0.0
    return Hyper(0.0, 0.0), 0.0


def _decide(tree, values, rtol: float, atol: float, comparisons: list) -> bool:
    kind = tree[0]
    if kind == "constant":
        return tree[1]
    if kind in ("and", "or", "not"):
        results = [_decide(branch, values, rtol, atol, comparisons) for branch in tree[1]]
        return all(results) if kind == "and" else any(results) if kind == "or" else not results[0]
    (left, left_scale), (right, right_scale) = _limit(tree[1], values, rtol), _limit(tree[2], values, rtol)
    if math.isnan(left.finite) or math.isnan(right.finite):
        return False
    # the band of the comparison, as during flow: rtol times the round-off scale of its finite sides
    comparison = Comparison.of(tree[3], kind, left, right, rtol, atol, max(left_scale, right_scale))
    comparisons.append(comparison)
    return comparison.result
