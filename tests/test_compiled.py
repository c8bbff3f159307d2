"""The compiled (numba) kernels give the Python methods' results.

Every model structure and set of modes compiles a kernel of its own (about
20–30 s on first use): tests that need one no other test shares are marked
``slow`` and run with ``pytest -m slow`` or ``HBG_SLOW=1``."""

import numpy as np
import pytest

pytest.importorskip("numba")

from models import bouncing_ball, falling_rod  # noqa: E402
from switching import SimulationError  # noqa: E402

BOUNCES = np.array([0.451523640986, 1.173961466563, 1.751911727025, 2.214271935394])


@pytest.fixture(scope="module")
def ball():
    return bouncing_ball.build()


# compiles a numba kernel of its own (20-45 s): in the slow set until issue 14 compiles one kernel per installation
@pytest.mark.slow
def test_fixed_step_kernels_reproduce_the_python_steps_exactly(ball):
    for method, jit in (("rk4", "rk4-jit"), ("euler", "euler-jit")):
        python = ball.simulate(2.5, method, dt=0.01)
        compiled = ball.simulate(2.5, jit, dt=0.01)
        assert len(python.t) == len(compiled.t)
        np.testing.assert_array_equal(compiled.event_times, python.event_times)
        np.testing.assert_allclose(compiled.x, python.x, rtol=0, atol=1e-13)


def test_rk45_kernel_takes_scipys_steps(ball):
    python = ball.simulate(2.5, "RK45", rtol=1e-6)
    compiled = ball.simulate(2.5, "RK45-jit", rtol=1e-6)
    assert python.stats["steps"] == compiled.stats["steps"] and len(python.t) == len(compiled.t)
    np.testing.assert_allclose(compiled.t, python.t, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(compiled.x, python.x, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(compiled.event_times[:4], BOUNCES, atol=1e-9)


def test_compiled_path_with_dependent_states_and_mythical_modes():
    model = falling_rod.build(mu=0.002)
    python = model.simulate(0.4, "RK45", rtol=1e-9, atol=1e-12)
    compiled = model.simulate(0.4, "RK45-jit", rtol=1e-9, atol=1e-12)
    assert [s.kind for s in compiled.events[0].steps] == ["start", "mythical", "continuous"]
    assert compiled.events[0].t == pytest.approx(python.events[0].t, abs=1e-13)
    np.testing.assert_allclose(compiled.x[-1], python.x[-1], rtol=1e-9, atol=1e-12)


def test_compiled_methods_refuse_what_they_cannot_do(ball):
    with pytest.raises(SimulationError, match="t_eval needs 'RK45'"):
        ball.simulate(1.0, "RK45-jit", t_eval=[0.5])
    with pytest.raises(SimulationError, match="fixed-step"):
        ball.simulate(1.0, "rk4-jit")


def test_zeno_is_detected_on_the_compiled_path_too(ball):
    from switching import ZenoError

    with pytest.raises(ZenoError) as info:
        ball.simulate(10.0, "RK45-jit", rtol=1e-8)
    assert info.value.accumulation_time == pytest.approx(0.451523640986 * 9, abs=1e-6)


# Dask's workers are new processes: each compiles the kernels of the modes it reaches (~100 s) until
# issue 14 remembers compiled modes across processes; tests/test_sweep.py covers the sweep itself
@pytest.mark.slow
def test_simulate_many_runs_a_sweep_on_all_cores_and_keeps_failures_apart():
    from switching import simulate_many

    sets = [{"mu": 0.002}, {"mu": 0.005}, {"mu": 0.004}, {"mu": 0.003}]
    results = simulate_many(falling_rod.build, sets, 0.3, "RK45-jit", workers=2, rtol=1e-9, atol=1e-12,
                            output="events")
    assert [r.parameters for r in results] == sets  # in order
    last = [r.instants[0][-1] for r in results]
    assert last == [("contact|slide_neg", "continuous"), ("contact|stuck", "continuous"),
                    ("contact|slide_neg", "continuous"), ("contact|slide_neg", "continuous")]
    broken = simulate_many(bouncing_ball.build, [{"e": 0.5}, {"e": 0.8}], 5.0, "RK45", workers=2)
    assert [r.ok for r in broken] == [False, False] and "Zeno" in broken[0].error
    assert len(broken[0].event_times) >= 8  # the partial run came back


# ------------------------------------------------ instants resolved in compiled code

def _same_run(model, t_end, method, python_method, **options):
    """Run Python first (visiting the modes), then the compiled method twice:
    the second compiled run covers every mode and resolves every instant in
    compiled code."""
    python = model.simulate(t_end, python_method, **options)
    model.simulate(t_end, method, **options)
    compiled = model.simulate(t_end, method, **options)
    assert compiled.stats["instants resolved in Python"] == 0
    return python, compiled


def test_mythical_modes_and_a_posteriori_impulses_are_resolved_in_compiled_code():
    """Diode circuit: opening the switch passes (open, off) as a mythical
    mode because the a posteriori guard sees the pulse of v_D.  The compiled
    resolution sees the same pulse (impulse area Σ ∂v_D/∂ẋ·Δx), passes the
    same modes, and the decay after the switch matches the closed form."""
    from models import diode_circuit

    model = diode_circuit.build()
    python, compiled = _same_run(model, 1.0, "RK45-jit", "RK45", rtol=1e-9, atol=1e-12)
    assert [e.mode_after.label for e in compiled.events] == [e.mode_after.label for e in python.events]
    assert compiled.events[0].kinds == python.events[0].kinds
    assert "mythical" in compiled.events[0].kinds
    np.testing.assert_allclose(compiled.event_times, python.event_times, rtol=0, atol=1e-12)
    np.testing.assert_allclose(compiled.x[-1], python.x[-1], rtol=1e-8, atol=1e-12)


# compiles a numba kernel of its own (20-45 s): in the slow set until issue 14 compiles one kernel per installation
@pytest.mark.slow
def test_pinnacle_chains_are_resolved_in_compiled_code():
    """Four touching balls, e = 1: one instant passes three pinnacles (Newton
    impacts), the velocities end as (0, 0, 0, v0) in both paths."""
    from models import ball_chain

    model = ball_chain.build(N=4, e=1.0)
    python, compiled = _same_run(model, 0.5, "RK45-jit", "RK45", output="events")
    (instant,) = compiled.events
    assert instant.kinds.count("pinnacle") == 3 and instant.kinds == python.events[0].kinds
    p = instant.x_after[:4]
    np.testing.assert_allclose(p, python.events[0].x_after[:4], rtol=0, atol=1e-15)
    np.testing.assert_allclose(p, [0.0, 0.0, 0.0, 1.0], atol=1e-15)


def test_an_initial_mythical_instant_is_resolved_in_compiled_code():
    """A ball released on the floor moving down: the instant at t = 0 is an
    impact (v⁺ = −e·v), then the flight; the same as the Python path."""
    model = bouncing_ball.build(y0=0.0, v0=-2.0)
    python, compiled = _same_run(model, 0.3, "RK45-jit", "RK45", rtol=1e-9, atol=1e-12)
    assert compiled.events[0].t == 0.0 and python.events[0].t == 0.0
    assert compiled.events[0].x_after[0] == pytest.approx(1.6, abs=1e-15)  # p = m·v, v⁺ = −0.8·(−2)
    assert compiled.events[0].kinds == python.events[0].kinds
    np.testing.assert_array_equal(compiled.x[:3], python.x[:3])  # x0, then the instant's before and after
    np.testing.assert_allclose(compiled.x[-1], python.x[-1], rtol=1e-9, atol=1e-12)


def test_modes_outside_the_compiled_set_flow_in_python_until_the_next_run(ball):
    """A fresh model: the first compiled run covers only the initial mode;
    leaving it hands the instant to Python, and the flows there use scipy's
    RK45 (the same steps).  The next run covers both modes."""
    fresh = bouncing_ball.build(e=0.7)
    first = fresh.simulate(2.0, "RK45-jit", rtol=1e-8, output="events")
    second = fresh.simulate(2.0, "RK45-jit", rtol=1e-8, output="events")
    assert first.stats["instants resolved in Python"] == len(first.events) > 0
    assert second.stats["instants resolved in Python"] == 0
    np.testing.assert_allclose(second.event_times, first.event_times, rtol=0, atol=1e-12)
    v1 = np.sqrt(2 * 9.81)
    t_first = np.sqrt(2 / 9.81)
    assert second.event_times[1] == pytest.approx(t_first + 2 * 0.7 * v1 / 9.81, abs=1e-9)


@pytest.mark.slow  # compiles a kernel of its own (~20–30 s)
def test_a_divergence_of_time_in_the_kernel_is_reported_by_python():
    """Plastic chain at v_th = 0: the kernel sees a pinnacle repeat its state
    and hands the instant back; Python reports the loop, as in the Python path."""
    from models import ball_chain
    from switching import DivergenceOfTimeError

    model = ball_chain.build(N=4, e=0.0, v_th=0.0)
    with pytest.raises(DivergenceOfTimeError):
        model.simulate(0.5, "RK45", output="events")
    with pytest.raises(DivergenceOfTimeError, match="repeats with the same state") as info:
        model.simulate(0.5, "RK45-jit", output="events")
    assert info.value.instant.t == pytest.approx(0.1, abs=1e-13)


# compiles a numba kernel of its own (20-45 s): in the slow set until issue 14 compiles one kernel per installation
@pytest.mark.slow
def test_the_compiled_rk45_reports_stiffness():
    """A damped contact relaxing at k/b = 1e8 /s after separation: RK45 is held
    at its stability limit; Hairer's test stops the kernel with StiffnessError
    naming the mode, the step and |hλ| (≈ 3.3 for Dormand–Prince)."""
    from models import ball_chain
    from switching import StiffnessError

    model = ball_chain.build(N=2, compliant=True, k=1e8, b=1.0)
    with pytest.raises(StiffnessError) as python:  # the Python path visits both modes and stops too
        model.simulate(0.5, "RK45", rtol=1e-8, atol=1e-12)
    with pytest.raises(StiffnessError) as info:
        model.simulate(0.5, "RK45-jit", rtol=1e-8, atol=1e-12)
    error = info.value
    assert 0.1 < error.t < 0.1005 and abs(error.t - python.value.t) < 1e-4
    assert "contact1=free" in str(error) and "Radau" in str(error)
    assert 3.25 < error.h_lambda < 4.0 and error.h < 1e-7
    momenta = error.trajectory.x[:, :2]
    np.testing.assert_allclose(momenta.sum(axis=1), 1.0, atol=1e-12)


@pytest.mark.slow  # compiles a kernel of its own (~20–30 s)
@pytest.mark.parametrize("method, factor", [("euler", 3.0), ("rk4", 4.0)])
def test_fixed_step_kernels_report_stiffness_where_python_does(method, factor):
    """Touching balls on an undamped contact, ω·dt = 3 and 4 (beyond Euler's
    2 and rk4's 2.78): the kernels apply the same rule as the Python steppers and
    stop at the same time with the same |h·λ|."""
    import math

    from models import ball_chain
    from switching import StiffnessError

    k = 1e10
    omega = math.sqrt(2 * k)
    model = ball_chain.build(N=2, compliant=True, k=k, distance=0.0)
    errors = []
    for name in (method, method, f"{method}-jit"):  # Python visits the modes, the kernel covers them
        with pytest.raises(StiffnessError) as info:
            model.simulate(10 * math.pi / omega, name, dt=factor / omega)
        errors.append(info.value)
    python, compiled = errors[1], errors[2]
    assert compiled.t == python.t and compiled.limit == python.limit
    assert compiled.h_lambda == pytest.approx(python.h_lambda, rel=1e-12)
    assert f"{method}-jit is beyond its stability limit" in str(compiled) and "dt <" in str(compiled)


@pytest.mark.slow  # compiles a kernel of its own (~20–30 s)
def test_a_kernel_for_the_reachable_modes_resolves_the_first_run_in_compiled_code():
    """compiled_model("reachable") explores the modes from the initial one
    (verify's exploration): the first compiled run then needs no Python at
    any instant, and gives the bounce times of the closed form."""
    model = bouncing_ball.build(e=0.5, v_rest=0.3)
    compiled = model.compiled_model("reachable")
    assert {m.label for m in compiled.modes} == {"flight", "impact", "rest"}
    run = model.simulate(2.0, "RK45-jit", rtol=1e-10, atol=1e-12, output="events")
    assert run.stats["instants resolved in Python"] == 0
    v, t_bounce, times = np.sqrt(2 * 9.81), np.sqrt(2 / 9.81), []
    while v > 0.3:
        times.append(t_bounce)
        v *= 0.5
        t_bounce += 2 * v / 9.81
    np.testing.assert_allclose(run.event_times[: len(times)], times, atol=1e-9)
    assert run.modes[-1].label == "rest"


@pytest.mark.parametrize("case", [pytest.param("time pulse", marks=pytest.mark.slow),  # a kernel of its own
                                  pytest.param("state re-crossing", marks=pytest.mark.slow),
                                  pytest.param("grazing touch", marks=pytest.mark.slow)])
def test_a_guard_holding_only_inside_a_step_is_caught_by_the_compiled_methods(case):
    """The in-step cases of test_extremes (a guard holding only between two of
    a step's sample points): the kernel's event detection is the Python
    path's (_GuardScan: refined extrema of the comparisons' margins, holds
    between comparisons changing truth), so the compiled methods find the
    same events at the same times.  At the grazing touch, y − h is within
    its band for 0.29 µs only and the ball is nearly at rest: a round-off
    difference of the states (1e-16 m) moves the located time by ~1e-10 s."""
    import math

    from test_extremes import G, pulse_gate, sensor_ball

    if case == "time pulse":
        model, t_end, runs, atol = pulse_gate(0.26, 0.27), 1.0, [("rk4", {"dt": 0.1}), ("RK45", {})], 1e-13
    else:
        d = 1e-3 if case == "state re-crossing" else 0.0
        model, t_end = sensor_ball(1.0, math.sqrt(2 * G * (1.0 + d))), 0.6
        runs = [("RK45", {}), ("rk4", {"dt": 0.2 if d else 0.45})]
        atol = 1e-13 if d else 1e-9
    for method, options in runs:
        python, compiled = _same_run(model, t_end, f"{method}-jit", method, **options)
        assert len(python.events) == 2
        assert [e.mode_after.label for e in compiled.events] == [e.mode_after.label for e in python.events]
        np.testing.assert_allclose(compiled.event_times, python.event_times, rtol=0, atol=atol)
        if case == "time pulse":
            np.testing.assert_allclose(compiled.event_times, [0.26, 0.27], rtol=0, atol=1e-12)
            assert compiled.state("Q")[-1] == pytest.approx(0.02, abs=1e-12)


# ------------------------------------------------ the kernel's call: scalars, buffers, workspaces


def test_kernel_calls_keep_one_signature_and_reused_workspaces_change_nothing(ball):
    """Scalars of any numeric type reach the kernel as float64/int64 (a new
    type combination would compile the whole kernel again), and workspaces
    reused from call to call — zeroed where read before written — give each
    run the results of a fresh one, bit for bit."""
    first = ball.simulate(2.5, "RK45-jit", rtol=1e-6, output="events")
    compiled = ball.compiled_model()
    ball.simulate(1, "RK45-jit", rtol=np.float32(1e-5), atol=1e-8, max_step=2, event_samples=np.int64(5),
                  x0=[2, 1])
    ball.simulate(1.5, "rk4-jit", dt=np.float64(0.01), x0=[-1.0, 0.5])
    again = ball.simulate(2.5, "RK45-jit", rtol=1e-6, output="events")
    assert len(compiled.module.run.signatures) == 1
    np.testing.assert_array_equal(again.t, first.t)
    np.testing.assert_array_equal(again.x, first.x)
    assert again.mode_labels == first.mode_labels


def test_a_workspace_smaller_than_the_kernel_needs_is_refused_before_anything_runs(ball):
    ball.simulate(0.1, "RK45-jit", rtol=1e-6, output="events")
    compiled = ball.compiled_model()
    buffers = compiled.buffers(False)
    wf, wi, wb = compiled.workspace(3, ball.max_steps_per_instant)
    tol = ball.tolerance
    args = (2, 0, 3, ball.max_steps_per_instant, False, 10**9, False, 0.0, 1.0, 0.0, 1e-6, 1e-9, np.inf, 0.0,
            tol.rtol, tol.atol, tol.jump_rtol, tol.jump_atol, ball.initial_state(), ball.parameter_array,
            np.zeros(0), *buffers)
    status, n_saved, n_events, t, mode, steps = compiled.module.run(*args, wf[:-1], wi, wb)
    assert (status, n_saved, n_events, t, steps) == (7, 0, 0, 0.0, 0)
    status, *_ = compiled.module.run(*args, wf, wi, wb)
    assert status == 0
