"""Run-time support of generated code, in plain Python (no sympy, no numpy),
so that exported modules carry it along.

:class:`Hyper` is a value ``impulse·δ + finite``: generated *raw* signal and
guard functions are called with ``Hyper`` state derivatives, and ordinary
operators then compute the impulse area (linear in the pulses) and the finite
part of the result.  A product of two pulses, a pulse in a denominator or
inside a nonlinear function has no meaning and raises :class:`PulseError`.
:func:`decide` compares two such values with a tolerance band (``<=``
includes the band, ``<`` excludes it; a non-zero impulse dominates).
"""

import math

__all__ = ["Hyper", "PulseError", "H", "decide", "hyper"]


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


class H:
    """Function namespace used by generated *raw* (impulse-aware) code."""

    pi = math.pi
    e = math.e
    inf = math.inf
    abs = staticmethod(lambda x: abs(hyper(x)))
    max = staticmethod(max)
    min = staticmethod(min)

    @staticmethod
    def copysign(magnitude, x):
        h = hyper(x)
        key = h.impulse or h.finite
        return Hyper(0.0, math.copysign(float(magnitude), key))


for _name in (
    "sin cos tan asin acos atan atan2 sinh cosh tanh asinh acosh atanh exp log log10 log2 sqrt floor ceil"
).split():
    setattr(H, _name, staticmethod(_smooth(getattr(math, _name))))


def decide(op: str, left, right, rtol: float, atol: float) -> bool:
    """``left op right`` for ``op`` in ``<, <=, >, >=, ==, !=``, on numbers or
    :class:`Hyper` values, with the band ``rtol·max(|left|, |right|) + atol``."""
    left, right = hyper(left), hyper(right)
    impulse = left.impulse - right.impulse
    if impulse and abs(impulse) > 1e-6 * max(abs(left.impulse), abs(right.impulse)):
        if op in ("<", "<="):
            return impulse < 0
        if op in (">", ">="):
            return impulse > 0
        return op == "!="
    diff = left.finite - right.finite
    scale = max(abs(left.finite), abs(right.finite))
    band = rtol * scale + atol if math.isfinite(scale) else 0.0
    if op == "<=":
        return diff <= band
    if op == "<":
        return diff < -band
    if op == ">=":
        return diff >= -band
    if op == ">":
        return diff > band
    if op == "==":
        return abs(diff) <= band
    if op == "!=":
        return abs(diff) > band
    raise ValueError(f"unknown comparison {op!r}")
