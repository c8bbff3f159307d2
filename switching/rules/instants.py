"""The resolution of an instant (the paper's selMode, DESIGN §6), as reverse
communication: which mode is passed next, when the instant ends, and when
it diverges.

An instant begins in the mode the flow ran in, with the a priori state
``x``.  Each *pass* through a candidate mode ``m``:

1. the caller evaluates the jump ``x⁺ = g_m(x)`` and decides the guards of
   ``m`` — a priori guards on ``x``, a posteriori guards on ``x⁺`` with the
   impulses of the jump (the pulse: :mod:`switching.rules.jumps`); on the
   first pass, when the jump carries no pulse, every guard is decided on
   ``x`` as during flow (:func:`decides_as_in_flow`: an event located in
   flow is then seen to hold by the same arithmetic that located it);
2. a transition fired: ``m`` is *mythical* — the state stays ``x`` and the
   next pass is in the mode the fired transitions reach.  That mode already
   passed in this chain of mythical modes is a divergence of time
   (:data:`REPEATS_IN_CHAIN`; ``detail`` is its place in the chain) —
   unless the cycle is a *tie* (below);
3. none fired: the state takes ``x⁺`` and the caller decides every guard of
   ``m`` on ``x⁺`` as during flow (no jump from here):
   * none fires: ``m`` is the continuous mode, the instant ends
     (:data:`CONTINUOUS`);
   * one fires: ``m`` is a *pinnacle*, entered and left at once; the next
     pass starts a new chain from the mode reached.  A pinnacle of the same
     mode with the same state (within ``10⁻¹²`` relative, among that mode's
     last :data:`PINNACLES_COMPARED` pinnacles) is a divergence of time
     (:data:`PINNACLE_REPEATS`; ``detail`` is the earlier pinnacle's place).

**Ties at the edge.**  A comparison is *at its edge* when its sides differ
by no more than its tolerance band (equality up to round-off,
:mod:`codegen.decision`; no impulse deciding it); a guard holds *strictly*
when it holds however its comparisons at their edge are decided, and a
pass fired *at a tie* (:data:`FIRED_AT_TIE`) when every transition it fired
holds, but none strictly — an inclusive comparison (``>=``, ``<=``, ``==``)
holding within its band: ``v_D >= 0`` at ``v_D = 0``.  When the chain of
mythical modes returns to a mode ``chain[j]`` and every pass of the cycle
``chain[j:]`` fired at a tie, no switch of the cycle is taken (no switching
on a tie): the instant rests in ``chain[j]``, the mode where the cycle
began — the caller jumps in it, takes ``x = x⁺`` and decides its guards as
in flow, strictly (:data:`JUMP_AT_TIE`): none holding strictly, it is the
continuous mode (:data:`CONTINUOUS`, ``detail`` = ``j``); one holding
strictly, it is a pinnacle as in 3.  This is physical: at equality the
modes of the cycle describe one and the same state at this instant (an
ideal diode at rest, off with ``v_D = 0`` or on with ``i_D = 0``), so each
is consistent and resting in the first leaves the state consistent; the
flow then decides, each guard holding at its edge counted only once it
holds strictly (``switching.simulate.events.GuardScan``, ``strict``), so the
diode turns on when ``v_D`` becomes positive, off when ``i_D`` becomes
negative, as with strict guards.  A cycle with one pass that fired
strictly (a comparison holding beyond its band) is a divergence of time,
as before (DESIGN §6): the paper's diode with a holding current above its
current, its colliding balls without a separating condition (touching, the
collision guard holds at a tie after a separation that holds strictly).
That holds even where the mode left only at a tie would be a consistent
rest: an ideal diode with ``v_D >= 0`` to turn on, turning off against a
capacitor (``i_D < 0`` at the located crossing, ``v_D = 0`` after it), loops
off → on → off; ``switching.simulate.resolution`` names such switches and
says to write them strictly (``v_D > 0``), as ``models.circuits`` does.
The compiled kernel reports every firing as strict (it does not tell ties
apart), so a tie's cycle reaches Python, which resolves it by this rule.

More than ``max_steps`` passes end the instant with :data:`TOO_MANY_STEPS`.

Modes are integers the caller chooses (the kernel's mode codes, or the
Python path's numbering of the modes met): the rule only compares them.
The caller owns the memory: ``chain[max_steps + 1]`` (modes),
``pin_modes[P]`` and ``pin_x[P, n]`` (the pinnacles' modes and states);
with no room for another pinnacle the rule answers :data:`NO_ROOM`.

In Python::

    state = instant_begin(mode, chain)
    while state[0] in (JUMP_AND_DECIDE, DECIDE_AS_FLOW, JUMP_AT_TIE):
        ...  # the caller's step, as state[0] says, in mode state[2]
        state = instant_next(state, fired, target, x, max_steps, chain, pin_modes, pin_x)

``fired``: 0 (``False``) none fired, 1 (``True``, :data:`FIRED`) a
transition fired, :data:`FIRED_AT_TIE` transitions fired, all at a tie.
``state`` is the tuple ``(action, passes, mode, chain length, pinnacles,
detail, ties from)`` of integers, ``ties from`` the first place in the
chain from which every pass fired at a tie.
"""

from __future__ import annotations

__all__ = ["CONTINUOUS", "DECIDE_AS_FLOW", "FIRED", "FIRED_AT_TIE", "JUMP_AND_DECIDE", "JUMP_AT_TIE", "NO_ROOM",
           "PINNACLES_COMPARED", "PINNACLE_REPEATS", "REPEATS_IN_CHAIN", "RULES", "TOO_MANY_STEPS",
           "decides_as_in_flow", "instant_begin", "instant_next"]

RULES = ("instant_begin", "instant_next", "decides_as_in_flow")

#: the caller: jump in ``state[2]``, decide its guards on ``(x, x⁺)``, report what fired
JUMP_AND_DECIDE = 0
#: the caller: take ``x = x⁺`` and decide every guard of ``state[2]`` on ``x`` as in flow, report what fired
DECIDE_AS_FLOW = 1
#: the instant ends in the continuous mode ``state[2]`` (its state: the last ``x``)
CONTINUOUS = 2
#: divergence of time: the mode reached repeats in the chain of mythical modes at ``chain[state[5]]``
REPEATS_IN_CHAIN = 3
#: divergence of time: the pinnacle repeats the pinnacle ``state[5]`` (same mode, same state)
PINNACLE_REPEATS = 4
#: the instant took ``max_steps`` passes and did not end
TOO_MANY_STEPS = 5
#: no room left in ``pin_modes`` / ``pin_x`` for another pinnacle
NO_ROOM = 6
#: the caller: a cycle of ties began at ``state[2]`` (``chain[state[5]]``): jump in it, take ``x = x⁺`` and decide
#: every guard as in flow, counting only those that hold strictly; report what fired
JUMP_AT_TIE = 7

#: ``fired``: a transition fired, holding strictly (beyond the band of a comparison it needs)
FIRED = 1
#: ``fired``: every transition that fired holds only at a tie (some comparison within its band)
FIRED_AT_TIE = 2

#: a pinnacle's state is compared with this many earlier pinnacles of its mode (bounded work
#: per pinnacle; a longer cycle ends at the cap on steps)
PINNACLES_COMPARED = 64
#: states within this relative distance (and 10⁻³⁰⁰ absolute) are the same
SAME_STATE_RTOL = 1e-12


def instant_begin(mode, chain):
    """The state of an instant beginning in ``mode`` (``chain[0] = mode``):
    its first pass jumps and decides (:data:`JUMP_AND_DECIDE`)."""
    chain[0] = mode
    return (JUMP_AND_DECIDE, 1, mode, 1, 0, -1, 0)


def decides_as_in_flow(state, pulse_free):
    """Whether this pass decides every guard on ``x`` as during flow: the
    first pass of the instant, when its jump carries no pulse."""
    return state[1] == 1 and pulse_free


def instant_next(state, fired, target, x, max_steps, chain, pin_modes, pin_x):
    """The state after the caller's step: ``fired`` whether a transition of
    mode ``state[2]`` fired (0, :data:`FIRED` or :data:`FIRED_AT_TIE`),
    ``target`` the mode the fired transitions reach, ``x`` the state after
    the step (``x⁺`` after :data:`DECIDE_AS_FLOW` and :data:`JUMP_AT_TIE`)."""
    action, passes, mode, n_chain, n_pin, ties_from = state[0], state[1], state[2], state[3], state[4], state[6]
    if action == JUMP_AND_DECIDE:
        if not fired:
            return (DECIDE_AS_FLOW, passes, mode, n_chain, n_pin, -1, ties_from)
        if fired != FIRED_AT_TIE:  # the pass at chain[n_chain - 1] fired strictly
            ties_from = n_chain
        for j in range(n_chain):  # mythical
            if chain[j] == target:
                if j < ties_from:
                    return (REPEATS_IN_CHAIN, passes, target, n_chain, n_pin, j, ties_from)
                if passes >= max_steps:  # a cycle of ties: rest where it began
                    return (TOO_MANY_STEPS, passes, mode, n_chain, n_pin, -1, ties_from)
                return (JUMP_AT_TIE, passes + 1, target, n_chain, n_pin, j, ties_from)
        if passes >= max_steps:
            return (TOO_MANY_STEPS, passes, mode, n_chain, n_pin, -1, ties_from)
        chain[n_chain] = target
        return (JUMP_AND_DECIDE, passes + 1, target, n_chain + 1, n_pin, -1, ties_from)
    if not fired:
        return (CONTINUOUS, passes, mode, n_chain, n_pin, state[5] if action == JUMP_AT_TIE else -1, ties_from)
    compared = 0  # a pinnacle
    for j in range(n_pin - 1, -1, -1):
        if pin_modes[j] == mode:
            same = True  # |x_j − x_i| ≤ 10⁻³⁰⁰ + 10⁻¹²·|x_i| for all i (a rule calls no other function)
            for i in range(x.shape[0]):
                if not abs(pin_x[j, i] - x[i]) <= 1e-300 + SAME_STATE_RTOL * abs(x[i]):
                    same = False
                    break
            if same:
                return (PINNACLE_REPEATS, passes, mode, n_chain, n_pin, j, ties_from)
            compared += 1
            if compared == PINNACLES_COMPARED:
                break
    if n_pin >= pin_modes.shape[0]:
        return (NO_ROOM, passes, mode, n_chain, n_pin, -1, ties_from)
    pin_modes[n_pin] = mode
    for i in range(x.shape[0]):
        pin_x[n_pin, i] = x[i]
    if passes >= max_steps:
        return (TOO_MANY_STEPS, passes, mode, n_chain, n_pin + 1, -1, ties_from)
    chain[0] = target
    return (JUMP_AND_DECIDE, passes + 1, target, 1, n_pin + 1, -1, 0)
