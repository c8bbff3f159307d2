"""The hybrid simulator against exact answers: bounce times, Zeno time,
closed-form switched circuits, convergence orders across events."""

import math

import numpy as np
import pytest
import sympy as sp
from switching_models import diode_circuit, rc_relay, rc_relay_exact

from bondgraph import BondGraph, I, One, R, Se, Zero
from models import bouncing_ball
from switching import (
    Automaton,
    HybridModel,
    NonFiniteStateError,
    SimulationError,
    StepSizeError,
    ZenoError,
)

BOUNCES = np.array([0.451523640986, 1.173961466563, 1.751911727025, 2.214271935394])
ZENO_TIME = math.sqrt(2 / 9.81) * (1 + 0.8) / (1 - 0.8)  # t1 (1 + e)/(1 - e) = 4.0637…


@pytest.mark.parametrize("method", ["RK45", "RK23", "DOP853", "Radau", "LSODA"])
def test_bounce_times_exact_for_adaptive_methods(method):
    trajectory = bouncing_ball.build().simulate(2.5, method, rtol=1e-6)
    # the reference has 12 decimals: agreement to its rounding, far inside 1e-9
    np.testing.assert_allclose(trajectory.event_times[:4], BOUNCES, rtol=0, atol=1e-9)
    assert len(trajectory.events) == 4


def test_bdf_bounce_times_limited_by_its_integration_error_only():
    """BDF's global error at rtol 1e-6 is ~1e-7 (a property of the method);
    event location on its interpolant adds nothing: tighter rtol, exact times."""
    model = bouncing_ball.build()
    loose = model.simulate(2.5, "BDF", rtol=1e-6)
    assert np.max(np.abs(loose.event_times[:4] - BOUNCES)) < 1e-6
    tight = model.simulate(2.5, "BDF", rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(tight.event_times[:4], BOUNCES, rtol=0, atol=1e-9)


@pytest.mark.parametrize("dt", [1e-3, 5e-4])
def test_euler_bounce_times_within_order_dt(dt):
    trajectory = bouncing_ball.build().simulate(2.5, "euler", dt=dt)
    error = np.max(np.abs(trajectory.event_times[:4] - BOUNCES))
    assert error < 20 * dt  # O(dt), with a modest constant
    assert error > 0.1 * dt  # and genuinely first order, not accidentally exact


def test_bounce_state_after_each_impact():
    trajectory = bouncing_ball.build().simulate(2.5, "RK45", rtol=1e-8)
    v_impact = 9.81 * BOUNCES[0]
    for k, instant in enumerate(trajectory.events[:4]):
        v_before = instant.x_before[0] / 1.0
        v_after = instant.x_after[0] / 1.0
        assert v_before == pytest.approx(-v_impact * 0.8**k, rel=1e-8)
        assert v_after == pytest.approx(0.8 * v_impact * 0.8**k, rel=1e-8)
        assert instant.kinds == ["start", "pinnacle", "continuous"]


def test_zeno_accumulation_is_detected_at_the_analytic_time():
    model = bouncing_ball.build(v_rest=0.0)
    with pytest.raises(ZenoError) as info:
        model.simulate(10.0, "RK45", rtol=1e-8)
    assert info.value.accumulation_time == pytest.approx(ZENO_TIME, abs=1e-6)
    assert "4.0637" in str(info.value)
    partial = info.value.trajectory
    assert len(partial.events) >= 8 and partial.t[-1] < ZENO_TIME  # nothing computed is lost
    stopped = model.simulate(10.0, "RK45", rtol=1e-8, on_zeno="stop")
    assert stopped.stopped == "zeno" and stopped.t[-1] < ZENO_TIME
    assert stopped.stats["zeno accumulation time [s]"] == pytest.approx(ZENO_TIME, abs=1e-6)


def test_resting_rule_ends_the_bouncing():
    model = bouncing_ball.build(v_rest=0.5)
    trajectory = model.simulate(10.0, "RK45", rtol=1e-8)
    assert trajectory.modes[-1].label == "rest"
    assert trajectory.state("y")[-1] == pytest.approx(0.0, abs=1e-9)
    assert trajectory.signal("v")[-1] == 0.0
    # the last impact speed is the first one below v_rest
    speeds = 9.81 * BOUNCES[0] * 0.8 ** np.arange(40)
    assert len(trajectory.events) == int(np.argmax(speeds <= 0.5)) + 1


def test_time_switched_rl_circuit_matches_closed_form_across_the_switch():
    g = BondGraph("rl")
    sw, node, loop = g.add(One("sw", controlled=True)), g.add(Zero("node")), g.add(One("loop"))
    g.connect(Se("V", "V"), sw)
    g.connect(sw, R("R", "R"))
    g.connect(sw, node)
    g.connect(node, loop)
    g.connect(loop, I("L", "L"))
    g.connect(node, R("R_fw", "R_fw"))
    switch = Automaton("switch", {"closed": {"sw": True}, "open": {"sw": False}}, "closed")
    switch.add_transition("closed", "open", "t >= t_open")
    V, R_, R_fw, L, t_open = 10.0, 2.0, 8.0, 0.5, 0.3
    model = HybridModel(g, [switch], dict(V=V, R=R_, R_fw=R_fw, L=L, t_open=t_open))
    times = np.linspace(0, 1.0, 41)
    trajectory = model.simulate(1.0, "RK45", rtol=1e-9, atol=1e-12, t_eval=times)
    R_th = R_ * R_fw / (R_ + R_fw)

    i_open = V / R_ * (1 - math.exp(-t_open * R_th / L))

    def exact(t):
        if t < t_open:
            return V / R_ * (1 - math.exp(-t * R_th / L))
        return i_open * math.exp(-(t - t_open) * R_fw / L)

    assert trajectory.event_times[0] == pytest.approx(t_open, abs=1e-12)
    for t, p in zip(trajectory.t, trajectory.state("p_L")):
        assert p / L == pytest.approx(exact(t), rel=1e-7, abs=1e-9)


def test_dependent_states_stay_on_their_constraints():
    from switching_models import falling_rod

    model = falling_rod()
    x0 = np.zeros(6)
    x0[5] = 0.8  # theta
    x0[4] = 0.5 * math.sin(0.8)  # the tip starts on the floor
    trajectory = model.simulate(0.5, "RK45", rtol=1e-6, x0=x0, mode="stuck")
    m, J, l = 1.0, 1 / 12, 0.5
    px, py, pJ, th = (trajectory.state(n) for n in ("rod/p_x", "rod/p_y", "rod/p_J", "rod/theta"))
    stuck = np.array([mode.label == "stuck" for mode in trajectory.modes])
    assert stuck.sum() > 5
    np.testing.assert_allclose(px[stuck] / m, -l * np.sin(th[stuck]) * pJ[stuck] / J, rtol=0, atol=1e-14)
    np.testing.assert_allclose(py[stuck] / m, l * np.cos(th[stuck]) * pJ[stuck] / J, rtol=0, atol=1e-14)


def fitted_order(method, dts, t_end=3.0):
    exact, events = rc_relay_exact(t_end)
    assert len(events) == 2
    model = rc_relay()
    errors = []
    for dt in dts:
        trajectory = model.simulate(t_end, method, dt=dt, output="events")
        errors.append(abs(trajectory.state("q_C")[-1] - exact))
    slope = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    return slope, errors


def test_euler_converges_with_order_one_across_events():
    slope, errors = fitted_order("euler", [4e-3, 2e-3, 1e-3, 5e-4])
    assert 0.85 < slope < 1.15, (slope, errors)


def test_rk4_converges_with_order_four_across_events():
    slope, errors = fitted_order("rk4", [0.08, 0.04, 0.02, 0.01])
    assert 3.6 < slope < 4.4, (slope, errors)
    assert errors[-1] < 1e-8


def test_output_control():
    model = bouncing_ball.build()
    events_only = model.simulate(2.5, "RK45", output="events")
    assert len(events_only.t) == 1 + 2 * 4 + 1  # start, before/after each bounce, end
    times = np.linspace(0, 2.5, 26)
    sampled = model.simulate(2.5, "RK45", rtol=1e-8, t_eval=times)
    np.testing.assert_array_equal(sampled.t, times)  # the requested times, no others
    assert len(sampled.events) == 4 and sampled.event_index == []
    y = sampled.state("y")
    t_first = sampled.t < BOUNCES[0]
    np.testing.assert_allclose(y[t_first], 1 - 9.81 * sampled.t[t_first] ** 2 / 2, atol=1e-9)


def test_bad_options_are_clear_errors():
    model = bouncing_ball.build()
    with pytest.raises(SimulationError, match="fixed-step: give a positive step dt"):
        model.simulate(1.0, "euler")
    with pytest.raises(SimulationError, match="adaptive: give rtol/atol, not dt"):
        model.simulate(1.0, "RK45", dt=0.1)
    with pytest.raises(SimulationError, match="unknown method 'RK99'"):
        model.simulate(1.0, "RK99")
    with pytest.raises(SimulationError, match="must be after t0"):
        model.simulate(0.0)


def test_non_finite_state_raises_with_mode_and_time_and_keeps_the_partial_run():
    g = BondGraph("blowup")
    j = g.add(One("j"))
    k = sp.Symbol("k")
    g.connect(Se("push", k * sp.Symbol("p_m") ** 2), j)  # dp/dt = k p²: blows up at t = 1/(k p0)
    g.connect(j, I("m", "m"))
    sw = g.add(Zero("dummy", controlled=True))
    g.connect(j, sw)
    g.connect(sw, R("Rd", "Rd"))
    a = Automaton("a", {"off": {"dummy": False}, "on": {"dummy": True}}, "off")
    model = HybridModel(g, [a], {"k": 1.0, "m": 1.0, "Rd": 1.0}, initial_state={"p_m": 1.0})
    with pytest.raises((NonFiniteStateError, StepSizeError)) as info:
        model.simulate(2.0, "rk4", dt=0.05)
    assert "t ≈" in str(info.value) or "t =" in str(info.value)
    assert "a=off" in str(info.value)
    assert len(info.value.trajectory.t) > 10 and info.value.trajectory.t[-1] > 0.9


def test_diode_circuit_current_is_continuous_and_decays_as_rl():
    model = diode_circuit(I_th=0.0, p0=0.0, t_open=0.5)
    trajectory = model.simulate(1.0, "RK45", rtol=1e-10, atol=1e-12)
    i = trajectory.signal("i_L")
    opening, diode_off = trajectory.events
    assert opening.kinds == ["start", "mythical", "continuous"]
    k = trajectory.event_index[0]
    assert i[k - 1] == i[k]  # the inductor current does not jump
    i0, R_, L, V_th = i[k], 1.0, 0.1, 0.7
    assert i0 == pytest.approx(10 * (1 - math.exp(-0.5 * R_ / L)), rel=1e-8)
    freewheel = (trajectory.t > 0.5) & (trajectory.t < diode_off.t)
    tau = trajectory.t[freewheel] - 0.5
    exact = (i0 + V_th / R_) * np.exp(-tau * R_ / L) - V_th / R_
    np.testing.assert_allclose(i[freewheel], exact, rtol=1e-7, atol=1e-9)
    # the current reaches zero where the closed form says, and the diode turns off there
    assert diode_off.t == pytest.approx(0.5 + L / R_ * math.log((i0 + V_th / R_) / (V_th / R_)), abs=1e-9)
    assert diode_off.mode_after.label == "open|off" and i[-1] == pytest.approx(0, abs=1e-12)


def test_trajectory_exports(tmp_path):
    trajectory = bouncing_ball.build().simulate(1.0, "RK45")
    text = trajectory.to_csv(signals=["v"])
    header = text.splitlines()[0].split(",")
    assert header == ["t", "p", "y", "v", "mode"]
    trajectory.to_csv(tmp_path / "ball.csv")
    assert (tmp_path / "ball.csv").read_text() == text.replace("\n", "\r\n") or (tmp_path / "ball.csv").stat().st_size > 0
    trajectory.to_npz(tmp_path / "ball.npz", signals=["v"])
    data = np.load(tmp_path / "ball.npz")
    np.testing.assert_array_equal(data["t"], trajectory.t)
    assert list(data["state_names"]) == ["p", "y"] and data["signal:v"].shape == trajectory.t.shape
    summary = trajectory.summary()
    assert "contact=impact" in summary and "pinnacle ×1" in summary and "1 instant" in summary and "1 instants" not in summary


def test_divergence_during_a_run_keeps_the_partial_trajectory():
    from switching import DivergenceOfTimeError

    model = diode_circuit(I_th=20.0, p0=0.0, t_open=0.5)
    with pytest.raises(DivergenceOfTimeError) as info:
        model.simulate(1.0, "RK45")
    partial = info.value.trajectory
    assert partial is not None and partial.t[-1] == pytest.approx(0.5)
    assert partial.state("p_L")[-1] > 0.5  # the charging phase is all there


def test_a_round_off_jump_still_lands_exactly_on_the_constraint():
    """A jump below the pulse threshold carries no impulse, but the state still
    takes the exact projection: a contact entered with a 4.5e-13 velocity
    mismatch conserves momentum to round-off."""
    from models import colliding_balls

    model = colliding_balls.build(m1=1, m2=1, e=0.0, v_th=0.0)
    x = np.array([0.25 + 4.5e-13, 0.25, 0.0, 0.2])  # p1, p2, pos1, pos2: touching
    trajectory = model.simulate(1.0, x0=x, mode="free")
    assert abs(trajectory.x[-1][:2].sum() - x[:2].sum()) < 1e-15


@pytest.mark.parametrize("case", ["ball rk4", "ball euler", "ball RK45", "rod rk4", "rod euler", "rod DOP853",
                                  "diode rk4", "diode euler", "diode Radau"])
def test_fast_paths_give_the_results_of_numpy_arrays_bit_for_bit(case, monkeypatch):
    """For speed the generated rates, constraints and guard sides run on
    Python floats, and euler and rk4 step small systems on lists of floats;
    the results are those of the same operations on numpy arrays and
    scalars, bit for bit — events, dependent states (the pivoting rod's rates
    do not read them, so its stages skip them) and mode sequence included."""
    from models.graphs import pivoting_rod

    from switching.simulate import driver as simulator

    name, method = case.split()
    if name == "ball":
        model, t_end, dt = bouncing_ball.build(), 2.5, 0.01
    elif name == "rod":
        model = HybridModel(pivoting_rod(), [], {"m": 1.0, "J": 1 / 12, "l": 0.5, "g": 9.81},
                            initial_state={"rod/theta": 0.9})
        t_end, dt = 1.0, 0.0134
    else:
        model, t_end, dt = diode_circuit(I_th=0.0, p0=0.0, t_open=0.5), 1.0, 1e-3
    options = {"dt": dt} if method in ("euler", "rk4") else {"rtol": 1e-8, "atol": 1e-10}
    fast = model.simulate(t_end, method, **options)

    def on_arrays_only(generated):
        def call(x, *args):
            if isinstance(x, list):
                raise TypeError("floats refused: numpy scalars only")
            return generated(x, *args)

        return call

    for mode in set(fast.modes):  # every generated function of every mode visited, on arrays only
        cm = model.compiled_mode(mode)
        for attribute in ("_rates", "_phi", "_sides"):
            monkeypatch.setattr(cm, attribute, on_arrays_only(getattr(cm, attribute)))
    monkeypatch.setattr(simulator, "_LIST_STATES", 0)  # and steps on arrays
    arrays = model.simulate(t_end, method, **options)
    assert len(fast.t) == len(arrays.t) > 10 and fast.mode_labels == arrays.mode_labels
    np.testing.assert_array_equal(fast.t, arrays.t)
    np.testing.assert_array_equal(fast.x, arrays.x)
    if name != "rod":
        assert len(fast.events) >= 2
