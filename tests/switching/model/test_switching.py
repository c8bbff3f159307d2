"""Switching semantics against exact answers: jumps, impulses, mode resolution."""

import numpy as np
import pytest
import sympy as sp
from switching_models import ball_row, diode_circuit, falling_rod, independent_switches, parallel_capacitors

from switching import DivergenceOfTimeError, InitialStateProjected


# ---------------------------------------------------------------- the diode circuit (paper Fig. 1)


def test_opening_the_switch_passes_a_mythical_mode_and_keeps_the_flux():
    model = diode_circuit(I_th=0.1, p0=1.0)
    x = model.initial_state()
    instant = model.resolve(x, "closed|off", t=1.0)
    assert [s.mode.label for s in instant.steps] == ["closed|off", "open|off", "open|on"]
    assert instant.kinds == ["start", "mythical", "continuous"]
    # invariance of state across the mythical mode: the inductor's flux is unchanged
    assert instant.x_after[model.state_index[model.state("p_L")]] == 1.0
    assert np.array_equal(instant.x_after, x)
    fired = instant.steps[1].fired[0]
    assert (fired.automaton, fired.source, fired.target, fired.when) == ("diode", "off", "on", "a posteriori")


def test_the_mythical_mode_would_have_released_the_flux_as_an_impulse():
    model = diode_circuit(p0=1.0)
    me = model.mode_equations("open|off")
    x = np.array([1.0])
    x_plus = me.apply_jump(x, 1.0)
    assert x_plus[0] == 0.0  # no current path: the flux would have to vanish
    # v_D = -dp_L/dt carries the impulse -Δp_L = +1 V·s: an infinite forward voltage
    form = me.signal("v_D")
    assert sp.simplify(form.impulse[model.state("p_L")] + 1) == 0


def test_holding_current_above_the_inductor_current_is_a_divergence_of_time():
    model = diode_circuit(I_th=20.0, p0=1.0)  # i_L = 10 A < I_th
    with pytest.raises(DivergenceOfTimeError) as info:
        model.resolve(model.initial_state(), "closed|off", t=1.0)
    message = str(info.value)
    assert "open, diode=off" in message and "repeats in a chain of mythical modes" in message
    assert "i_D <= I_th" in message and "v_D >= V_th" in message
    loop = [step.mode.label for step in info.value.loop]
    assert loop == ["open|off", "open|on"]
    assert info.value.instant.steps[0].kind == "start"  # the partial record is attached


def test_verify_finds_the_diode_loop_and_explores_only_reachable_modes():
    report = diode_circuit(I_th=20.0).verify(samples=10)
    assert not report.ok
    assert any({m.label for m in modes} == {"open|off", "open|on"} for modes, _ in report.loops)
    assert {m.label for m in report.explored} <= {"closed|off", "open|off", "open|on", "closed|on"}


# ---------------------------------------------------------------- colliding balls


@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_two_balls_newtons_rule(e):
    m1, m2, v1, v2 = 1.5, 0.5, 2.0, -1.0
    model = ball_row([m1, m2], e)
    x = np.array([m1 * v1, m2 * v2, 0.0, 0.0])  # p1, p2, x1, x2 (touching)
    instant = model.resolve(x, None, 0.0)
    assert instant.kinds == ["start", "pinnacle", "continuous"]
    p1, p2 = instant.x_after[:2]
    u1, u2 = p1 / m1, p2 / m2
    assert p1 + p2 == pytest.approx(m1 * v1 + m2 * v2, rel=1e-14, abs=1e-14)
    assert u2 - u1 == pytest.approx(-e * (v2 - v1), rel=1e-14, abs=1e-14)
    # the paper's Eq. (9) in closed form for unequal masses
    M = m1 + m2
    assert u1 == pytest.approx(((m1 - e * m2) * v1 + (1 + e) * m2 * v2) / M, rel=1e-13)
    assert u2 == pytest.approx(((m2 - e * m1) * v2 + (1 + e) * m1 * v1) / M, rel=1e-13)


def test_equal_balls_eq_9():
    e = 0.5
    model = ball_row([1.0, 1.0], e)
    instant = model.resolve(np.array([3.0, 1.0, 0.0, 0.0]), None, 0.0)
    v1, v2 = instant.x_after[:2]
    assert v1 == pytest.approx((1 - e) / 2 * 3 + (1 + e) / 2 * 1, rel=1e-14)
    assert v2 == pytest.approx((1 + e) / 2 * 3 + (1 - e) / 2 * 1, rel=1e-14)


def test_four_ball_chain_passes_three_pinnacles_in_one_instant():
    v = 1.7
    model = ball_row([1.0] * 4, 1.0)
    x = np.zeros(8)
    x[0] = v
    instant = model.resolve(x, None, 0.0)
    assert instant.kinds == ["start", "pinnacle", "pinnacle", "pinnacle", "continuous"]
    assert [m.label for m in instant.pinnacles] == ["collide|free|free", "free|collide|free", "free|free|collide"]
    np.testing.assert_allclose(instant.x_after[:4], [0, 0, 0, v], atol=1e-15)
    assert instant.x_after[:4].sum() == pytest.approx(v, rel=1e-15)
    assert 0.5 * np.sum(instant.x_after[:4] ** 2) == pytest.approx(0.5 * v**2, rel=1e-15)
    assert instant.mode_after.label == "free|free|free"


def test_collide_guard_without_separating_condition_is_divergence_not_a_hang():
    model = ball_row([1.0, 1.0], 0.8, separating=False)
    with pytest.raises(DivergenceOfTimeError) as info:
        model.resolve(np.array([1.0, 0.0, 0.0, 0.0]), None, 0.0)
    assert "repeats" in str(info.value) and "collide" in str(info.value)
    report = ball_row([1.0, 1.0], 0.8, separating=False).verify(samples=5)
    assert report.loops


def test_step_cap_stops_runaway_resolution():
    model = ball_row([1.0] * 4, 1.0)
    model.max_steps_per_instant = 2
    x = np.zeros(8)
    x[0] = 1.0
    from switching import TooManyStepsError

    with pytest.raises(TooManyStepsError) as info:
        model.resolve(x, None, 0.0)
    assert "more than 2 discrete steps" in str(info.value)


def test_step_cap_message_shows_the_ends_of_the_instant_and_how_to_raise_the_cap():
    """A light ball between two heavy ones (e = 1) rattles ~222 times in one
    instant; with a cap of 50 the message shows steps 1–3 and 48–50, the
    state reached, and the setting that raises the cap."""
    from switching import TooManyStepsError

    model = ball_row([1.0, 1e-4, 1.0], 1.0, v_th=1e-9)
    model.max_steps_per_instant = 50
    x = np.zeros(6)
    x[0] = 1.0
    with pytest.raises(TooManyStepsError) as info:
        model.resolve(x, None, 0.0)
    text = str(info.value)
    assert "at t = 0: more than 50 discrete steps at one instant in model 'balls'" in text
    assert "raise the cap (now 50): HybridModel(..., max_steps_per_instant=500)" in text
    assert "model.max_steps_per_instant = 500" in text
    assert all(f"step {k}:" in text for k in (1, 2, 3, 48, 49, 50))
    assert "step 4:" not in text and "step 47:" not in text and "… 44 more steps …" in text
    assert "The state after step 50: p1 = " in text and "x3 = 0." in text
    assert len(text.splitlines()) < 25
    assert len(info.value.instant.steps) == 50
    with pytest.raises(TooManyStepsError, match=r"max_steps= argument of resolve \(the model's own cap is 50\)"):
        model.resolve(x, None, 0.0, max_steps=20)


def test_a_long_pinnacle_loop_is_shortened_and_names_the_repeating_mode_and_state():
    """Four touching balls, e = 0, v_th = 0: the pinnacles converge to equal
    velocities v0/N = 0.25 m/s and then repeat a state; the message lists 6
    of the 81 pinnacles and says which mode and state repeat.  The
    exception's ``loop`` keeps all of them."""
    import re

    from models import ball_chain

    with pytest.raises(DivergenceOfTimeError) as info:
        ball_chain.build(N=4, e=0.0, v_th=0.0).simulate(0.5, "RK45", output="events")
    text, loop = str(info.value), info.value.loop
    assert len(loop) == 81 and all(step.kind == "pinnacle" for step in loop)
    assert "repeats with the same state after 81 pinnacles" in text
    assert text.count("[pinnacle]") == 6 and "… 75 more steps …" in text
    steps = info.value.instant.steps
    found = re.search(r"mode (.+) at step (\d+) has the state it had at step (\d+)", text)
    mode, last, first = found.group(1), int(found.group(2)), int(found.group(3))
    assert last == len(steps) and mode == steps[-1].mode.describe() == steps[first - 1].mode.describe()
    np.testing.assert_allclose(steps[first - 1].x_after, steps[-1].x_after, rtol=1e-12)
    assert "the state: p1 = 0.25, p2 = 0.25, p3 = 0.25, p4 = 0.25, pos1 = 0.1, pos2 = 0.2" in text
    assert len(text.splitlines()) < 30
    # a short loop is shown whole
    with pytest.raises(DivergenceOfTimeError) as short:
        ball_row([1.0, 1.0], 0.8, separating=False).resolve(np.array([1.0, 0.0, 0.0, 0.0]), None, 0.0)
    lines = str(short.value).splitlines()
    assert [line for line in lines if line.startswith("  step ")] == [
        f"  step {k}: {step.mode.describe()} [mythical]" for k, step in enumerate(short.value.loop, start=3)
    ]
    assert not any("more steps" in line for line in lines)


# ---------------------------------------------------------------- capacitors


def test_switching_capacitors_together_conserves_charge_and_equalises_voltage():
    C1, C2, v1, v2 = 1e-3, 2e-3, 5.0, 1.0
    model = parallel_capacitors(C1, C2, v1, v2)
    instant = model.resolve(model.initial_state(), None, t=0.0)
    q1, q2 = instant.x_after
    assert q1 + q2 == pytest.approx(C1 * v1 + C2 * v2, rel=1e-14)
    assert q1 / C1 == pytest.approx(q2 / C2, rel=1e-14)
    assert instant.kinds == ["start", "continuous"]
    # the symbolic jump map is the charge-sharing projection
    g = model.mode_equations("closed").g
    qa, qb, Ca, Cb = sp.symbols("q_C1 q_C2 C1 C2")
    assert sp.simplify(g[qa] - Ca * (qa + qb) / (Ca + Cb)) == 0


# ---------------------------------------------------------------- the falling rod


def random_pre_impact_states(model, n, seed):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        x = np.zeros(len(model.states))
        idx = {s.name: k for k, s in enumerate(model.states)}
        x[idx["rod/p_x"]], x[idx["rod/p_y"]], x[idx["rod/p_J"]] = rng.normal(size=3)
        x[idx["rod/theta"]] = rng.uniform(0.2, 1.4)
        yield x, idx


def test_rod_sticking_jump_is_conservation_of_state():
    model = falling_rod()
    m, J, l = 1.0, 1.0 / 12, 0.5
    me = model.mode_equations("stuck")
    for x, idx in random_pre_impact_states(model, 25, seed=1):
        plus = me.apply_jump(x, 0.0)
        th = x[idx["rod/theta"]]
        vx, vy, w = x[idx["rod/p_x"]] / m, x[idx["rod/p_y"]] / m, x[idx["rod/p_J"]] / J
        vx1, vy1, w1 = plus[idx["rod/p_x"]] / m, plus[idx["rod/p_y"]] / m, plus[idx["rod/p_J"]] / J
        # tip A = centre - l (cos θ, sin θ): its velocity after is zero
        assert vx1 + l * np.sin(th) * w1 == pytest.approx(0, abs=1e-14)
        assert vy1 - l * np.cos(th) * w1 == pytest.approx(0, abs=1e-14)
        # angular momentum about the contact point is conserved
        L_before = J * w + m * l * (np.cos(th) * vy - np.sin(th) * vx)
        L_after = J * w1 + m * l * (np.cos(th) * vy1 - np.sin(th) * vx1)
        assert L_after == pytest.approx(L_before, rel=1e-13, abs=1e-14)
        # the paper's Eq. (5) with l -> -l
        assert w1 == pytest.approx((w * J + m * l * (np.cos(th) * vy - np.sin(th) * vx)) / (J + m * l**2), rel=1e-13, abs=1e-14)
        # positions do not jump
        for name in ("rod/x", "rod/y", "rod/theta"):
            assert plus[idx[name]] == x[idx[name]]


def test_rod_symbolic_jump_matches_eq_5():
    model = falling_rod()
    g = model.mode_equations("stuck").g
    m, J, l = sp.symbols("m J l")
    px, py, pJ, th = (model.state(n) for n in ("rod/p_x", "rod/p_y", "rod/p_J", "rod/theta"))
    vx, vy, w = px / m, py / m, pJ / J
    expected_w = (w * J + m * l * (sp.cos(th) * vy - sp.sin(th) * vx)) / (J + m * l**2)
    assert sp.simplify(g[pJ] / J - expected_w) == 0
    assert sp.simplify(g[px] / m - (-l * sp.sin(th) * expected_w)) == 0
    assert sp.simplify(g[py] / m - (l * sp.cos(th) * expected_w)) == 0


def test_normal_and_friction_impulses_equal_the_momentum_changes():
    model = falling_rod()
    for x, idx in random_pre_impact_states(model, 10, seed=2):
        x[idx["rod/y"]] = 0.5 * np.sin(x[idx["rod/theta"]])  # tip on the floor
        m, J, l = 1.0, 1.0 / 12, 0.5
        tip_vy = x[idx["rod/p_y"]] / m - l * np.cos(x[idx["rod/theta"]]) * x[idx["rod/p_J"]] / J
        if tip_vy >= 0:
            continue  # not approaching: no impact
        try:
            instant_record = model.resolve(x, "free", 0.0)
        except DivergenceOfTimeError:
            continue  # an impact that would pull on the floor (no friction model here)
        plus = instant_record.x_after
        assert instant_record.modes[1].label == "stuck"
        dpx = plus[idx["rod/p_x"]] - x[idx["rod/p_x"]]
        dpy = plus[idx["rod/p_y"]] - x[idx["rod/p_y"]]
        assert instant_record.impulse("normal_force") == pytest.approx(dpy, rel=1e-12, abs=1e-14)
        assert instant_record.impulse("friction_force") == pytest.approx(dpx, rel=1e-12, abs=1e-14)
        assert instant_record.impulse("normal_force") > 0  # the floor pushes


def test_initial_state_off_the_constraint_is_projected_and_reported():
    opened = parallel_capacitors(initial="open")
    assert np.allclose(opened.initial_state(), [5e-3, 2e-3]) and opened.initial_projection is None
    closed = parallel_capacitors(initial="closed")
    with pytest.warns(InitialStateProjected, match="q_C1"):
        x0 = closed.initial_state()
    assert x0[0] / 1e-3 == pytest.approx(x0[1] / 2e-3)
    assert closed.initial_projection is not None


# ---------------------------------------------------------------- laziness


def test_asking_for_one_mode_derives_one_mode():
    model = independent_switches(20)
    assert model.derivation_count == 0
    mode = model.mode({"a7": "closed"})
    me = model.mode_equations(mode)
    assert model.derivation_count == 1
    assert model.derived_modes == (mode,)
    equations_cached = [k for k in model.graph.derived.entries if k[0] == "equations"]
    assert len(equations_cached) == 1
    assert model.mode_equations(mode) is me and model.derivation_count == 1
    # and the mode has the expected equations: cell 7 charges, the others do not
    q7, q3 = model.state("q_C7"), model.state("q_C3")
    assert sp.simplify(me.f[q7] - (sp.Symbol("V") - q7 / sp.Symbol("C")) / sp.Symbol("R")) == 0
    assert me.f[q3] == 0


def test_the_model_wing_imports_no_wing_above_it():
    """``switching/model/`` is the definition: the library, the simulator,
    the analyses and model files are reached through the services they
    register (switching.model.services), never imported by it."""
    import ast
    from pathlib import Path

    import switching.model as package

    above = ("library", "simulate", "analysis", "sweep", "files")
    for path in Path(package.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                target = ("." * node.level) + (node.module or "")
                assert not any(target.startswith((f"..{w}", f"switching.{w}")) for w in above), (path.name, target)


def test_every_model_service_is_registered():
    from dataclasses import fields

    from switching.model.services import SERVICES, Services, provide

    for field in fields(Services):
        assert getattr(SERVICES, field.name).__name__ != "missing", field.name
    with pytest.raises(TypeError, match="no model service 'plot'"):
        provide(plot=print)


def test_the_co_energies_of_storage_are_derived_once_for_the_modes_of_a_scene():
    """Each mode reads a storage element's co-energy from its own state; the modes of a ball chain
    (no automaton state sets a value) share those expressions, kept with the graph's derivations."""
    from models import ball_chain

    model = ball_chain.build(N=6, e=1.0)
    automata = model.initial_mode.automata
    for k in range(len(automata)):  # (derived here: a run may read the modes' functions from the disk cache)
        me = model.mode_equations({a: "collide" if j == k else "free" for j, a in enumerate(automata)})
        assert me._bond_values  # (made when an expression first reads a bond)
    entries = [k for k in model.derivation_graph.derived.entries if k[0] == "storage co-energies"]
    assert entries == [("storage co-energies", ())] and model.derivation_count == 5
    me = model.mode_equations(model.derived_modes[-1])
    for el in model.derivation_graph.storage:  # the momentum's flow is p/m, signed by its bond
        (bond,) = model.derivation_graph.bonds_of(el.name)
        assert me._bond_values[bond.flow] == bond.sign_at(el.name) * el.output(el.state)
