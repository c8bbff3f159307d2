"""Guards written as text, parsed into sympy *without executing code*.

Grammar (usual precedence, ``**``/``^`` right-associative)::

    condition := disjunct ('or' disjunct)*          ('||' also accepted)
    disjunct  := negation ('and' negation)*         ('&&' also accepted)
    negation  := ('not' | '!') negation | comparison
    comparison:= sum (('<' | '<=' | '>' | '>=' | '==' | '!=') sum)*   (chains are 'and'-ed)
    sum       := product (('+' | '-') product)*
    product   := unary (('*' | '/') unary)*
    unary     := ('-' | '+') unary | power
    power     := atom (('**' | '^') unary)?
    atom      := number | name | function '(' sum (',' sum)* ')' | '(' condition ')'
                 | 'true' | 'false' | 'pi'

Names are looked up in the mapping the caller gives (signals, states,
parameters, ``t``); a hierarchical name such as ``rod/theta`` is one name if
known, otherwise ``/`` is a division.  Unknown plain names become parameter
symbols (their values are then required like any other parameter).
Functions: abs, sign, sqrt, exp, log, sin, cos, tan, asin, acos, atan, atan2,
sinh, cosh, tanh, min, max.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import sympy as sp
from sympy.core.relational import Relational
from sympy.logic.boolalg import Boolean, BooleanAtom, BooleanFunction

from .errors import GuardSyntaxError

__all__ = ["parse_condition", "parse_expression", "FUNCTIONS"]

FUNCTIONS = {
    "abs": sp.Abs,
    "sign": sp.sign,
    "sqrt": sp.sqrt,
    "exp": sp.exp,
    "log": sp.log,
    "sin": sp.sin,
    "cos": sp.cos,
    "tan": sp.tan,
    "asin": sp.asin,
    "acos": sp.acos,
    "atan": sp.atan,
    "atan2": sp.atan2,
    "sinh": sp.sinh,
    "cosh": sp.cosh,
    "tanh": sp.tanh,
    "min": sp.Min,
    "max": sp.Max,
}

_TOKEN = re.compile(
    r"\s*(?:"
    r"(?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*(?:/[A-Za-z_][A-Za-z0-9_]*)*)"
    r"|(?P<op><=|>=|==|!=|\*\*|&&|\|\||[-+*/^()<>,!])"
    r")"
)
_KEYWORDS = {"and", "or", "not", "true", "false", "pi"}
_RELATIONS = {"<": sp.Lt, "<=": sp.Le, ">": sp.Gt, ">=": sp.Ge, "==": sp.Eq, "!=": sp.Ne}


def _tokenize(text: str, names: Mapping[str, sp.Basic]) -> list[tuple[str, str, int]]:
    tokens, pos = [], 0
    text = text.rstrip()
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if not m or m.end() == pos:
            raise GuardSyntaxError(f"unexpected character {text[pos]!r}", text, pos)
        start = m.start(m.lastgroup)
        kind, value = m.lastgroup, m.group(m.lastgroup)
        if kind == "name" and "/" in value and value not in names:
            # the longest known hierarchical names, divided by what is left
            parts = value.split("/")
            offset, i = start, 0
            while i < len(parts):
                j = next(
                    (j for j in range(len(parts), i, -1) if "/".join(parts[i:j]) in names),
                    i + 1,
                )
                name = "/".join(parts[i:j])
                tokens.append(("name", name, offset))
                offset += len(name)
                if j < len(parts):
                    tokens.append(("op", "/", offset))
                    offset += 1
                i = j
        else:
            tokens.append((kind, value, start))
        pos = m.end()
    tokens.append(("end", "", len(text)))
    return tokens


class _Parser:
    def __init__(self, text: str, names: Mapping[str, sp.Basic]):
        self.text = text
        self.names = names
        self.tokens = _tokenize(text, names)
        self.i = 0

    # -- token helpers
    def peek(self):
        return self.tokens[self.i]

    def take(self):
        tok = self.tokens[self.i]
        self.i += 1
        return tok

    def accept(self, *values) -> bool:
        kind, value, _ = self.peek()
        if (kind == "op" or (kind == "name" and value in _KEYWORDS)) and value in values:
            self.i += 1
            return True
        return False

    def expect(self, value):
        if not self.accept(value):
            _, got, pos = self.peek()
            raise GuardSyntaxError(f"expected {value!r}, found {got or 'the end'!r}", self.text, pos)

    def fail(self, message):
        raise GuardSyntaxError(message, self.text, self.peek()[2])

    # -- grammar
    def condition(self):
        left = self.disjunct()
        while self.accept("or", "||"):
            left = sp.Or(self._boolean(left), self._boolean(self.disjunct()))
        return left

    def disjunct(self):
        left = self.negation()
        while self.accept("and", "&&"):
            left = sp.And(self._boolean(left), self._boolean(self.negation()))
        return left

    def negation(self):
        if self.accept("not", "!"):
            return sp.Not(self._boolean(self.negation()))
        return self.comparison()

    def comparison(self):
        left = self.sum()
        relations = []
        while self.peek()[0] == "op" and self.peek()[1] in _RELATIONS:
            op = self.take()[1]
            right = self.sum()
            relations.append(_RELATIONS[op](self._number(left), self._number(right), evaluate=False))
            left = right
        if not relations:
            return left
        return relations[0] if len(relations) == 1 else sp.And(*relations)

    def sum(self):
        left = self.product()
        while True:
            if self.accept("+"):
                left = self._number(left) + self._number(self.product())
            elif self.accept("-"):
                left = self._number(left) - self._number(self.product())
            else:
                return left

    def product(self):
        left = self.unary()
        while True:
            if self.accept("*"):
                left = self._number(left) * self._number(self.unary())
            elif self.accept("/"):
                left = self._number(left) / self._number(self.unary())
            else:
                return left

    def unary(self):
        if self.accept("-"):
            return -self._number(self.unary())
        if self.accept("+"):
            return self._number(self.unary())
        return self.power()

    def power(self):
        base = self.atom()
        if self.accept("**", "^"):
            return self._number(base) ** self._number(self.unary())
        return base

    def atom(self):
        kind, value, pos = self.peek()
        if kind == "number":
            self.take()
            return sp.Float(value) if any(c in value for c in ".eE") else sp.Integer(value)
        if kind == "op" and value == "(":
            self.take()
            inner = self.condition()
            self.expect(")")
            return inner
        if kind == "name":
            self.take()
            if value == "true":
                return sp.true
            if value == "false":
                return sp.false
            if value == "pi":
                return sp.pi
            if value in ("and", "or", "not"):
                raise GuardSyntaxError(f"{value!r} needs a condition on its left", self.text, pos)
            if self.peek()[1] == "(" and self.peek()[0] == "op":
                return self.call(value, pos)
            if value in self.names:
                return self.names[value]
            return sp.Symbol(value)
        raise GuardSyntaxError(f"expected a number, a name or '(' but found {value or 'the end'!r}", self.text, pos)

    def call(self, name, pos):
        if name not in FUNCTIONS:
            raise GuardSyntaxError(
                f"unknown function {name!r}; available: {', '.join(sorted(FUNCTIONS))}", self.text, pos
            )
        self.expect("(")
        args = [self._number(self.sum())]
        while self.accept(","):
            args.append(self._number(self.sum()))
        self.expect(")")
        try:
            return FUNCTIONS[name](*args)
        except TypeError:
            raise GuardSyntaxError(f"wrong number of arguments to {name}()", self.text, pos) from None

    # -- type checks
    def _number(self, value):
        if isinstance(value, (Relational, BooleanFunction, BooleanAtom)):
            self.fail("a condition is used where a number is expected")
        return value

    def _boolean(self, value):
        if not isinstance(value, (Relational, BooleanFunction, BooleanAtom)):
            self.fail(f"{value} is a number, not a condition (compare it with <, <=, >, >=, == or !=)")
        return value

    def parse(self, want_condition: bool):
        result = self.condition()
        if self.peek()[0] != "end":
            self.fail(f"unexpected {self.peek()[1]!r}")
        if want_condition:
            return self._boolean(result)
        return self._number(result)


def parse_condition(text: str, names: Mapping[str, sp.Basic] | None = None) -> Boolean:
    """Parse a guard such as ``"tip_y <= 0 and tip_vy < 0"`` into a sympy Boolean."""
    if not isinstance(text, str) or not text.strip():
        raise GuardSyntaxError("a guard must be a non-empty text or a sympy condition", str(text))
    return _Parser(text, names or {}).parse(want_condition=True)


def parse_expression(text: str, names: Mapping[str, sp.Basic] | None = None) -> sp.Expr:
    """Parse an arithmetic expression such as ``"m*(vy - g)"`` into sympy."""
    if not isinstance(text, str) or not text.strip():
        raise GuardSyntaxError("an expression must be a non-empty text", str(text))
    return _Parser(text, names or {}).parse(want_condition=False)
