"""The Wright omega function on real arguments, written once as a plain
function of floats in the subset numba compiles (and :mod:`codegen.native`
translates), so that the Python namespace of generated code, the raw
(impulse-aware) namespace, exported modules and generated machine code all
compute it with the very same operations.  It imports only :mod:`math`.

``ω(z)`` is the solution ``w`` of ``w + log w = z``: ``ω(z) = W₀(eᶻ)``, the
principal branch of Lambert's W at ``eᶻ``, for every real ``z`` — without
ever forming ``eᶻ``, so the diode and exponential laws whose inverses are
``W₀(a·e^b)`` (with ``a·e^b`` far beyond the floating-point range) are
computed as ``ω(log a + b)`` (:mod:`codegen.lambert` rewrites them).  It is
increasing, ``ω(z) > 0``, ``dω/dz = ω/(1 + ω)``, ``ω(z) = eᶻ − e²ᶻ + O(e³ᶻ)``
as ``z → −∞`` and ``ω(z) = z − log z + log z/z + O((log z/z)²)`` as ``z → ∞``.
"""

from math import exp, log

__all__ = ["wrightomega"]


def wrightomega(z):
    """``ω(z)``: the real ``w > 0`` with ``w + log w = z`` (``W₀(eᶻ)``).

    Below ``z = −36`` (``eᶻ < 2.4·10⁻¹⁶``) ``ω = eᶻ − e²ᶻ`` to rounding.
    Up to ``z = 0``, Halley's iteration on ``w·eʷ = x`` with ``x = eᶻ``
    (``≥ 2.3·10⁻¹⁶``): ``f = w·eʷ − x``,
    ``w ← w − f/(eʷ(w + 1) − (w + 2)f/(2w + 2))``; its residual is relative
    to ``x``, where ``z − w − log w`` would carry the rounding of
    ``log w ≈ z`` (``|z|`` units in the last place).  Above ``z = 0``
    (``ω > 0.567``) the Fritsch–Shafer–Crowley iteration (fourth order)
    on ``w + log w = z``: with ``r = z − w − log w`` and
    ``q = 2(1 + w)(1 + w + 2r/3)``, ``w ← w·(1 + r/(1 + w)·(q − r)/(q − 2r))``
    (computed as ``(q′ − b/2)/(q′ − b)`` with ``q′ = q/(2(1 + w))`` and
    ``b = r/(1 + w)``, so that nothing overflows).
    Each stops when its step is below ``2⁻⁵²·w`` (two to four steps) from
    the starts of Lawrence, Corless and Jeffrey (*Algorithm 917*, ACM TOMS
    38(3), 2012) on the real axis: ``z − log z + log z/z`` for ``z > 1``,
    the series ``1 + s/2 + s²/16 − s³/192 − s⁴/3072 + 13s⁵/61440``
    (``s = z − 1``) about ``ω(1) = 1`` for ``−2 < z ≤ 1``, and ``x(1 − x)``
    below; the result is within a few units in the last place.  ``ω(−∞) =
    0``, ``ω(∞) = ∞``, ``ω(nan) = nan``."""
    if z != z:
        return z
    if z < -36.0:
        w = exp(z)
        return w - w * w
    if z > 1.7976931348623157e308:
        return z
    if z > 1.0:
        lz = log(z)
        w = z - lz + lz / z
    elif z > -2.0:
        s = z - 1.0
        w = 1.0 + s * (0.5 + s * (1.0 / 16.0 + s * (-1.0 / 192.0 + s * (-1.0 / 3072.0 + s * (13.0 / 61440.0)))))
    else:
        w = exp(z) * (1.0 - exp(z))
    if z <= 0.0:
        x = exp(z)
        for _ in range(8):
            e = exp(w)
            f = w * e - x
            step = f / (e * (w + 1.0) - (w + 2.0) * f / (2.0 * w + 2.0))
            w = w - step
            if abs(step) <= 2.220446049250313e-16 * w:
                return w
        return w
    for _ in range(8):
        r = z - w - log(w)
        a = 1.0 + w
        b = r / a
        q = a + 2.0 * r / 3.0  # (q/(2a) of the formula: no overflow for z up to the largest double)
        step = w * b * ((q - 0.5 * b) / (q - b))
        w = w + step
        if abs(step) <= 2.220446049250313e-16 * w:
            return w
    return w
