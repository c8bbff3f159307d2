"""Batches of one model in one kernel call (simulate_batch, simulate_many of a model): every run
equals ``model.simulate`` with the set's values, to the bit — the runs the batch call completes,
and those it leaves to simulate (Zeno behaviour, a mode not compiled yet, more instants than a
run's record holds, a value the model refuses)."""

import warnings

import numba
import numpy as np
import pytest

from bondgraph import ParameterValueError
from models import bouncing_ball, falling_rod
from switching import InitialStateProjected, simulate_batch, simulate_many
from switching.simulate.zeno import ZenoWatch
from switching.sweep.kernel_batch import FirstCallAnswered

# e and y0 such that the ball with v_rest = 0 accumulates (Zeno) before t_end in some runs, not in others
SETS = [{"e": e, "y0": y0} for e in (0.5, 0.8, 0.9) for y0 in (0.5, 1.0, 2.0)]
T_END = 2.0


def single(p, t_end=T_END, method="RK45-jit", **options):
    """``bouncing_ball.build(**p).simulate(...)``: its trajectory, or its error (carrying what it computed)."""
    try:
        return bouncing_ball.build(**p).simulate(t_end, method, **options), None
    except Exception as exc:  # noqa: BLE001 - the run's error is compared
        return getattr(exc, "trajectory", None), exc


@pytest.fixture(scope="module")
def ball():
    return bouncing_ball.build()


def assert_batch_is_simulate(batch, sets, t_end=T_END, method="RK45-jit", **options):
    for r, p in enumerate(sets):
        trajectory, error = single(p, t_end, method, **options)
        assert (batch.status[r] == "failed") == (error is not None), (p, batch.errors[r])
        if error is not None:
            assert batch.errors[r] == str(error)
            assert not batch.in_kernel[r]
        assert batch.t[r] == trajectory.t[-1]
        np.testing.assert_array_equal(batch.x[r], trajectory.x[-1])
        assert batch.modes[r] == trajectory.mode_labels[-1]
        assert batch.event_counts[r] == len(trajectory.event_times)
        np.testing.assert_array_equal(batch.event_times[r, :batch.event_counts[r]], trajectory.event_times)
        assert np.isnan(batch.event_times[r, batch.event_counts[r]:]).all()
        if error is None:
            assert batch.steps[r] == trajectory.stats["steps"]


def test_a_batch_gives_every_run_as_simulate_gives_it(ball):
    batch = simulate_batch(ball, SETS, T_END, "RK45-jit", rtol=1e-8)
    assert_batch_is_simulate(batch, SETS, rtol=1e-8, output="events")
    zeno = [r for r, s in enumerate(batch.status) if s == "failed"]
    assert zeno and len(zeno) < len(SETS)  # both kinds of run are in the grid
    assert all("Zeno" in batch.errors[r] for r in zeno)
    assert batch.in_kernel[[r for r in range(len(SETS)) if r not in zeno]].all()
    np.testing.assert_array_equal(batch.final("y"), batch.x[:, list(batch.state_names).index("y")])


def test_the_model_keeps_its_own_values_after_a_batch(ball):
    before = dict(ball.parameter_values), dict(ball.initial_parameters), ball.initial_state()
    simulate_batch(ball, SETS[:3], T_END, "RK45-jit")
    assert dict(ball.parameter_values) == before[0] and dict(ball.initial_parameters) == before[1]
    np.testing.assert_array_equal(ball.initial_state(), before[2])


def test_the_states_at_requested_times_are_simulate_s(ball):
    te = np.linspace(0.0, T_END, 21)
    batch = simulate_batch(ball, SETS, T_END, "RK45-jit", rtol=1e-9, t_eval=te)
    np.testing.assert_array_equal(batch.t_eval, te)
    for r, p in enumerate(SETS):
        trajectory, error = single(p, rtol=1e-9, t_eval=te)
        kept = np.isin(trajectory.t, te)
        np.testing.assert_array_equal(batch.samples[r, :kept.sum()], trajectory.x[kept])
        assert np.isnan(batch.samples[r, kept.sum():]).all() == (error is not None or kept.sum() == len(te))
    np.testing.assert_array_equal(batch.at_times("y"), batch.samples[:, :, list(batch.state_names).index("y")])


def test_runs_with_more_instants_than_their_record_holds_are_finished_by_simulate(ball):
    batch = simulate_batch(ball, SETS, T_END, "RK45-jit", event_capacity=2, on_zeno="stop")
    assert_batch_is_simulate(batch, SETS, on_zeno="stop", output="events")
    assert not batch.in_kernel[batch.event_counts > 2].any()
    assert {"stopped", "ok"} <= set(batch.status)


def test_a_mode_not_compiled_yet_is_met_by_simulate_and_then_compiled_for_the_runs_after():
    model = bouncing_ball.build()
    sets = [{"e": 0.8, "y0": 1.0}, {"e": 0.8, "y0": 1.0, "v_rest": 3.0}, {"e": 0.7, "y0": 1.5, "v_rest": 3.0}]
    batch = simulate_batch(model, sets, T_END, "RK45-jit", rtol=1e-8)
    assert batch.modes[1] == batch.modes[2] == "contact=rest"
    for r, p in enumerate(sets):
        trajectory, error = single(p, rtol=1e-8, output="events")
        assert error is None
        np.testing.assert_array_equal(batch.x[r], trajectory.x[-1])
        np.testing.assert_array_equal(batch.event_times[r, :batch.event_counts[r]], trajectory.event_times)


def test_a_set_the_model_refuses_fails_its_run_alone(ball):
    sets = [{"e": 0.8}, {"e": 0.8, "y_0": 1.0}, {"e": float("nan")}, {"e": 0.7}]
    batch = simulate_batch(ball, sets, 1.0, "RK45-jit")
    assert batch.status == ["ok", "failed", "failed", "ok"]
    assert "y_0" in batch.errors[1] and "y0" in batch.errors[1]  # the unknown name and the closest known one
    assert "nan" in batch.errors[2]
    assert np.isnan(batch.x[1]).all()


def test_the_runs_do_not_depend_on_the_threads_they_ran_on(ball):
    sets = [{"e": e, "y0": 1.0 + k / 10} for k, e in enumerate(np.linspace(0.7, 0.9, 12))]
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = simulate_batch(ball, sets, T_END, "RK45-jit", rtol=1e-8)
    finally:
        numba.set_num_threads(threads)
    many = simulate_batch(ball, sets, T_END, "RK45-jit", rtol=1e-8)
    np.testing.assert_array_equal(one.x, many.x)
    np.testing.assert_array_equal(one.event_times, many.event_times)


def test_a_batch_takes_a_compiled_method_of_one_kind_and_its_own_options(ball):
    for method in ("RK45", "auto", "Radau"):
        with pytest.raises(ParameterValueError, match="compiled kernel with one method"):
            simulate_batch(ball, SETS, T_END, method)
    for option in ({"x0": [1.0, 0.0]}, {"output": "steps"}, {"progress": print}, {"samples": 10}):
        with pytest.raises(ParameterValueError, match=next(iter(option))):
            simulate_batch(ball, SETS, T_END, "RK45-jit", **option)
    with pytest.raises(ParameterValueError, match="event_capacity"):
        simulate_batch(ball, SETS, T_END, "RK45-jit", event_capacity=0)
    with pytest.raises(ParameterValueError, match="HybridModel"):
        simulate_batch(bouncing_ball.build, SETS, T_END, "RK45-jit")
    with pytest.raises(ParameterValueError, match="not a dict"):
        simulate_batch(ball, [0.8], T_END, "RK45-jit")


def test_simulate_many_of_a_model_gives_simulate_s_trajectories_and_metrics(ball):
    def peak(trajectory):
        return {"bounces": len(trajectory.event_times), "v_end": float(trajectory.x[-1, 1])}

    for method in ("RK45-jit", "RK45"):
        results = simulate_many(ball, SETS, T_END, method, rtol=1e-8, metrics=peak)
        for p, result in zip(SETS, results):
            trajectory, error = single(p, method=method, rtol=1e-8)
            assert result.parameters == p
            assert (error is None) == result.ok
            np.testing.assert_array_equal(result.t, trajectory.t)
            np.testing.assert_array_equal(result.x, trajectory.x)
            assert result.modes == trajectory.mode_labels
            np.testing.assert_array_equal(result.event_times, trajectory.event_times)
            if result.ok:
                assert result.metrics == peak(trajectory)
            else:
                assert result.error == str(error)
    with pytest.raises(ParameterValueError, match="workers"):
        simulate_many(ball, SETS, T_END, "RK45-jit", workers=2)


def test_a_batch_of_the_falling_rod_meets_its_sticking_and_sliding_modes_as_simulate_does():
    model = falling_rod.build()
    sets = [{"mu": mu} for mu in (0.001, 0.005, 0.3)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InitialStateProjected)
        batch = simulate_batch(model, sets, 0.5, "RK45-jit", rtol=1e-9, atol=1e-12)
        for r, p in enumerate(sets):
            trajectory = falling_rod.build(**p).simulate(0.5, "RK45-jit", rtol=1e-9, atol=1e-12, output="events")
            np.testing.assert_array_equal(batch.x[r], trajectory.x[-1])
            np.testing.assert_array_equal(batch.event_times[r, :batch.event_counts[r]], trajectory.event_times)
            assert batch.modes[r] == trajectory.mode_labels[-1]


@pytest.mark.slow
def test_an_implicit_batch_is_simulate_s_too(ball):
    batch = simulate_batch(ball, SETS, T_END, "rodas-jit", rtol=1e-8)
    assert_batch_is_simulate(batch, SETS, method="rodas-jit", rtol=1e-8, output="events")


def test_the_zeno_test_of_many_runs_is_the_watch_s_test():
    rng = np.random.default_rng(7)
    rows, counts, skip, expected = [], [], [], []
    for k in range(300):
        count = int(rng.integers(0, 12))
        gaps = 10.0 ** rng.uniform(-12, 0, count)
        times = np.cumsum(gaps) + rng.uniform(0, 5)
        if k % 7 == 0 and count > 2:
            times[2] = times[1]  # a repeated instant
        first = int(rng.integers(0, 2)) if count else 0
        watch = ZenoWatch(8, 10.0, 1e-9)
        expected.append(watch.quiet(times[first:].tolist()))
        rows.append(np.pad(times, (0, 12 - count), constant_values=np.nan))
        counts.append(count)
        skip.append(first)
    quiet = ZenoWatch(8, 10.0, 1e-9).quiet_rows(np.array(rows), np.array(counts), np.array(skip))
    np.testing.assert_array_equal(quiet, expected)
    assert 0 < sum(expected) < len(expected)


def test_a_replay_refuses_a_first_call_other_than_its_batch_call(ball):
    answered = FirstCallAnswered(None, object(), {"kind": 2, "mode": None, "t": 0.0, "t_end": 1.0, "save": 0,
                                                  "max_steps": 10, "x": np.zeros(2)})
    with pytest.raises(RuntimeError, match="a bug"):
        answered.run(kind=2, mode=None, t=0.0, t_end=2.0, save=0, max_steps=10, x=np.zeros(2))


def test_a_batch_s_frame_has_the_columns_of_a_sweep_s(ball):
    pd = pytest.importorskip("pandas")
    from switching import to_frame

    batch = simulate_batch(ball, SETS, T_END, "RK45-jit", rtol=1e-8)
    frame = to_frame(batch)
    swept = to_frame(simulate_many(ball, SETS, T_END, "RK45-jit", rtol=1e-8, output="events"))
    pd.testing.assert_frame_equal(frame, swept.drop(columns="wall_time"), check_dtype=False)


def test_a_set_may_give_initial_states_by_name_as_simulate_s_x0(ball):
    sets = [{"y": 1.5}, {"y": 0.8, "p": 2.0, "e": 0.7}, {"p": -1.0}]
    batch = simulate_batch(ball, sets, T_END, "RK45-jit", rtol=1e-8)
    names = list(ball.state_names)
    for r, p in enumerate(sets):
        values = {k: v for k, v in p.items() if k not in names}
        model = bouncing_ball.build(**values)
        x0 = model.initial_state()
        for name in set(p) & set(names):
            x0[names.index(name)] = p[name]
        trajectory = model.simulate(T_END, "RK45-jit", rtol=1e-8, x0=x0, output="events")
        np.testing.assert_array_equal(batch.x[r], trajectory.x[-1])
        np.testing.assert_array_equal(batch.event_times[r, :batch.event_counts[r]], trajectory.event_times)
    assert batch.in_kernel[1:].all()
    bad = simulate_batch(ball, [{"y": float("inf")}], T_END, "RK45-jit")
    assert bad.status == ["failed"] and "x0" in bad.errors[0]


def test_a_boost_converter_batch_over_duty_load_and_initial_voltage_is_simulate_s():
    from models import boost_converter

    sets = [{"D": d, "R_load": r, "v_C0": v} for d in (0.3, 0.7) for r in (5.0, 20.0) for v in (0.0, 12.0)]
    for method, options in (("RK45-jit", {"rtol": 1e-8}), ("rk4-jit", {"dt": 2e-7})):
        batch = simulate_batch(boost_converter.build(), sets, 5e-4, method, **options)
        for r, p in enumerate(sets):
            trajectory = boost_converter.build(**p).simulate(5e-4, method, output="events", **options)
            np.testing.assert_array_equal(batch.x[r], trajectory.x[-1])
            np.testing.assert_array_equal(batch.event_times[r, :batch.event_counts[r]], trajectory.event_times)
        assert batch.in_kernel[1:].all() and (batch.event_counts == 10).all()


def test_hbg_sweep_batch_writes_the_rows_of_simulate_s_runs(tmp_path, capsys):
    pd = pytest.importorskip("pandas")
    from models import cli

    csv = tmp_path / "grid.csv"
    code = cli.main(["sweep", "bouncing-ball", "--grid", "e=0.7:0.9:3", "--grid", "y0=1,2", "--set", "v_rest=0.1",
                     "--t-end", "2", "--method", "RK45-jit", "--batch", "--csv", str(csv), "--metric", "max:v"])
    out = capsys.readouterr().out
    assert code == 0 and "this process, kernel calls in batches" in out and "6 ok" in out
    frame = pd.read_csv(csv)
    assert list(frame["v_rest"]) == [0.1] * 6
    for _, row in frame.iterrows():
        trajectory = bouncing_ball.build(e=row["e"], y0=row["y0"], v_rest=0.1).simulate(2.0, "RK45-jit", rtol=1e-8)
        assert row["events"] == len(trajectory.event_times)
        assert row["final_y"] == trajectory.x[-1, list(trajectory.state_names).index("y")]
        assert row["max:v"] == trajectory.signal("v").max()
    assert cli.main(["sweep", "ball-chain", "--grid", "N=2,3", "--batch", "--csv", str(csv)]) != 0
    assert "--batch: N is not a parameter or a state" in capsys.readouterr().err


@pytest.mark.skipif(not hasattr(__import__("os"), "fork"), reason="os.fork: POSIX only")
def test_a_process_forked_after_a_batch_runs_its_own_batches(ball):
    import os
    import pickle

    sets = [{"e": e} for e in (0.7, 0.75, 0.8, 0.85)]
    here = simulate_batch(ball, sets, T_END, "RK45-jit", rtol=1e-8)  # (numba's thread pool has run here)
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: GNU OpenMP's pool would terminate it; its batch runs on one thread
        try:
            there = simulate_batch(ball, sets, T_END, "RK45-jit", rtol=1e-8)
            os.write(write, pickle.dumps((there.x, there.event_times)))
        finally:
            os._exit(0)
    os.close(write)
    with os.fdopen(read, "rb") as pipe:
        received = pipe.read()
    _, status = os.waitpid(pid, 0)
    assert status == 0 and received, "the forked process's batch did not finish"
    x, times = pickle.loads(received)
    np.testing.assert_array_equal(x, here.x)
    np.testing.assert_array_equal(times, here.event_times)


def test_a_batch_s_arrays_are_read_by_state_name(ball):
    from bondgraph.errors import UnknownNameError

    batch = simulate_batch(ball, SETS[:2], T_END, "RK45-jit")
    with pytest.raises(UnknownNameError, match="no state 'v'.*p, y"):
        batch.final("v")
    with pytest.raises(ParameterValueError, match="t_eval"):
        batch.at_times("y")


def test_a_new_process_loads_the_batch_from_the_caches_and_gives_the_same_runs(ball):
    import json
    import subprocess
    import sys
    from pathlib import Path

    sets = [{"e": e, "y0": 1.0 + e} for e in (0.6, 0.7, 0.8)]
    here = simulate_batch(ball, sets, T_END, "RK45-jit", rtol=1e-8)  # (compiled or loaded here: cached)
    code = ("import json; from models import bouncing_ball; from switching import simulate_batch; "
            f"b = simulate_batch(bouncing_ball.build(), {sets!r}, {T_END!r}, 'RK45-jit', rtol=1e-8); "
            "print(json.dumps([b.x.tolist(), b.event_times.tolist(), b.in_kernel.tolist()]))")
    done = subprocess.run([sys.executable, "-c", code], cwd=Path(__file__).resolve().parents[3], capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    x, times, in_kernel = json.loads(done.stdout.strip().splitlines()[-1])
    np.testing.assert_array_equal(np.array(x), here.x)
    np.testing.assert_array_equal(np.array(times), here.event_times)
    assert all(in_kernel[1:])
