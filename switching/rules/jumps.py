"""The pulse at a jump: the change of state ``Δx = x⁺ − x`` that carries
Dirac pulses, with round-off removed.

A jump map evaluated in floating point moves states it leaves unchanged in
exact arithmetic by a few units of round-off.  Such a change must carry no
pulse: a signal with an impulse part ``a(x)ᵀΔx`` (DESIGN §5) would compare
as ±∞ in a guard.  So a component of ``Δx`` counts only when

    |Δx_i| > jump_rtol · s + jump_atol,   s = max over the moved states j of max(|x_j|, |x⁺_j|),

the moved states being those the mode's jump map may change (its
participating and dependent states; a NaN among them does not count in
``s``); with none, ``Δx = 0``.  The state itself
still takes the exact ``x⁺``: only the pulse is cleaned.

A change within the state's own motion over the round-off of the instant's
time, ``|Δx_i| ≤ motion_i = MOTION_ULPS·ulp(t)·|ẋ_i|`` (``ẋ`` the rates of
the mode that flowed into the instant), is no jump either: an instant is
located to a few units in the last place of ``t``, so the state at it is
known only to within that motion.  An inductor's current located crossing
zero at 8e-17 A·H off (its flux moving 7e-16 in one ulp of t = 4.9 ms) and
set to 0 by a diode that stops conducting moves no charge: a pulse there
decided the diodes of a bridge with line inductance back and forth, a Zeno
of round-off.  Homogeneous in units, as the rest of the band.
"""

from __future__ import annotations

__all__ = ["RULES", "MOTION_ULPS", "jump_pulse"]

#: the units in the last place of ``t`` within which an instant is located (the motion band above)
MOTION_ULPS = 64.0

RULES = ("jump_pulse",)


def jump_pulse(x, xp, moved, n_moved, rtol, atol, motion, d):
    """``d[:] = x⁺ − x`` (``x``, ``xp``: arrays of one length) with the
    components within the band above set to 0; ``moved[:n_moved]`` are the
    indices of the moved states, ``rtol``, ``atol`` the jump's tolerances,
    ``motion`` each state's motion band (zeros where no mode flowed into the
    instant).  Returns whether all of ``d`` is 0 (the jump carries no pulse)."""
    for i in range(x.shape[0]):
        d[i] = xp[i] - x[i]
    if n_moved == 0:
        for i in range(x.shape[0]):
            d[i] = 0.0
        return True
    scale = 0.0
    for j in range(n_moved):  # (comparisons, not max(): the builtin of Python and numba's differ on NaN)
        i = moved[j]
        if abs(x[i]) > scale:
            scale = abs(x[i])
        if abs(xp[i]) > scale:
            scale = abs(xp[i])
    band = rtol * scale + atol
    none = True
    for i in range(x.shape[0]):
        if abs(d[i]) <= band + motion[i]:
            d[i] = 0.0
        else:
            none = False
    return none
