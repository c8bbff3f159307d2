"""The resolution of an instant (the paper's selMode, DESIGN §6) through
mythical modes and pinnacles, by the rule :mod:`switching.rules.instants`
(which :func:`switching.simulate.resolution.resolve_instant` follows too):
``x⁺ = g_β(x)`` from the a priori ``x`` of the last real mode, a posteriori
guards on ``x⁺`` with the impulses ``Σ_k ∂side/∂ẋ_k · Δx_k`` of the jump (the
pulse of the rule :mod:`switching.rules.jumps`), the next mode from the fired
automata.  Modes are known to the rule by their codes.

Whatever needs more than that — a mode outside the model's compiled set, a
numerical (nonlinear) jump map, a pulse in a side that is not affine in
``ẋ``, a mode repeating in a mythical chain or a pinnacle repeating its
state (a divergence of time, which Python reports in full), the cap on steps
per instant — returns -1: Python resolves that instant (deterministically,
so the results are the same).  The mode functions' ``fire`` does not tell a
guard holding only at a tie from one holding strictly, so every firing
reaches the rule as strict (:data:`~switching.rules.instants.FIRED`): a
cycle of ties is a repeat here, and Python rests it by the same rule
(``JUMP_AT_TIE``); the flow after such a rest runs in Python, counting a
guard only once it holds strictly (``switching.simulate.driver``).
"""

from __future__ import annotations

import numpy as np

from ..rules.instants import CONTINUOUS, DECIDE_AS_FLOW, JUMP_AND_DECIDE
from ..rules.jumps import MOTION_ULPS
from .calls import finite, fire, fy, jump
from .compiler import decides_as_in_flow, inline, instant_begin, instant_next, jit, jump_pulse, stamp_with_rules

__all__ = ["mode_of", "next_code", "resolve"]

@inline
def next_code(m, target, mstates, radix):
    """The code ``Σ_a state_a·radix_a`` of the mode reached from mode m when each automaton a with
    ``target[a] ≥ 0`` moves to that state (the others stay)."""
    code = 0
    for a in range(radix.shape[0]):
        state = target[a] if target[a] >= 0 else mstates[m, a]
        code += state * radix[a]
    return code


@inline
def mode_of(code, codes, code_ids):
    """The number of the mode of ``code`` in the sorted ``codes`` (their numbers ``code_ids``), or -1 (not
    compiled)."""
    lo = 0
    hi = codes.shape[0]
    while lo < hi:  # (np.searchsorted's left side, written out: its implementation's module is not imported)
        mid = (lo + hi) >> 1
        if codes[mid] < code:
            lo = mid + 1
        else:
            hi = mid
    if lo < codes.shape[0] and codes[lo] == code:
        return code_ids[lo]
    return -1


@jit
def resolve(m0, x_in, t, M, tol, max_instant, R):
    """Resolve the instant from the a priori x_in in mode m0 by the rule switching.rules.instants (the passes
    through mythical modes and pinnacles are the rule's; the jumps and guards are the modes' own functions).
    Returns the mode reached (its state in xa) and the number of passes, or -1: Python must resolve it.
    x, xp, d [n], target [automata], chain [max_instant + 1], pin_m [P], pin_x [P, n]: scratch."""
    rtol, atol, jrtol, jatol = tol
    s, post, xa, x, xp, d, target, chain, pin_m, pin_x, motion = R
    moved, n_moved, mstates, radix = M.tables[2], M.lengths[2], M.mstates, M.radix
    codes, code_ids, mode_codes = M.codes[0], M.codes[1], M.codes[2]
    n = x_in.shape[0]
    for i in range(n):
        x[i] = x_in[i]
        motion[i] = 0.0
    # each state's motion within the round-off of t in m0, the mode that flowed into the instant (rules.jumps)
    k, ind = M.lengths[0][m0], M.tables[0]
    if k > 0:
        for i in range(k):
            xp[i] = x_in[ind[m0, i]]
        fy(m0, xp, t, M, d)
        unit = MOTION_ULPS * np.spacing(abs(t))
        for i in range(k):
            if np.isfinite(d[i]):
                motion[ind[m0, i]] = unit * abs(d[i])
    cur = m0
    state = instant_begin(mode_codes[m0], chain)
    while True:
        action = state[0]
        if action == JUMP_AND_DECIDE:
            if state[1] > 1:  # (the first pass is in m0 itself, found by its number even where codes overflow)
                cur = mode_of(state[2], codes, code_ids)
            if cur < 0 or not jump(cur, x, t, M, xp):
                return -1, 0
            quiet = decides_as_in_flow(state, jump_pulse(x, xp, moved[cur], n_moved[cur], jrtol, jatol, motion, d))
            after = xp
        elif action == DECIDE_AS_FLOW:
            for i in range(n):
                x[i] = xp[i]
                d[i] = 0.0
            if not finite(x):
                return -1, 0
            quiet = True
            after = x
        elif action == CONTINUOUS:
            for i in range(n):
                xa[i] = x[i]
            return cur, state[1]
        else:  # a divergence of time, the cap on steps, no room: Python resolves it and reports it in full
            return -1, 0
        for a in range(target.shape[0]):
            target[a] = -1
        if not fire(cur, x, after, t, M, d, s, post, rtol, atol, target, quiet):
            return -1, 0
        fired = False
        for a in range(target.shape[0]):
            if target[a] >= 0:
                fired = True
        state = instant_next(state, fired, next_code(cur, target, mstates, radix), x, max_instant, chain, pin_m,
                             pin_x)


stamp_with_rules(globals(), __name__)
