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
Functions: abs, sign, sqrt, exp, log (``log(x, base)`` too), sin, cos, tan,
asin, acos, atan, atan2, sinh, cosh, tanh, min, max, step and Heaviside.

The unit step
-------------
``step(x)`` and ``Heaviside(x)`` are the engineers' unit step, *right-continuous*:
0 for ``x < 0`` and 1 for ``x ≥ 0``, so ``step(0) = 1`` (sympy's
``Heaviside(x, 1)``; sympy's own ``Heaviside(x)`` is ½ at 0).
``Heaviside(x, h0)`` gives the value at 0 explicitly: ``Heaviside(x, 1/2)`` is
sympy's ``Heaviside(x)``, the form a model built in Python with
``sp.Heaviside(x)`` is written to a model file in.  Where a step jumps — in an
element law, or in an input given as an expression of time
(:mod:`switching.model.stepped_inputs`) — it is a law switch
(:mod:`bondgraph.law_switches`): the crossing of ``x = 0`` is located as an
event and the flows on either side see 0 and 1, so a source ``V*step(t - t1)``
is off up to ``t1`` and on after it.  The value at 0 is what a signal, a guard
or an input's value reads where ``x = 0`` — ``V`` at ``t1``: the source is on
from ``t1`` itself — and what a law that stays continuous across the step
(``c*f*step(f)``, left as written) reads.

Limits
------
Bad text never hangs the parser and never reaches sympy's exact arithmetic
unchecked: every piece is checked *before* sympy combines it, and each
violation raises :class:`~switching.errors.GuardSyntaxError` (a
``ValueError``) that names the culprit, says what to do and puts a caret
under it.  No real guard comes near these limits (the longest guard of the
shipped models has 21 tokens and nests 2 levels):

* :data:`MAX_TOKENS` numbers, names and operators in one text;
* :data:`MAX_NESTING` levels of nesting — each parenthesis, function call,
  prefix sign or ``not``, and exponent counts one level;
* :data:`MAX_NUMBER_LENGTH` characters in one number literal;
* every number, written or computed from numbers (``1e400``, ``10**400``,
  ``9**9**9``, ``1e300*1e300``, ``exp(1000)``), must be finite in double
  precision: at most :data:`MAX_MAGNITUDE` in magnitude, and not a nonzero
  value that rounds to 0 (below :data:`MIN_MAGNITUDE`).  The size of a
  numeric power is bounded from logarithms in floating point before sympy
  computes it, so exponent towers fail at once;
* division by a number that is 0 (``1/0``, ``x/(2-2)``), 0 to a negative
  power, and anything sympy evaluates to an infinity or NaN (``log(0)``,
  ``tan(pi/2)``, ``atan2(0, 0)``) are refused rather than becoming ``zoo``
  (a guard that would silently never fire);
* a power of a non-numeric base (``x**e``) takes a numeric exponent of at
  most :data:`MAX_SYMBOLIC_EXPONENT` in magnitude;
* exact fractions sympy keeps (``1/3``, ``2**-500``) have at most
  :data:`MAX_EXACT_BITS` bits in numerator and denominator;
* ``min``/``max`` take at most :data:`MAX_MINMAX_ARGUMENTS` values (nested
  calls of the same function merge into one), as sympy compares them pairwise.
"""

from __future__ import annotations

import cmath
import math
import re
import sys
from collections.abc import Mapping

import sympy as sp
from sympy.core.relational import Relational
from sympy.logic.boolalg import Boolean, BooleanAtom, BooleanFunction

from ..errors import GuardSyntaxError

__all__ = [
    "parse_condition",
    "parse_expression",
    "FUNCTIONS",
    "MAX_TOKENS",
    "MAX_NESTING",
    "MAX_NUMBER_LENGTH",
    "MAX_MAGNITUDE",
    "MIN_MAGNITUDE",
    "MAX_SYMBOLIC_EXPONENT",
    "MAX_EXACT_BITS",
    "MAX_MINMAX_ARGUMENTS",
    "unit_step",
]


def unit_step(x, value_at_zero=sp.S.One):
    """``Heaviside(x, h0)``: 0 for ``x < 0``, 1 for ``x > 0`` and ``h0`` at
    ``x = 0``, by default 1 (the right-continuous unit step of the module
    docstring)."""
    return sp.Heaviside(x, value_at_zero)


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
    "step": unit_step,
    "Heaviside": unit_step,
}

# -- limits (see the module docstring); a real guard never meets them
#: Numbers, names and operators in one text.  sympy's canonical ordering makes
#: long sums cost O(n² log n): 1000 terms already take about a second.
MAX_TOKENS = 2_000
#: Nesting levels: parentheses, function calls, prefix signs / ``not`` and exponents.
MAX_NESTING = 100
#: Characters in one number literal (``1.5e300`` is the way to write big numbers).
MAX_NUMBER_LENGTH = 100
#: Largest magnitude of a number: the largest finite double (≈ 1.8e308).
MAX_MAGNITUDE = sys.float_info.max
#: Smallest magnitude of a nonzero number: the smallest subnormal double; a
#: nonzero number that rounds to 0 in double precision is refused.
MIN_MAGNITUDE = 5e-324
#: Largest magnitude of a numeric exponent of a non-numeric base (``x**1000``).
MAX_SYMBOLIC_EXPONENT = 1_000
#: Bits in the numerator or denominator of an exact fraction sympy keeps
#: (``2**-1074``, the smallest double, needs 1075); sympy's exact roots and
#: sums of such fractions slow down quadratically beyond.
MAX_EXACT_BITS = 1_080
#: Values in one ``min``/``max`` (sympy compares them pairwise).
MAX_MINMAX_ARGUMENTS = 8

_LOG10_MAX = math.log10(MAX_MAGNITUDE)
_LOG10_MIN = math.log10(MIN_MAGNITUDE)
_FOLD = 32  # 'and'/'or' chains longer than this are built in one sympy call
_FRAMES_PER_LEVEL = 10  # Python frames one nesting level costs at most (a parenthesis: 9)
_ARITY = {"atan2": (2,), "log": (1, 2), "min": None, "max": None, "Heaviside": (1, 2)}  # default: one argument
_UNITS = {sp.S.One, sp.S.NegativeOne, sp.I, -sp.I}  # exact powers of these stay small
_NONFINITE = {
    sp.S.ComplexInfinity: "complex infinity (zoo)",
    sp.S.NaN: "NaN",
    sp.S.Infinity: "infinity",
    sp.S.NegativeInfinity: "-infinity",
}

_TOKEN = re.compile(
    r"\s*(?:"
    r"(?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*(?:/[A-Za-z_][A-Za-z0-9_]*)*)"
    r"|(?P<op><=|>=|==|!=|\*\*|&&|\|\||[-+*/^()<>,!])"
    r")",
    re.ASCII,  # digits and spaces are ASCII ones: '١' (an Arabic-Indic one) is refused, not read as 1
)
_SPACES = " \t\n\r\f\v"  # the spaces between tokens: ASCII ones (what re.ASCII's \s matches)
_KEYWORDS = {"and", "or", "not", "true", "false", "pi"}
_RELATIONS = {"<": sp.Lt, "<=": sp.Le, ">": sp.Gt, ">=": sp.Ge, "==": sp.Eq, "!=": sp.Ne}


#: a run of names divided by ``/`` of at most this many parts is read trying every join of them (a few
#: look-ups: ``p2/m``); a longer one, trying joins of at most as many parts as the longest known name has
_PARTS_TRIED = 8


def _tokenize(text: str, names: Mapping[str, sp.Basic]) -> list[tuple[str, str, int]]:
    tokens, pos = [], 0
    text = text.rstrip(_SPACES)
    longest = None  # the most parts of a known hierarchical name: bounds the search below (a look at every
    # name, made once a text of a long run of divisions needs it: a scene's thousand guards and signals are
    # parsed against thousands of names, and their divisions ``p2/m`` of two parts need no bound)
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if not m or m.end() == pos:
            bad = len(text) - len(text[pos:].lstrip(_SPACES))  # (the culprit, not the spaces before it)
            raise GuardSyntaxError(f"unexpected character {text[bad]!r}"
                                   + (" (numbers are written with the digits 0-9)" if text[bad].isdigit() else ""),
                                   text, bad)
        start = m.start(m.lastgroup)
        kind, value = m.lastgroup, m.group(m.lastgroup)
        if kind == "name" and "/" in value and value not in names:
            # the longest known hierarchical names, divided by what is left
            parts = value.split("/")
            if longest is None and len(parts) > _PARTS_TRIED:
                longest = max((name.count("/") + 1 for name in names if "/" in name), default=1)
            reach = len(parts) if len(parts) <= _PARTS_TRIED else longest  # (no name has more parts than longest)
            offset, i = start, 0
            while i < len(parts) and len(tokens) <= MAX_TOKENS:
                j = next(
                    (j for j in range(min(len(parts), i + reach), i, -1) if "/".join(parts[i:j]) in names),
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
        if len(tokens) > MAX_TOKENS:
            raise GuardSyntaxError(
                f"the text is longer than {MAX_TOKENS} tokens (numbers, names and operators; the excess "
                "starts here); split it into named signals or pass a sympy expression",
                text,
                tokens[MAX_TOKENS][2],
            )
        pos = m.end()
    tokens.append(("end", "", len(text)))
    return tokens


# -- double-precision estimates of numeric pieces (None: not a number)


def _finite(value) -> bool:
    return cmath.isfinite(value) if isinstance(value, complex) else math.isfinite(value)


def _real_if_possible(value):
    if isinstance(value, complex) and value.imag == 0:
        return value.real
    return value


def _estimate(expr):
    """The double value of a sympy number given through ``names``, else None."""
    if not getattr(expr, "is_Number", False):
        return None
    try:
        value = expr.p / expr.q if expr.is_Rational else float(expr)
    except (OverflowError, TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None


def _estimate_call(name: str, values: list):
    """Estimate ``name(*values)``; raises OverflowError / ValueError /
    ZeroDivisionError where the result is not finite; None where no estimate
    is made (sympy decides)."""
    if name in ("min", "max"):
        if any(isinstance(v, complex) for v in values):
            return None
        return (min if name == "min" else max)(values)
    if name == "atan2":
        y, x = values
        if isinstance(y, complex) or isinstance(x, complex):
            return None
        return math.atan2(y, x)
    if name in ("step", "Heaviside"):
        return _step_value(values)
    if name == "log" and len(values) == 2:
        z, base = values
        if z == 0 or base == 0:
            raise ZeroDivisionError
        return _real_if_possible(cmath.log(z) / cmath.log(base))
    (z,) = values
    if name == "abs":
        return abs(z)
    if name == "sign":
        return 0.0 if z == 0 else _real_if_possible(z / abs(z))
    if name == "log" and z == 0:
        raise ZeroDivisionError
    return _real_if_possible(getattr(cmath, name)(z))


def _step_value(values: list):
    """The unit step of ``values[0]``: 0 below 0, 1 above, ``values[1]`` (else
    1) at 0; None for a complex argument (sympy refuses it)."""
    z = values[0]
    if isinstance(z, complex):
        return None
    if z == 0:
        return 1.0 if len(values) == 1 else values[1]
    return 1.0 if z > 0 else 0.0


def _exact_bits(expr, depth: int = 2) -> int:
    """The most bits in a numerator or denominator of the exact fractions in
    ``expr`` down to ``depth`` levels (where sympy's combining puts new ones:
    the number itself, coefficients of terms, exponents)."""
    best, stack = 0, [(expr, depth)]
    while stack:
        e, d = stack.pop()
        if e.is_Rational:
            best = max(best, e.p.bit_length(), e.q.bit_length())
        elif d and (e.is_Add or e.is_Mul or e.is_Pow):
            stack.extend((a, d - 1) for a in e.args)
    return best


class _Node:
    """A parsed piece: its sympy form, a double-precision estimate of its value
    when it is a number (None otherwise), and where it lies in the text."""

    __slots__ = ("expr", "value", "start", "end")

    def __init__(self, expr, value, start: int, end: int):
        self.expr = expr
        self.value = value
        self.start = start
        self.end = end


class _Parser:
    def __init__(self, text: str, names: Mapping[str, sp.Basic]):
        self.text = text
        self.names = names
        self.tokens = _tokenize(text, names)
        self.i = 0
        self.depth = 0

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

    def _end(self) -> int:
        """End of the last token taken."""
        _, value, pos = self.tokens[self.i - 1]
        return pos + len(value)

    def _enter(self, pos: int):
        self.depth += 1
        if self.depth > MAX_NESTING:
            raise GuardSyntaxError(
                f"nesting deeper than {MAX_NESTING} levels at position {pos} (parentheses, function calls, "
                "signs, 'not' and exponents each count one); split the condition into simpler parts, "
                "e.g. named signals",
                self.text,
                pos,
            )

    def _leave(self):
        self.depth -= 1

    def _quote(self, start: int, end: int) -> str:
        piece = self.text[start:end]
        if len(piece) > 60:
            return f"{piece[:28] + '…' + piece[-28:]!r} ({len(piece)} characters)"
        return repr(piece)

    def _error(self, message: str, pos: int) -> GuardSyntaxError:
        return GuardSyntaxError(message, self.text, pos)

    def _not_finite(self, start: int, end: int, how: str = "") -> GuardSyntaxError:
        how = how or f"its magnitude exceeds the largest double, {MAX_MAGNITUDE:.4g}"
        return self._error(
            f"{self._quote(start, end)} is not a finite number in double precision ({how}); "
            "use smaller numbers, other units or a different formula",
            start,
        )

    def _underflow(self, start: int, end: int) -> GuardSyntaxError:
        return self._error(
            f"{self._quote(start, end)} underflows to 0 in double precision (its magnitude is below "
            f"{MIN_MAGNITUDE:.3g}); write 0, or use other units",
            start,
        )

    def _checked(self, node: _Node) -> _Node:
        """Refuse what sympy evaluated to an infinity/NaN, and exact fractions
        that grew too long."""
        expr = node.expr
        parts = (expr, *expr.args) if expr.is_Add or expr.is_Mul or expr.is_Pow else (expr,)
        bad = next((part for part in parts if part in _NONFINITE), None)
        if bad is not None:
            raise self._not_finite(node.start, node.end, f"it evaluates to {_NONFINITE[bad]}")
        if _exact_bits(expr) > MAX_EXACT_BITS:
            raise self._error(
                f"{self._quote(node.start, node.end)} makes an exact fraction with more than {MAX_EXACT_BITS} bits; "
                "write the numbers as decimals (0.25 rather than 1/4) so that they are computed in floating point",
                node.start,
            )
        return node

    # -- grammar
    def condition(self):
        left = self.disjunct()
        args = None
        while self.accept("or", "||"):
            if args is None:
                args = [self._boolean(left).expr]
            args.append(self._boolean(self.disjunct()).expr)
        return left if args is None else _Node(_chain(sp.Or, args), None, left.start, self._end())

    def disjunct(self):
        left = self.negation()
        args = None
        while self.accept("and", "&&"):
            if args is None:
                args = [self._boolean(left).expr]
            args.append(self._boolean(self.negation()).expr)
        return left if args is None else _Node(_chain(sp.And, args), None, left.start, self._end())

    def negation(self):
        pos = self.peek()[2]
        if self.accept("not", "!"):
            self._enter(pos)
            inner = self._boolean(self.negation())
            self._leave()
            return _Node(sp.Not(inner.expr), None, pos, self._end())
        return self.comparison()

    def comparison(self):
        left = self.sum()
        start = left.start
        relations = []
        while self.peek()[0] == "op" and self.peek()[1] in _RELATIONS:
            op = self.take()[1]
            right = self.sum()
            relations.append(_RELATIONS[op](self._number(left).expr, self._number(right).expr, evaluate=False))
            left = right
        if not relations:
            return left
        expr = relations[0] if len(relations) == 1 else sp.And(*relations)
        return _Node(expr, None, start, self._end())

    def sum(self):
        left = self.product()
        while True:
            if self.accept("+"):
                op = "+"
            elif self.accept("-"):
                op = "-"
            else:
                return left
            self._number(left)
            left = self._arithmetic(op, left, self._number(self.product()))

    def product(self):
        left = self.unary()
        while True:
            if self.accept("*"):
                op = "*"
            elif self.accept("/"):
                op = "/"
            else:
                return left
            self._number(left)
            left = self._arithmetic(op, left, self._number(self.unary()))

    def unary(self):
        pos = self.peek()[2]
        if self.accept("-"):
            self._enter(pos)
            inner = self._number(self.unary())
            self._leave()
            value = None if inner.value is None else -inner.value
            return _Node(-inner.expr, value, pos, inner.end)
        if self.accept("+"):
            self._enter(pos)
            inner = self._number(self.unary())
            self._leave()
            return _Node(inner.expr, inner.value, pos, inner.end)
        return self.power()

    def power(self):
        base = self.atom()
        pos = self.peek()[2]
        if self.accept("**", "^"):
            self._number(base)
            self._enter(pos)
            exponent = self._number(self.unary())
            self._leave()
            return self._power(base, exponent)
        return base

    def atom(self):
        kind, value, pos = self.peek()
        if kind == "number":
            self.take()
            return self._literal(value, pos)
        if kind == "op" and value == "(":
            self.take()
            self._enter(pos)
            inner = self.condition()
            self.expect(")")
            self._leave()
            return _Node(inner.expr, inner.value, pos, self._end())
        if kind == "name":
            self.take()
            end = pos + len(value)
            if value == "true":
                return _Node(sp.true, None, pos, end)
            if value == "false":
                return _Node(sp.false, None, pos, end)
            if value == "pi":
                return _Node(sp.pi, math.pi, pos, end)
            if value in ("and", "or", "not"):
                raise GuardSyntaxError(f"{value!r} needs a condition on its left", self.text, pos)
            if self.peek()[1] == "(" and self.peek()[0] == "op":
                return self.call(value, pos)
            if value in self.names:
                expr = self.names[value]
                return _Node(expr, _estimate(expr), pos, end)
            return _Node(sp.Symbol(value), None, pos, end)
        raise GuardSyntaxError(f"expected a number, a name or '(' but found {value or 'the end'!r}", self.text, pos)

    def call(self, name, pos):
        if name not in FUNCTIONS:
            raise GuardSyntaxError(
                f"unknown function {name!r}; available: {', '.join(sorted(FUNCTIONS))}", self.text, pos
            )
        self._enter(pos)
        self.expect("(")
        args = [self._number(self.sum())]
        while self.accept(","):
            args.append(self._number(self.sum()))
        self.expect(")")
        self._leave()
        return self._apply(name, args, pos, self._end())

    # -- numbers and operations, each checked before sympy computes it
    def _literal(self, text: str, pos: int) -> _Node:
        end = pos + len(text)
        value = float(text)  # Python's own parser: fast for any length, inf when too large
        if math.isinf(value):
            raise self._not_finite(pos, end, f"beyond ±{MAX_MAGNITUDE:.4g}")
        if value == 0 and re.search("[1-9]", re.split("[eE]", text)[0]):
            raise self._underflow(pos, end)
        if len(text) > MAX_NUMBER_LENGTH:
            raise self._error(
                f"the number {self._quote(pos, end)} is longer than {MAX_NUMBER_LENGTH} characters; "
                "write it with fewer digits in exponent notation (e.g. 1.5e300)",
                pos,
            )
        if any(c in text for c in ".eE"):
            return _Node(sp.Float(text), value, pos, end)
        return _Node(sp.Integer(text.lstrip("0") or "0"), value, pos, end)

    def _arithmetic(self, op: str, left: _Node, right: _Node) -> _Node:
        start, end = left.start, right.end
        a, b = left.value, right.value
        if op == "/" and b is not None and b == 0:
            raise self._error(
                f"division by zero: the divisor {self._quote(right.start, right.end)} of "
                f"{self._quote(start, end)} is 0; remove the division or divide by something that is not 0",
                right.start,
            )
        value = None
        if a is not None and b is not None:
            try:
                value = a + b if op == "+" else a - b if op == "-" else a * b if op == "*" else a / b
            except (OverflowError, ZeroDivisionError):
                value = math.inf
            if not _finite(value):
                raise self._not_finite(start, end)
            if value == 0 and op in "*/" and a != 0 and b != 0:
                raise self._underflow(start, end)
            value = _real_if_possible(value)
        x, y = left.expr, right.expr
        expr = x + y if op == "+" else x - y if op == "-" else x * y if op == "*" else x / y
        return self._checked(_Node(expr, value, start, end))

    def _power(self, base: _Node, exponent: _Node) -> _Node:
        start, end = base.start, exponent.end
        b, e = base.value, exponent.value
        if b is None and e is not None and abs(e) > MAX_SYMBOLIC_EXPONENT:
            raise self._error(
                f"the power {self._quote(start, end)} has the exponent {self._quote(exponent.start, end)} "
                f"(about {abs(e):.3g}), beyond ±{MAX_SYMBOLIC_EXPONENT} for a base that is not a number; "
                "rescale the quantity or compare logarithms instead",
                exponent.start,
            )
        value = None
        if b is not None and e is not None:
            value = self._power_value(base, exponent)
        return self._checked(_Node(base.expr**exponent.expr, value, start, end))

    def _power_value(self, base: _Node, exponent: _Node):
        """Bound the size of a numeric power from logarithms before anything
        computes it; return its double value."""
        start, end = base.start, exponent.end
        b, e = base.value, exponent.value
        if b == 0:
            if (e.real if isinstance(e, complex) else e) < 0:
                raise self._error(
                    f"{self._quote(start, end)} raises 0 to a negative power, a division by zero; "
                    "remove it or use a base that is not 0",
                    start,
                )
            return 1.0 if e == 0 else 0.0
        try:
            log_b = math.log(b) if isinstance(b, float) and b > 0 else cmath.log(b)
            w = e * log_b
            log10 = (w.real if isinstance(w, complex) else w) / math.log(10)
        except OverflowError:
            log10 = math.inf
        if math.isnan(log10) or log10 > _LOG10_MAX:
            about = f"about 10^{log10:.3g}, " if math.isfinite(log10) else ""
            raise self._not_finite(start, end, f"{about}beyond the largest double, {MAX_MAGNITUDE:.4g}")
        if log10 < _LOG10_MIN:
            raise self._underflow(start, end)
        if exponent.expr.is_Rational and base.expr not in _UNITS:
            # an exact power: its digits grow with the exponent, even when its
            # double value is modest ((1 + 1/10**30)**(10**6) is 1.0 in doubles)
            bits = abs(e) * max((math.log2(max(abs(n.p), n.q)) for n in base.expr.atoms(sp.Rational)), default=0)
            if bits > MAX_EXACT_BITS:
                raise self._error(
                    f"{self._quote(start, end)} would make an exact fraction of about {bits:.3g} bits "
                    f"(at most {MAX_EXACT_BITS}); write the base as a decimal (1.5 rather than 3/2) "
                    "so that it is computed in floating point",
                    start,
                )
        try:
            value = b**e
        except (OverflowError, ZeroDivisionError):
            value = math.inf
        if not _finite(value):
            raise self._not_finite(start, end)
        if value == 0:
            raise self._underflow(start, end)
        return _real_if_possible(value)

    def _apply(self, name: str, args: list, pos: int, end: int) -> _Node:
        arity = _ARITY.get(name, (1,))
        if arity is not None and len(args) not in arity:
            raise GuardSyntaxError(f"wrong number of arguments to {name}()", self.text, pos)
        function = FUNCTIONS[name]
        if name in ("min", "max"):
            count = sum(len(a.expr.args) if isinstance(a.expr, function) else 1 for a in args)
            if count > MAX_MINMAX_ARGUMENTS:
                raise self._error(
                    f"{name}() of {count} values (nested {name}() calls merge into one); at most "
                    f"{MAX_MINMAX_ARGUMENTS}: split it into named signals",
                    pos,
                )
        value = None
        values = [a.value for a in args]
        if all(v is not None for v in values):
            try:
                value = _estimate_call(name, values)
            except OverflowError:
                value = math.inf
            except (ValueError, ZeroDivisionError):  # a pole: log(0), log(x, 1)
                raise self._not_finite(pos, end, "it is infinite or undefined there") from None
            if value is not None and not _finite(value):
                raise self._not_finite(pos, end)
        try:
            expr = function(*(a.expr for a in args))
        except TypeError:
            raise GuardSyntaxError(f"wrong number of arguments to {name}()", self.text, pos) from None
        except ValueError as error:  # e.g. min/max of a complex number
            raise GuardSyntaxError(f"{name}() cannot take these arguments: {error}", self.text, pos) from None
        if value == 0 and expr != 0 and all(v != 0 for v in values):
            raise self._underflow(pos, end)
        return self._checked(_Node(expr, value, pos, end))

    # -- type checks
    def _number(self, node):
        if isinstance(node.expr, (Relational, BooleanFunction, BooleanAtom)):
            self.fail("a condition is used where a number is expected")
        return node

    def _boolean(self, node):
        if not isinstance(node.expr, (Relational, BooleanFunction, BooleanAtom)):
            self.fail(f"{node.expr} is a number, not a condition (compare it with <, <=, >, >=, == or !=)")
        return node

    def parse(self, want_condition: bool):
        result = self.condition()
        if self.peek()[0] != "end":
            self.fail(f"unexpected {self.peek()[1]!r}")
        if want_condition:
            return self._boolean(result).expr
        return self._number(result).expr


def _chain(operator, args):
    """``a op b op c …`` as the left fold sympy has always built, but in one
    call past :data:`_FOLD` operands (the fold costs O(n² log n); the result
    is logically the same and at most simpler)."""
    result = args[0]
    for arg in args[1:_FOLD]:
        result = operator(result, arg)
    return operator(result, *args[_FOLD:]) if len(args) > _FOLD else result


def _stack_depth() -> int:
    frame, depth = sys._getframe(), 0
    while frame is not None:
        frame, depth = frame.f_back, depth + 1
    return depth


def _parse(text: str, names: Mapping[str, sp.Basic], want_condition: bool):
    # MAX_NESTING levels of recursive descent need room on Python's stack
    # whatever the caller's depth; make it for the parse, then give it back
    needed = _stack_depth() + MAX_NESTING * _FRAMES_PER_LEVEL + 500
    limit = sys.getrecursionlimit()
    if limit < needed:
        sys.setrecursionlimit(needed)
    try:
        return _Parser(text, names).parse(want_condition)
    except RecursionError:
        raise GuardSyntaxError(
            "the text is nested too deeply for Python's stack; split the condition into simpler parts", text
        ) from None
    finally:
        if limit < needed and sys.getrecursionlimit() == needed:
            sys.setrecursionlimit(limit)


def parse_condition(text: str, names: Mapping[str, sp.Basic] | None = None) -> Boolean:
    """Parse a guard such as ``"tip_y <= 0 and tip_vy < 0"`` into a sympy Boolean.

    Raises :class:`GuardSyntaxError` for text that is not a condition or
    breaks one of the module's limits (see the module docstring)."""
    if not isinstance(text, str) or not text.strip():
        raise GuardSyntaxError("a guard must be a non-empty text or a sympy condition", str(text))
    return _parse(text, names or {}, want_condition=True)


def parse_expression(text: str, names: Mapping[str, sp.Basic] | None = None) -> sp.Expr:
    """Parse an arithmetic expression such as ``"m*(vy - g)"`` into sympy.

    Raises :class:`GuardSyntaxError` like :func:`parse_condition`."""
    if not isinstance(text, str) or not text.strip():
        raise GuardSyntaxError("an expression must be a non-empty text", str(text))
    return _parse(text, names or {}, want_condition=False)
