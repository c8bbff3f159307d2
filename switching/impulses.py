"""Values with a Dirac part: ``a·δ + b`` and the comparisons guards make on them.

A signal that depends on state derivatives carries a Dirac pulse when the
state jumps: with ``s = s(x, dx/dt)``, a jump ``x → x⁺`` gives the impulse
area ``a = (∂s/∂ẋ)ᵀ (x⁺ − x)`` and the finite part ``b = s(x⁺, f(x⁺))``.
Guards compare such values the way the paper's Lemma 5.3 does: a non-zero
impulse dominates (it is ``±∞`` by its sign), equal impulses fall back to the
finite parts.  :func:`evaluate` walks a sympy expression with this
arithmetic; :func:`compare` decides a relation within a tolerance band scaled
to the operands (``<=`` includes the band, ``<`` excludes it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import sympy as sp

from .errors import ImpulseError

__all__ = ["Impulsive", "evaluate", "compare", "Tolerance"]


@dataclass(frozen=True)
class Impulsive:
    """``impulse · δ(t − t_s) + finite``."""

    impulse: float
    finite: float

    def __str__(self) -> str:
        if self.impulse:
            return f"{self.impulse:.6g}·δ + {self.finite:.6g}"
        return f"{self.finite:.6g}"


@dataclass(frozen=True)
class Tolerance:
    """Band for comparisons at an instant: ``rtol·scale + atol``."""

    rtol: float = 1e-9
    atol: float = 1e-12

    def band(self, *magnitudes: float) -> float:
        finite = [abs(m) for m in magnitudes if math.isfinite(m)]
        return self.rtol * (max(finite) if finite else 0.0) + self.atol


def _num(value) -> Impulsive:
    return Impulsive(0.0, float(value))


def evaluate(expr: sp.Basic, values: Mapping[sp.Symbol, float], impulses: Mapping[sp.Symbol, float]) -> Impulsive:
    """Evaluate ``expr`` with ``values`` for its symbols, where a symbol in
    ``impulses`` (a state-derivative symbol) also carries a Dirac part of that
    area.  Raises :class:`ImpulseError` for a product of two pulses or a
    nonlinear function of one."""
    if expr.is_Number or expr in (sp.pi, sp.E):
        return _num(float(expr))
    if expr.is_Symbol:
        try:
            return Impulsive(float(impulses.get(expr, 0.0)), float(values[expr]))
        except KeyError:
            raise ImpulseError(f"no value for {expr} while evaluating a guard") from None
    args = [evaluate(a, values, impulses) for a in expr.args]
    if expr.is_Add:
        return Impulsive(sum(a.impulse for a in args), sum(a.finite for a in args))
    if expr.is_Mul:
        pulsed = [a for a in args if a.impulse]
        finite = math.prod(a.finite for a in args)
        if not pulsed:
            return _num(finite)
        if len(pulsed) > 1:
            raise ImpulseError(f"{expr} multiplies two Dirac pulses; such a product has no meaning")
        rest = math.prod(a.finite for a in args if a is not pulsed[0])
        return Impulsive(pulsed[0].impulse * rest, finite)
    if expr.is_Pow:
        base, exponent = args
        if exponent.impulse:
            raise ImpulseError(f"{expr} raises to an impulsive power")
        if base.impulse:
            if exponent.finite == 1:
                return base
            raise ImpulseError(f"{expr} is a nonlinear function of a Dirac pulse")
        return _num(base.finite**exponent.finite)
    if isinstance(expr, sp.Abs):
        (a,) = args
        if a.impulse:
            s = math.copysign(1.0, a.impulse)
            return Impulsive(abs(a.impulse), s * a.finite)
        return _num(abs(a.finite))
    if isinstance(expr, sp.sign):
        (a,) = args
        key = a.impulse or a.finite
        return _num(0.0 if key == 0 else math.copysign(1.0, key))
    if isinstance(expr, (sp.Min, sp.Max)):
        pick = min if isinstance(expr, sp.Min) else max
        return pick(args, key=lambda a: (a.impulse, a.finite))
    if any(a.impulse for a in args):
        raise ImpulseError(f"{expr} is a nonlinear function of a Dirac pulse")
    numeric = expr.func(*[sp.Float(a.finite) for a in args])
    return _num(complex(numeric.evalf()).real if not numeric.is_real else float(numeric))


def compare(relation: type, left: Impulsive, right: Impulsive, tol: Tolerance) -> bool:
    """Decide ``left <rel> right`` for a sympy relation class (Lt, Le, Gt, Ge, Eq, Ne)."""
    impulse = left.impulse - right.impulse
    impulse_band = tol.rtol * max(abs(left.impulse), abs(right.impulse)) * 1e3
    diff = left.finite - right.finite
    band = tol.band(left.finite, right.finite)
    if abs(impulse) > impulse_band and impulse != 0:
        sign = 1 if impulse > 0 else -1
        if relation in (sp.Lt, sp.Le, sp.StrictLessThan, sp.LessThan):
            return sign < 0
        if relation in (sp.Gt, sp.Ge, sp.StrictGreaterThan, sp.GreaterThan):
            return sign > 0
        if relation is sp.Eq or relation is sp.Equality:
            return False
        return True  # Ne
    if relation in (sp.Le, sp.LessThan):
        return diff <= band
    if relation in (sp.Lt, sp.StrictLessThan):
        return diff < -band
    if relation in (sp.Ge, sp.GreaterThan):
        return diff >= -band
    if relation in (sp.Gt, sp.StrictGreaterThan):
        return diff > band
    if relation in (sp.Eq, sp.Equality):
        return abs(diff) <= band
    if relation in (sp.Ne, sp.Unequality):
        return abs(diff) > band
    raise ImpulseError(f"unsupported relation {relation}")
