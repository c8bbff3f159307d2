"""The values of a netlist's component line, written as TOML and read back to the same Python values.

Each value has a shape (:data:`models.netlist_calls.SHAPES`) and is written so that it reads back
exactly (the same parts, the same model, the same run to the bit):

=============  ================================================================================
a number       a TOML float, written with ``repr`` (the same double read back)
a text         a TOML string: a parameter name, an expression of ``t``, a condition, a signal's
               text — passed to the builder as written, which parses it (never evaluates it)
true/false     a TOML boolean
sympy          ``{ expression = "2*R0" }``, printed by :mod:`switching.language.exprtext`
an input       ``{ input = "u" }`` (:class:`~models.circuits.Input`)
a PWM          ``{ period = 1e-05, duty = 0.5, delay = 2.5e-06, carrier = "sawtooth" }`` (``delay`` left
               out when 0, ``carrier`` when ``"triangle"``)
a law          ``{ of = "v", law = "1e-12*(exp(v/0.025) - 1)" }``: the law's expression of its
               variable ``of``; read back as a :class:`TextLaw` (a function of one argument)
limits         ``{ lo = 0.0, hi = 0.95 }`` (a controller's output limits; either side may be left out)
=============  ================================================================================

Reading checks each value's shape and parses every text with the toolkit's parser
(:mod:`switching.language.parsing`: no eval, no sympify of the text), within the size limits of model
files (:mod:`switching.files.errors`), so that a bad expression is refused at its component's line;
what a value means (a parameter name where a number is taken, a duty out of range) is the builder's
to check, and its refusal is reported at that line too.
"""

from __future__ import annotations

import json
import math
import numbers
import re
from dataclasses import dataclass

import sympy as sp

from bondgraph.symbols import t as TIME
from switching.errors import GuardSyntaxError
from switching.files.errors import (
    MAX_EXPRESSION_CHARS,
    MAX_EXPRESSION_TOKENS,
    count_tokens,
)
from switching.files.source import RESERVED_NAMES, kind_of
from switching.language.exprtext import ExpressionTextError, as_doubles, expression_text
from switching.language.parsing import parse_condition, parse_expression

from .circuits import PWM, Input
from .netlist import NAME
from .netlist_calls import SHAPES

__all__ = ["TextLaw", "toml_string", "toml_key", "toml_number", "toml_inline", "encode", "decode", "parsed_text"]


@dataclass(frozen=True)
class TextLaw:
    """A component's law read from a file: ``expression`` of the symbol ``variable``; called with
    the element's own variable, as the builder calls a law given as a function."""

    variable: sp.Symbol
    expression: sp.Expr

    def __call__(self, x):
        return self.expression.xreplace({self.variable: x})


class Unwritable(ValueError):
    """A value no model file can hold (the writer names the component and the argument)."""


# ------------------------------------------------------------------ TOML pieces


def toml_string(text: str) -> str:
    """A TOML basic string."""
    return json.dumps(str(text), ensure_ascii=False).replace("\x7f", "\\u007f")


def toml_key(name: str) -> str:
    """``name`` as a TOML key: bare where TOML allows it, else quoted."""
    return name if re.fullmatch(r"[A-Za-z0-9_-]+", name) else toml_string(name)


def toml_number(value) -> str:
    """A finite number as a TOML float that reads back to the same double."""
    number = float(value)
    if not math.isfinite(number):
        raise Unwritable(f"{number} is not a finite number")
    return repr(number)


def toml_inline(fields: dict) -> str:
    """An inline table of ``fields`` (key → TOML text)."""
    return "{ " + ", ".join(f"{toml_key(k)} = {v}" for k, v in fields.items()) + " }" if fields else "{}"


def _is_number(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, sp.Basic))


# ------------------------------------------------------------------ writing


def _number_or_text(value) -> str:
    if _is_number(value):
        return toml_number(value)
    if isinstance(value, str):
        return toml_string(value)
    raise Unwritable(f"{value!r} is neither a number nor a text")


def _expression(expr) -> str:
    try:
        return toml_inline({"expression": toml_string(expression_text(expr))})
    except ExpressionTextError as error:
        raise Unwritable(f"{expr} cannot be written as text: {error}") from None


def _law(function, base: str) -> str:
    """``{ of = ..., law = ... }`` of a law given as a function of one argument (or a :class:`TextLaw`)."""
    placeholder = sp.Dummy(base)
    try:
        expr = sp.sympify(function(placeholder))
    except Exception as error:  # noqa: BLE001 - a user's function: whatever it raises, it cannot be written
        raise Unwritable(f"its law {function!r} gives no expression of a symbol ({error})") from None
    taken = {s.name for s in expr.free_symbols if s != placeholder} | RESERVED_NAMES
    name, k = base, 2
    while name in taken:
        name, k = f"{base}{k}", k + 1
    try:
        text = expression_text(expr.xreplace({placeholder: sp.Symbol(name)}))
    except ExpressionTextError as error:
        raise Unwritable(f"its law {expr} cannot be written as text: {error}") from None
    return toml_inline({"of": toml_string(name), "law": toml_string(text)})


def encode(value, argument) -> str | None:
    """``value`` of ``argument`` (an :class:`~models.netlist_calls.Argument`) as TOML text, ``None``
    when there is nothing to write; :class:`Unwritable` when no file can hold it."""
    shape = argument.shape
    if shape == "law":
        return None if value is None else _law(value, argument.of)
    if shape == "limits":
        sides = {k: _number_or_text(v) for k, v in zip(("lo", "hi"), value or (None, None)) if v is not None}
        return toml_inline(sides) if sides else None
    if shape == "flag":
        if not isinstance(value, bool):
            raise Unwritable(f"{value!r} is not true or false")
        return "true" if value else "false"
    if shape == "number":
        if not _is_number(value):
            raise Unwritable(f"{value!r} is not a number")
        return toml_number(value)
    if isinstance(value, PWM) and shape == "schedule":
        fields = {"period": _number_or_text(value.period), "duty": _number_or_text(value.duty)}
        if value.delay:
            fields["delay"] = toml_number(value.delay)
        if value.carrier != "triangle":
            fields["carrier"] = toml_string(value.carrier)
        return toml_inline(fields)
    if shape != "value":  # a text, a condition, a schedule's condition
        if not isinstance(value, str):
            raise Unwritable(f"{value!r} is not a text")
        return toml_string(value)
    if isinstance(value, Input):
        return toml_inline({"input": toml_string(value.name)})
    if isinstance(value, sp.Expr):
        return _expression(value)
    return _number_or_text(value)


# ------------------------------------------------------------------ reading


def parsed_text(text, src, keys, culprit: str, what: str, condition: bool = False) -> sp.Basic:
    """``text`` parsed by the toolkit's parser within the model files' size limits (names it does not
    know are symbols: the builder decides what they are); else a
    :class:`~switching.files.errors.ModelFileError` at ``keys`` naming ``culprit``."""
    if not isinstance(text, str):
        raise src.error(f"{what} must be a text, not {kind_of(text)}", keys, culprit)
    if len(text) > MAX_EXPRESSION_CHARS or count_tokens(text) > MAX_EXPRESSION_TOKENS:
        raise src.error(f"{what} is longer than a model file allows ({MAX_EXPRESSION_CHARS} characters, "
                        f"{MAX_EXPRESSION_TOKENS} names, numbers and operators); name its parts as parameters",
                        keys, culprit)
    try:
        return (parse_condition if condition else parse_expression)(text, {"t": TIME})
    except GuardSyntaxError as error:
        raise src.error(f"{what} {text!r} cannot be read: {error}", keys, culprit) from None


def _plain(value, src, keys, culprit: str, what: str):
    """A number, or a text parsed (a parameter name, an expression)."""
    if _is_number(value):
        return value
    if isinstance(value, str):
        parsed_text(value, src, keys, culprit, what)
        return value
    raise src.error(f"{what} must be a number or a text, not {kind_of(value)}", keys, culprit)


def _name(value, src, keys, culprit: str, what: str) -> str:
    if not isinstance(value, str) or not NAME.fullmatch(value) or value in RESERVED_NAMES:
        raise src.error(f"{what} must be a name (letters, digits and '_', not a word of the expression "
                        f"language), not {value!r}", keys, culprit)
    return value


def _decode_table(value, shape: str, src, keys, culprit: str, what: str):
    """A value written as a table: an expression, an input, a PWM, a law or limits."""
    if shape == "law":
        table = src.table(value, keys, what, allowed=("of", "law"), required=("of", "law"), culprit=culprit)
        of = _name(table["of"], src, keys + ("of",), culprit, f"the variable of {what}")
        variable = sp.Symbol(of)
        text = table["law"]
        parsed_text(text, src, keys + ("law",), culprit, what)
        return TextLaw(variable, as_doubles(parse_expression(text, {"t": TIME, of: variable})))
    if shape == "limits":
        table = src.table(value, keys, what, allowed=("lo", "hi"), culprit=culprit)
        return tuple(None if side not in table else _plain(table[side], src, keys + (side,), culprit, what)
                     for side in ("lo", "hi"))
    if shape == "schedule" and "period" in value:
        table = src.table(value, keys, "a PWM", allowed=("period", "duty", "delay", "carrier"),
                          required=("period", "duty"), culprit=culprit)
        delay = table.get("delay", 0.0)
        if not _is_number(delay):
            raise src.error(f"the PWM's delay must be a number, not {kind_of(delay)}", keys + ("delay",), culprit)
        carrier = table.get("carrier", "triangle")
        if not isinstance(carrier, str):
            raise src.error(f"the PWM's carrier must be a text, not {kind_of(carrier)}", keys + ("carrier",), culprit)
        return PWM(_plain(table["period"], src, keys + ("period",), culprit, "the PWM's period"),
                   _plain(table["duty"], src, keys + ("duty",), culprit, "the PWM's duty"), delay, carrier)
    if shape == "value" and "expression" in value:
        table = src.table(value, keys, what, allowed=("expression",), culprit=culprit)
        return as_doubles(parsed_text(table["expression"], src, keys + ("expression",), culprit, what))
    if shape == "value" and "input" in value:
        table = src.table(value, keys, what, allowed=("input",), culprit=culprit)
        return Input(_name(table["input"], src, keys + ("input",), culprit, "an input's name"))
    raise src.error(f"{what} must be {SHAPES[shape]}, not a table of {', '.join(map(repr, value)) or 'nothing'}",
                    keys, culprit)


def decode(value, argument, src, keys, culprit: str):
    """The Python value a file's ``value`` of ``argument`` stands for (the module docstring); else a
    :class:`~switching.files.errors.ModelFileError` at ``keys`` naming ``culprit`` (``"component 'R1'"``)."""
    shape, what = argument.shape, argument.keyword
    expected = f"{what} must be {SHAPES[shape]}, not {kind_of(value)}"
    if isinstance(value, dict):
        return _decode_table(value, shape, src, keys, culprit, what)
    if shape == "flag":
        if not isinstance(value, bool):
            raise src.error(expected, keys, culprit)
        return value
    if shape == "number":
        if not _is_number(value):
            raise src.error(expected, keys, culprit)
        return value
    if shape in ("law", "limits") or (shape != "value" and not isinstance(value, str)):
        raise src.error(expected, keys, culprit)
    if isinstance(value, str):
        parsed_text(value, src, keys, culprit, what, condition=shape in ("condition", "schedule"))
        return value
    if not _is_number(value):
        raise src.error(expected, keys, culprit)
    return value
