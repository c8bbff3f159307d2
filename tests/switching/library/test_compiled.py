"""The compiled (numba) kernel gives the Python methods' results.

The kernel (switching.kernel.loop) is compiled once per installation (about 25 s,
then loaded from numba's cache); each model compiles only its modes'
functions (0.3–3.5 s each, then cached in the test session's cache directory)."""

import numpy as np
import pytest

pytest.importorskip("numba")

from models import bouncing_ball, falling_rod  # noqa: E402
from switching import SimulationError  # noqa: E402
from checkout import ROOT

BOUNCES = np.array([0.451523640986, 1.173961466563, 1.751911727025, 2.214271935394])


@pytest.fixture(scope="module")
def ball():
    return bouncing_ball.build()


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
    with pytest.raises(SimulationError, match="fixed-step"):
        ball.simulate(1.0, "rk4-jit")
    model = _driven_relay(lambda t: 1.0 + np.sin(5.0 * t))  # a Python function: compiled code cannot call it
    with pytest.raises(SimulationError, match="input\\(s\\) 'u' of model 'relay' are Python functions") as info:
        model.simulate(1.0, "RK45-jit")
    assert "use 'RK45', or give them as ExpressionInput" in str(info.value)


def _driven_relay(u):
    """The relay of switching_models charged from an input ``u`` instead of the constant V."""
    import sympy as sp

    from bondgraph import BondGraph, C, One, R, Se, Zero
    from switching import Automaton, HybridModel

    g = BondGraph("relay")
    n = g.add(Zero("n"))
    a, b = g.add(One("a", controlled=True)), g.add(One("b", controlled=True))
    g.connect(Se("V", sp.Symbol("u")), a)
    g.input("u")
    g.connect(a, R("R1", "R1"))
    g.connect(a, n)
    g.connect(n, C("C", "C"))
    g.connect(n, b)
    g.connect(b, R("R2", "R2"))
    relay = Automaton("relay", {"charge": {"a": True, "b": False}, "discharge": {"a": False, "b": True}}, "charge")
    relay.add_transition("charge", "discharge", "q_C/C >= 0.8")
    relay.add_transition("discharge", "charge", "q_C/C <= 0.3")
    return HybridModel(g, [relay], dict(R1=1.0, R2=0.5, C=1.0), inputs={"u": u})


def test_inputs_given_as_expressions_of_t_run_compiled():
    """An ExpressionInput (what a model file holds) is compiled into the
    per-mode functions: the same events and states as the Python path,
    dense output included."""
    from switching import ExpressionInput

    model = _driven_relay(ExpressionInput("A*(1 + sin(w*t))", {"A": 1.0, "w": 5.0}))
    t_eval = np.linspace(0.0, 4.0, 41)
    python, compiled = _same_run(model, 4.0, "RK45-jit", "RK45", rtol=1e-9, atol=1e-12, t_eval=t_eval)
    assert len(python.events) >= 4
    assert [e.mode_after.label for e in compiled.events] == [e.mode_after.label for e in python.events]
    np.testing.assert_allclose(compiled.event_times, python.event_times, rtol=0, atol=1e-10)
    np.testing.assert_allclose(compiled.x, python.x, rtol=1e-9, atol=1e-11)
    fixed = [model.simulate(4.0, method, dt=0.01, output="events") for method in ("rk4", "rk4-jit")]
    np.testing.assert_allclose(fixed[1].event_times, fixed[0].event_times, rtol=0, atol=1e-12)


# ------------------------------------------------ requested output times (t_eval) from the kernel's dense output


@pytest.mark.parametrize("method, options", [("RK45", {"rtol": 1e-6}), ("rk4", {"dt": 0.01}),
                                             ("euler", {"dt": 0.01})])
def test_t_eval_on_the_compiled_methods_samples_the_kernels_dense_output(ball, method, options):
    """The samples at requested times come from the same interpolant as the
    Python path's (scipy's RK45 dense output, rk4's cubic Hermite, Euler's
    line): exactly one row per requested time (sorted), the same on both
    paths, and the instants' before/after states the same on both too
    (``at_instants``).  Times exactly at t0 and t_end, and ones inside a step
    ending in an event, are all there; with ``samples=N`` the instants' rows
    come in between, in the same order."""
    t_eval = np.concatenate([[0.0], np.linspace(0.01, 2.49, 97), BOUNCES[:2], [2.5]])
    ball.simulate(2.5, method, **options)  # Python visits both modes: the kernel covers them
    python = ball.simulate(2.5, method, t_eval=t_eval, **options)
    compiled = ball.simulate(2.5, f"{method}-jit", t_eval=t_eval, **options)
    assert compiled.stats["instants resolved in Python"] == 0
    np.testing.assert_array_equal(compiled.t, np.sort(t_eval))
    np.testing.assert_array_equal(python.t, np.sort(t_eval))
    np.testing.assert_allclose(compiled.x, python.x, rtol=1e-10, atol=1e-10)
    assert compiled.mode_labels == python.mode_labels
    assert compiled.event_index == python.event_index == [] and len(python.events) == 4
    for mine, theirs in zip(compiled.at_instants(), python.at_instants()):
        if isinstance(mine, np.ndarray):
            np.testing.assert_allclose(mine, theirs, rtol=1e-10, atol=1e-10)
        else:
            assert mine == theirs
    python = ball.simulate(2.5, method, samples=101, **options)
    compiled = ball.simulate(2.5, f"{method}-jit", samples=101, **options)
    assert len(compiled.t) == len(python.t) == 101 + 2 * len(python.events)
    np.testing.assert_allclose(compiled.t, python.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(compiled.x, python.x, rtol=1e-10, atol=1e-10)
    assert compiled.mode_labels == python.mode_labels and compiled.event_index == python.event_index
    np.testing.assert_array_equal(compiled.without_instants().t, np.linspace(0.0, 2.5, 101))


def test_t_eval_after_an_initial_instant_resolved_in_the_kernel_samples_the_state_after_it():
    """Released on the floor moving down: the instant at t = 0 is resolved in
    the kernel; the sample requested at t = 0 is the state after it (v⁺ = 1.6),
    as on the Python path; the state before it is the instant's record."""
    model = bouncing_ball.build(y0=0.0, v0=-2.0)
    t_eval = [0.0, 0.1, 0.2, 0.3]
    python, compiled = _same_run(model, 0.3, "RK45-jit", "RK45", rtol=1e-9, atol=1e-12, t_eval=t_eval)
    assert compiled.events[0].t == 0.0
    np.testing.assert_array_equal(compiled.t, t_eval)
    np.testing.assert_array_equal(compiled.t, python.t)
    np.testing.assert_allclose(compiled.x, python.x, rtol=1e-9, atol=1e-12)
    assert compiled.x[0][0] == pytest.approx(1.6, abs=1e-15)
    jumps = compiled.at_instants()
    assert jumps.t[0] == 0.0 and jumps.x_before[0][0] == -2.0 and jumps.x_after[0][0] == pytest.approx(1.6, abs=1e-15)


def test_zeno_is_detected_on_the_compiled_path_too(ball):
    from switching import ZenoError

    with pytest.raises(ZenoError) as info:
        ball.simulate(10.0, "RK45-jit", rtol=1e-8)
    assert info.value.accumulation_time == pytest.approx(0.451523640986 * 9, abs=1e-6)


def test_a_run_stopped_at_a_zeno_accumulation_in_the_kernel_counts_the_steps_up_to_it():
    """The kernel goes on past the instant where the run's Zeno watch stops it; the run counts the steps up to
    that instant (each event records the steps before it), as the Python path does: its RK45 takes the same
    steps as the kernel's on the ball (it was 0, the stopping call's steps dropped)."""
    runs = {method: bouncing_ball.build(e=0.5).simulate(3.0, method, rtol=1e-8, on_zeno="stop", output=output)
            for method in ("RK45", "RK45-jit") for output in ("events", "steps")}
    steps = {method: run.stats["steps"] for method, run in runs.items()}
    assert all(run.stopped == "zeno" for run in runs.values())
    assert len(set(steps.values())) == 1 and steps[next(iter(steps))] > 0, steps


# Dask's workers are new processes: the kernel and the modes' functions come from the disk caches
def test_simulate_many_runs_a_sweep_on_all_cores_and_keeps_failures_apart():
    from switching import simulate_many

    sets = [{"mu": 0.002}, {"mu": 0.005}, {"mu": 0.004}, {"mu": 0.003}]
    results = simulate_many(falling_rod.build, sets, 0.3, "RK45-jit", workers=2, rtol=1e-9, atol=1e-12,
                            output="events")
    assert [r.parameters for r in results] == sets  # in order
    last = [r.instants[0][-1] for r in results]
    slide, stuck = "contact=contact, friction=slide_neg", "contact=contact, friction=stuck"
    assert last == [(slide, "continuous"), (stuck, "continuous"), (slide, "continuous"), (slide, "continuous")]
    broken = simulate_many(bouncing_ball.build, [{"e": 0.5}, {"e": 0.8}], 5.0, "RK45", workers=2)
    assert [r.ok for r in broken] == [False, False] and "Zeno" in broken[0].error
    assert len(broken[0].event_times) >= 8  # the partial run came back


def test_a_shared_model_runs_compiled_with_each_runs_parameter_values():
    """A sweep moves each run's values onto one shared model (switching.sweep.batch):
    the kernel reads the values of now, not those of the first run."""
    from switching.sweep.batch import shared_model

    with shared_model(bouncing_ball.build, {"e": 0.8}) as model:
        model.simulate(2.0, "RK45", rtol=1e-8, output="events")
        first = model.simulate(2.0, "RK45-jit", rtol=1e-8, output="events")
    with shared_model(bouncing_ball.build, {"e": 0.5}) as model:
        python = model.simulate(1.2, "RK45", rtol=1e-8, output="events")
        second = model.simulate(1.2, "RK45-jit", rtol=1e-8, output="events")
    assert second.stats["instants resolved in Python"] == 0
    np.testing.assert_allclose(second.event_times, python.event_times, rtol=0, atol=1e-12)
    t1 = np.sqrt(2 / 9.81)
    assert first.event_times[1] == pytest.approx(t1 * 2.6, abs=1e-9)  # 1 + 2e
    assert second.event_times[1] == pytest.approx(t1 * 2.0, abs=1e-9)


def _relay_driven_at(A):
    from switching import ExpressionInput

    return _driven_relay(ExpressionInput("A*(1 + sin(w*t))", {"A": A, "w": 5.0}))


def test_a_shared_model_runs_compiled_with_each_runs_inputs():
    """The same for inputs (expressions of t compiled into the modes' functions)."""
    from switching.sweep.batch import shared_model

    runs = []
    for A in (1.0, 1.5):
        with shared_model(_relay_driven_at, {"A": A}) as model:
            python = model.simulate(3.0, "RK45", rtol=1e-9, atol=1e-12, output="events")
            model.simulate(3.0, "RK45-jit", rtol=1e-9, atol=1e-12, output="events")
            compiled = model.simulate(3.0, "RK45-jit", rtol=1e-9, atol=1e-12, output="events")
        np.testing.assert_allclose(compiled.event_times, python.event_times, rtol=0, atol=1e-10)
        runs.append(python.event_times[0])
    assert runs[1] < runs[0] - 0.1  # a stronger drive charges faster


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


def test_a_mode_first_reached_during_a_run_is_compiled_and_handed_to_the_next_kernel_call(ball):
    """A fresh model: the first compiled run covers only the initial mode;
    the first impact leaves the set, so Python resolves that instant, the
    impact mode's function is compiled, and the kernel's next call resolves
    every later instant.  The next run needs no Python at all."""
    from switching.library.jit_model import forget_modes

    fresh = bouncing_ball.build(e=0.7)
    forget_modes(fresh)  # what other tests' runs compiled is remembered in the disk cache
    first = fresh.simulate(2.0, "RK45-jit", rtol=1e-8, output="events")
    second = fresh.simulate(2.0, "RK45-jit", rtol=1e-8, output="events")
    assert first.stats["instants resolved in Python"] == 1 and len(first.events) > 3
    assert second.stats["instants resolved in Python"] == 0
    np.testing.assert_allclose(second.event_times, first.event_times, rtol=0, atol=1e-12)
    v1 = np.sqrt(2 * 9.81)
    t_first = np.sqrt(2 / 9.81)
    assert second.event_times[1] == pytest.approx(t_first + 2 * 0.7 * v1 / 9.81, abs=1e-9)


def test_a_mode_numba_cannot_compile_flows_in_python(monkeypatch):
    """A mode whose function numba refuses (here: made to) is left out of the
    kernel's set with a warning; every instant through it is resolved in
    Python, with the same results."""
    from numba.core.errors import TypingError

    import switching.library.jit_model as jm

    model = bouncing_ball.build(e=0.6)
    jm.forget_modes(model)
    real = jm.mode_function

    def refuse(model, mode):
        if mode.label == "impact":
            raise TypingError("No implementation of function Function(<ufunc 'foo'>)")
        return real(model, mode)

    monkeypatch.setattr(jm, "mode_function", refuse)
    python = model.simulate(1.5, "RK45", rtol=1e-8, output="events")
    with pytest.warns(RuntimeWarning, match="impact of model 'bouncing_ball' cannot be compiled by numba"):
        compiled = model.simulate(1.5, "RK45-jit", rtol=1e-8, output="events")
    assert compiled.stats["instants resolved in Python"] == len(compiled.events) == len(python.events) == 3
    np.testing.assert_allclose(compiled.event_times, python.event_times, rtol=0, atol=1e-12)


_NEW_PROCESS = """
import json, sys
from models import bouncing_ball
model = bouncing_ball.build(e=0.7)
run = model.simulate(2.0, "RK45-jit", rtol=1e-8, output="events")
print(json.dumps({"python": run.stats["instants resolved in Python"], "events": len(run.events)}))
"""


def test_a_new_process_covers_the_modes_met_before_from_its_first_run(tmp_path):
    """The modes a model's compiled runs have met are remembered in the disk
    cache: a second process resolves every instant of its first run in
    compiled code.  The remembered set only grows."""
    import json
    import os
    import subprocess
    import sys

    from codegen.cache import SourceCache
    from switching.library.jit_model import remember_modes, remembered_modes

    environment = dict(os.environ, HBG_CACHE_DIR=str(tmp_path))

    def new_process():
        done = subprocess.run([sys.executable, "-c", _NEW_PROCESS], env=environment, capture_output=True, text=True,
                              cwd=str(ROOT), timeout=600)
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout.splitlines()[-1])

    first, second = new_process(), new_process()
    assert first["python"] == 1 and first["events"] > 3  # the first impact, in Python: then its mode is compiled
    assert second["python"] == 0 and second["events"] == first["events"]
    model = bouncing_ball.build()
    model.cache = SourceCache(tmp_path)
    assert {m.label for m in remembered_modes(model)} == {"flight", "impact"}
    remember_modes(model, [model.mode("flight")])  # a smaller set adds nothing, removes nothing
    assert {m.label for m in remembered_modes(model)} == {"flight", "impact"}


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


@pytest.mark.parametrize("case", ["time pulse", "state re-crossing", "grazing touch"])
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
    from switching.kernel import loop as kernel

    first = ball.simulate(2.5, "RK45-jit", rtol=1e-6, output="events")
    ball.simulate(1, "RK45-jit", rtol=np.float32(1e-5), atol=1e-8, max_step=2, event_samples=np.int64(5),
                  x0=[2, 1])
    ball.simulate(1.5, "rk4-jit", dt=np.float64(0.01), x0=[-1.0, 0.5])
    again = ball.simulate(2.5, "RK45-jit", rtol=1e-6, output="events")
    # one specialisation per family: explicit (its last argument None) and, if another test ran one, implicit
    last = [str(signature[-1]) for signature in kernel.run.signatures]
    assert last.count("none") == 1 and len(last) - last.count("none") <= 1
    np.testing.assert_array_equal(again.t, first.t)
    np.testing.assert_array_equal(again.x, first.x)
    assert again.mode_labels == first.mode_labels


def test_a_workspace_smaller_than_the_kernel_needs_is_refused_before_anything_runs(ball):
    from switching.kernel import loop as kernel

    ball.simulate(0.1, "RK45-jit", rtol=1e-6, output="events")
    compiled = ball.compiled_model()
    buffers = compiled.buffers(False)
    wf, wi, wb = compiled.workspace(3, ball.max_steps_per_instant)
    tol = ball.tolerance
    ints = np.array([2, 0, 3, ball.max_steps_per_instant, 0, 10**9, 0], dtype=np.int64)
    floats = np.array([0.0, 1.0, 0.0, 1e-6, 1e-9, np.inf, 0.0, tol.rtol, tol.atol, tol.jump_rtol, tol.jump_atol])
    args = (compiled.record, ints, floats, ball.initial_state(), np.zeros(0), buffers)
    status, n_saved, n_events, t, mode, steps, n_dense = kernel.run(*args, (wf[:-1], wi, wb), None)
    assert (status, n_saved, n_events, t, steps, n_dense) == (7, 0, 0, 0.0, 0, 0)
    status, *_ = kernel.run(*args, (wf, wi, wb), None)
    assert status == 0


# ------------------------------------------------ method="auto"


def test_auto_chooses_the_compiled_rk45_when_its_kernel_is_cached(ball):
    from switching.library.jit_model import choose_method, remembered_modes

    ball.simulate(2.5, "RK45-jit", rtol=1e-6, output="events")  # the kernel and the modes' functions, loaded here
    choice = choose_method(ball, 0.0, 2.5, 1e-6)
    covered = {ball.initial_mode, *ball.visited_modes, *remembered_modes(ball)}  # other tests' modes too
    reason = f"the kernel and the functions of its {len(covered)} mode(s) are compiled (cached)"
    assert (choice.method, choice.reason) == ("RK45-jit", reason)
    python = ball.simulate(2.5, "RK45", rtol=1e-6)
    auto = ball.simulate(2.5, "auto", rtol=1e-6)
    assert auto.stats["method"] == "RK45-jit" and auto.stats["steps"] == python.stats["steps"]
    assert auto.stats["method chosen by auto"] == "RK45-jit: " + reason
    np.testing.assert_allclose(auto.x, python.x, rtol=1e-10, atol=1e-10)


def test_auto_runs_python_until_compiling_pays(tmp_path, monkeypatch):
    """Without the kernel compiled, auto runs RK45 in Python and measures its
    speed; a later run expected to take longer than compiling is compiled.
    With the kernel compiled, only the modes' functions are to pay for.
    Without numba, or with inputs given as Python functions, it is RK45,
    and the stats say why."""
    import codegen.jit
    import switching.library.jit_model as jm
    from codegen.cache import SourceCache

    model = bouncing_ball.build()
    model.cache = SourceCache(tmp_path)
    monkeypatch.setattr(jm, "load_seconds", lambda: 0.0)  # (the compiled path loaded: its load is another test's)
    monkeypatch.setattr(jm, "kernel_compiled", lambda implicit=False: False)  # as on a new installation
    monkeypatch.setattr(jm, "mode_compiled", lambda model, mode: False)
    run = model.simulate(0.5, "auto")
    assert run.stats["method"] == "RK45"
    assert run.stats["method chosen by auto"] == ("RK45: the compiled kernel is not cached yet and this model's "
                                                  "Python speed is not known yet (this run measures it)")
    speed = model.cache.record(jm._speed_key(model))
    # the run's work, not its wall time: steps and instants per simulated second
    assert speed == {"steps": run.stats["steps"] / 0.5, "instants": len(run.events) / 0.5, "rtol": 1e-6}
    # ≈ 0.1 s per simulated second: steps at the model's price of a step
    model.cache.write_record(jm._speed_key(model), {"steps": 0.1 / jm.python_run_seconds(model, 1, 0),
                                                    "instants": 0.0, "rtol": 1e-6})
    cost = jm.KERNEL_COMPILE_SECONDS + 2 * jm.MODE_COMPILE_SECONDS  # the kernel and both modes (visited)
    short, long = (jm.choose_method(model, 0.0, f * cost / 0.1, 1e-6) for f in (0.5, 2.0))  # (0.5, 2)·cost
    assert short.method == "RK45" and short.reason == (
        f"a Python run is expected to take ≈ {0.5 * cost:.3g} s, less than compiling the kernel and the functions "
        f"of 2 mode(s) (≈ {cost:g} s)")
    assert long.method == "RK45-jit" and f"≈ {2 * cost:.3g} s, more than compiling" in long.reason
    tighter = jm.choose_method(model, 0.0, 0.5 * cost / 0.1, 1e-6 / 2**10)  # 4× the steps (steps ∝ rtol^(-1/5))
    assert tighter.method == "RK45-jit" and f"≈ {2 * cost:.3g} s" in tighter.reason
    monkeypatch.setattr(jm, "kernel_compiled", lambda implicit=False: True)
    modes_cost = 2 * jm.MODE_COMPILE_SECONDS
    choice = jm.choose_method(model, 0.0, 0.5 * modes_cost / 0.1, 1e-6)  # half of compiling 2 modes' functions
    assert choice.method == "RK45" and "less than compiling the functions of 2 mode(s)" in choice.reason
    model.cache.write_record(jm._speed_key(model), None)
    choice = jm.choose_method(model, 0.0, 10.0, 1e-6)
    assert (choice.method, choice.reason) == ("RK45-jit", "the kernel is cached; compiling the functions of 2 mode(s) "
                                              f"costs ≈ {2 * jm.MODE_COMPILE_SECONDS:g} s")
    with pytest.raises(SimulationError, match="give rtol/atol, not dt"):
        model.simulate(0.5, "auto", dt=0.01)
    driven = _driven_relay(lambda t: 1.0)
    choice = jm.choose_method(driven, 0.0, 1.0, 1e-6)
    assert choice.method == "RK45" and "'u' of model 'relay' are Python functions" in choice.reason
    monkeypatch.setattr(codegen.jit, "available", lambda: False)
    choice = jm.choose_method(model, 0.0, 200.0, 1e-6)
    assert (choice.method, choice.reason) == ("RK45", "numba is not installed (pip install '.[fast]' for the "
                                              "compiled path)")


def test_auto_s_choice_does_not_depend_on_the_machine_s_load(tmp_path, monkeypatch):
    """The record a Python run leaves for the next choice is its work (steps, instants), not its wall time:
    the same run on a machine a thousand times slower leaves the same record, and the next run of the same
    command takes the same engine (issue 45, item 10)."""
    import time

    import switching.library.jit_model as jm
    import switching.simulate.driver as driver
    from codegen.cache import SourceCache

    monkeypatch.setattr(jm, "load_seconds", lambda: 0.0)  # (the compiled path loaded)
    monkeypatch.setattr(jm, "kernel_compiled", lambda implicit=False: False)
    monkeypatch.setattr(jm, "mode_compiled", lambda model, mode: False)
    records, choices = [], []
    for slowdown in (1.0, 1000.0):
        model = bouncing_ball.build()
        model.cache = SourceCache(tmp_path / f"x{slowdown:g}")
        clock = time.perf_counter
        monkeypatch.setattr(driver._time, "perf_counter", lambda: clock() * slowdown)  # a loaded machine
        run = model.simulate(0.5, "auto")
        monkeypatch.setattr(driver._time, "perf_counter", clock)
        assert run.stats["method"] == "RK45"
        records.append(model.cache.record(jm._speed_key(model)))
        choices.append([(c.method, c.reason) for c in (jm.choose_method(model, 0.0, span, 1e-6)
                                                       for span in (1.0, 1e3, 1e5))])
    assert records[0] == records[1] and choices[0] == choices[1]
    assert [method for method, _ in choices[0]] == ["RK45", "RK45", "RK45-jit"]


def test_auto_measures_python_first_where_a_mode_is_costly_to_compile(tmp_path, monkeypatch):
    """A mode's function of a large scene takes seconds to compile (about 0.7 ms
    per generated line, ten lines per state or transition): with the Python
    speed unknown, auto runs Python first even with the kernel cached; with it
    known, every mode to compile is priced at that size."""
    import switching.library.jit_model as jm
    from codegen.cache import SourceCache
    from models import ball_chain

    assert jm.mode_compile_seconds(bouncing_ball.build()) == jm.MODE_COMPILE_SECONDS
    model = ball_chain.build(N=60, e=1.0)
    model.cache = SourceCache(tmp_path)
    monkeypatch.setattr(jm, "load_seconds", lambda: 0.0)  # (the compiled path loaded)
    monkeypatch.setattr(jm, "kernel_compiled", lambda implicit=False: True)
    monkeypatch.setattr(jm, "mode_compiled", lambda model, mode: False)
    per_mode = jm.mode_compile_seconds(model)
    assert per_mode == pytest.approx(jm.MODE_COMPILE_SECONDS_PER_ITEM * (120 + 2 * 59))
    choice = jm.choose_method(model, 0.0, 1.0, 1e-9)
    assert (choice.method, choice.reason) == ("RK45", f"compiling a mode's function of this model costs ≈ "
                                              f"{per_mode:.2g} s and its Python speed is not known yet (this run "
                                              "measures it)")
    model.cache.write_record(jm._speed_key(model), {"steps": 0.5 / jm.python_run_seconds(model, 1, 0),
                                                    "instants": 0.0, "rtol": 1e-9})
    assert jm.choose_method(model, 0.0, 1.0, 1e-9).method == "RK45"  # 0.5 s against ≈ 1.7 s for the initial mode
    assert jm.choose_method(model, 0.0, 100.0, 1e-9).method == "RK45-jit"


def test_auto_runs_python_where_loading_the_compiled_path_would_cost_more(tmp_path, monkeypatch):
    """Issue 46: a new process pays numba's import and the kernel's load before its first compiled run
    (≈ 0.3 s); auto runs Python where a run is expected to take less, until the Python runs it so chose
    would add up past that cost (then the path is loaded and pays for itself).  An RK45-jit run leaves the
    record of its work a Python RK45 run leaves (the same steps); a stiff initial mode is compiled anyway."""
    import switching.library.jit_model as jm
    from codegen.cache import SourceCache

    model = bouncing_ball.build()
    model.cache = SourceCache(tmp_path)
    monkeypatch.setattr(jm, "kernel_compiled", lambda implicit=False: True)
    monkeypatch.setattr(jm, "mode_compiled", lambda model, mode: True)
    monkeypatch.setitem(jm._PYTHON_INSTEAD, "seconds", 0.0)
    monkeypatch.setattr(jm, "load_seconds", lambda: 0.3)  # (a new process: nothing loaded)
    assert jm.choose_method(model, 0.0, 1.0, 1e-6).method == "RK45-jit"  # (its speed not known yet)
    monkeypatch.setattr(jm, "load_seconds", lambda: 0.0)
    compiled = model.simulate(2.0, "auto", rtol=1e-6)
    python = model.simulate(2.0, "RK45", rtol=1e-6)
    assert compiled.stats["method"] == "RK45-jit"
    assert model.cache.record(jm._speed_key(model)) == {"steps": python.stats["steps"] / 2.0,
                                                        "instants": len(python.events) / 2.0, "rtol": 1e-6}
    monkeypatch.setattr(jm, "python_run_seconds", lambda model, steps, instants: 0.11)  # (each run: 0.11 s)
    monkeypatch.setattr(jm, "load_seconds", lambda: 0.3)
    first = jm.choose_method(model, 0.0, 2.0, 1e-6)
    assert (first.method, first.reason) == ("RK45", "a Python run is expected to take ≈ 0.11 s, less than loading "
                                            "the compiled path into this process (≈ 0.3 s: numba's import and "
                                            "the kernel's load)")
    assert jm.choose_method(model, 0.0, 2.0, 1e-6).reason == first.reason  # (a choice alone adds nothing up)
    for _ in range(2):  # (0.11, then 0.22 s of Python runs made instead of the load)
        run = model.simulate(2.0, "auto", rtol=1e-6)
        assert run.stats["method"] == "RK45" and run.stats["method chosen by auto"] == "RK45: " + first.reason
    last = jm.choose_method(model, 0.0, 2.0, 1e-6)  # (0.33 s would pass the load's 0.3 s)
    assert last.method == "RK45-jit" and last.reason.startswith("the kernel and the functions of its")
    import switching.library.spectrum as spectrum

    monkeypatch.setitem(jm._PYTHON_INSTEAD, "seconds", 0.0)
    monkeypatch.setattr(spectrum, "mode_stiffness", lambda *args: spectrum.ModeStiffness(True, 1e6, "stiff here"))
    assert jm.choose_method(model, 0.0, 2.0, 1e-6).method == "RK45-jit"  # (stiff: compiled, whatever the load)


# ------------------------------------------------ the command line


def test_hbg_run_takes_every_compiled_method_with_its_default_output(tmp_path):
    """``hbg run MODEL --method RK45-jit`` with the CLI's default --samples
    (``samples=500``: from the kernel's dense output) writes the rows the plain RK45
    writes; the fixed-step compiled methods take --dt; --method auto is
    accepted and says what it chose."""
    import os
    import subprocess
    import sys

    def hbg(*args):
        done = subprocess.run([sys.executable, "-m", "models.cli", *args], capture_output=True, text=True,
                              timeout=600, env={**os.environ, "MPLBACKEND": "Agg"},
                              cwd=str(ROOT))
        assert done.returncode == 0, done.stderr
        return done.stdout

    rows = {}
    for method in ("RK45", "RK45-jit"):
        out = hbg("run", "bouncing-ball", "--t-end", "2", "--method", method, "--npz", str(tmp_path / f"{method}.npz"))
        assert f"method: {method}" in out
        rows[method] = np.load(tmp_path / f"{method}.npz")
    assert len(rows["RK45-jit"]["t"]) == len(rows["RK45"]["t"]) and len(rows["RK45"]["t"]) >= 500
    np.testing.assert_allclose(rows["RK45-jit"]["t"], rows["RK45"]["t"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(rows["RK45-jit"]["x"], rows["RK45"]["x"], rtol=1e-9, atol=1e-9)
    assert "method: rk4-jit" in hbg("run", "bouncing-ball", "--t-end", "1", "--method", "rk4-jit", "--dt", "0.01")
    assert "method chosen by auto: RK45" in hbg("run", "bouncing-ball", "--t-end", "1", "--method", "auto")


def test_read_only_arrays_run_compiled_as_writable_ones():
    """The kernel is called through its compiled entry point with fixed
    argument types: read-only initial states, output times and parameter
    arrays are copied into that type, not misread."""
    model = bouncing_ball.build()
    times = np.linspace(0.0, 1.5, 16)
    reference = model.simulate(1.5, "RK45-jit", t_eval=times, x0=model.initial_state())
    frozen_times, frozen_x0 = times.copy(), model.initial_state()
    frozen_times.setflags(write=False)
    frozen_x0.setflags(write=False)
    model.parameter_array.setflags(write=False)
    try:
        again = model.simulate(1.5, "RK45-jit", t_eval=frozen_times, x0=frozen_x0)
    finally:
        model.parameter_array.setflags(write=True)
    np.testing.assert_array_equal(again.t, reference.t)
    np.testing.assert_array_equal(again.x, reference.x)


def test_the_kernel_is_known_compiled_per_family_from_numba_s_disk_index(ball):
    """``kernel_compiled(implicit=…)`` tells the explicit specialisation of
    the kernel's run from the implicit one by the type of run's last
    argument, in this process or in numba's disk index (what ``auto`` and
    the CLI's notice price)."""
    from numba.core import types

    from codegen.numba_internals import cached_signatures
    from switching.library.jit_model import kernel, kernel_compiled

    ball.simulate(0.5, "RK45-jit", rtol=1e-6, output="events")
    assert kernel_compiled(implicit=False)
    on_disk = cached_signatures(kernel().run)
    assert any(isinstance(signature[-1], types.NoneType) for signature in on_disk)
    ball.simulate(0.5, "rodas-jit", rtol=1e-6, output="events")
    assert kernel_compiled(implicit=True)
    assert any(not isinstance(signature[-1], types.NoneType) for signature in cached_signatures(kernel().run))
