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
  or after :data:`BISECTIONS` halvings;
* the first hold of a guard in a bracket ``(lo, hi]`` (none holding at
  ``lo``, one at ``hi``) is narrowed down to adjacent floating-point numbers
  by :func:`narrow_begin` and :func:`narrow_next`: the ITP method (I. F. D.
  Oliveira and R. H. C. Takahashi, *An enhancement of the bisection method
  average performance preserving minmax optimality*, ACM TOMS 47, 2020) on
  a *guide*, the margin of a part that changes truth between the ends
  (:func:`switching_part`; none: bisection) — regula falsi,
  moved toward the middle by ``δ = 0.2·w²/w₀`` (``w`` the bracket's width,
  ``w₀`` the first; at least 4 ulps, so the probe lands beyond a root the
  interpolation found), and kept within the reach that leaves bisection's
  worst count of probes plus one.  Which end a probe replaces is decided by
  whether a guard holds there, never by the guide: the guide only chooses
  where to look, so the bracket found is a change of the guards' truth as
  bisection's is — where the guards change truth once in the bracket, the
  same two adjacent numbers — in about 12 evaluations of the guards instead
  of 50.
"""

import math

import numpy as np

__all__ = ["BISECTIONS", "OVERSHOOT", "PROBES", "RULES", "halve", "narrow_begin", "narrow_next", "parabola_peak",
           "peak_in_reach", "switching_part", "worth_refining"]

RULES = ("halve", "narrow_begin", "narrow_next", "parabola_peak", "peak_in_reach", "switching_part",
         "worth_refining")

OVERSHOOT = 3.0  # a sampled extremum is refined when 3× its predicted rise would reach the guard
BISECTIONS = 200  # halvings at most (a bracket of floats reaches adjacent numbers within ~2100: never binding
# unless the ends are not finite)
PROBES = BISECTIONS + 1  # probes at most when narrowing (bisection's count plus ITP's slack)


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


def switching_part(truths_lo, truths_hi, signs, count):
    """The guide of a narrowing: the first tracked part (``signs[i]`` ≠ 0)
    of the first ``count`` whose truth differs between the bracket's ends
    ``truths_lo`` and ``truths_hi`` — its margin crosses its threshold in the
    bracket; -1 when none does (the narrowing bisects).  Where several
    change, the first guides: often one comparison in several guards (the
    same margin), else a guide that may mislead, which costs probes, never
    the bracket."""
    for i in range(count):
        if signs[i] != 0 and truths_lo[i] != truths_hi[i]:
            return i
    return -1


ITP_KAPPA = 0.2  # the ITP truncation δ = κ·w·(w/w₀) (κ₁ = 0.2/w₀, κ₂ = 2: Oliveira and Takahashi's choice)
ITP_SLACK = 1.0  # n₀: probes granted beyond bisection's count
ROUND_OFF = 4.0 * 2.220446049250313e-16  # the least truncation, relative to the bracket's larger end: 4 ulps


def narrow_begin(lo, hi, v_lo):
    """The state of a narrowing of ``(lo, hi]`` (no guard holding at ``lo``,
    one at ``hi``; ``v_lo`` the guide at ``lo``: the margin of the
    :func:`switching_part`, NaN without one).  Its probe,
    ``state[-1]``, is ``hi`` itself: the caller hands :func:`narrow_next`
    what it knows there (a guard holds; the guide) for the first probe
    inside.  The state is the tuple ``(lo, hi, v_lo, v_hi, width0, spacing,
    n_max, count, probe)``: the bracket and its ends' guide values, the first
    width, the least spacing of floating-point numbers in the bracket (at its
    end nearer 0), the probes bisection needs at most to reach
    adjacent numbers plus :data:`ITP_SLACK` (ITP's bound on the probes), the
    probes made (−1: none yet), the point to evaluate next."""
    least = min(abs(lo), abs(hi)) if (lo > 0.0) == (hi > 0.0) else 0.0  # the least magnitude in the bracket
    spacing = float(np.spacing(least))
    width = hi - lo
    n_max = ITP_SLACK
    if spacing < width < math.inf:
        n_max += math.ceil(math.log2(width) - math.log2(spacing))
    return (lo, hi, v_lo, math.nan, width, spacing, n_max, -1.0, hi)


def narrow_next(state, holds, value):
    """One step of a narrowing: ``holds`` — a guard holds at the probe
    ``state[-1]`` — and ``value``, the guide there.  Returns ``(done,
    state)``: the next probe ``state[-1]`` (ITP's interpolate, truncate and
    project); when ``done``, ``(state[0], state[1])`` is the bracket:
    adjacent numbers, or :data:`PROBES` made.  In Python::

        state = narrow_begin(lo, hi, guide_lo)
        done, state = narrow_next(state, True, guide_hi)
        while not done:
            tau = state[-1]
            done, state = narrow_next(state, holds_at(tau), guide_at(tau))
        lo, hi = state[0], state[1]
    """
    lo, hi, v_lo, v_hi, width0, spacing, n_max, count, probe = state
    if holds:
        hi = probe
        v_hi = value
    else:
        lo = probe
        v_lo = value
    count += 1.0
    mid = 0.5 * (lo + hi)  # as halve
    if mid <= lo or mid >= hi or count >= PROBES:
        return True, (lo, hi, v_lo, v_hi, width0, spacing, n_max, count, hi)
    width = hi - lo
    probe = mid
    if v_lo < 0.0 and v_hi > 0.0:
        falsi = lo + width * (-v_lo / (v_hi - v_lo))  # interpolate: regula falsi
        if lo < falsi and falsi < hi:
            toward = mid - falsi
            sigma = 1.0 if toward > 0.0 else -1.0
            delta = max(ITP_KAPPA * width * (width / width0), ROUND_OFF * max(abs(lo), abs(hi)))
            probe = falsi + sigma * delta if delta <= abs(toward) else mid  # truncate toward the middle
            reach = max(math.ldexp(spacing, int(n_max - count) - 1) - 0.5 * width, 0.0)
            if abs(probe - mid) > reach:  # project: never slower than bisection by more than ITP_SLACK
                probe = mid - sigma * reach
            if not (lo < probe and probe < hi):
                probe = mid
    return False, (lo, hi, v_lo, v_hi, width0, spacing, n_max, count, probe)
