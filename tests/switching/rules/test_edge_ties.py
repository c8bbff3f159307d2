"""Ties at the edge (switching.rules.instants): a cycle of switches each
enabled only by an inclusive comparison within its band takes none of them.

The half-wave rectifier — a source ``Vm sin(w t)``, an ideal diode, a
resistor — starts at rest (``v_D = i_D = 0``).  With the guards an engineer
writes first, ``v_D >= 0`` on and ``i_D <= 0`` off, the diode off at
``v_D = 0`` and on at ``i_D = 0`` are the same state: the instant rests
where it began and the flow decides.  The exact answer: the diode conducts
while ``sin(w t) > 0`` and blocks while it is negative, switching at
``t = kπ/w``, with ``i_D = max(Vm sin(w t), 0)/R``.
"""

import math

import numpy as np
import pytest
import sympy as sp
from scipy.optimize import brentq

from bondgraph import C as Capacitor
from bondgraph import BondGraph, One, R, Se, Zero, t
from models import diode_circuit
from switching import Automaton, HybridModel
from switching.errors import DivergenceOfTimeError
from switching.rules import instants

VM, W, RLOAD = 10.0, 2 * math.pi * 50, 1e3
HALF = math.pi / W  # a half-wave [s]
T_END = 4.5 * HALF  # two periods and a quarter


def half_wave(turn_on: str, turn_off: str, capacitor: float | None = None, vm: float = VM) -> HybridModel:
    """The rectifier with the diode's guards as given (both a posteriori);
    with ``capacitor`` [F] a capacitor across the load; ``vm`` the source's amplitude [V]."""
    g = BondGraph("half_wave")
    node, diode = g.add(Zero("n")), g.add(One("D", controlled=True))
    g.connect(Se("Vs", sp.Symbol("Vm") * sp.sin(sp.Symbol("w") * t)), diode, name="source")
    g.connect(diode, node, name="diode_out")
    g.connect(node, R("Rload", "Rload"))
    parameters = {"Vm": vm, "w": W, "Rload": RLOAD}
    if capacitor is not None:
        g.connect(node, Capacitor("C1", "C1"))
        parameters["C1"] = capacitor
    automaton = Automaton("D", {"off": {"D": False}, "on": {"D": True}}, "off")
    automaton.add_transition("off", "on", turn_on, "a posteriori")
    automaton.add_transition("on", "off", turn_off, "a posteriori")
    return HybridModel(g, [automaton], parameters,
                       signals={"v_D": "e_source - e_diode_out", "i_D": "f_source"}, name="half_wave")


INCLUSIVE, STRICT = ("v_D >= 0", "i_D <= 0"), ("v_D > 0", "i_D < 0")


def _switches(run):
    """``(t, mode before, mode after)`` of the instants that changed the mode."""
    return [(e.t, e.mode_before.label, e.mode_after.label) for e in run.events if e.mode_before != e.mode_after]


def _check_rectifier(run):
    """The exact answer: switching at kπ/w (the first turn-on at t = 0⁺), conducting on the positive half-waves."""
    switches = _switches(run)
    assert [(before, after) for _, before, after in switches] == [("off", "on"), ("on", "off")] * 2 + [("off", "on")]
    assert switches[0][0] < 1e-12 * HALF
    for k, (t_switch, _, _) in enumerate(switches[1:], start=1):
        assert t_switch == pytest.approx(k * HALF, rel=1e-9)
    times = np.array(run.t)
    inside = [j for j, tau in enumerate(times) if min(abs(tau / HALF - k) for k in range(6)) > 1e-6]
    on = [run.modes[j].label == "on" for j in inside]
    assert on == [math.sin(W * times[j]) > 0 for j in inside]
    current = np.asarray(run.signal("i_D"))[inside]
    exact = np.maximum(VM * np.sin(W * times[inside]), 0.0) / RLOAD
    assert np.max(np.abs(current - exact)) < 1e-9 * VM / RLOAD


@pytest.mark.parametrize("guards", [INCLUSIVE, STRICT], ids=["inclusive", "strict"])
def test_the_rectifier_starting_at_rest_conducts_on_the_positive_half_waves(guards):
    _check_rectifier(half_wave(*guards).simulate(T_END, "RK45", rtol=1e-10, atol=1e-14))


def test_inclusive_and_strict_guards_switch_at_the_same_instants():
    inclusive = _switches(half_wave(*INCLUSIVE).simulate(T_END, "RK45", rtol=1e-10, atol=1e-14))
    strict = _switches(half_wave(*STRICT).simulate(T_END, "RK45", rtol=1e-10, atol=1e-14))
    assert [s[1:] for s in inclusive] == [s[1:] for s in strict]
    assert np.allclose([s[0] for s in inclusive], [s[0] for s in strict], rtol=1e-12, atol=1e-15)


def test_the_tie_at_rest_is_recorded_and_takes_no_switch():
    run = half_wave(*INCLUSIVE).simulate(HALF / 2, "RK45", rtol=1e-10, atol=1e-14)
    first = run.events[0]
    assert first.t == 0.0 and [s.mode.label for s in first.steps] == ["off", "on", "off"]
    assert first.kinds == ["tie", "tie", "continuous"] and first.mythical == []
    assert all(not fired.strict for step in first.steps[:2] for fired in step.fired)


@pytest.mark.parametrize("method", ["RK45", "Radau", "RK45-jit"])
def test_a_diode_that_stays_at_rest_rests_once_and_flows_to_the_end(method):
    # no source: v_D = i_D = 0 for ever; the flow from the rest counts v_D >= 0 only once it holds strictly, so it
    # never fires (else an event at every float after the last)
    if method.endswith("-jit"):
        pytest.importorskip("numba")
    run = half_wave(*INCLUSIVE, vm=0.0).simulate(T_END, method, rtol=1e-10, atol=1e-14)
    assert run.t[-1] == T_END and len(run.events) == 1 and run.events[0].kinds == ["tie", "tie", "continuous"]
    assert {mode.label for mode in run.modes} == {"off"}
    assert np.all(np.asarray(run.signal("i_D")) == 0.0)


def test_the_compiled_kernel_gives_the_same_modes_and_instants():
    pytest.importorskip("numba")
    python = half_wave(*INCLUSIVE).simulate(T_END, "RK45", rtol=1e-10, atol=1e-14)
    compiled = half_wave(*INCLUSIVE).simulate(T_END, "RK45-jit", rtol=1e-10, atol=1e-14)
    _check_rectifier(compiled)
    assert [s[1:] for s in _switches(compiled)] == [s[1:] for s in _switches(python)]
    assert np.allclose([s[0] for s in _switches(compiled)], [s[0] for s in _switches(python)], rtol=1e-12,
                       atol=1e-15)
    assert [e.mode_after.label for e in compiled.events] == [e.mode_after.label for e in python.events]
    # the kernel ran the flows and left the tie at rest to Python (it reports every firing as strict)
    assert compiled.stats["method"] == "RK45-jit" and compiled.stats["instants resolved in Python"] >= 1


CAP = 1e-5  # [F]: ωRC = π


def test_the_rectifier_with_a_capacitor_turns_off_where_tan_wt_is_minus_wrc():
    run = half_wave(*STRICT, capacitor=CAP).simulate(2.5 * 2 * HALF, "RK45", rtol=1e-11, atol=1e-16)
    switches = _switches(run)
    assert [(b, a) for _, b, a in switches] == [("off", "on"), ("on", "off")] * 3
    tau = RLOAD * CAP
    for k in range(3):
        t_off = (math.pi - math.atan(W * tau) + 2 * math.pi * k) / W
        assert switches[2 * k + 1][0] == pytest.approx(t_off, rel=1e-9)
        if k:  # the turn-on: the source meets the capacitor's exponential discharge from the last turn-off
            last = (math.pi - math.atan(W * tau) + 2 * math.pi * (k - 1)) / W
            v_off = VM * math.sin(W * last)
            t_on = brentq(lambda x: VM * math.sin(W * x) - v_off * math.exp(-(x - last) / tau),
                          2 * math.pi * k / W, (2 * math.pi * k + math.pi / 2) / W, xtol=1e-16, rtol=1e-15)
            assert switches[2 * k][0] == pytest.approx(t_on, rel=1e-9)


def test_a_switch_only_at_a_tie_in_a_loop_that_is_no_cycle_of_ties_is_named_with_the_strict_guard():
    # turning off, i_D <= 0 holds beyond its band at the located crossing (the current is negative there) and off
    # finds v_D = 0 (the capacitor followed the source): v_D >= 0 sends it back only at a tie — a loop with a strict
    # switch, a divergence of time, whose message says which guard to write strictly
    with pytest.raises(DivergenceOfTimeError) as info:
        half_wave(*INCLUSIVE, capacitor=CAP).simulate(2 * HALF, "RK45", rtol=1e-11, atol=1e-16)
    t_off = (math.pi - math.atan(W * RLOAD * CAP)) / W
    assert info.value.instant.t == pytest.approx(t_off, rel=1e-9)
    message = str(info.value)
    assert "Step 2 left D=off only at a tie: D's guard [v_D >= 0]" in message
    assert "Write the guards that switched only at a tie strictly (v_D > 0 for v_D >= 0)" in message


def test_a_cycle_with_a_guard_holding_beyond_its_band_still_diverges():
    # the paper's diode circuit with a holding current above the inductor's current: i_D <= I_th holds by 190 A
    with pytest.raises(DivergenceOfTimeError) as info:
        diode_circuit.build(I_th=200.0).simulate(1.0, "RK45", rtol=1e-8)
    assert "repeats in a chain of mythical modes" in str(info.value)
    assert any(fired.strict for step in info.value.loop for fired in step.fired)


def test_a_loop_with_a_guard_holding_with_room_to_spare_still_diverges():
    # at rest, off → on holds by 1 V (v_D >= −1 at v_D = 0), on → off only at a tie (i_D = 0): not a cycle of ties
    with pytest.raises(DivergenceOfTimeError, match="repeats in a chain of mythical modes") as info:
        half_wave("v_D >= -1", "i_D <= 0").simulate(T_END, "RK45")
    assert info.value.instant.t == 0.0
    assert [fired.strict for step in info.value.loop for fired in step.fired] == [True, False]


# ------------------------------------------------------------------ the rule itself, on scripts of answers

A, B, C = 0, 1, 2
TIE, FIRED = instants.FIRED_AT_TIE, instants.FIRED
ASKS = (instants.JUMP_AND_DECIDE, instants.DECIDE_AS_FLOW, instants.JUMP_AT_TIE)


def _drive(begin, step, script, max_steps=10, n=1):
    """The rule answered by ``script``: each ``(fired, target, x)`` answers one request; the states it passed."""
    chain = np.zeros(max_steps + 1, dtype=np.int64)
    pin_modes, pin_x = np.zeros(8, dtype=np.int64), np.zeros((8, n))
    state = begin(A, chain)
    trail = [tuple(state)]
    for fired, target, x in script:
        assert state[0] in ASKS, trail
        state = step(state, fired, target, np.array(x, dtype=float), max_steps, chain, pin_modes, pin_x)
        trail.append(tuple(state))
    return trail


#: scripts and the rule's last state: (action, mode, detail)
_SCRIPTS = {
    "a cycle of ties rests where it began": (
        [(TIE, B, [0]), (TIE, A, [0]), (0, A, [0])],
        (instants.CONTINUOUS, A, 0)),
    "the rest is asked for in the mode where the cycle began": (
        [(TIE, B, [0]), (TIE, A, [0])],
        (instants.JUMP_AT_TIE, A, 0)),
    "a strict switch into a cycle of ties rests where the cycle began": (
        [(FIRED, B, [0]), (TIE, C, [0]), (TIE, B, [0]), (0, B, [0])],
        (instants.CONTINUOUS, B, 1)),
    "a cycle with a strict switch back diverges": (
        [(TIE, B, [0]), (FIRED, A, [0])],
        (instants.REPEATS_IN_CHAIN, A, 0)),
    "a cycle with a strict switch out diverges": (  # a capacitor's diode turning off, with inclusive guards
        [(FIRED, B, [0]), (TIE, A, [0])],
        (instants.REPEATS_IN_CHAIN, A, 0)),
    "a strict switch inside a longer cycle of ties makes it diverge": (
        [(TIE, B, [0]), (FIRED, C, [0]), (TIE, A, [0])],
        (instants.REPEATS_IN_CHAIN, A, 0)),
    "a guard holding strictly at the rest makes it a pinnacle, and a new chain": (
        [(TIE, B, [0]), (TIE, A, [0]), (FIRED, B, [1]), (TIE, A, [1]), (TIE, B, [1])],
        (instants.JUMP_AT_TIE, B, 0)),
    "a strict switch of a chain before a pinnacle does not count in the next chain": (
        [(FIRED, B, [0]), (0, B, [0]), (FIRED, C, [1]), (TIE, A, [1]), (TIE, C, [1])],
        (instants.JUMP_AT_TIE, C, 0)),
    "ties of a chain before a pinnacle do not count in the next chain": (
        [(TIE, B, [0]), (0, B, [0]), (FIRED, C, [1]), (FIRED, A, [1]), (TIE, C, [1])],
        (instants.REPEATS_IN_CHAIN, C, 0)),
}


@pytest.mark.parametrize("name", sorted(_SCRIPTS))
def test_the_rule_rests_at_a_cycle_of_ties_and_diverges_otherwise(name):
    script, (action, mode, detail) = _SCRIPTS[name]
    last = _drive(instants.instant_begin, instants.instant_next, script)[-1]
    assert (last[0], last[2], last[5]) == (action, mode, detail), last


def test_a_rest_at_a_tie_counts_its_pass_against_the_cap():
    last = _drive(instants.instant_begin, instants.instant_next, [(TIE, B, [0]), (TIE, A, [0])], max_steps=2)[-1]
    assert last[0] == instants.TOO_MANY_STEPS


def test_the_rule_on_ties_python_and_compiled_agree():
    numba = pytest.importorskip("numba")
    begin, step = numba.njit(instants.instant_begin), numba.njit(instants.instant_next)
    for name, (script, _) in sorted(_SCRIPTS.items()):
        assert _drive(instants.instant_begin, instants.instant_next, script) == _drive(begin, step, script), name


def test_run_summaries_explain_the_kind_of_a_tie():
    from switching.simulate.trajectory import STEP_KINDS

    run = half_wave(*INCLUSIVE).simulate(HALF / 2, "RK45", rtol=1e-10, atol=1e-14)
    kinds = {step.kind for instant in run.events for step in instant.steps}
    assert "tie" in kinds and kinds <= set(STEP_KINDS)
