"""sympy expressions and conditions as text that :mod:`switching.language.parsing` reads back exactly.

:func:`expression_text` and :func:`condition_text` print in the grammar of
:func:`~switching.language.parsing.parse_expression` / :func:`~switching.language.parsing.parse_condition`
(``+ - * / **``, the functions of :data:`switching.language.parsing.FUNCTIONS`, ``pi``,
``<``, ``<=``, …, ``and``, ``or``, ``not``), so that parsing the text with the
expression's names gives back the *same* sympy tree (``srepr`` equal), not just an
equivalent one: a model written to a file and read again has the same disk-cache
fingerprint.  What makes that work:

* sympy keeps sums and products in one canonical order whatever the order they
  were built in, so the printed order of terms is free (the usual reading order
  is used);
* a product ``a·b·c⁻¹`` is printed ``a*b/c`` and read back as ``a*b*c**(-1)``;
  sympy distributes an integer power over a product, so ``a/(b*c)`` also gives
  ``a·b⁻¹·c⁻¹`` back;
* a float is printed with Python's shortest round-trip form (``repr``), and a
  reader turns every float it parses into the nearest double (:func:`as_doubles`):
  sympy would otherwise keep the 17 digits of ``0.30000000000000004`` at more
  than double precision;
* ``/`` between two names is spaced (``p_J / J``): ``rod/p_J/J`` would read as
  the hierarchical name ``rod/p_J/J`` if the model had one.

Only what the parser can produce is printed: numbers (integers, fractions,
finite floats), symbols with valid names, ``pi``, ``E`` (as ``exp(1)``), the
parser's functions (a ``Heaviside(x, h0)`` as ``step(x)`` when ``h0 = 1``, else
as ``Heaviside(x, h0)``: ``Heaviside(x, 1/2)`` for sympy's ``Heaviside(x)``),
relations and ``and``/``or``/``not``.  Anything else (a ``Piecewise``, a
complex number, a derivative, a ``Dummy``) raises :class:`ExpressionTextError`
saying what it is.

Example::

    >>> import sympy as sp
    >>> from switching.language.parsing import parse_expression
    >>> m, g, p = sp.symbols("rod/m g rod/p_y")
    >>> expr = p / m - g * sp.sin(sp.Symbol("theta")) ** 2 / 2
    >>> text = expression_text(expr)
    >>> text
    '-g*sin(theta)**2/2 + rod/p_y / rod/m'
    >>> names = {s.name: s for s in expr.free_symbols}
    >>> sp.srepr(parse_expression(text, names)) == sp.srepr(expr)
    True
"""

from __future__ import annotations

import math
import re

import sympy as sp
from sympy.core.relational import Relational
from sympy.logic.boolalg import And, BooleanFalse, BooleanTrue, Not, Or

from bondgraph.symbols import NAME_PATTERN

from .parsing import FUNCTIONS

__all__ = ["ExpressionTextError", "expression_text", "condition_text", "as_doubles"]


class ExpressionTextError(ValueError):
    """A sympy object that the text grammar cannot express; ``node`` is the culprit."""

    def __init__(self, message: str, node=None):
        super().__init__(message)
        self.node = node


#: sympy class → name in the grammar (``sqrt`` is a power and printed as one)
_FUNCTION_NAMES = {cls: name for name, cls in FUNCTIONS.items() if isinstance(cls, type)}
#: names that the parser reads as something other than a symbol
_RESERVED = {"and", "or", "not", "true", "false", "pi"}
_RELATION_OPS = {sp.StrictLessThan: "<", sp.LessThan: "<=", sp.StrictGreaterThan: ">",
                 sp.GreaterThan: ">=", sp.Equality: "==", sp.Unequality: "!="}

# precedence levels, loosest first
_OR, _AND, _NOT, _REL, _ADD, _MUL, _POW, _ATOM = range(8)
_TRAILING_WORD = re.compile(r"[A-Za-z0-9_]+$")
_NAME_START = re.compile(r"^[A-Za-z_]")


def as_doubles(expr):
    """``expr`` with every float replaced by the nearest double (sympy keeps a
    float written with more than 15 digits at a higher precision)."""
    floats = {f: sp.Float(float(f)) for f in expr.atoms(sp.Float) if f._prec != 53}
    return expr.xreplace(floats) if floats else expr


def expression_text(expr) -> str:
    """``expr`` as text in the grammar of :func:`~switching.language.parsing.parse_expression`."""
    expr = sp.sympify(expr)
    if isinstance(expr, (Relational, And, Or, Not, BooleanTrue, BooleanFalse)):
        raise ExpressionTextError(f"{expr} is a condition, not an expression", expr)
    return _text(expr)[0]


def condition_text(condition) -> str:
    """``condition`` as text in the grammar of :func:`~switching.language.parsing.parse_condition`."""
    if not isinstance(condition, (Relational, And, Or, Not, BooleanTrue, BooleanFalse)):
        raise ExpressionTextError(f"{condition} is not a condition (a relation, and/or/not, true/false)", condition)
    return _text(condition)[0]


def _wrap(part: tuple[str, int], level: int, strict: bool = False) -> str:
    """The text of ``part``, in parentheses when it binds looser than ``level``
    (or as loose, with ``strict``)."""
    text, own = part
    return f"({text})" if own < level or (strict and own == level) else text


def _text(node) -> tuple[str, int]:
    """(text, precedence level) of one node."""
    if isinstance(node, BooleanTrue):
        return "true", _ATOM
    if isinstance(node, BooleanFalse):
        return "false", _ATOM
    if isinstance(node, Or):
        return " or ".join(_wrap(_text(a), _AND) for a in _ordered(node.args)), _OR
    if isinstance(node, And):
        return " and ".join(_wrap(_text(a), _NOT) for a in _ordered(node.args)), _AND
    if isinstance(node, Not):
        return f"not {_wrap(_text(node.args[0]), _NOT)}", _NOT
    if isinstance(node, Relational):
        op = _RELATION_OPS.get(type(node))
        if op is None:
            raise ExpressionTextError(f"the relation {node} ({type(node).__name__}) has no text form", node)
        left, right = node.args
        return f"{_wrap(_text(left), _ADD)} {op} {_wrap(_text(right), _ADD)}", _REL
    if node.is_Number:
        return _number(node)
    if isinstance(node, sp.Dummy):
        raise ExpressionTextError(f"the placeholder {node} cannot be written as text", node)
    if node.is_Symbol:
        return _symbol(node), _ATOM
    if node is sp.pi:
        return "pi", _ATOM
    if node is sp.E:
        return "exp(1)", _ATOM
    if node.is_Add:
        return _add(node)
    if node.is_Mul:
        return _mul(node)
    if node.is_Pow:
        return _pow(node)
    if isinstance(node, sp.Heaviside):
        return _step(node), _ATOM
    if type(node) in _FUNCTION_NAMES:
        return f"{_FUNCTION_NAMES[type(node)]}({', '.join(_text(a)[0] for a in node.args)})", _ATOM
    raise ExpressionTextError(
        f"{node} ({type(node).__name__}) cannot be written as text; the text grammar has numbers, names, "
        f"+ - * / **, pi and the functions {', '.join(sorted(FUNCTIONS))}",
        node,
    )


def _step(node) -> str:
    """``Heaviside(x, h0)`` as ``step(x)`` when ``h0 = 1`` (the text's unit
    step), else as ``Heaviside(x, h0)`` (sympy's ``Heaviside(x)`` has ``h0 = 1/2``)."""
    argument, at_zero = node.args
    if at_zero == 1:
        return f"step({_text(argument)[0]})"
    return f"Heaviside({_text(argument)[0]}, {_text(at_zero)[0]})"


def _ordered(args):
    return sorted(args, key=sp.default_sort_key)


def _symbol(node) -> str:
    name = node.name
    if not NAME_PATTERN.fullmatch(name) or name in _RESERVED:
        raise ExpressionTextError(
            f"the symbol {name!r} cannot be written as text: names are letters, digits and '_' "
            f"(hierarchy with '/'), and not one of {', '.join(sorted(_RESERVED))}",
            node,
        )
    return name


def _number(node) -> tuple[str, int]:
    if node.is_Integer:
        return str(int(node)), (_ADD if node < 0 else _ATOM)
    if node.is_Rational:
        return f"{node.p}/{node.q}", _MUL if node.p > 0 else _ADD
    if node.is_Float:
        value = float(node)
        if not math.isfinite(value):
            raise ExpressionTextError(f"the number {node} is not finite", node)
        text = repr(value)
        return text, (_ADD if value < 0 else _ATOM)
    raise ExpressionTextError(f"the number {node} ({type(node).__name__}) cannot be written as text", node)


def _negative(term) -> bool:
    """True when the term prints with a leading minus sign (a negative coefficient)."""
    if term.is_Number:
        return bool(term < 0)
    if term.is_Mul:
        coefficient = term.args[0]
        return bool(coefficient.is_Number and coefficient < 0)
    return False


def _add(node) -> tuple[str, int]:
    pieces = []
    for k, term in enumerate(node.as_ordered_terms()):
        if _negative(term):
            body = _wrap(_text(-term), _MUL)
            pieces.append(f"-{body}" if k == 0 else f" - {body}")
        else:
            body = _wrap(_text(term), _ADD)
            pieces.append(body if k == 0 else f" + {body}")
    return "".join(pieces), _ADD


def _mul(node) -> tuple[str, int]:
    coefficient, factors = node.as_coeff_mul()
    sign = ""
    if coefficient.is_Number and coefficient < 0:
        sign, coefficient = "-", -coefficient
    numerator, denominator = [], []
    if coefficient is not sp.S.One:  # a float 1.0 stays: it is part of the tree
        if coefficient.is_Rational and not coefficient.is_Integer:
            if coefficient.p != 1:
                numerator.append(sp.Integer(coefficient.p))
            denominator.append(sp.Integer(coefficient.q))
        else:
            numerator.append(coefficient)
    for factor in factors:
        exponent = factor.exp if factor.is_Pow else None
        if exponent is not None and exponent.is_Number and exponent < 0:
            denominator.append(sp.Pow(factor.base, -exponent))
        else:
            numerator.append(factor)
    text = _product(numerator) if numerator else "1"
    if denominator:
        bottom = _product(denominator) if len(denominator) > 1 else _wrap(_text(denominator[0]), _MUL, strict=True)
        if len(denominator) > 1:
            bottom = f"({bottom})"
        text = _divide(text, bottom)
    return f"{sign}{text}", (_ADD if sign else _MUL)


def _product(factors) -> str:
    ordered = [f for f in factors if f.is_Number] + _ordered([f for f in factors if not f.is_Number])
    return "*".join(_wrap(_text(f), _MUL) for f in ordered)


def _divide(top: str, bottom: str) -> str:
    word = _TRAILING_WORD.search(top)
    if word and _NAME_START.match(word.group()) and _NAME_START.search(bottom):
        return f"{top} / {bottom}"
    return f"{top}/{bottom}"


def _pow(node) -> tuple[str, int]:
    base, exponent = node.args
    if exponent == sp.S.Half:
        return f"sqrt({_text(base)[0]})", _ATOM
    if exponent.is_Number and exponent < 0:
        return _reciprocal(base, -exponent)
    base_text = _text(base)
    # the base binds tighter than '**' only as an atom; a negative number needs parentheses
    base_str = base_text[0] if base_text[1] == _ATOM else f"({base_text[0]})"
    exponent_text = _text(exponent)
    exponent_str = exponent_text[0] if exponent_text[1] == _ATOM else f"({exponent_text[0]})"
    return f"{base_str}**{exponent_str}", _POW


def _reciprocal(base, exponent) -> tuple[str, int]:
    """``1/base**exponent`` for a positive number ``exponent``."""
    bottom = _text(sp.Pow(base, exponent))
    return _divide("1", _wrap(bottom, _MUL, strict=True)), _MUL
