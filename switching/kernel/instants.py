"""The resolution of an instant (the paper's selMode, DESIGN §6; the
reference is :func:`switching.simulate.resolution.resolve_instant`) through
mythical modes and pinnacles: ``x⁺ = g_β(x)`` from the a priori ``x`` of the
last real mode, a posteriori guards on ``x⁺`` with the impulses
``Σ_k ∂side/∂ẋ_k · Δx_k`` of the jump (the pulse of the rule
:mod:`switching.rules.jumps`), the next mode from the fired automata.

Whatever needs more than that — a mode outside the model's compiled set, a
numerical (nonlinear) jump map, a pulse in a side that is not affine in
``ẋ``, a mode repeating in a mythical chain or a pinnacle repeating its
state (a divergence of time, which Python reports in full), the cap on steps
per instant — returns -1: Python resolves that instant (deterministically,
so the results are the same).
"""

from __future__ import annotations

import numpy as np

from .calls import finite, fire, jump
from .compiler import inline, jit, jump_pulse, stamp_with_rules

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
    if codes.shape[0] == 0:
        return -1
    j = np.searchsorted(codes, code)
    if j < codes.shape[0] and codes[j] == code:
        return code_ids[j]
    return -1


@jit
def resolve(m0, x_in, t, M, tol, max_instant, R):
    """Resolve the instant from the a priori x_in in mode m0 (switching.simulate.resolution).
    Returns the mode reached (its state in xa) and the number of modes passed, or -1: Python must resolve it.
    x, xp, d [n], target [automata], chain [max_instant + 1], pin_m [P], pin_x [P, n]: scratch."""
    rtol, atol, jrtol, jatol = tol
    s, post, xa, x, xp, d, target, chain, pin_m, pin_x = R
    moved, n_moved, mstates, radix = M.tables[2], M.lengths[2], M.mstates, M.radix
    codes, code_ids, mode_codes = M.codes[0], M.codes[1], M.codes[2]
    n = x_in.shape[0]
    for i in range(n):
        x[i] = x_in[i]
    n_chain = 1
    chain[0] = mode_codes[m0]
    n_pin = 0
    cur = m0
    for passes in range(1, max_instant + 1):
        if cur < 0:
            return -1, 0
        if not jump(cur, x, t, M, xp):
            return -1, 0
        quiet = jump_pulse(x, xp, moved[cur], n_moved[cur], jrtol, jatol, d) and passes == 1
        for a in range(target.shape[0]):
            target[a] = -1
        if not fire(cur, x, xp, t, M, d, s, post, rtol, atol, target, quiet):
            return -1, 0
        fired = False
        for a in range(target.shape[0]):
            if target[a] >= 0:
                fired = True
        if fired:  # cur was mythical
            code = next_code(cur, target, mstates, radix)
            for j in range(n_chain):
                if chain[j] == code:
                    return -1, 0  # divergence of time: Python reports the loop
            chain[n_chain] = code
            n_chain += 1
            cur = mode_of(code, codes, code_ids)
            continue
        for i in range(n):
            x[i] = xp[i]
        if not finite(x):
            return -1, 0
        for i in range(n):
            d[i] = 0.0
        if not fire(cur, x, x, t, M, d, s, post, rtol, atol, target, True):
            return -1, 0
        fired = False
        for a in range(target.shape[0]):
            if target[a] >= 0:
                fired = True
        if not fired:  # continuous
            for i in range(n):
                xa[i] = x[i]
            return cur, passes
        # a pinnacle; one repeating its state is a divergence of time, reported by Python
        if n_pin == pin_m.shape[0]:
            return -1, 0
        for j in range(n_pin):
            if pin_m[j] == cur:
                same = True
                for i in range(n):
                    if abs(pin_x[j, i] - x[i]) > 1e-300 + 1e-12 * abs(x[i]):
                        same = False
                        break
                if same:
                    return -1, 0
        pin_m[n_pin] = cur
        for i in range(n):
            pin_x[n_pin, i] = x[i]
        n_pin += 1
        code = next_code(cur, target, mstates, radix)
        n_chain = 1
        chain[0] = code
        cur = mode_of(code, codes, code_ids)
    return -1, 0


stamp_with_rules(globals(), __name__)
