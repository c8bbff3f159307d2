"""Real numbers only.

Every quantity of a bond graph (effort, flow, state, parameter, restitution)
is a real number.  A complex value given where one is expected (``C=1j``, a
capacitance ``sp.I``, a resistance ``2+3j``, a restitution ``sqrt(-1)``, a
parameter ``np.complex128(1+2j)``) would ride along in the equations and have
its imaginary part dropped, with a ``ComplexWarning`` at best, when numbers
are stored: it is refused where it is given, with
:class:`~bondgraph.errors.ParameterValueError` naming it.  A complex number
whose imaginary part is exactly zero is its real part.
"""

from __future__ import annotations

from numbers import Complex, Real

import sympy as sp

from .errors import ParameterValueError

__all__ = ["imaginary_part", "real_expression", "real_number"]


def imaginary_part(value) -> float:
    """The imaginary part of a number (Python, numpy or sympy), 0 for a
    real one and for anything that is not a number."""
    if isinstance(value, sp.Basic):
        if not value.is_number or not value.has(sp.I):
            return 0.0
        try:
            return float(sp.im(value).evalf())
        except (TypeError, ValueError):
            return float("nan")  # complex infinity and the like: not real either
    if isinstance(value, Complex) and not isinstance(value, Real):
        return float(complex(value).imag)
    return 0.0


def _refusal(what: str, value, name: str) -> ParameterValueError:
    return ParameterValueError(
        f"{what} is {value!r}, a complex value: the toolkit computes with real numbers only (efforts, flows, "
        "states, parameters and restitution coefficients are real). Give a real value.", name, value)


def real_number(value, what: str, name: str):
    """``value`` itself (its real part for a complex number with a zero
    imaginary part); :class:`ParameterValueError` when it is complex."""
    if isinstance(value, (float, int)):  # (real: told without the number tower's abstract checks, ~4 µs)
        return value
    imag = imaginary_part(value)
    if imag != 0:
        raise _refusal(what, value, name)
    if isinstance(value, Complex) and not isinstance(value, Real):
        return complex(value).real
    return value


def real_expression(expr: sp.Basic, what: str, given=None) -> sp.Basic:
    """``expr`` when it has no imaginary unit ``I`` in it; else
    :class:`ParameterValueError` (a law, value or modulus written with ``I``
    yields complex values)."""
    if not isinstance(expr, sp.Basic) or not expr.has(sp.I):
        return expr
    if expr.is_number and imaginary_part(expr) == 0:
        return sp.re(expr)
    shown = given if given is not None else expr
    if expr.is_number:
        raise _refusal(what, shown, what)
    raise ParameterValueError(
        f"{what} is {expr}, which has the imaginary unit I in it: the toolkit computes with real numbers only. "
        "Write it with real numbers and functions (I*I = -1, exp(I*x) + exp(-I*x) = 2*cos(x)).", what, shown)
