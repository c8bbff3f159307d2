"""Discontinuous element laws (issue 13): law switches located as events, and
sliding (Filippov) motions instead of chattering.

Exact answers: a block of mass m, momentum p0, stopped by Coulomb friction
μN (and a viscous damper c) stops at t* = (m/c)·ln(1 + c·p0/(μNm))
(t* = p0/(μN) without damper) after x* = (m/c)·(v0 + μN/c)·(1 − e^{−c t*/m}) − μN t*/c
(v0²·m/(2μN) without damper), then stays at rest; under a force F below μN
it stays stuck, above it slides with acceleration (F − μN)/m.  The bang-bang
loop ẋ = 2·H(1 − x) − x reaches x = 1 at t = ln 2 and slides there.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from bondgraph import C, DerivationError, I, One, R, Se, Sf, Zero, BondGraph
from bondgraph.errors import UnknownNameError
from bondgraph.law_switches import law_switches
from switching import Automaton, HybridModel, StiffnessError

MU, N_FORCE = 0.5, 9.81


def friction_graph(damper=False, push=False, law=None):
    """A mass ``m`` on a 1-junction with Coulomb friction written as an R law
    (``e = μN·sign(f)``), optionally a damper ``c`` and a pushing force ``F``;
    displacement ``x`` of the mass."""
    mu, N = sp.symbols("mu N")
    g = BondGraph("block")
    v = g.add(One("v"))
    if push:
        g.connect(Se("push", "F"), v)
    g.connect(v, I("m", "m"))
    g.connect(v, R("fr", effort_law=law or (lambda f: mu * N * sp.sign(f))))
    if damper:
        g.connect(v, R("damper", "c"))
    g.displacement("x", "m")
    return g


def sign_block(p0=2.0, m=1.0, c=None, F=None, N=N_FORCE, mu=MU):
    g = friction_graph(damper=c is not None, push=F is not None)
    values = {"m": m, "mu": mu, "N": N}
    if c is not None:
        values["c"] = c
    if F is not None:
        values["F"] = F
    return HybridModel(g, [], values, initial_state={"p_m": p0})


def automaton_block(p0=2.0, m=1.0, c=None, F=0.0, N=N_FORCE, mu=MU):
    """The same block with a stick/slip automaton: a friction source ``σ·μN``
    whose direction σ the automaton sets, and a controlled 0-junction that
    locks the velocity to zero while stuck (as the falling rod does)."""
    g = BondGraph("block")
    v = g.add(One("v"))
    g.connect(Se("push", "F"), v)
    g.connect(v, I("m", "m"))
    g.connect(v, Se("fr", sp.Symbol("sigma") * sp.Symbol("mu") * sp.Symbol("N")))
    if c is not None:
        g.connect(v, R("damper", "c"))
    lock = g.add(Zero("lock", controlled=True))
    g.connect(v, lock, name="hold")
    g.connect(lock, Sf("still", 0))
    g.displacement("x", "m")
    friction = Automaton(
        "friction",
        {"forward": {"lock": False}, "backward": {"lock": False}, "stuck": {"lock": True}},
        "forward" if p0 > 0 else "stuck",
        values={"forward": {"sigma": 1}, "backward": {"sigma": -1}, "stuck": {"sigma": 0}},
    )
    friction.add_transition("forward", "stuck", "p_m < 0", pulses=False)  # the stop is continuous
    friction.add_transition("backward", "stuck", "p_m > 0", pulses=False)
    friction.add_transition("stuck", "forward", "e_hold > mu*N", "a posteriori")
    friction.add_transition("stuck", "backward", "e_hold < -mu*N", "a posteriori")
    values = {"m": m, "mu": mu, "N": N, "F": F}
    if c is not None:
        values["c"] = c
    return HybridModel(g, [friction], values, initial_state={"p_m": p0})


def stop_of(p0, m, mu, N, c=None):
    """Closed-form stop time and distance of the friction block."""
    if c is None:
        return p0 / (mu * N), (p0 / m) ** 2 * m / (2 * mu * N)
    t_stop = m / c * math.log(1 + c * p0 / (mu * N * m))
    v0, a = p0 / m, mu * N / c
    return t_stop, m / c * (v0 + a) * (1 - math.exp(-c * t_stop / m)) - a * t_stop


# ---------------------------------------------------------------- derivation


def test_sign_law_becomes_a_switch_with_the_flow_as_surface():
    g = friction_graph()
    copy, switches = law_switches(g)
    (sw,) = switches
    assert (sw.name, sw.element) == ("fr_law", "fr")
    assert sp.simplify(sw.surface - g.flow("fr")) == 0
    mu, N = sp.symbols("mu N")
    rate = copy.equations().rate("p_m")
    assert sp.simplify(rate + mu * N * sw.sigma) == 0
    assert g.elements["fr"].effort_law.has(sp.sign)  # the user's graph is unchanged


def test_sliding_mode_holds_the_block_with_the_static_force():
    model = sign_block(F=3.0)
    me = model.mode_equations({"fr_law": "sliding"})
    assert sp.simplify(me.f[model.state("p_m")]) == 0
    static = me.finite(me.to_raw(model.derivation_graph.effort("fr")))
    assert sp.simplify(static - sp.Symbol("F")) == 0  # the friction force balances the push


def test_a_friction_law_says_stuck_and_slipping_and_reads_the_generic_names():
    """Issue 44: a dry friction law's automaton names its sliding (Filippov) state ``stuck`` and its
    branches ``slipping_pos``/``slipping_neg``; the generic names it had still read as those states."""
    model = sign_block()
    (sw,) = model.law_switches.values()
    assert sw.friction == 1
    assert list(model.automata[-1].states) == ["slipping_pos", "slipping_neg", "stuck"]
    assert model.mode("fr_law=sliding").describe() == "fr_law=stuck"
    assert model.mode({"fr_law": "positive"}) == model.mode("slipping_pos")
    assert model.mode("negative").label == "slipping_neg"
    assert model.mode_equations({"fr_law": "sliding"}) is model.mode_equations("fr_law=stuck")
    with pytest.raises(UnknownNameError, match="no state 'slipping'.*also read: positive as slipping_pos"):
        model.mode("fr_law=slipping")


def test_a_friction_law_on_minus_its_flow_names_each_branch_by_the_flow():
    """A Piecewise friction law whose condition is ``f < 0`` switches on ``s = −f``: its positive branch
    (``s > 0``) slips backwards, and is named so."""
    mu, N = sp.symbols("mu N")
    g = friction_graph(law=lambda f: sp.Piecewise((-mu * N, f < 0), (mu * N, True)))
    model = HybridModel(g, [], {"m": 1.0, "mu": MU, "N": N_FORCE}, initial_state={"p_m": -2.0})
    (sw,) = model.law_switches.values()
    assert sw.friction == -1 and sp.simplify(sw.surface + g.flow("fr")) == 0
    assert model.initial_mode.describe() == "fr_law=slipping_neg"
    assert model.mode("fr_law=positive").describe() == "fr_law=slipping_neg"  # σ = +1: the generic name
    (event,) = model.simulate(1.0, "RK45").events
    assert event.mode_after.describe() == "fr_law=stuck"


def test_laws_of_no_known_meaning_keep_the_generic_names():
    model = bang_bang()
    (sw,) = model.law_switches.values()
    assert sw.friction == 0
    assert list(model.automata[-1].states) == ["positive", "negative", "sliding"] and not model.automata[-1].aliases


def test_continuous_laws_are_left_as_written():
    e = sp.Symbol("e")
    orifice = lambda e: sp.Symbol("Cv") * sp.sqrt(sp.Abs(e)) * sp.sign(e)  # noqa: E731
    for law in (orifice, lambda f: sp.Min(f, 1) + sp.Max(f, -1), lambda f: sp.Abs(f),
                lambda f: sp.Piecewise((f, f > 0), (0, True))):
        g = friction_graph(law=law)
        copy, switches = law_switches(g)
        assert switches == () and copy is g, law(e)


def test_piecewise_with_a_jump_switches_on_each_condition():
    law = lambda f: sp.Piecewise((2, f > 1), (sp.Piecewise((0, f > -1), (-2, True)), True))  # noqa: E731
    g = friction_graph(law=law)
    copy, switches = law_switches(g)
    assert len(switches) == 2
    flow = g.flow("fr")
    surfaces = {sp.expand(sw.surface) for sw in switches}
    assert surfaces == {sp.expand(flow - 1), sp.expand(flow + 1)}
    s1, s2 = switches
    law_rewritten = copy.elements["fr"].effort_law
    for a, b, expected in ((1, 1, 2), (-1, 1, 0), (-1, -1, -2)):
        assert law_rewritten.xreplace({s1.sigma: a, s2.sigma: b}) == expected


def test_piecewise_condition_must_be_one_comparison():
    law = lambda f: sp.Piecewise((1, sp.And(f > 0, f < 2)), (0, True))  # noqa: E731
    with pytest.raises(DerivationError, match="not one comparison"):
        law_switches(friction_graph(law=law))


def test_sliding_needs_the_switch_affine_in_the_rate():
    g = friction_graph(law=lambda f: sp.Symbol("mu") * sp.Symbol("N") * sp.exp(sp.sign(f)))
    model = HybridModel(g, [], {"m": 1, "mu": MU, "N": N_FORCE}, initial_state={"p_m": 2})
    with pytest.raises(DerivationError, match="nonlinearly"):
        model.mode_equations({"fr_law": "sliding"})


def test_law_switch_name_clash_is_reported():
    g = friction_graph()
    clash = Automaton("fr_law", {"a": {}}, "a")
    with pytest.raises(Exception, match="rename that automaton"):
        HybridModel(g, [clash], {"m": 1, "mu": MU, "N": N_FORCE})


# ---------------------------------------------------------------- the friction block


@pytest.mark.parametrize("method", ["RK45", "Radau", "LSODA", "DOP853"])
def test_block_stops_at_the_exact_time_and_distance_then_rests(method):
    p0, m = 2.0, 1.0
    t_stop, distance = stop_of(p0, m, MU, N_FORCE)
    tr = sign_block(p0, m).simulate(1.0, method, rtol=1e-6)
    (event,) = tr.events
    assert abs(event.t - t_stop) <= 1e-9
    assert event.mode_after.label == "stuck"
    x = tr.state("x")
    assert abs(x[-1] - distance) <= 1e-9 * distance
    after = tr.t > t_stop + 1e-9
    assert np.all(np.abs(tr.state("p_m")[after]) <= 1e-12 * p0)  # at rest to round-off
    assert np.ptp(x[after]) <= 1e-12 * distance
    if method == "RK45":
        assert len(tr.t) <= 100


@pytest.mark.parametrize("method", ["RK45", "LSODA"])
def test_damped_block_stops_at_the_exact_time(method):
    p0, m, c = 2.0, 1.5, 0.8
    t_stop, distance = stop_of(p0, m, MU, N_FORCE, c)
    tr = sign_block(p0, m, c=c).simulate(2.0, method, rtol=1e-10, atol=1e-12)
    (event,) = tr.events
    assert abs(event.t - t_stop) <= 1e-9
    assert abs(tr.state("x")[-1] - distance) <= 1e-8 * distance


@pytest.mark.parametrize("method, order, largest", [("euler", 1, 0.01), ("rk4", 4, 0.1)])
def test_fixed_step_stop_time_converges_with_the_methods_order(method, order, largest):
    """The located stop's error, largest over several initial momenta (where the
    stop falls inside a step changes the interpolant's error), against dt."""
    m, c = 1.5, 0.8
    steps = [largest / 2**k for k in range(5)]
    envelope = []
    for dt in steps:
        worst = 0.0
        for p0 in np.linspace(1.6, 2.4, 7):
            t_stop, _ = stop_of(p0, m, MU, N_FORCE, c)
            tr = sign_block(p0, m, c=c).simulate(1.5, method, dt=dt)  # no StiffnessError at the stop
            (event,) = tr.events
            worst = max(worst, abs(event.t - t_stop))
            assert np.all(np.abs(tr.state("p_m")[tr.t > event.t + 1e-9]) <= 1e-12)
        envelope.append(worst)
    slope = np.polyfit(np.log(steps), np.log(envelope), 1)[0]
    assert order - 0.25 <= slope <= order + 0.5, (envelope, slope)


def test_no_chattering_steps_for_the_adaptive_method():
    tr = sign_block().simulate(10.0, "RK45", rtol=1e-6)
    assert len(tr.t) <= 100 and len(tr.events) == 1


@pytest.mark.parametrize("F", [3.0, -4.0, 4.9])
def test_force_below_the_friction_limit_keeps_the_block_stuck(F):
    model = sign_block(p0=0.0, F=F)
    assert model.initial_mode.label == "stuck"
    tr = model.simulate(2.0, "RK45")
    assert tr.events == [] or all(e.mode_after.label == "stuck" for e in tr.events)
    assert np.all(tr.state("p_m") == 0.0) and np.all(tr.state("x") == 0.0)
    assert np.allclose(tr.signal("e_fr"), F, rtol=1e-14)  # static friction balances the push


@pytest.mark.parametrize("F", [6.0, -7.5])
def test_force_above_the_friction_limit_slides_with_the_exact_acceleration(F):
    m, t_end = 2.0, 1.5
    model = sign_block(p0=0.0, m=m, F=F)
    tr = model.simulate(t_end, "RK45", rtol=1e-10)
    (event,) = tr.events
    assert event.t == 0.0 and event.mode_after.label == ("slipping_pos" if F > 0 else "slipping_neg")
    a = (F - math.copysign(MU * N_FORCE, F)) / m
    assert abs(tr.state("p_m")[-1] / m - a * t_end) <= 1e-12 * abs(a * t_end)
    assert abs(tr.state("x")[-1] - a * t_end**2 / 2) <= 1e-10 * abs(a * t_end**2)


def test_block_on_a_slope_stays_stuck_below_the_friction_angle():
    m, g0, mu = 1.0, 9.81, 0.5
    for theta, stuck in ((math.atan(mu) * 0.9, True), (math.atan(mu) * 1.1, False)):
        model = sign_block(p0=0.0, m=m, F=m * g0 * math.sin(theta), N=m * g0 * math.cos(theta), mu=mu)
        tr = model.simulate(1.0, "RK45", rtol=1e-10)
        if stuck:
            assert np.all(tr.state("p_m") == 0.0)
        else:
            a = g0 * (math.sin(theta) - mu * math.cos(theta))
            assert abs(tr.state("p_m")[-1] - m * a) <= 1e-10 * m * a


def test_sign_law_and_stick_slip_automaton_give_the_same_stop():
    p0, m, c = 2.0, 1.5, 0.8
    by_law = sign_block(p0, m, c=c).simulate(2.0, "RK45", rtol=1e-10, atol=1e-12)
    by_automaton = automaton_block(p0, m, c=c).simulate(2.0, "RK45", rtol=1e-10, atol=1e-12)
    assert len(by_law.events) == len(by_automaton.events) == 1
    assert abs(by_law.events[0].t - by_automaton.events[0].t) <= 1e-10
    assert by_automaton.events[0].mode_after.label == "stuck"
    assert abs(by_law.state("x")[-1] - by_automaton.state("x")[-1]) <= 1e-10
    # pushed from rest above the limit: both slide forward at once
    law = sign_block(p0=0.0, F=6.0).simulate(1.0, "RK45", rtol=1e-10)
    auto = automaton_block(p0=0.0, F=6.0).simulate(1.0, "RK45", rtol=1e-10)
    assert abs(law.state("x")[-1] - auto.state("x")[-1]) <= 1e-12


@pytest.mark.parametrize("length, mass", [(1e3, 1.0), (1e-3, 1.0), (1.0, 1e3), (1e3, 1e-3)])
def test_same_modes_and_instants_in_other_units(length, mass):
    """Lengths in mm (or km), masses in g (or t): forces scale by mass·length,
    momenta too; the stop and the modes are the same."""
    p0, m, c = 2.0, 1.5, 0.8
    base = sign_block(p0, m, c=c).simulate(2.0, "RK45", rtol=1e-10, atol=1e-12)
    scaled = sign_block(p0 * mass * length, m * mass, c=c * mass, N=N_FORCE * mass * length).simulate(
        2.0, "RK45", rtol=1e-10, atol=1e-12 * mass * length)
    assert [e.mode_after.label for e in scaled.events] == [e.mode_after.label for e in base.events]
    assert abs(scaled.events[0].t - base.events[0].t) <= 1e-10  # both within the method's tolerance
    assert abs(scaled.state("x")[-1] / length - base.state("x")[-1]) <= 1e-9


# ---------------------------------------------------------------- bang-bang


def bang_bang():
    """ẋ = u − x with u = 2·Heaviside(1 − x): a source switched by the state."""
    q = sp.Symbol("q_C")
    g = BondGraph("bang")
    j = g.add(One("j"))
    g.connect(Se("u", 2 * sp.Heaviside(1 - q)), j)
    g.connect(j, C("C", 1))
    g.connect(j, R("R", 1))
    return HybridModel(g, [], {}, initial_state={"q_C": 0})


@pytest.mark.parametrize("method, kw, tol", [("RK45", {"rtol": 1e-10, "atol": 1e-12}, 1e-9),
                                             ("rk4", {"dt": 1e-3}, 1e-9), ("LSODA", {"rtol": 1e-10}, 1e-7)])
def test_bang_bang_loop_slides_along_x_equal_one(method, kw, tol):
    tr = bang_bang().simulate(3.0, method, **kw)
    (event,) = tr.events
    assert abs(event.t - math.log(2)) <= tol
    assert event.mode_after.label == "sliding"
    after = tr.t > event.t
    assert np.allclose(tr.state("q_C")[after], 1.0, rtol=0, atol=1e-9)
    assert np.allclose(tr.signal("e_u")[after], 1.0, rtol=1e-12)  # the equivalent control u = x = 1
    if method == "RK45":
        assert len(tr.t) <= 100


# ---------------------------------------------------------------- stiffness check


def stiff_graph():
    g = BondGraph("stiff")
    j = g.add(Zero("j"))
    g.connect(j, C("C", "C"))
    g.connect(j, R("R", "R"))
    return g


def test_stiffness_check_can_be_turned_off_and_advice_names_it():
    model = HybridModel(stiff_graph(), [], {"C": 1e-3, "R": 1.0}, initial_state={"q_C": 1.0})
    with pytest.raises(StiffnessError) as info:
        model.simulate(0.1, "rk4", dt=0.01)
    assert "stiffness_check=False" in str(info.value) and "dt <" in str(info.value)
    tr = model.simulate(0.1, "rk4", dt=0.01, stiffness_check=False)  # runs on (and diverges, as told)
    assert abs(tr.state("q_C")[-1]) > 1.0
    ok = model.simulate(0.1, "rk4", dt=2e-4)  # the advice can be followed
    assert abs(ok.state("q_C")[-1] - math.exp(-100.0)) <= 1e-6


@pytest.mark.parametrize("method", ["euler", "rk4"])
def test_compiled_fixed_step_methods_turn_the_stiffness_check_off_like_python(method):
    pytest.importorskip("numba")
    model = HybridModel(stiff_graph(), [], {"C": 1e-3, "R": 1.0}, initial_state={"q_C": 1.0})
    with pytest.raises(StiffnessError):
        model.simulate(0.1, method + "-jit", dt=0.01)
    python = model.simulate(0.1, method, dt=0.01, stiffness_check=False)
    compiled = model.simulate(0.1, method + "-jit", dt=0.01, stiffness_check=False)
    assert abs(compiled.state("q_C")[-1]) > 1.0  # runs on, and diverges, as the Python path does
    np.testing.assert_allclose(compiled.x, python.x, rtol=1e-12)
    np.testing.assert_array_equal(compiled.t, python.t)


def test_compiled_RK45_turns_hairers_stiffness_test_off():
    """A flow that would take 1e4 more steps at its stability-bound step is
    reported as stiff; without the check it runs to the end, decaying as
    e^(−t/RC) to round-off."""
    pytest.importorskip("numba")
    model = HybridModel(stiff_graph(), [], {"C": 1e-3, "R": 1.0}, initial_state={"q_C": 1.0})
    with pytest.raises(StiffnessError):
        model.simulate(50.0, "RK45-jit", output="events")
    run = model.simulate(50.0, "RK45-jit", output="events", stiffness_check=False)
    assert run.t[-1] == 50.0 and abs(run.state("q_C")[-1]) < 1e-6
    assert run.stats["steps"] > 10_000


def test_two_blocks_held_by_friction_solve_their_static_forces_together():
    """Two blocks joined by a compressed spring (force q/c = 2 N < μN): both
    slide on their surfaces at once; each friction force balances the spring."""
    mu, N = sp.symbols("mu N")
    g = BondGraph("two")
    v1, v2, s = g.add(One("v1")), g.add(One("v2")), g.add(Zero("s"))
    g.connect(v1, I("m1", "m"))
    g.connect(v2, I("m2", "m"))
    g.connect(v1, R("fr1", effort_law=lambda f: mu * N * sp.sign(f)))
    g.connect(v2, R("fr2", effort_law=lambda f: mu * N * sp.sign(f)))
    g.connect(v1, s)
    g.connect(s, v2)
    g.connect(s, C("k", "c"))
    model = HybridModel(g, [], {"m": 1, "mu": MU, "N": N_FORCE, "c": 0.01}, initial_state={"q_k": 0.02})
    assert model.initial_mode.label == "stuck|stuck"
    tr = model.simulate(1.0, "RK45")
    assert tr.events == [] and np.all(tr.state("p_m1") == 0) and np.all(tr.state("p_m2") == 0)
    assert np.allclose(tr.signal("e_fr1"), -2.0, rtol=1e-12) and np.allclose(tr.signal("e_fr2"), 2.0, rtol=1e-12)
    # pulled apart harder than friction holds: both slip away from the stuck state at once
    strong = HybridModel(g, [], {"m": 1, "mu": MU, "N": N_FORCE, "c": 0.01}, initial_state={"q_k": 0.08})
    (event,) = strong.simulate(0.01, "RK45").events
    assert event.t == 0.0 and event.mode_after.label == "slipping_neg|slipping_pos"


@pytest.mark.parametrize("method, kw, tol", [("rk4", {"dt": 0.1}, 1e-6), ("RK45", {"rtol": 1e-10}, 1e-9)])
def test_a_step_in_time_written_as_heaviside_is_an_event(method, kw, tol):
    """An RC circuit (R = C = 1) whose source steps to V0 at t = 1: the step is
    located (not stepped over), and v_C = V0·(1 − e^{−(t−1)}) after it."""
    from bondgraph import t as time

    g = BondGraph("rc")
    j = g.add(One("j"))
    g.connect(Se("V", sp.Heaviside(time - 1) * sp.Symbol("V0")), j)
    g.connect(j, R("R", 1))
    g.connect(j, C("C", 1))
    model = HybridModel(g, [], {"V0": 2.0})
    assert model.initial_mode.label == "negative"
    tr = model.simulate(3.0, method, **kw)
    (event,) = tr.events
    assert abs(event.t - 1.0) <= 1e-12 and event.mode_after.label == "positive"
    assert abs(tr.state("q_C")[-1] - 2.0 * (1 - math.exp(-2.0))) <= tol
