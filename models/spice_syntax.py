"""SPICE's text as :mod:`models.spice` reads it: the errors, numbers with their scale factors,
``{expression}`` values (parsed by the toolkit's own parser, never evaluated as code), logical lines
(comments removed, continuations joined) and the tokens of a card."""

from __future__ import annotations

import re
from dataclasses import dataclass
from fractions import Fraction

import sympy as sp

from bondgraph import HybridBondGraphError
from switching.language.parsing import FUNCTIONS, parse_expression

__all__ = ["SpiceNetlistError", "SpiceSyntaxError", "UnsupportedCardError", "SpiceExportError", "exact_number",
           "number", "evaluate", "translate", "float_text", "Expression", "Card", "logical_lines", "card_tokens",
           "keywords", "is_word", "as_expression"]


# ---------------------------------------------------------------------------------------------- errors

class SpiceNetlistError(HybridBondGraphError, ValueError):
    """A netlist this reader does not take: ``source`` (its path, or ``<text>``), ``line`` (the number
    of the card's first line, 1-based) and ``card`` (its text) say where; the message says what to do."""

    def __init__(self, message: str, line: int | None = None, card: str = "", source: str = ""):
        super().__init__(message)
        self.line, self.card, self.source = line, card, source


class SpiceSyntaxError(SpiceNetlistError):
    """A card that is not written as SPICE writes it (a missing node or value, an unclosed
    parenthesis, a number that is none)."""


class UnsupportedCardError(SpiceNetlistError):
    """A card outside the subset read (a transistor, an ``.ac`` analysis, a model type, an option)."""


class SpiceExportError(HybridBondGraphError, ValueError):
    """A part of a circuit that :func:`write` cannot express in SPICE; ``part`` names it."""

    def __init__(self, message: str, part: str = ""):
        super().__init__(message)
        self.part = part


# ---------------------------------------------------------------------------------------------- numbers

#: SPICE's scale factors (case-insensitive; ``meg`` and ``mil`` before ``m``)
_SCALES = {"t": Fraction(10**12), "g": Fraction(10**9), "meg": Fraction(10**6), "k": Fraction(1000),
           "mil": Fraction(254, 10**7), "m": Fraction(1, 1000), "u": Fraction(1, 10**6),
           "n": Fraction(1, 10**9), "p": Fraction(1, 10**12), "f": Fraction(1, 10**15),
           "a": Fraction(1, 10**18)}
_NUMBER = re.compile(r"([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)([A-Za-z]*)")
#: the most characters a number's digits may have (the toolkit's parser's limit)
MAX_NUMBER_LENGTH = 100


def exact_number(text: str) -> Fraction | None:
    """The exact value of a SPICE number (``"10uF"`` → 1/100000), ``None`` if ``text`` is none:
    digits with an optional exponent, then letters — a scale (``t g meg k mil m u n p f a``, any case)
    and unit letters after it, which are ignored (``"1kOhm"``, ``"5V"``)."""
    match = _NUMBER.fullmatch(text.strip())
    if not match or len(match.group(1)) > MAX_NUMBER_LENGTH:
        return None
    exponent = re.search(r"[eE]([+-]?\d+)$", match.group(1))
    if exponent and abs(int(exponent.group(1))) > 400:  # (beyond a double's range; 10**10**8 is no number to build)
        return None
    letters = match.group(2).lower()
    scale = next((_SCALES[s] for s in ("meg", "mil") if letters.startswith(s)), None)
    if scale is None:
        scale = _SCALES.get(letters[:1], Fraction(1))
    return Fraction(match.group(1)) * scale


def number(text: str) -> float:
    """A SPICE number as a float: ``number("1meg")`` = 1e6, ``number("1m")`` = 1e-3,
    ``number("10uF")`` = 1e-5; :class:`SpiceSyntaxError` when ``text`` is no number."""
    value = exact_number(text)
    if value is None:
        raise SpiceSyntaxError(f"{text!r} is not a SPICE number (digits, an optional exponent, then an "
                               "optional scale t g meg k m u n p f and units: 10uF, 1kOhm, 2.2e-3)")
    return float(value)


def float_text(value) -> str:
    """A number as the expression texts write it: the float's shortest exact form."""
    return repr(float(value))


# ---------------------------------------------------------------------------------------------- expressions

#: SPICE's names of functions the toolkit's parser knows by another name
_FUNCTION_NAMES = {"ln": "log", "sgn": "sign", "u": "step"}
_EXPRESSION_TOKEN = re.compile(r"(?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?[A-Za-z]*)"
                               r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*)|(?P<space>\s+)|(?P<other>.)")


def _exact(value: Fraction | float) -> sp.Expr:
    """A value as sympy keeps it exactly (a rational of modest size), else as a float."""
    if isinstance(value, Fraction) and max(abs(value.numerator), value.denominator).bit_length() <= 512:
        return sp.Rational(value.numerator, value.denominator)
    return sp.Float(float(value))


def translate(text: str, lookup, time: bool = False) -> tuple[str, dict]:
    """SPICE expression ``text`` as the toolkit's parser reads it: numbers (scales included) and
    ``.param`` names (``lookup(name)`` → value, or ``None``) become names bound to their exact values
    (with ``time``: written in as floats, and ``time`` is ``t``), SPICE's function names the
    parser's.  Returns the text and the names' values.  An unknown name is a :class:`SpiceSyntaxError`."""
    parts, names = [], {}
    for match in _EXPRESSION_TOKEN.finditer(text):
        kind, token = match.lastgroup, match.group()
        following = text[match.end():].lstrip()[:1]
        if kind == "number":
            value = exact_number(token)
            if value is None:
                raise SpiceSyntaxError(f"{token!r} in {{{text}}} is not a number")
            parts.append(_bound(value, names, time))
        elif kind == "name":
            parts.append(_name_in_expression(token, following, text, lookup, names, time))
        else:
            parts.append(token)
    return "".join(parts), names


def _name_in_expression(token, following, text, lookup, names, time) -> str:
    """One name of an expression: a function (when a ``(`` follows), ``pi``, ``time``, or a parameter."""
    lower = token.lower()
    if following == "(":
        if time and lower in ("v", "i"):
            raise UnsupportedCardError(f"{{{text}}} reads a node voltage or a current ({token}(…)): only "
                                       "expressions of time and .param values are read")
        function = _FUNCTION_NAMES.get(lower, lower)
        if function not in FUNCTIONS:
            raise SpiceSyntaxError(f"{{{text}}}: unknown function {token!r}; known: "
                                   f"{', '.join(sorted(set(FUNCTIONS) - {'Heaviside'}))}, ln, sgn, u")
        return function
    if lower == "pi":
        return "pi"
    if time and lower == "time":
        return "t"
    value = lookup(lower)
    if value is None:
        raise SpiceSyntaxError(f"{{{text}}}: unknown parameter {token!r}; define it with .param "
                               f"{token}=value")
    return _bound(value, names, time)


def _bound(value, names: dict, inline: bool) -> str:
    """A value in a translated expression: written in as a float (``inline``), or a name bound to it."""
    if inline:
        return f"({float_text(value)})"
    names[f"spice_value_{len(names)}"] = _exact(value)
    return f"spice_value_{len(names) - 1}"


def evaluate(text: str, lookup=lambda name: None) -> Fraction | float:
    """The value of a SPICE expression (the text inside ``{…}``) of numbers and parameters
    (``lookup(name)`` → value or ``None``), parsed by :func:`switching.language.parsing.parse_expression`
    (never evaluated as code); exact where the arithmetic is rational."""
    translated, names = translate(text, lookup)
    try:
        value = parse_expression(translated, names)
    except HybridBondGraphError as error:
        why = str(error).splitlines()[0]
        for name, value in sorted(names.items(), key=lambda item: -len(item[0])):  # (the numbers, not their names)
            why = why.replace(name, float_text(value))
        raise SpiceSyntaxError(f"{{{text}}} is not an expression of numbers and parameters: {why}") from None
    if not isinstance(value, sp.Expr) or not value.is_number or not value.is_real:
        raise SpiceSyntaxError(f"{{{text}}} is not a real number")
    if value.is_Rational:
        return Fraction(int(value.p), int(value.q))
    return float(value)


# ---------------------------------------------------------------------------------------------- lines and tokens

class Expression(str):
    """A ``{…}`` (or ``'…'``) expression among a card's tokens: its text without the delimiters."""


@dataclass(frozen=True)
class Card:
    """One logical line: the number of its first physical line, its text (comments removed,
    continuations joined) and its tokens."""

    line: int
    text: str
    tokens: tuple

    @property
    def head(self) -> str:
        return self.tokens[0]


def _uncommented(raw: str) -> str:
    """A physical line without its comment: a whole ``*`` line, or what follows ``;`` or `` $``."""
    if raw.lstrip().startswith("*"):
        return ""
    raw = raw.split(";", 1)[0]
    match = re.search(r"\s\$", raw)
    return raw[:match.start()] if match else raw


def logical_lines(text: str, where) -> tuple[str, list[tuple[int, str]], list[str]]:
    """``(title, [(line, text)], notes)``: the title (the first line, a leading ``*`` dropped), then
    each card with its continuation lines joined, up to ``.end``; ``.control`` … ``.endc`` blocks are
    skipped.  ``where(cls, line, text, message)`` makes the errors."""
    physical = text.splitlines()
    title = physical[0].strip().lstrip("*").strip() if physical else ""
    cards, notes, control = [], [], None
    for number_, raw in enumerate(physical[1:], start=2):
        line = _uncommented(raw).strip()
        word = line.split(None, 1)[0].lower() if line else ""
        if control is not None:
            control = None if word == ".endc" else control
            continue
        if not line:
            continue
        if word == ".control":
            control = number_
            notes.append(f"line {number_}: the .control … .endc block (ngspice's commands) is skipped")
        elif line.startswith("+"):
            if not cards:
                raise where(SpiceSyntaxError, number_, line, "a continuation line ('+') with no card before "
                            "it; the first line of a netlist is its title")
            cards[-1] = (cards[-1][0], f"{cards[-1][1]} {line[1:].strip()}")
        elif word == ".end":
            break
        else:
            cards.append((number_, line))
    if control is not None:
        raise where(SpiceSyntaxError, control, ".control", "a .control block without its .endc")
    return title, cards, notes


def card_tokens(text: str) -> tuple:
    """The tokens of a card: words, ``(``, ``)``, ``=``, and ``{…}``/``'…'`` expressions
    (:class:`Expression`); commas separate like spaces."""
    out, i = [], 0
    while i < len(text):
        ch = text[i]
        if ch.isspace() or ch == ",":
            i += 1
        elif ch in "()=":
            out.append(ch)
            i += 1
        elif ch in "{'":
            i = _expression_token(text, i, out)
        elif ch == "}":
            raise SpiceSyntaxError("a '}' without its '{'")
        else:
            j = i
            while j < len(text) and not (text[j].isspace() or text[j] in ",()={}'"):
                j += 1
            out.append(text[i:j])
            i = j
    return tuple(out)


def _expression_token(text: str, start: int, out: list) -> int:
    """Append the ``{…}`` (nested braces) or ``'…'`` expression at ``start``; return where it ends."""
    if text[start] == "'":
        end = text.find("'", start + 1)
        if end < 0:
            raise SpiceSyntaxError("a quote ' without its closing quote")
        out.append(Expression(text[start + 1:end]))
        return end + 1
    depth = 0
    for j in range(start, len(text)):
        depth += {"{": 1, "}": -1}.get(text[j], 0)
        if depth == 0:
            out.append(Expression(text[start + 1:j]))
            return j + 1
    raise SpiceSyntaxError("a '{' without its '}'")


def keywords(tokens) -> tuple[list, dict]:
    """``(positional, {key (lower case): value token})`` of ``tokens``: ``KEY = value`` pairs wherever
    they are; parentheses are dropped."""
    tokens = [t for t in tokens if isinstance(t, Expression) or t not in ("(", ")")]
    positional, keys, i = [], {}, 0
    while i < len(tokens):
        if i + 1 < len(tokens) and tokens[i + 1] == "=":
            if i + 2 >= len(tokens):
                raise SpiceSyntaxError(f"{tokens[i]}= has no value")
            keys[str(tokens[i]).lower()] = tokens[i + 2]
            i += 3
        else:
            positional.append(tokens[i])
            i += 1
    return positional, keys


def is_word(token) -> bool:
    """Is ``token`` a plain word (no expression, parenthesis or ``=``)?"""
    return isinstance(token, str) and not isinstance(token, Expression) and token not in ("(", ")", "=")


def as_expression(token):
    """A ``.param`` value: a bare ``2*a`` is an expression as ``{2*a}`` is."""
    return token if isinstance(token, Expression) else Expression(token)
