"""Run-time support of generated code, in plain Python (no sympy, no numpy),
so that exported modules carry it along.

:class:`Hyper` is a value ``impulse·δ + finite``: generated *raw* signal and
guard functions are called with ``Hyper`` state derivatives, and ordinary
operators then compute the impulse area (linear in the pulses) and the finite
part of the result.  A product of two pulses, a pulse in a denominator or
inside a nonlinear function has no meaning and raises :class:`PulseError`.
:func:`decide` compares two such values with a tolerance band (``<=``
includes the band, ``<`` excludes it; a non-zero impulse dominates), widened
by the comparison's round-off scale (:mod:`codegen.roundoff`): the rules of
:mod:`codegen.decision`, which the compiled kernel compiles too;
:class:`Comparison` keeps the figures of one decision for the record.
"""

import math

from .decision import OPS, band, finite_holds, pulse_decides, pulse_holds
from .omega import wrightomega

__all__ = ["Comparison", "Hyper", "PulseError", "H", "decide", "hyper"]


class PulseError(ArithmeticError):
    """An operation on a Dirac pulse that has no meaning."""


class Hyper:
    """``impulse·δ(t − t_s) + finite``."""

    __slots__ = ("impulse", "finite")

    def __init__(self, impulse, finite):
        self.impulse = float(impulse)
        self.finite = float(finite)

    def __repr__(self):
        return f"Hyper({self.impulse!r}, {self.finite!r})"

    def __str__(self):
        if self.impulse:
            return f"{self.impulse:.6g}·δ + {self.finite:.6g}"
        return f"{self.finite:.6g}"

    # arithmetic -----------------------------------------------------------
    def __add__(self, other):
        o = hyper(other)
        return Hyper(self.impulse + o.impulse, self.finite + o.finite)

    __radd__ = __add__

    def __neg__(self):
        return Hyper(-self.impulse, -self.finite)

    def __pos__(self):
        return self

    def __sub__(self, other):
        return self + (-hyper(other))

    def __rsub__(self, other):
        return hyper(other) + (-self)

    def __mul__(self, other):
        o = hyper(other)
        if self.impulse and o.impulse:
            raise PulseError("a product of two Dirac pulses has no meaning")
        return Hyper(self.impulse * o.finite + o.impulse * self.finite, self.finite * o.finite)

    __rmul__ = __mul__

    def __truediv__(self, other):
        o = hyper(other)
        if o.impulse:
            raise PulseError("a Dirac pulse in a denominator has no meaning")
        return Hyper(self.impulse / o.finite, self.finite / o.finite)

    def __rtruediv__(self, other):
        return hyper(other) / self

    def __pow__(self, exponent):
        e = hyper(exponent)
        if e.impulse:
            raise PulseError("an impulsive exponent has no meaning")
        if self.impulse:
            if e.finite == 1:
                return self
            raise PulseError("a power of a Dirac pulse has no meaning")
        return Hyper(0.0, self.finite**e.finite)

    def __rpow__(self, base):
        return hyper(base) ** self

    def __abs__(self):
        if self.impulse:
            return Hyper(abs(self.impulse), math.copysign(1.0, self.impulse) * self.finite)
        return Hyper(0.0, abs(self.finite))

    # ordering (lexicographic: the pulse dominates) -------------------------
    def _key(self):
        return (self.impulse, self.finite)

    def __lt__(self, other):
        return self._key() < hyper(other)._key()

    def __le__(self, other):
        return self._key() <= hyper(other)._key()

    def __gt__(self, other):
        return self._key() > hyper(other)._key()

    def __ge__(self, other):
        return self._key() >= hyper(other)._key()

    def __eq__(self, other):
        try:
            return self._key() == hyper(other)._key()
        except TypeError:
            return NotImplemented

    def __hash__(self):
        return hash(self._key())

    def __float__(self):
        if self.impulse:
            raise PulseError("a Dirac pulse has no finite value")
        return self.finite


def hyper(value) -> Hyper:
    """Coerce a number (or a :class:`Hyper`) to :class:`Hyper`."""
    if isinstance(value, Hyper):
        return value
    return Hyper(0.0, float(value))


def _smooth(fn):
    def apply(*args):
        hs = [hyper(a) for a in args]
        if any(h.impulse for h in hs):
            raise PulseError(f"{fn.__name__} of a Dirac pulse has no meaning")
        return Hyper(0.0, fn(*[h.finite for h in hs]))

    apply.__name__ = fn.__name__
    return apply


def _nan_where_math_raises(fn, args):
    """``fn(*args)``, NaN where :mod:`math` raises (overflow, a domain error, a division by zero)."""
    try:
        return fn(*args)
    except (OverflowError, ValueError, ZeroDivisionError):
        return math.nan


class H:
    """Function namespace used by generated *raw* (impulse-aware) code."""

    pi = math.pi
    e = math.e
    inf = math.inf
    abs = staticmethod(lambda x: abs(hyper(x)))
    max = staticmethod(max)
    min = staticmethod(min)

    @staticmethod
    def elementwise(fn, *args):
        """``fn`` (a function of floats: a numeric inverse, :mod:`codegen.inverse`)
        at ``args``: on floats a float; on arrays (anything with a non-zero
        ``ndim``) an array, element by element over their broadcast; on
        :class:`Hyper` values a finite :class:`Hyper` (a pulse raises
        :class:`PulseError`: a law's inverse of a pulse has no meaning).
        Where :mod:`math` raises inside ``fn`` (a value past the floating-point
        range: ``exp(1000)``, where machine code goes on with ``inf``) the
        value is NaN."""
        if any(isinstance(a, Hyper) for a in args):
            return _smooth(lambda *v: _nan_where_math_raises(fn, v))(*args)
        if any(getattr(a, "ndim", 0) for a in args):
            import numpy as np

            return np.vectorize(lambda *v: _nan_where_math_raises(fn, v), otypes=[float])(*args)
        return _nan_where_math_raises(fn, [float(a) for a in args])

    @staticmethod
    def copysign(magnitude, x):
        h = hyper(x)
        key = h.impulse or h.finite
        return Hyper(0.0, math.copysign(float(magnitude), key))


for _name in (
    "sin cos tan asin acos atan atan2 sinh cosh tanh asinh acosh atanh exp log log10 log2 sqrt floor ceil"
).split():
    setattr(H, _name, staticmethod(_smooth(getattr(math, _name))))
H.wrightomega = staticmethod(_smooth(wrightomega))


def _code(op):
    """The number of the comparison ``op`` (:data:`codegen.decision.OPS`)."""
    code = OPS.get(op)
    if code is None:
        raise ValueError(f"unknown comparison {op!r}")
    return code


def _margin(op, diff, band):
    """Signed distance of ``diff = left − right`` from the decision's edge:
    ``≥ 0`` holds for inclusive comparisons, ``> 0`` for strict ones."""
    if op == "<=":
        return band - diff
    if op == "<":
        return -band - diff
    if op == ">=":
        return diff + band
    if op == ">":
        return diff - band
    if op == "==":
        return band - abs(diff)
    if op == "!=":
        return abs(diff) - band
    raise ValueError(f"unknown comparison {op!r}")


def decide(op: str, left, right, rtol: float, atol: float, scale: float = 0.0) -> bool:
    """``left op right`` for ``op`` in ``<, <=, >, >=, ==, !=``, on numbers or
    :class:`Hyper` values, with the band ``rtol·max(|left|, |right|, scale) +
    atol`` (``scale``: the comparison's round-off scale, :mod:`codegen.roundoff`).
    ``<=``, ``>=`` and ``==`` include the band, ``<``, ``>`` and ``!=`` exclude
    it; a non-zero impulse dominates any finite part."""
    if not (isinstance(left, Hyper) or isinstance(right, Hyper)):  # (numbers: no impulse, the finite parts decide)
        lf, rf = float(left), float(right)
        return finite_holds(_code(op), lf, rf, band(lf, rf, scale, rtol, atol))
    left, right = hyper(left), hyper(right)
    code = _code(op)
    if pulse_decides(left.impulse, right.impulse):
        return pulse_holds(code, left.impulse, right.impulse)
    return finite_holds(code, left.finite, right.finite, band(left.finite, right.finite, scale, rtol, atol))


class Comparison:
    """One decided comparison, for the record of an instant: ``text``, the
    ``left`` and ``right`` values (:class:`Hyper` or numbers), the ``band``
    used, the round-off ``scale``, ``result``, and ``margin`` — the signed
    distance of ``left − right`` from the decision's edge (``None`` when an
    impulse decided)."""

    __slots__ = ("text", "op", "left", "right", "scale", "band", "margin", "result")

    def __init__(self, text, op, left, right, scale, band, margin, result):
        self.text, self.op, self.left, self.right = text, op, left, right
        self.scale, self.band, self.margin, self.result = scale, band, margin, result

    @classmethod
    def of(cls, text, op, left, right, rtol, atol, scale=0.0):
        """Decide ``left op right`` as :func:`decide` does and keep the figures."""
        lh, rh = hyper(left), hyper(right)
        code = _code(op)
        if pulse_decides(lh.impulse, rh.impulse):
            return cls(text, op, left, right, scale, None, None, pulse_holds(code, lh.impulse, rh.impulse))
        width = band(lh.finite, rh.finite, scale, rtol, atol)
        margin = _margin(op, lh.finite - rh.finite, width)
        return cls(text, op, left, right, scale, width, margin, finite_holds(code, lh.finite, rh.finite, width))

    @property
    def edge_ulps(self):
        """``|margin|`` in units in the last place of the comparison's largest
        magnitude (``max(|left|, |right|, scale)``): how many round-offs would
        have flipped the decision (``inf`` when an impulse decided)."""
        if self.margin is None:
            return math.inf
        lh, rh = hyper(self.left), hyper(self.right)
        magnitude = max(abs(lh.finite), abs(rh.finite), self.scale if math.isfinite(self.scale) else 0.0)
        unit = math.ulp(magnitude) if magnitude > 0 else math.ulp(0.0)
        return abs(self.margin) / unit

    def __iter__(self):  # (text, left, right, result), as the records of earlier versions
        return iter((self.text, self.left, self.right, self.result))

    def __str__(self):
        text = f"{self.text}: {self.left} vs {self.right} → {self.result}"
        if self.band is not None:
            text += f" (band {self.band:.3g})"
        return text
