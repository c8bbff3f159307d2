"""The guards' comparison with its round-off band, written once: plain
functions on floats that numba compiles and Python calls.  It lives on
codegen's floor because :func:`codegen.runtime.decide` (the Python path,
generated guard code and exported modules) calls it; the callers above
(a compiled simulation kernel, generated per-mode machine code) compile these
very functions rather than copies.

A comparison ``left op right`` of two signals, each with an impulse part
``i`` and a finite part ``f`` (DESIGN §5), ``op`` numbered as in :data:`OPS`
(``<`` 0, ``<=`` 1, ``>`` 2, ``>=`` 3, ``==`` 4, ``!=`` 5), is decided in
steps, each a rule of its own (a function numba compiles by itself; the
caller composes them, as :func:`codegen.runtime.decide` and the kernel's
``decide`` do):

* a pulse decides (:func:`pulse_decides`, :func:`pulse_holds`) when the
  impulses differ by more than ``10⁻⁶·max(|i_l|, |i_r|)``: ``δ = i_l − i_r``
  compares as ``±∞`` (``<``, ``<=``: ``δ < 0``; ``>``, ``>=``: ``δ > 0``;
  ``==`` never, ``!=`` always);
* otherwise the finite parts (:func:`finite_holds`), ``d = f_l − f_r``,
  with the band (:func:`band`) ``b = rtol·max(|f_l|, |f_r|, s) + atol``
  (``s`` the comparison's round-off scale, :mod:`codegen.roundoff`, counted
  when finite; ``b = 0`` when a side is not finite): ``<`` is ``d < −b``,
  ``<=`` ``d ≤ b``, ``>`` ``d > b``, ``>=`` ``d ≥ −b``, ``==`` ``|d| ≤ b``,
  ``!=`` ``|d| > b`` — the inclusive comparisons include the band, the
  strict ones exclude it (the paper's section 4.3).

The band has the units of the compared signals (``rtol`` relative,
``atol`` in those units).  Maxima are written as comparisons: Python's
``max`` and numba's may differ on NaN.
"""

from math import isfinite

__all__ = ["OPS", "RULES", "band", "finite_holds", "larger", "pulse_decides", "pulse_holds"]

RULES = ("band", "finite_holds", "larger", "pulse_decides", "pulse_holds")

#: the comparisons' numbers
OPS = {"<": 0, "<=": 1, ">": 2, ">=": 3, "==": 4, "!=": 5}


def larger(a, b):
    """The larger of two round-off scales, a non-finite one counted as 0."""
    a = a if isfinite(a) else 0.0
    b = b if isfinite(b) else 0.0
    return a if a > b else b


def band(lf, rf, sc, rtol, atol):
    """``rtol·max(|lf|, |rf|, sc) + atol``: the band of a comparison of the
    finite parts ``lf``, ``rf`` with round-off scale ``sc`` (counted when
    finite); 0 when a side is not finite."""
    left = abs(lf)
    right = abs(rf)
    scale = right if right > left else left
    if not isfinite(scale):
        return 0.0
    if isfinite(sc) and sc > scale:
        scale = sc
    return rtol * scale + atol


def pulse_decides(li, ri):
    """Do the impulse parts ``li``, ``ri`` decide the comparison: ``δ = li −
    ri`` non-zero and beyond ``10⁻⁶·max(|li|, |ri|)``?"""
    impulse = li - ri
    left = abs(li)
    right = abs(ri)
    return impulse != 0.0 and abs(impulse) > 1e-6 * (right if right > left else left)


def pulse_holds(op, li, ri):
    """``left op right`` decided by the impulses (when :func:`pulse_decides`):
    ``δ = li − ri`` compares as ``±∞``."""
    impulse = li - ri
    if op <= 1:
        return impulse < 0.0
    if op <= 3:
        return impulse > 0.0
    return op == 5


def finite_holds(op, lf, rf, width):
    """``left op right`` decided by the finite parts ``lf``, ``rf`` with the
    band ``width`` (:func:`band`): the inclusive comparisons include it, the
    strict ones exclude it."""
    diff = lf - rf
    if op == 0:
        return diff < -width
    if op == 1:
        return diff <= width
    if op == 2:
        return diff > width
    if op == 3:
        return diff >= -width
    if op == 4:
        return abs(diff) <= width
    return abs(diff) > width
