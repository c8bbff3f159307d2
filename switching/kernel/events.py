"""Event location within one step, as the Python path's
``switching.simulate.events.GuardScan`` (the reference: this is its
translation): the guards at ``samples`` interior points and at the step's
end; besides, a guard holding only between two points — a comparison part
whose margin has an extremum between points within reach of its threshold
(parabola through three points, the previous step's last point included,
refined by Brent's method on the interpolant: the rule
:mod:`switching.rules.maximize`), or two or more parts of one guard changing
truth between two points (each change bisected, the guards tested just after
each); the first time a guard holds located by bisection on the step's
interpolant down to adjacent floating-point numbers.

A part's margin is ``±(left − right) ± b`` with the band ``b`` of the rule
:func:`codegen.decision.band` (units of the compared signals): ≥ 0
(inclusive) or > 0 (strict) exactly where the part holds.

The points of a step are slots of the arrays ``ptau [slots]``, ``pmg [slots,
parts]`` (margins), ``ptr [slots, parts]`` (truths), ``phd [slots]`` (a
guard holds): slot 0 (:data:`S_START`) the flow's last point (the step's
start), 1 (:data:`S_BEFORE`) the previous step's point before its end, 2 the
narrowing's last point not holding (:func:`bisect`), 3 unused, 4 (:data:`S_INSIDE`) a hold
found between the changes of parts, 5 (:data:`S_SCRATCH`) scratch, 6…
(:data:`S_STEP`) the step's points.
"""

from __future__ import annotations

import numpy as np

from .calls import gparts, holds, holds_at
from ..rules.bracket import BISECTIONS
from .compiler import (band, dispatch, halve, inline, maximize_begin, maximize_next, narrow_begin, narrow_next,
                       parabola_peak, peak_in_reach, stamp_with_rules, switching_part, worth_refining)
from .flow import interp, rk45_dense

__all__ = ["S_BEFORE", "S_INSIDE", "S_SCRATCH", "S_START", "S_STEP", "bisect", "event_in_step", "first_hold",
           "margin_peak", "pieces", "point"]

S_START = 0
S_BEFORE = 1
S_INSIDE = 4
S_SCRATCH = 5
S_STEP = 6


@inline
def _parts(slot, tau, hd, m, s, rtol, atol, M, PT):
    """A point into ``slot``: the margins and truths of the parts from the sides ``s`` (the band rule of
    codegen.decision; as switching.simulate.events._GuardForm), the time and whether a guard holds (``hd``)."""
    ptau, pmg, ptr, phd = PT
    prel, psign, pinc, npart = M.tables[3], M.tables[4], M.tables[5], M.lengths[3]
    for i in range(npart[m]):
        if psign[m, i] == 0:
            r = prel[m, i]
            left = s[3 * r]
            right = s[3 * r + 1]
            pmg[slot, i] = 0.0
            ptr[slot, i] = abs(left - right) > band(left, right, s[3 * r + 2], rtol, atol)
        else:
            mg = _margin(m, i, s, rtol, atol, M)
            pmg[slot, i] = mg
            ptr[slot, i] = mg >= 0.0 if pinc[m, i] != 0 else mg > 0.0
    ptau[slot] = tau
    phd[slot] = hd
    return hd


@dispatch
def point(slot, tau, at, yv, kind, m, k, t_old, h, A, E, M, rtol, atol, PT):
    """The guards at ``tau`` into ``slot``: on ``yv`` if ``at`` (a step's end, a flow's start), else on the
    interpolant.  Returns whether a guard holds.  (Callers pass np.int64/np.bool_ constants: a literal
    argument would compile a specialisation of this function per value.)"""
    template, z, dbuf, s, tmp = E
    ptau, pmg, ptr, phd = PT
    if at:
        hd = holds_at(m, yv, tau, M, s, rtol, atol)
    else:
        _interpolate(kind, t_old, h, A, tau, tmp)
        hd = holds_at(m, tmp, tau, M, s, rtol, atol)
    return _parts(slot, tau, hd, m, s, rtol, atol, M, PT)


@inline
def _interpolate(kind, t_old, h, A, tau, out):
    """:func:`.flow.interp`, RK45's inlined (the same values, without a call at each of a step's points)."""
    if kind == 2:
        rk45_dense(A[0], A[2], A[4], h, (tau - t_old) / h, out)
    else:
        interp(kind, t_old, h, A, tau, out)


@inline
def _differ(a, b, count, ptr):
    """Do the points in slots a and b differ in a part's truth?"""
    for i in range(count):
        if ptr[a, i] != ptr[b, i]:
            return True
    return False


@inline
def _copy_point(src, dst, ptau, pmg, ptr, phd):
    ptau[dst] = ptau[src]
    phd[dst] = phd[src]
    for i in range(pmg.shape[1]):
        pmg[dst, i] = pmg[src, i]
        ptr[dst, i] = ptr[src, i]


@inline
def _samples(kind, m, t_old, t_new, h, A, E, M, rtol, atol, samples, PT, order):
    """The step's sample points (GuardScan's): ``samples`` interior points evenly spaced, then the step's end,
    each into the next slot from S_STEP and listed in ``order`` after the flow's last point (slot S_START),
    up to the first where a guard holds.  Returns ``(cnt, nxt, last)``: the points listed, the next free slot,
    the index in ``order`` of the point holding (-1: none)."""
    y_new = A[2]
    template, z, dbuf, s, tmp = E
    ptau = PT[0]
    nxt = S_STEP
    order[0] = S_START
    cnt = 1
    last = -1
    span = t_new - t_old
    for j in range(1, samples + 1):
        tau = t_old + span * j / (samples + 1)
        if ptau[order[cnt - 1]] < tau and tau < t_new:  # a step of a few ulps has fewer distinct points
            _interpolate(kind, t_old, h, A, tau, tmp)
            hd = _parts(nxt, tau, holds(m, tmp, tau, M, s, rtol, atol), m, s, rtol, atol, M, PT)
            order[cnt] = nxt
            cnt += 1
            nxt += 1
            if hd:
                return cnt, nxt, cnt - 1
    hd = _parts(nxt, t_new, holds(m, y_new, t_new, M, s, rtol, atol), m, s, rtol, atol, M, PT)
    order[cnt] = nxt
    cnt += 1
    nxt += 1
    if hd:
        last = cnt - 1
    return cnt, nxt, last


@inline
def _window(j, count, last, i, ext, ptau, pmg):
    """Is the point ``ext[j]`` a maximum of part i's margin worth a parabola (GuardScan.extrema): an interior
    maximum, rising at the step's end (no hold in the step), or falling from the flow's start?  Returns ``(ok,
    c0, low, high, w0, w1, windowed)``: the first of the three points of the parabola, the bracket to search,
    the window the parabola's peak must fall in (``windowed``)."""
    mj = pmg[ext[j], i]
    if 0 < j < count - 1:
        if not (mj >= pmg[ext[j - 1], i] and mj >= pmg[ext[j + 1], i]):
            return False, 0, 0.0, 0.0, 0.0, 0.0, False
        return True, j - 1, ptau[ext[j - 1]], ptau[ext[j + 1]], -np.inf, np.inf, False
    if j == count - 1 and last < 0 and mj > pmg[ext[j - 1], i]:  # rising at the step's end
        return (True, j - 2, ptau[ext[j - 1]], ptau[ext[j]], ptau[ext[j - 1]], 2 * ptau[ext[j]] - ptau[ext[j - 1]],
                True)
    if j == 0 and mj > pmg[ext[1], i]:  # falling from the flow's start
        return True, 0, ptau[ext[0]], ptau[ext[1]], 2 * ptau[ext[0]] - ptau[ext[1]], ptau[ext[1]], True
    return False, 0, 0.0, 0.0, 0.0, 0.0, False


@inline
def _near_threshold(i, c0, low, high, w0, w1, windowed, t_old, t_new, ext, ptau, pmg):
    """Does the parabola through the points ``ext[c0:c0 + 3]`` of part i's margin peak within reach of the
    threshold (the rule :func:`switching.rules.bracket.peak_in_reach`, ``reference`` the largest of the three),
    in the window?  Returns ``(ok, low, high)``: the bracket clipped to the step."""
    a0, a1, a2 = ext[c0], ext[c0 + 1], ext[c0 + 2]
    ok, at, value = parabola_peak(ptau[a0], ptau[a1], ptau[a2], pmg[a0, i], pmg[a1, i], pmg[a2, i])
    if not ok:
        return False, low, high
    reference = max(pmg[a0, i], max(pmg[a1, i], pmg[a2, i]))
    if windowed and not (w0 < at and at < w1):
        return False, low, high
    if not peak_in_reach(value, reference):
        return False, low, high
    low = max(low, t_old)
    high = min(high, t_new)
    return high > low, low, high


@inline
def _is_new(tau, ext, count, order, cnt, total, ptau):
    """Is ``tau`` none of the points scanned (``ext[:count]``) nor of those added (``order[cnt:total]``)?"""
    for jj in range(count):
        if ptau[ext[jj]] == tau:
            return False
    for jj in range(cnt, total):
        if ptau[order[jj]] == tau:
            return False
    return True


@inline
def _by_time(order, total, ptau):
    """``order[:total]`` sorted by the points' times (insertion sort: stable)."""
    for j in range(1, total):
        slot = order[j]
        jj = j
        while jj > 0 and ptau[order[jj - 1]] > ptau[slot]:
            order[jj] = order[jj - 1]
            jj -= 1
        order[jj] = slot


@inline
def _extrema(kind, m, k, t_old, t_new, h, A, E, M, rtol, atol, PT, SC, cnt, nxt, last):
    """GuardScan.extrema: for each comparison part whose margin comes within reach of its threshold, each
    maximum of the margin between the points (the previous step's point before its end included when
    ``scan[0]``) refined by Brent's method (:func:`margin_peak`) into a new point.  Returns ``(total, nxt)``: the
    points in ``order`` (in time order), the next free slot."""
    y_new = A[2]
    ptau, pmg, ptr, phd = PT
    order, ext, iscr, fscr, q, scan = SC
    psign, npart = M.tables[4], M.lengths[3]
    first = 0
    count = 0
    if scan[0] != 0:
        ext[0] = S_BEFORE
        first = 1
        count = 1
    for j in range(cnt):
        ext[count] = order[j]
        count += 1
    total = cnt
    if count < 3:
        return total, nxt
    for i in range(npart[m]):
        if psign[m, i] == 0:
            continue
        top = pmg[ext[0], i]
        bottom = top
        for j in range(1, count):
            v = pmg[ext[j], i]
            top = max(top, v)
            bottom = min(bottom, v)
        if not worth_refining(top, bottom):
            continue  # holds all along, or far from its threshold all along
        for j in range(first, count):
            if ptr[ext[j], i]:
                continue
            ok, c0, low, high, w0, w1, windowed = _window(j, count, last, i, ext, ptau, pmg)
            if not ok:
                continue
            ok, low, high = _near_threshold(i, c0, low, high, w0, w1, windowed, t_old, t_new, ext, ptau, pmg)
            if not ok:
                continue
            tau = margin_peak(i, low, high, kind, m, k, t_old, h, A, E, M, rtol, atol, PT)
            if _is_new(tau, ext, count, order, cnt, total, ptau):
                point(nxt, tau, np.bool_(False), y_new, kind, m, k, t_old, h, A, E, M, rtol, atol, PT)
                order[total] = nxt
                total += 1
                nxt += 1
    if total > cnt:
        _by_time(order, total, ptau)
    return total, nxt


@inline
def _first_bracket(kind, m, k, t_old, h, A, E, M, rtol, atol, PT, SC, total):
    """GuardScan.first_hold: between the first two consecutive points where a guard starts to hold — at the
    later point, or inside, found from parts changing truth (:func:`pieces`) — the bracket ``(lo, hi)`` of the
    first hold, bisected down to adjacent floating-point numbers and verified with the guards themselves (else
    the plain bracket of the two points); ``(-1.0, -1.0)`` if no guard holds in the step."""
    template, z, dbuf, s, tmp = E
    ptau, pmg, ptr, phd = PT
    order = SC[0]
    P = M.lengths[3][m]
    for j in range(1, total):
        a = order[j - 1]
        b = order[j]
        if phd[b]:
            lo, tau = bisect(a, b, kind, m, k, t_old, h, A, E, M, rtol, atol, PT)
            if lo != a and _differ(a, lo, P, ptr):
                inside = pieces(a, lo, kind, m, k, t_old, h, A, E, M, rtol, atol, PT, SC)
                if inside >= 0:
                    lo, tau = bisect(a, inside, kind, m, k, t_old, h, A, E, M, rtol, atol, PT)
            end = b
        else:
            if not _differ(a, b, P, ptr):
                continue
            inside = pieces(a, b, kind, m, k, t_old, h, A, E, M, rtol, atol, PT, SC)
            if inside < 0:
                continue
            lo, tau = bisect(a, inside, kind, m, k, t_old, h, A, E, M, rtol, atol, PT)
            end = inside
        # verified: tau checked with the guards themselves (else the plain bracket)
        interp(kind, t_old, h, A, tau, tmp)
        if holds_at(m, tmp, tau, M, s, rtol, atol):
            return ptau[lo], tau
        return ptau[a], ptau[end]
    return -1.0, -1.0


@dispatch
def event_in_step(kind, m, k, t_old, t_new, h, A, E, M, rtol, atol, samples, PT, SC):
    """First time in (t_old, t_new] a guard holds, or -1.0: switching.simulate.events.GuardScan.first_hold (the
    sample points, refined extrema of the parts' margins, holds between parts changing truth) and locate_event.
    ``scan[0]``: the previous step's point before its end is in slot 1 (reset at every flow start)."""
    template, z, dbuf, s, tmp = E
    ptau, pmg, ptr, phd = PT
    order, scan = SC[0], SC[5]
    if M.lengths[4][m] == 0:
        return -1.0
    cnt, nxt, last = _samples(kind, m, t_old, t_new, h, A, E, M, rtol, atol, samples, PT, order)
    total, nxt = _extrema(kind, m, k, t_old, t_new, h, A, E, M, rtol, atol, PT, SC, cnt, nxt, last)
    lo_a, hi_b = _first_bracket(kind, m, k, t_old, h, A, E, M, rtol, atol, PT, SC, total)
    if hi_b < 0.0:
        if total >= 2:
            _copy_point(order[total - 2], S_BEFORE, ptau, pmg, ptr, phd)
            _copy_point(order[total - 1], S_START, ptau, pmg, ptr, phd)
            scan[0] = 1
        return -1.0
    # switching.simulate.events.locate_event
    return first_hold(lo_a, hi_b, kind, m, t_old, h, A, M, s, tmp, rtol, atol)[1]


@dispatch
def first_hold(t_lo, hi, kind, m, t_old, h, A, M, s, tmp, rtol, atol):
    """Bisection of the step's interpolant over (t_lo, hi] (no guard holding at ``t_lo``, one at ``hi``) down to
    adjacent floating-point numbers: ``(t_lo, hi)``, the last time seen not holding and the first holding."""
    for _ in range(BISECTIONS):
        more, mid = halve(t_lo, hi)
        if not more:
            break
        _interpolate(kind, t_old, h, A, mid, tmp)
        if holds_at(m, tmp, mid, M, s, rtol, atol):
            hi = mid
        else:
            t_lo = mid
    return t_lo, hi


@inline
def _margin(m, i, s, rtol, atol, M):
    """The margin of the tracked part i of mode m from the sides ``s``, as :func:`_parts` computes it."""
    r = M.tables[3][m, i]
    left = s[3 * r]
    right = s[3 * r + 1]
    d = left - right
    width = band(left, right, s[3 * r + 2], rtol, atol)
    return (d if M.tables[4][m, i] > 0 else -d) + (width if M.tables[5][m, i] != 0 else -width)


@dispatch
def bisect(a, b, kind, m, k, t_old, h, A, E, M, rtol, atol, PT):
    """GuardScan.locate: ``(a, b]`` (slots: no guard holding at the point ``a``, one at ``b``) narrowed down to
    adjacent floating-point numbers (the rules ``narrow_begin``/``narrow_next`` of
    :mod:`switching.rules.bracket`, guided by the margin of the ``switching_part``); ``(lo, hi)``, ``lo`` the
    slot of the last point seen not holding."""
    template, z, dbuf, s, tmp = E
    ptau, pmg, ptr, phd = PT
    part = switching_part(ptr[a], ptr[b], M.tables[4][m], M.lengths[3][m])
    v_lo = pmg[a, part] if part >= 0 else np.nan
    v_hi = pmg[b, part] if part >= 0 else np.nan
    done, state = narrow_next(narrow_begin(ptau[a], ptau[b], v_lo), True, v_hi)
    t_lo = ptau[a]
    while not done:
        tau = state[-1]
        _interpolate(kind, t_old, h, A, tau, tmp)
        hd = holds_at(m, tmp, tau, M, s, rtol, atol)
        if not hd:
            t_lo = tau
        done, state = narrow_next(state, hd, _margin(m, part, s, rtol, atol, M) if part >= 0 else np.nan)
    if t_lo == ptau[a]:
        return a, state[1]
    # the last point not holding, evaluated again (deterministic) for its parts' truths
    lo = 2
    interp(kind, t_old, h, A, t_lo, tmp)
    _parts(lo, t_lo, holds_at(m, tmp, t_lo, M, s, rtol, atol), m, s, rtol, atol, M, PT)
    return lo, state[1]


@dispatch
def pieces(a, b, kind, m, k, t_old, h, A, E, M, rtol, atol, PT, SC):
    """GuardScan.pieces: the slot of a point inside (a, b) where a guard holds although it holds at neither
    end, found from parts changing truth in between; -1 if none.  iscr [2·parts], fscr [parts], q [parts]."""
    y_new = A[2]  # the step's end (an argument of point where it is not read)
    template, z, dbuf, s, tmp = E
    ptau, pmg, ptr, phd = PT
    order, ext, iscr, fscr, q, scan = SC
    pguard, npart, nguard = M.tables[6], M.lengths[3], M.lengths[4]
    P = npart[m]
    if not _differ(a, b, P, ptr):
        return -1
    changed = False
    for i in range(P):
        iscr[P + i] = 0
    for g in range(nguard[m]):
        ns = 0
        for i in range(P):
            if pguard[m, i] == g and ptr[a, i] != ptr[b, i]:
                iscr[ns] = i
                ns += 1
        if ns < 2:
            continue
        # possible: can guard g hold for some truth values of the switching parts, the others as at a?
        for i in range(P):
            q[i] = ptr[a, i]
        can = False
        for combination in range(1 << ns):
            for bit in range(ns):
                q[iscr[bit]] = (combination >> bit) & 1 == 1
            if gparts(m, g, q, M):
                can = True
                break
        if can:
            changed = True
            for bit in range(ns):
                iscr[P + iscr[bit]] = 1
    if not changed:
        return -1
    nt = 0
    for i in range(P):
        if iscr[P + i] == 0:
            continue
        # switch: the first time after which part i has its truth value at b
        lo = ptau[a]
        hi = ptau[b]
        truth_lo = ptr[a, i]
        for _ in range(BISECTIONS):
            more, mid = halve(lo, hi)
            if not more:
                break
            point(np.int64(S_SCRATCH), mid, np.bool_(False), y_new, kind, m, k, t_old, h, A, E, M, rtol, atol, PT)
            if ptr[S_SCRATCH, i] == truth_lo:
                lo = mid
            else:
                hi = mid
        fscr[nt] = hi
        nt += 1
    for j in range(1, nt):  # the times in order
        tau = fscr[j]
        jj = j
        while jj > 0 and fscr[jj - 1] > tau:
            fscr[jj] = fscr[jj - 1]
            jj -= 1
        fscr[jj] = tau
    for j in range(nt):
        tau = fscr[j]
        if j > 0 and tau == fscr[j - 1]:
            continue
        if tau < ptau[b]:
            if point(np.int64(S_INSIDE), tau, np.bool_(False), y_new, kind, m, k, t_old, h, A, E, M, rtol, atol, PT):
                return S_INSIDE
    return -1


@dispatch
def margin_peak(i, a, b, kind, m, k, t_old, h, A, E, M, rtol, atol, PT):
    """A maximum on [a, b] of the margin of part i on the step's interpolant, or the first point found where it
    is ≥ 0 (the part holds): the rule switching.rules.maximize (Brent's method), as switching.simulate.events does."""
    y_new = A[2]  # the step's end (an argument of point where it is not read)
    pmg = PT[1]
    state = maximize_begin(a, b)
    done = False
    while not done:
        point(np.int64(S_SCRATCH), state[-1], np.bool_(False), y_new, kind, m, k, t_old, h, A, E, M, rtol, atol, PT)
        done, state = maximize_next(state, pmg[S_SCRATCH, i])
    return state[-1]


stamp_with_rules(globals(), __name__)
