"""Event bracketing: the rules by which a step's event scan decides where to
look more closely, and how far it narrows a bracket.

Event detection (:class:`switching.simulate.events.GuardScan` and its
compiled translation :mod:`switching.kernel.events`) samples a
guard part's margin ``m(τ)`` (signal units; ``τ`` in the model's time unit)
at points of a step:

* a part is *worth refining* unless it holds all along (``min m > 0``) or
  stays far from its threshold all along: ``max m + (1 + O)·(max m − min m)
  < 0`` with the overshoot ``O`` = :data:`OVERSHOOT`;
* a sampled maximum is refined when the parabola through it and its two
  neighbours (:func:`parabola_peak`) is concave and its peak ``v`` would
  reach 0 with ``O`` times its predicted rise above the largest sample ``r``:
  ``v + O·(v − r) ≥ 0`` (:func:`peak_in_reach`);
* a bracket ``(lo, hi]`` is bisected (:func:`halve`) down to adjacent
  floating-point numbers: the midpoint ``(lo + hi)/2`` rounds onto an end,
  or after :data:`BISECTIONS` halvings.
"""

__all__ = ["BISECTIONS", "OVERSHOOT", "RULES", "halve", "parabola_peak", "peak_in_reach", "worth_refining"]

RULES = ("halve", "parabola_peak", "peak_in_reach", "worth_refining")

OVERSHOOT = 3.0  # a sampled extremum is refined when 3× its predicted rise would reach the guard
BISECTIONS = 200  # halvings at most (a bracket of floats reaches adjacent numbers within ~2100: never binding
# unless the ends are not finite)


def halve(lo, hi):
    """``(more, mid)``: the midpoint ``(lo + hi)/2`` of a bracket, and whether
    it lies strictly inside (else ``lo`` and ``hi`` are adjacent
    floating-point numbers: the bisection is done)."""
    mid = 0.5 * (lo + hi)
    return not (mid <= lo or mid >= hi), mid


def parabola_peak(t0, t1, t2, m0, m1, m2):
    """``(ok, time, value)`` of the maximum of the parabola through ``(t0,
    m0)``, ``(t1, m1)``, ``(t2, m2)`` (``t0 < t1 < t2``): with the divided
    differences ``d₁ = (m1 − m0)/(t1 − t0)``, ``d₂ = (m2 − m1)/(t2 − t1)`` and
    the curvature ``c = (d₂ − d₁)/(t2 − t0)``, the peak is at ``(t0 + t1)/2 −
    d₁/(2c)`` with value ``m0 + d₁·(τ − t0) + c·(τ − t0)·(τ − t1)``; not ok
    when the times are not increasing or the parabola is not concave."""
    if not (t0 < t1 and t1 < t2):
        return False, 0.0, 0.0
    d1 = (m1 - m0) / (t1 - t0)
    d2 = (m2 - m1) / (t2 - t1)
    curvature = (d2 - d1) / (t2 - t0)
    if not curvature < 0.0:
        return False, 0.0, 0.0
    at = 0.5 * (t0 + t1) - d1 / (2 * curvature)
    return True, at, m0 + d1 * (at - t0) + curvature * (at - t0) * (at - t1)


def peak_in_reach(value, reference):
    """Would a margin peaking at ``value`` reach 0 with :data:`OVERSHOOT`
    times its rise above the largest sampled margin ``reference``?"""
    return not value + OVERSHOOT * (value - reference) < 0.0


def worth_refining(top, bottom):
    """Is a part whose sampled margins lie in ``[bottom, top]`` worth a closer
    look: neither holding all along nor far from its threshold all along?"""
    return not (bottom > 0.0 or top + (1.0 + OVERSHOOT) * (top - bottom) < 0.0)
