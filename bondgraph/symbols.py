"""Symbols shared by the whole toolkit and the conversion of user values to sympy.

No text is ever evaluated: a string given where an expression is expected must
be a plain (optionally hierarchical) name and becomes a :class:`sympy.Symbol`.
Expressions are passed as sympy objects built in the user's own code.
"""

from __future__ import annotations

import re
from numbers import Number

import sympy as sp
from sympy.core.relational import Relational
from sympy.logic.boolalg import BooleanAtom, BooleanFunction

from .errors import InvalidGraphError
from .reals import real_expression

__all__ = ["t", "as_expr", "parameter", "rate_symbol", "check_name", "NAME_PATTERN"]

#: Time, the one independent variable [s].  Use it in source expressions,
#: e.g. ``Se("V", V0 * sp.sin(w * t))``.
t = sp.Symbol("t")

#: Element, parameter and state names: identifiers, optionally joined by ``/``
#: for hierarchy (``cell3/C``).
NAME_PATTERN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*")  # use fullmatch: a whole name


def check_name(name: str, what: str = "name") -> str:
    """Return ``name`` if it is a valid (hierarchical) identifier, else raise."""
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise InvalidGraphError(
            f"invalid {what} {name!r}: use letters, digits and '_' (not starting with a digit), "
            "with '/' separating hierarchy levels, e.g. 'cell3/C'"
        )
    return name


def parameter(name: str) -> sp.Symbol:
    """The parameter symbol called ``name`` (validated, no assumptions)."""
    return sp.Symbol(check_name(name, "parameter name"))


def as_expr(value, what: str = "value") -> sp.Expr:
    """Convert a user value to a sympy expression without evaluating text.

    numbers → sympy numbers (floats stay floats); a string → the parameter
    symbol of that name (it must be a plain name, not a formula); sympy
    expressions pass unchanged.  Complex values (``1j``, ``sp.I``, a law
    with ``I`` in it) are refused (:mod:`bondgraph.reals`).
    """
    if isinstance(value, sp.Basic):
        if isinstance(value, (Relational, BooleanFunction, BooleanAtom)):
            raise InvalidGraphError(f"{what} must be an expression, not a condition: {value}")
        return real_expression(value, what)
    if isinstance(value, bool):
        raise InvalidGraphError(f"{what} must be a number, a parameter name or a sympy expression, not {value!r}")
    if isinstance(value, Number):
        return real_expression(sp.sympify(value), what, value)  # numbers only: no text reaches sympify
    if isinstance(value, str):
        if not NAME_PATTERN.fullmatch(value):
            raise InvalidGraphError(
                f"{what} {value!r} is not a parameter name; formulas are not parsed from text here: "
                "build them with sympy (e.g. sp.Symbol('R0') * f**3)"
            )
        return sp.Symbol(value)
    raise InvalidGraphError(
        f"{what} must be a number, a parameter name or a sympy expression, got {type(value).__name__}"
    )


def rate_symbol(state: sp.Symbol) -> sp.Symbol:
    """The symbol standing for ``d(state)/dt`` in derivative-causality relations."""
    return sp.Symbol(f"d{state.name}/dt")
