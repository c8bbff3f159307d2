"""The options of a run (issue 32): no option can make a run spin, and an
option of the wrong kind is named before anything runs.

* A step that cannot advance ``t`` in floating point, options implying more
  steps (or guard tests, or sample memory) than ``max_steps`` allows, are
  refused up front — by the Python and the compiled methods alike, the
  compiled ones without compiling anything — and ``hbg run`` refuses them as
  usage errors (exit 2).
* ``max_steps`` is also a running count: a run taking more steps stops with
  :class:`StepLimitError`, its partial trajectory attached.
* Every option of the wrong kind or out of its bounds raises an error of the
  toolkit's hierarchy (:class:`OptionTypeError`, also a ``TypeError``;
  :class:`OptionValueError`, also a ``ValueError``) naming the option and the
  value, before any mode is derived.

Every case has a timeout: a regression that spins fails instead of hanging.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from bondgraph.errors import HybridBondGraphError
from models import bouncing_ball, cli, diode_circuit, two_tanks
from switching.errors import (OptionError, OptionTypeError, OptionValueError, SimulationError, StepLimitError,
                              StepSizeError, WorkLimitError)
from switching.simulate.run_options import DEFAULT_MAX_STEPS, MAX_OUTPUT_BYTES

pytestmark = pytest.mark.timeout(30)


@pytest.fixture
def ball():
    return bouncing_ball.build()


def no_compiling(model, monkeypatch, method="RK45-jit"):
    """For a compiled ``method``, make any compilation of ``model`` fail the
    test: a refusal up front needs none (a Python method is checked by
    :func:`refused`: nothing derived)."""
    if not method.endswith("-jit"):
        return

    def compiles(*args, **kwargs):
        raise AssertionError("the run compiled code before refusing its options")

    monkeypatch.setattr(model, "compiled_mode", compiles)
    monkeypatch.setattr(model, "compiled_model", compiles)


def refused(model, t_end, method, cls=WorkLimitError, **options):
    """The error ``model.simulate`` raises at once (within 2 s, nothing derived) for these options."""
    started = time.perf_counter()
    with pytest.raises(cls) as info:
        model.simulate(t_end, method, **options)
    assert time.perf_counter() - started < 2.0
    assert model.derivation_count == 0, "refused only after deriving modes"
    error = info.value
    assert isinstance(error, OptionError) and isinstance(error, SimulationError)
    assert isinstance(error, HybridBondGraphError) and error.trajectory is None
    return error


# ------------------------------------------------------------------ 2. runs that spin


@pytest.mark.parametrize("method", ["RK45", "LSODA", "RK45-jit"])
def test_a_max_step_below_the_resolution_of_t_is_refused_at_once(ball, monkeypatch, method):
    no_compiling(ball, monkeypatch, method)
    error = refused(ball, 1.0, method, max_step=1e-300)
    assert error.option == "max_step" and error.value == 1e-300
    assert "max_step = 1e-300 s is too small" in str(error) and "give max_step ≥ 2.22e-15 s" in str(error)


@pytest.mark.parametrize("method", ["euler", "rk4", "euler-jit", "rk4-jit"])
def test_a_step_of_1e_300_is_refused_at_once(ball, monkeypatch, method):
    no_compiling(ball, monkeypatch, method)
    error = refused(ball, 1.0, method, dt=1e-300)
    assert error.option == "dt" and error.value == 1e-300
    assert "dt = 1e-300 s is too small" in str(error) and "t + dt == t" in str(error)


@pytest.mark.parametrize("method", ["euler", "rk4", "euler-jit", "rk4-jit"])
def test_a_fixed_step_below_the_resolution_of_t_is_refused_like_spice(ball, monkeypatch, method):
    """t0 = 1e8 s, dt = 1e-9 s: t + dt == t (one ulp of 1e8 is 1.49e-8 s), though
    the run is only 1e6 steps long."""
    no_compiling(ball, monkeypatch, method)
    assert 1e8 + 1e-9 == 1e8
    error = refused(ball, 1e8 + 1e-3, method, dt=1e-9, t0=1e8)
    assert error.option == "dt" and error.limit == math.ulp(1e8 + 1e-3)
    message = str(error)
    assert "dt = 1e-09 s is too small" in message and "near 1e+08 s" in message and "t + dt == t" in message
    assert "give dt ≥ 1.49e-08 s" in message and "count time from nearer 0" in message


def test_a_step_just_above_the_resolution_of_t_runs():
    model = diode_circuit.build()
    trajectory = model.simulate(1e8 + 1e-6, "euler", dt=2e-8, t0=1e8, output="events")
    assert trajectory.t[-1] == 1e8 + 1e-6 and trajectory.stats["steps"] == 67


@pytest.mark.parametrize("method, options, option, steps", [
    ("euler", dict(dt=1e-9), "dt", "1e+10 steps"),
    ("rk4-jit", dict(dt=1e-9), "dt", "1e+10 steps"),
    ("RK45", dict(max_step=1e-9), "max_step", "1e+10 steps"),
    ("RK45-jit", dict(max_step=1e-9), "max_step", "1e+10 steps"),
    ("euler", dict(dt=0.01, max_steps=100), "dt", "250 steps"),
])
def test_options_implying_more_steps_than_max_steps_are_refused_with_the_figure(ball, monkeypatch, method, options,
                                                                               option, steps):
    no_compiling(ball, monkeypatch, method)
    error = refused(ball, 2.5 if "max_steps" in options else 10.0, method, **options)
    limit = options.get("max_steps", DEFAULT_MAX_STEPS)
    assert error.option == option and error.limit == limit
    message = str(error)
    assert f"{option} = {options[option]!r} s needs {steps}" in message and f"max_steps = {limit}" in message
    assert f"give {option} ≥" in message and "raise max_steps" in message


@pytest.mark.parametrize("method", ["RK45", "euler", "RK45-jit"])
def test_a_billion_guard_samples_per_step_are_refused(ball, monkeypatch, method):
    no_compiling(ball, monkeypatch, method)
    error = refused(ball, 1.0, method, OptionValueError, event_samples=10**9,
                    **({"dt": 0.01} if method == "euler" else {}))
    assert error.option == "event_samples" and error.value == 10**9
    assert "event_samples must be a whole number of guard samples per step ≥ 0 and ≤ 1000, got 1000000000" \
        in str(error)


def test_guard_tests_the_options_imply_are_bounded(ball):
    error = refused(ball, 1.0, "rk4", dt=1e-6, event_samples=100)
    assert error.option == "event_samples" and error.figure == pytest.approx(1.01e8)
    assert "1.01e+08 guard tests" in str(error) and "lower event_samples" in str(error)
    ball.simulate(1.0, "rk4", dt=1e-3, event_samples=100, output="events")  # 1e5 guard tests: fine


def test_sample_times_beyond_the_memory_cap_are_refused_with_the_memory_they_need(ball):
    t_eval = np.broadcast_to(np.float64(0.5), (10**8,))  # 1e8 sample times in 8 bytes
    error = refused(ball, 1.0, "RK45", t_eval=t_eval)
    assert error.option == "t_eval" and error.figure == 10**8 * 2 * 8 and error.limit == MAX_OUTPUT_BYTES
    assert "100000000 sample times × 2 states × 8 bytes = 1.49 GiB" in str(error) and "1 GiB" in str(error)


def test_a_run_taking_more_steps_than_max_steps_stops_with_its_partial_trajectory(ball):
    with pytest.raises(StepLimitError) as info:
        ball.simulate(2.5, "RK45", max_steps=10)
    error = info.value
    assert isinstance(error, SimulationError) and error.max_steps == 10
    assert "the run took max_steps = 10 steps and reached only t = " in str(error) and "raise max_steps" in str(error)
    partial = error.trajectory
    assert 0 < error.t < 2.5 and partial.t[-1] == error.t and np.all(np.diff(partial.t) >= 0)
    assert len(partial.events) >= 1  # the bounce before the limit is kept
    whole = ball.simulate(2.5, "RK45")
    assert whole.stats["steps"] > 10
    np.testing.assert_array_equal(partial.t[:5], whole.t[:5])  # the same run up to the limit


def test_a_fixed_step_run_taking_more_steps_than_max_steps_stops(ball):
    """rk4 with dt = 0.01 s over 2.5 s: 250 steps up front, 253 with the restarts after the bounces."""
    assert ball.simulate(2.5, "rk4", dt=0.01, output="events").stats["steps"] == 253
    with pytest.raises(StepLimitError) as info:
        ball.simulate(2.5, "rk4", dt=0.01, max_steps=251)
    assert info.value.max_steps == 251 and 2.4 < info.value.t < 2.5
    assert info.value.trajectory.t[-1] == info.value.t


def test_a_run_within_max_steps_is_untouched(ball):
    steps = ball.simulate(2.5, "RK45").stats["steps"]
    assert ball.simulate(2.5, "RK45", max_steps=steps).stats["steps"] == steps


def test_a_collapsing_step_stops_with_its_partial_trajectory():
    """At t0 = 1e15 s a step cannot be below 1.25 s: the tanks' fast mode needs less."""
    model = two_tanks.build()
    with pytest.raises(StepSizeError) as info:
        model.simulate(1e15 + 1000, "RK45", t0=1e15, rtol=1e-8)
    assert "step size collapsed" in str(info.value) and len(info.value.trajectory.t) > 1


@pytest.mark.parametrize("method", ["BDF", "Radau"])
def test_the_advice_after_a_collapsed_step_never_names_the_method_that_failed(method):
    model = two_tanks.build()
    with pytest.raises(StepSizeError) as info:
        model.simulate(1e15 + 1000, method, t0=1e15, rtol=1e-8)
    message = str(info.value)
    assert message.startswith(f"{method} failed")
    advice = message.split("try method=", 1)[1].split(")")[0]
    assert f"'{method}'" not in advice and "'LSODA'" in advice


@pytest.mark.slow
@pytest.mark.timeout(300)
@pytest.mark.parametrize("method, options, limit", [("RK45-jit", {}, 20), ("rk4-jit", dict(dt=0.01), 251)])
def test_the_compiled_kernel_honours_max_steps_as_a_running_count(ball, method, options, limit):
    whole = ball.simulate(2.5, method, **options)
    assert whole.stats["steps"] > limit
    with pytest.raises(StepLimitError) as info:
        ball.simulate(2.5, method, max_steps=limit, **options)
    error = info.value
    assert error.max_steps == limit and f"max_steps = {limit} steps" in str(error)
    assert 0 < error.t < 2.5 and error.trajectory.t[-1] == error.t
    n = len(error.trajectory.t) - 1
    np.testing.assert_array_equal(error.trajectory.t[:n], whole.t[:n])


# ------------------------------------------------------------------ 3. options of the wrong kind


WRONG = [
    # (method, option, value, class, words in the message)
    ("euler", "dt", "0.1", OptionTypeError, "dt must be a positive finite number of seconds, got '0.1'"),
    ("euler", "dt", True, OptionTypeError, "got True (True and False are not numbers)"),
    ("RK45", "rtol", "1e-6", OptionTypeError, "rtol must be a positive finite number, got '1e-6'"),
    ("RK45", "atol", "1e-9", OptionTypeError, "atol must be a positive finite number of the states' units"),
    ("RK45", "first_step", "0.01", OptionTypeError, "first_step must be a positive finite number of seconds"),
    ("RK45", "max_step", "1", OptionTypeError, "max_step must be a positive number of seconds (inf for no limit)"),
    ("RK45", "x0", ["1.0", "0"], OptionTypeError, "x0[0] = '1.0' is not a number; x0 needs one number per state"),
    ("RK45", "x0", np.array(["1.0", "0"]), OptionTypeError, "x0 must hold numbers, one per state (p, y)"),
    ("RK45", "x0", [True, 0.0], OptionTypeError, "x0[0] = True is not a number"),
    ("RK45", "t_eval", ["0.5"], OptionTypeError, "t_eval[0] = '0.5' is not a number of seconds"),
    ("RK45", "t0", True, OptionTypeError, "t0 must be a finite number of seconds, got True"),
    ("RK45", "keep_instants", "yes", OptionTypeError, "keep_instants must be True or False, got 'yes'"),
    ("RK45", "stiffness_check", "no", OptionTypeError, "stiffness_check must be True or False, got 'no'"),
    ("RK45", "zeno_window", 0, OptionValueError, "zeno_window must be a whole number of gap ratios ≥ 2"),
    ("RK45", "zeno_window", math.nan, OptionTypeError, "zeno_window must be a whole number"),
    ("RK45", "zeno_window", 10**9, OptionValueError, "≤ 1000, got 1000000000"),
    ("RK45", "zeno_min_gap", -1.0, OptionValueError, "zeno_min_gap must be a number ≥ 0 of seconds, got -1.0"),
    ("RK45", "zeno_min_gap", math.nan, OptionValueError, "zeno_min_gap must be a number ≥ 0 of seconds, got nan"),
    ("RK45", "event_samples", -1, OptionValueError, "event_samples must be a whole number"),
    ("RK45", "event_samples", 2.5, OptionTypeError, "event_samples must be a whole number"),
    ("RK45", "event_samples", True, OptionTypeError, "True and False are not numbers"),
    ("RK45", "max_events", 0, OptionValueError, "max_events must be a whole number of instants ≥ 1, got 0"),
    ("RK45", "max_events", -3, OptionValueError, "max_events must be a whole number of instants ≥ 1, got -3"),
    ("RK45", "max_events", 10.5, OptionTypeError, "max_events must be a whole number of instants ≥ 1, got 10.5"),
    ("RK45", "max_steps", 0, OptionValueError, "max_steps must be a whole number of steps ≥ 1, got 0"),
    ("RK45", "max_steps", 1e7, OptionTypeError, "max_steps must be a whole number of steps ≥ 1, got 10000000.0"),
    ("RK45", "progress", "yes", OptionTypeError, "progress must be None, True (a progress bar on stderr) or a "
     "function of the time [s]"),
    ("RK45", "progress", 1, OptionTypeError,
     "progress must be None, True (a progress bar on stderr) or a function of the time [s] (called as progress(t)), "
     "got 1"),
    ("RK45", "on_zeno", "ignore", OptionValueError, "on_zeno must be 'raise' or 'stop', got 'ignore'"),
    ("RK45", "output", 3, OptionTypeError, "output must be 'steps' or 'events', got 3"),
]


@pytest.mark.parametrize("method, option, value, cls, words", WRONG,
                         ids=[f"{option}={value!r}" for _, option, value, _, _ in WRONG])
def test_an_option_of_the_wrong_kind_or_out_of_bounds_is_named_before_anything_runs(ball, method, option, value,
                                                                                   cls, words):
    options = {option: value}
    if method == "euler" and option != "dt":
        options["dt"] = 0.01
    error = refused(ball, 1.0, method, cls, **options)
    assert isinstance(error, TypeError if cls is OptionTypeError else ValueError)
    assert error.option == option and words in str(error)


def test_a_method_that_is_not_text_is_named(ball):
    error = refused(ball, 1.0, 45, OptionTypeError)
    assert error.option == "method" and "unknown method 45; choose one of: euler, rk4" in str(error)


def test_sensitivity_tolerances_without_sensitivities_are_named(ball):
    error = refused(ball, 1.0, "RK45", OptionTypeError, sensitivity_rtol=1e-8)
    assert error.option == "sensitivity_rtol" and "give sensitivities=[...] too" in str(error)
    error = refused(ball, 1.0, "RK45", OptionTypeError, sensitivity_atol=1e-8)
    assert error.option == "sensitivity_atol"


@pytest.mark.parametrize("option, value, cls", [("sensitivity_rtol", "1e-8", OptionTypeError),
                                                ("sensitivity_atol", -1.0, OptionValueError)])
def test_sensitivity_tolerances_of_the_wrong_kind_are_named(ball, option, value, cls):
    error = refused(ball, 1.0, "RK45", cls, sensitivities=["e"], **{option: value})
    assert error.option == option and repr(value) in str(error)


def test_numpy_scalars_are_numbers():
    model = bouncing_ball.build()
    fixed = model.simulate(np.float32(1.0), "rk4", dt=np.float32(0.01), t0=np.int64(0), x0=np.array([0, 1]),
                           event_samples=np.int64(2), max_events=np.int32(100), max_steps=np.int64(1000),
                           zeno_window=np.int16(4), zeno_min_gap=np.float64(0.0), keep_instants=np.bool_(True),
                           stiffness_check=np.bool_(False), output="events")
    assert fixed.t[-1] == pytest.approx(1.0)
    adaptive = model.simulate(1.0, "RK45", rtol=np.float64(1e-6), atol=np.float32(1e-9), max_step=np.float64(0.5),
                              first_step=np.float16(0.01), t_eval=np.array([0, 1], dtype=np.int64),
                              progress=lambda t: None)
    assert adaptive.t[0] == 0.0 and adaptive.t[-1] == 1.0
    assert 0.5 in model.simulate(1.0, "RK45", t_eval=np.float64(0.5)).t  # one time, as a scalar


# ------------------------------------------------------------------ hbg run


def hbg(capsys, *args):
    """``hbg args`` in this process: (exit status, stdout, stderr)."""
    status = cli.main([str(a) for a in args])
    out = capsys.readouterr()
    assert "Traceback" not in out.err
    return status, out.out, out.err


@pytest.fixture
def nothing_compiles(monkeypatch):
    """The CLI's model compiles nothing (a refusal up front needs no kernel)."""
    from switching import HybridModel

    def compiles(*args, **kwargs):
        raise AssertionError("the run compiled code before refusing its options")

    monkeypatch.setattr(HybridModel, "compiled_mode", compiles)
    monkeypatch.setattr(HybridModel, "compiled_model", compiles)


@pytest.mark.parametrize("method", ["euler", "rk4-jit"])
def test_hbg_refuses_a_step_below_the_resolution_of_t_as_a_usage_error(capsys, request, method):
    if method.endswith("-jit"):
        request.getfixturevalue("nothing_compiles")
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--method", method, "--dt", "1e-300")
    assert status == cli.EXIT_USAGE
    assert "hbg: error: --dt: dt = 1e-300 s is too small" in err and "t + dt == t" in err
    assert out == ""


def test_hbg_refuses_a_step_needing_more_than_max_steps_and_names_the_flag(capsys):
    status, _, err = hbg(capsys, "run", "bouncing-ball", "--method", "euler", "--dt", "1e-9")
    assert status == cli.EXIT_USAGE
    assert "--dt: dt = 1e-09 s needs 2.5e+09 steps" in err and "max_steps = 10000000" in err
    status, _, err = hbg(capsys, "run", "bouncing-ball", "--method", "euler", "--dt", "0.01", "--max-steps", "100")
    assert status == cli.EXIT_USAGE and "needs 250 steps" in err and "max_steps = 100" in err


def test_hbg_sweep_refuses_a_step_no_run_could_take_before_starting_any(capsys, tmp_path):
    status, out, err = hbg(capsys, "sweep", "bouncing-ball", "--grid", "e=0.5,0.6", "--method", "euler",
                           "--dt", "1e-300", "--csv", tmp_path / "sweep.csv")
    assert status == cli.EXIT_USAGE and "--dt: dt = 1e-300 s is too small" in err
    assert "sweep of" not in out and not (tmp_path / "sweep.csv").exists()


def test_hbg_refuses_sample_times_beyond_the_memory_cap_before_making_them(capsys):
    status, _, err = hbg(capsys, "run", "bouncing-ball", "--samples", "1000000000")
    assert status == cli.EXIT_USAGE
    assert "--samples asks for 1000000000 sample times × 2 states × 8 bytes = 14.9 GiB" in err


@pytest.mark.parametrize("value", ["0", "-5"])
def test_hbg_max_steps_must_be_positive(capsys, value):
    status, _, err = hbg(capsys, "run", "bouncing-ball", "--max-steps", value)
    assert status == cli.EXIT_USAGE
    assert f"--max-steps: max_steps must be a whole number of steps ≥ 1, got {value}" in err


def test_hbg_max_steps_stops_a_run_and_saves_its_partial_run(capsys, tmp_path):
    data = tmp_path / "ball.csv"
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--max-steps", "8", "--samples", "0", "--csv", data)
    assert status == cli.EXIT_FAILED
    assert "the run took max_steps = 8 steps" in err and "the files hold the partial run up to t = " in err
    assert "partial trajectory" in out and data.stat().st_size > 0
