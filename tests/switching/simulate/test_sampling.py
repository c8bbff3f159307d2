"""Which rows a run returns (issue 29 item 2): ``t_eval=ts`` gives exactly
the times ``ts`` (as scipy's ``solve_ivp``), on the Python and the compiled
methods alike, the states there against closed forms; a time on an instant
gets the state after it (right-continuous); the instants' states before and
after are read with ``at_instants()``; ``samples=N`` gives ``N`` uniform
times and every instant's pair (``hbg run``'s rows)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bondgraph import BondGraph, I, One, R, Se, Zero
from models import bouncing_ball
from switching import Automaton, HybridModel, WorkLimitError
from switching.errors import OptionTypeError, OptionValueError

pytestmark = pytest.mark.timeout(300)

G, E, H = 9.81, 0.8, 1.0  # the ball's defaults: gravity [m/s²], restitution [1], drop height [m]
T1 = math.sqrt(2 * H / G)  # the first impact [s]


def ball_exact(t):
    """The bouncing ball (m = 1 kg, dropped from H at rest) in closed form at
    time ``t`` [s]: ``(p [kg·m/s], y [m])``, right-continuous at an impact
    (``p`` just after it).  Impact k ≥ 1 at ``t_k = T1 (1 + 2 Σ_{j<k} e^j)``,
    each flight after it a parabola leaving the floor at ``e^k g T1``."""
    t_k, v_up = T1, None
    if t < T1:
        return -G * t, H - G * t * t / 2
    k = 1
    while True:
        v_up = E ** k * G * T1
        flight = 2 * v_up / G
        if t < t_k + flight:
            tau = t - t_k
            return v_up - G * tau, v_up * tau - G * tau * tau / 2
        t_k += flight
        k += 1


def impacts(count):
    """The first ``count`` impact times [s] in closed form."""
    times, t_k = [], T1
    for k in range(count):
        times.append(t_k)
        t_k += 2 * E ** (k + 1) * T1
    return np.array(times)


METHODS = [("RK45", {}), ("DOP853", {}), ("Radau", {}), ("RK45-jit", {}),
           ("rk4", {"dt": 1e-3}), ("rk4-jit", {"dt": 1e-3})]


@pytest.fixture(scope="module")
def ball():
    model = bouncing_ball.build()
    model.simulate(2.5, "RK45")  # both modes visited: the compiled kernel covers them
    return model


def tolerances(options):
    return {} if "dt" in options else {"rtol": 1e-10, "atol": 1e-12}


@pytest.mark.parametrize("method, options", METHODS)
def test_t_eval_returns_exactly_the_times_asked_with_the_closed_form_states(ball, method, options):
    """40 times over four bounces: 40 rows, ``t`` equal to the times asked
    (no t0 twice, no t_end unasked, no instant rows), the states the closed
    form's.  Every flight is a parabola, which every method here integrates
    exactly (order ≥ 2; rk4's cubic Hermite interpolant holds it too): what is
    left is the impacts' location, to round-off on the interpolant, so the
    states agree far inside ``rtol`` = 1e-10 of the run; 1e-9 m bounds it for
    the fixed step too."""
    times = np.linspace(0.05, 2.45, 40)
    run = ball.simulate(2.5, method, t_eval=times, **options, **tolerances(options))
    np.testing.assert_array_equal(run.t, times)
    assert run.sampling == "times" and run.event_index == [] and len(run.events) == 4
    exact = np.array([ball_exact(t) for t in times])
    np.testing.assert_allclose(run.state("p"), exact[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(run.state("y"), exact[:, 1], rtol=0, atol=1e-9)
    # the jumps are not rows, but each instant's states are there by their accessor: p⁻ = −g·(flight), p⁺ = −e·p⁻
    jumps = run.at_instants()
    np.testing.assert_allclose(jumps.t, impacts(4), rtol=0, atol=1e-9)
    p = run.state_names.index("p")
    np.testing.assert_allclose(jumps.x_after[:, p], -E * jumps.x_before[:, p], rtol=1e-12)
    np.testing.assert_allclose(jumps.x_before[:, p], [-(E ** k) * G * T1 for k in range(4)], rtol=1e-9)
    assert [m.describe() for m in jumps.modes_before] == [m.describe() for m in jumps.modes_after]  # flight


@pytest.mark.parametrize("method, options", METHODS)
def test_a_requested_time_on_an_instant_gets_the_state_after_it(ball, method, options):
    """The run's own impact times (bit for bit: the steps do not depend on the
    times asked) among the requested ones: their rows hold the state just
    after the impact (right-continuous, as ``at_instants().x_after``), a time
    one ulp earlier the state just before it."""
    first = ball.simulate(2.5, method, output="events", **options, **tolerances(options))
    t_hit = first.event_times[:2]
    times = np.sort(np.concatenate([[0.0, 0.3], t_hit, np.nextafter(t_hit, -np.inf), [2.5]]))
    run = ball.simulate(2.5, method, t_eval=times, **options, **tolerances(options))
    np.testing.assert_array_equal(run.t, times)
    np.testing.assert_array_equal(run.event_times, first.event_times)
    jumps = run.at_instants()
    p = run.state_names.index("p")
    for k, t in enumerate(t_hit):
        row = int(np.flatnonzero(run.t == t)[0])
        np.testing.assert_allclose(run.x[row], jumps.x_after[k], rtol=1e-12, atol=1e-12)
        assert run.x[row][p] > 0 and run.x[row - 1][p] == pytest.approx(jumps.x_before[k][p], rel=1e-9)
        assert run.modes[row] == jumps.modes_after[k]


def _switched_rl():
    """An RL circuit whose switch opens at ``t >= t_open``: a guard on time
    alone, located where it first holds (within the guards' round-off band),
    whatever the steps."""
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
    return HybridModel(g, [switch], dict(V=10.0, R=2.0, R_fw=8.0, L=0.5, t_open=0.3))


@pytest.mark.parametrize("method", ["RK45", "RK45-jit"])
def test_a_run_ending_with_an_instant_has_its_last_requested_time(method):
    """The switch opens exactly at ``t_end``: the run ends with that instant
    and flows no further, and the time ``t_end`` still gets its row — the
    state after the instant, in the mode after it; the current is the closed
    form's, ``V/R (1 − exp(−t R_th/L))``, to ``rtol``."""
    model = _switched_rl()
    # the opening's time: the first t whose guard t >= t_open holds within the guards' round-off band
    t_open = model.simulate(0.6, "RK45", output="events").event_times[0]
    assert t_open == pytest.approx(0.3, abs=1e-12)
    times = np.linspace(0.0, t_open, 7)
    run = model.simulate(t_open, method, t_eval=times, rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(run.t, times)
    assert run.event_times[0] == t_open and run.modes[-1] == run.events[0].mode_after != run.modes[-2]
    R_th = 2.0 * 8.0 / 10.0
    exact = 10.0 / 2.0 * (1 - np.exp(-times * R_th / 0.5))
    np.testing.assert_allclose(run.state("p_L") / 0.5, exact, rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("method", ["RK45", "RK45-jit"])
def test_samples_gives_uniform_times_and_every_instants_pair(ball, method):
    """``samples=N``: the N times ``linspace(t0, t_end, N)`` and each impact's
    before and after rows, in time order; ``without_instants()`` leaves the
    N times, the very rows of ``t_eval`` at those times."""
    run = ball.simulate(2.5, method, samples=26, rtol=1e-10, atol=1e-12)
    assert run.sampling == "samples" and len(run.events) == 4 and len(run.t) == 26 + 2 * 4
    assert np.all(np.diff(run.t) >= 0)
    for k, after in enumerate(run.event_index):
        assert run.t[after - 1] == run.t[after] == run.events[k].t
        np.testing.assert_array_equal(run.x[after - 1], run.events[k].x_before)
        np.testing.assert_array_equal(run.x[after], run.events[k].x_after)
    plain = run.without_instants()
    np.testing.assert_array_equal(plain.t, np.linspace(0.0, 2.5, 26))
    requested = ball.simulate(2.5, method, t_eval=np.linspace(0.0, 2.5, 26), rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(plain.x, requested.x)
    exact = np.array([ball_exact(t) for t in plain.t])
    np.testing.assert_allclose(plain.state("p"), exact[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(plain.state("y"), exact[:, 1], rtol=0, atol=1e-9)
    p = run.state("p")  # an impact's rows: p⁻ = −e^k g T1 and p⁺ = e^(k+1) g T1
    np.testing.assert_allclose(p[[k - 1 for k in run.event_index]], [-(E ** k) * G * T1 for k in range(4)], rtol=1e-9)
    np.testing.assert_allclose(p[run.event_index], [E ** (k + 1) * G * T1 for k in range(4)], rtol=1e-9)


def test_default_output_is_every_step_and_events_keeps_only_what_is_forced(ball):
    """Python's default (``output="steps"``): the solver's steps, start and end, each impact's pair."""
    run = ball.simulate(2.5, "RK45")
    assert run.sampling == "steps" and run.t[0] == 0.0 and run.t[-1] == 2.5
    assert len(run.t) > 1 + 2 * 4 + 1 and len(run.event_index) == 4
    events = ball.simulate(2.5, "RK45", output="events")
    assert len(events.t) == 1 + 2 * 4 + 1


def test_zeno_stop_with_t_eval_keeps_the_times_reached_then_where_it_stopped():
    """``on_zeno="stop"`` ends the run at the accumulation of impacts: the
    rows are the requested times up to there, then the state where it
    stopped (the last impact's after state)."""
    model = bouncing_ball.build(e=0.5)
    times = np.linspace(0.0, 2.0, 21)
    run = model.simulate(2.0, "RK45", t_eval=times, on_zeno="stop", rtol=1e-10, atol=1e-12)
    t_stop = run.events[-1].t
    assert run.stopped == "zeno" and t_stop < math.sqrt(2 / G) * 3  # t1 (1 + e)/(1 - e)
    reached = times[times <= t_stop]
    np.testing.assert_array_equal(run.t[:-1], reached)
    assert run.t[-1] == t_stop and len(run.t) == len(reached) + 1
    np.testing.assert_array_equal(run.x[-1], run.events[-1].x_after)


def test_the_sampling_options_are_checked_and_named():
    ball = bouncing_ball.build()
    with pytest.raises(OptionValueError, match=r"samples=10 and t_eval .* not both") as info:
        ball.simulate(1.0, "RK45", samples=10, t_eval=[0.5])
    assert info.value.option == "samples"
    with pytest.raises(OptionValueError, match=r"samples must be a whole number .* ≥ 2, got 1"):
        ball.simulate(1.0, "RK45", samples=1)
    with pytest.raises(OptionTypeError, match=r"samples must be a whole number .* got 2\.5"):
        ball.simulate(1.0, "RK45", samples=2.5)
    with pytest.raises(WorkLimitError, match="samples asks for 100000000000 sample times") as info:
        ball.simulate(1.0, "RK45", samples=10**11)
    assert info.value.option == "samples"
    assert ball.derivation_count == 0  # refused before anything ran


@pytest.mark.parametrize("method", ["RK45", "RK45-jit"])
def test_samples_at_an_initial_instant_order_its_rows_before_after_then_the_time(method):
    """Released on the floor moving down (p = −2 kg·m/s): the instant at t0
    bounces it (p⁺ = −e·p⁻ = 1.6).  With ``samples=N`` the rows at t0 are the
    instant's before and after, then the time t0 itself with the state after
    it; with ``t_eval`` only the last."""
    model = bouncing_ball.build(y0=0.0, v0=-2.0)
    model.simulate(0.3, "RK45")  # both modes visited
    run = model.simulate(0.3, method, samples=4, rtol=1e-10, atol=1e-12)
    p = run.state_names.index("p")
    assert len(run.t) == 4 + 2 and list(run.t[:3]) == [0.0, 0.0, 0.0] and run.event_index == [1]
    assert [run.x[k][p] for k in range(3)] == [-2.0, pytest.approx(1.6, abs=1e-15), pytest.approx(1.6, abs=1e-15)]
    np.testing.assert_array_equal(run.without_instants().t, np.linspace(0.0, 0.3, 4))
    times = model.simulate(0.3, method, t_eval=[0.0, 0.3], rtol=1e-10, atol=1e-12)
    assert list(times.t) == [0.0, 0.3] and times.x[0][p] == pytest.approx(1.6, abs=1e-15)


def test_samples_without_kept_instants_is_the_uniform_times_alone():
    run = bouncing_ball.build().simulate(2.5, "RK45", samples=11, keep_instants=False)
    np.testing.assert_array_equal(run.t, np.linspace(0.0, 2.5, 11))
    assert run.instant_count == 4 and run.events == [] and run.event_index == []
    assert len(run.at_instants().t) == 0 and run.at_instants().x_before.shape == (0, 2)


def test_a_failed_runs_partial_trajectory_has_the_times_reached_then_where_it_failed():
    """The diode circuit with I_th = 100 has no consistent mode at the opening
    (t = 0.5 s, a divergence of time): the error's trajectory holds the
    requested times before it, then the state where the run stopped."""
    from models import diode_circuit
    from switching.errors import DivergenceOfTimeError

    times = np.linspace(0.0, 1.0, 11)
    with pytest.raises(DivergenceOfTimeError) as info:
        diode_circuit.build(I_th=100.0).simulate(1.0, "RK45", t_eval=times)
    partial = info.value.trajectory
    np.testing.assert_array_equal(partial.t[:-1], times[times < 0.5])
    assert partial.t[-1] == pytest.approx(0.5, abs=1e-12) and partial.sampling == "times"
