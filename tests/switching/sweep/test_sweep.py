"""Sweeps on Dask: results in input order and equal to serial runs, a worker
killed mid-sweep loses no run, failures stay with their run, metrics are
computed in the workers, the table and its plot, and ``hbg sweep`` end to end."""

import csv
import os
import signal
import threading
import time
from functools import partial
from pathlib import Path

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")
pd = pytest.importorskip("pandas")

from models import bouncing_ball  # noqa: E402
from models.cli import main  # noqa: E402
from switching import SignalMetrics, SweepInterrupted, parameter_grid, plot_sweep, simulate_many, to_frame  # noqa: E402

pytestmark = pytest.mark.timeout(120)

BALL = {"rtol": 1e-8}


@pytest.fixture(scope="module")
def client():
    """Two local worker processes, one thread each, shared by this module's tests."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster, set_as_default=False) as connection:  # used as given, not as default
            yield connection


def assert_same_runs(results, serial):
    assert [r.parameters for r in results] == [r.parameters for r in serial]
    for r, s in zip(results, serial):
        assert (r.status, r.error_type) == (s.status, s.error_type), r.error
        np.testing.assert_array_equal(r.t, s.t)
        np.testing.assert_array_equal(r.x, s.x)
        np.testing.assert_array_equal(r.event_times, s.event_times)
        assert r.modes == s.modes and r.instants == s.instants


# ------------------------------------------------------------------ a worker lost mid-sweep


def build_or_hang(victim, pid_file, **parameters):
    """``bouncing_ball.build``, except that the first attempt at ``victim``
    writes its process id to ``pid_file`` and waits there to be killed."""
    if parameters == victim and not os.path.exists(pid_file):
        Path(pid_file + ".tmp").write_text(str(os.getpid()))
        os.replace(pid_file + ".tmp", pid_file)
        time.sleep(60)
    return bouncing_ball.build(**parameters)


def kill_when_waiting(pid_file, killed):
    deadline = time.monotonic() + 60
    while not os.path.exists(pid_file) and time.monotonic() < deadline:
        time.sleep(0.01)
    pid = int(Path(pid_file).read_text())
    os.kill(pid, signal.SIGKILL)
    killed.append(pid)


def test_a_worker_killed_mid_sweep_has_its_runs_rerun_and_every_result_equals_serial_runs(tmp_path):
    sets = [{"e": float(e), "y0": y0} for e in np.linspace(0.8, 0.95, 8) for y0 in (1.0, 1.5)]
    victim, pid_file, killed = sets[9], str(tmp_path / "victim.pid"), []
    killer = threading.Thread(target=kill_when_waiting, args=(pid_file, killed), daemon=True)
    killer.start()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as connection:
        before = set(connection.run(os.getpid).values())
        results = simulate_many(partial(build_or_hang, victim, pid_file), sets, 2.5, "RK45", client=connection,
                                batch_size=2, **BALL)
        after = set(connection.run(os.getpid).values())
    killer.join(5)
    assert killed and killed[0] in before and killed[0] not in after  # a worker of the sweep died in a task
    with pytest.raises(ProcessLookupError):
        os.kill(killed[0], 0)
    assert all(r.ok for r in results)
    assert_same_runs(results, simulate_many(bouncing_ball.build, sets, 2.5, "RK45", client="serial", **BALL))


# ------------------------------------------------------------------ order, failures, metrics


def test_results_come_back_in_input_order_whatever_order_tasks_finish(client):
    # long runs (large y0: more bounces) first, one run per task: later tasks finish first
    sets = [{"y0": y0, "e": 0.9} for y0 in (8.0, 6.0, 0.5, 4.0, 0.3, 2.0, 0.2, 1.0)]
    results = simulate_many(bouncing_ball.build, sets, 4.0, "RK45", client=client, batch_size=1, **BALL)
    assert [r.parameters for r in results] == sets
    assert_same_runs(results, simulate_many(bouncing_ball.build, sets, 4.0, "RK45", client="serial", **BALL))


def test_a_failing_run_keeps_its_error_and_partial_run_while_the_others_succeed(client):
    # e = 0.5 runs into Zeno behaviour near t = 1.35 s; v_res is no parameter of the ball
    sets = [{"e": 0.8}, {"e": 0.5}, {"v_res": 1.0}, {"e": 0.9}]
    results = simulate_many(bouncing_ball.build, sets, 3.0, "RK45", client=client, batch_size=2, **BALL)
    assert [r.status for r in results] == ["ok", "failed", "failed", "ok"]
    zeno, typo = results[1], results[2]
    assert zeno.error_type == "ZenoError" and "Zeno" in zeno.error
    assert len(zeno.event_times) >= 8 and 1.3 < zeno.t[-1] < 1.4  # the partial run came back
    assert typo.error_type == "UnknownParameterError" and "did you mean 'v_rest'" in typo.error and not len(typo.t)
    assert results[0].t[-1] == pytest.approx(3.0) and results[3].t[-1] == pytest.approx(3.0)


def interrupting_build(**parameters):
    """Ctrl-C while the third parameter set is built (serial sweep)."""
    if parameters["e"] == 0.7:
        raise KeyboardInterrupt
    return bouncing_ball.build(**parameters)


def sleepy_build(delay=0.0, **parameters):
    """The bouncing ball, built after ``delay`` seconds (a long run, for a Dask sweep to interrupt)."""
    time.sleep(delay)
    return bouncing_ball.build(**parameters)


def test_ctrl_c_in_a_serial_sweep_keeps_the_runs_that_finished():
    sets = [{"e": e} for e in (0.9, 0.8, 0.7, 0.6)]
    with pytest.raises(SweepInterrupted) as info:
        simulate_many(interrupting_build, sets, 1.0, "RK45", client="serial", **BALL)
    assert isinstance(info.value, KeyboardInterrupt) and "2 of 4 runs had finished" in str(info.value)
    results = info.value.results
    assert [r.parameters for r in results] == sets
    assert [r.status for r in results] == ["ok", "ok", "failed", "failed"]
    assert {r.error_type for r in results[2:]} == {"SweepInterrupted"}
    assert results[1].t[-1] == pytest.approx(1.0)


def test_ctrl_c_in_a_dask_sweep_keeps_the_finished_tasks_and_cancels_the_rest(client, monkeypatch):
    sets = [{"e": 1.0}, {"e": 1.0, "y0": 2.0}, {"delay": 30.0}, {"delay": 30.0}]

    real_wait = distributed.wait

    def interrupted_wait(futures, **kwargs):  # Ctrl-C once the two short runs are back
        real_wait(futures[:2])
        raise KeyboardInterrupt

    monkeypatch.setattr(distributed, "wait", interrupted_wait)
    with pytest.raises(SweepInterrupted) as info:
        simulate_many(sleepy_build, sets, 5.0, "RK45", client=client, batch_size=1, **BALL)
    results = info.value.results
    assert [r.status for r in results[:2]] == ["ok", "ok"] and results[0].t[-1] == pytest.approx(5.0)
    assert [r.error_type for r in results[2:]] == ["SweepInterrupted", "SweepInterrupted"]


def worker_metrics(trajectory):
    """Computed where the run ran: the process id, and a signal (needs the model)."""
    return {"pid": os.getpid(), "v_final": float(trajectory.signal("v")[-1])}


def test_to_frame_has_one_row_per_run_and_metrics_computed_in_the_worker(client):
    sets = parameter_grid({"e": [0.8, 0.5], "y0": [1.0, 2.0]})
    results = simulate_many(bouncing_ball.build, sets, 3.0, "RK45", client=client, metrics=worker_metrics,
                            trajectories=False, **BALL)
    frame = to_frame(results)
    assert list(frame.columns) == ["e", "y0", "status", "error", "events", "first_event", "t_final", "final_p",
                                   "final_y", "pid", "v_final", "wall_time"]
    assert list(frame["e"]) == [0.8, 0.8, 0.5, 0.5] and list(frame["y0"]) == [1.0, 2.0, 1.0, 2.0]
    assert list(frame["status"]) == ["ok", "ok", "failed", "failed"]  # e = 0.5: Zeno before 3 s
    workers = set(client.run(os.getpid).values())
    assert set(frame["pid"][:2]) <= workers and os.getpid() not in workers
    assert frame["pid"][2:].isna().all()  # no metrics on a failed run
    ok = [r for r in results if r.ok]
    assert all(len(r.t) == 1 and not r.instants for r in results)  # trajectories=False: the last sample only
    serial = simulate_many(bouncing_ball.build, sets[:2], 3.0, "RK45", client="serial", **BALL)
    for row, r, s in zip(frame.itertuples(), ok, serial):
        assert row.events == len(s.event_times) and row.first_event == s.event_times[0]
        assert row.t_final == 3.0 and (row.final_p, row.final_y) == tuple(s.x[-1])
        assert row.v_final == pytest.approx(s.x[-1][0] / 1.0)  # v = p/m
        np.testing.assert_array_equal(r.event_times, s.event_times)
    assert frame["first_event"][2] == pytest.approx(np.sqrt(2 / 9.81))  # a failed run: its partial run
    assert frame["error"][2].startswith("Zeno") and frame["error"][:2].isna().all()


def test_a_metric_that_fails_fails_its_run_with_a_message_not_the_sweep():
    def fragile(trajectory):
        if trajectory.x[0, 1] > 1.5:
            raise ValueError("no metric above 1.5 m")
        return {"y_max": float(trajectory.x[:, 1].max())}

    results = simulate_many(bouncing_ball.build, [{"y0": 1.0}, {"y0": 2.0}], 1.0, client="serial",
                            metrics=fragile, **BALL)
    assert results[0].ok and results[0].metrics == {"y_max": 1.0}
    assert results[1].error_type == "ValueError" and "metrics callable fragile failed" in results[1].error
    assert "no metric above 1.5 m" in results[1].error and results[1].t[-1] == pytest.approx(1.0)


def test_signal_metrics_travel_to_the_workers_and_name_unknown_signals(client):
    metrics = SignalMetrics("final:y", "max:v", "min:v")
    (result,) = simulate_many(bouncing_ball.build, [{"y0": 2.0}], 1.0, client=client, metrics=metrics, **BALL)
    fresh = bouncing_ball.build(y0=2.0).simulate(1.0, **BALL)
    v = fresh.signal("v")
    assert result.metrics == {"final:y": fresh.x[-1, 1], "max:v": v.max(), "min:v": v.min()}
    with pytest.raises(Exception, match="no signal 'speed'"):
        SignalMetrics("final:speed").check(bouncing_ball.build())
    with pytest.raises(Exception, match="KIND:SIGNAL"):
        SignalMetrics("average:v")


def test_progress_bar_is_dasks(client, capsys):
    simulate_many(bouncing_ball.build, [{"e": 0.8}, {"e": 0.9}], 0.5, client=client, progress_bar=True, **BALL)
    assert "100% Completed" in capsys.readouterr().out


# ------------------------------------------------------------------ plot


def test_plot_sweep_draws_a_line_for_one_parameter_and_a_heat_map_for_two():
    from matplotlib.collections import QuadMesh

    from bondgraph.drawing import pyplot

    frame = pd.DataFrame({"e": [0.5, 0.6, 0.7] * 2, "law": ["paper"] * 3 + ["newton"] * 3,
                          "status": ["failed", "ok", "ok", "ok", "ok", "ok"], "events": [30, 12, 9, 31, 11, 8]})
    ax = plot_sweep(frame[frame["law"] == "paper"], "events", ["e"])
    (line,) = [line for line in ax.get_lines() if line.get_label() == "events"]
    np.testing.assert_array_equal(line.get_xdata(), [0.5, 0.6, 0.7])
    np.testing.assert_array_equal(line.get_ydata(), [np.nan, 12, 9])  # the failed run is no value
    assert any(line.get_label() == "failed" for line in ax.get_lines())
    pyplot().close(ax.figure)
    ax = plot_sweep(frame, "events", ["e", "law"])
    (mesh,) = [c for c in ax.collections if isinstance(c, QuadMesh)]
    cells = mesh.get_array()
    assert cells.shape == (2, 3) and cells.mask[0, 0] and cells[1, 0] == 31  # rows: laws in order of appearance
    assert [t.get_text() for t in ax.get_yticklabels()] == ["paper", "newton"]
    pyplot().close(ax.figure)
    with pytest.raises(Exception, match="several runs share"):
        plot_sweep(frame, "events", ["law"])


# ------------------------------------------------------------------ hbg sweep


def read_csv(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def test_hbg_sweep_on_a_running_scheduler_writes_the_table_and_a_heat_map(client, tmp_path, capsys):
    out, png = tmp_path / "sweep.csv", tmp_path / "sweep.png"
    status = main(["sweep", "bouncing-ball", "--grid", "e=0.8:0.9:3", "--grid", "y0=1,2", "--t-end", "2",
                   "--scheduler", client.scheduler.address, "--csv", str(out), "--plot", str(png),
                   "--metric", "max:v", "--metric", "events"])
    printed = capsys.readouterr().out
    assert status == 0, printed
    rows = read_csv(out)
    np.testing.assert_allclose([(float(r["e"]), float(r["y0"])) for r in rows],
                               [(e, y) for e in (0.8, 0.85, 0.9) for y in (1, 2)], rtol=1e-15)
    assert {r["status"] for r in rows} == {"ok"} and all(float(r["max:v"]) > 0 for r in rows)
    assert "heat map" in printed and png.read_bytes()[:4] == b"\x89PNG"


def test_hbg_sweep_on_one_local_worker_draws_a_line_and_keeps_failed_runs(tmp_path, capsys):
    out, png = tmp_path / "sweep.csv", tmp_path / "sweep.png"
    status = main(["sweep", "bouncing_ball", "--grid", "e=0.5,0.8", "--set", "y0=1.5", "--t-end", "3",
                   "--workers", "1", "--csv", str(out), "--plot", str(png), "--metric", "final_y"])
    captured = capsys.readouterr()
    assert status == 1  # a run failed: said, and kept in the table
    rows = read_csv(out)
    assert [r["status"] for r in rows] == ["failed", "ok"] and rows[0]["error"].startswith("Zeno")
    assert all(r["y0"] == "1.5" for r in rows)
    assert "on 1 local Dask worker" in captured.out and "(final_y, line)" in captured.out
    assert "1 failed with ZenoError, e.g. e=0.5" in captured.err
    assert png.stat().st_size > 1000


@pytest.mark.parametrize("args, message", [
    (["--grid", "mu=0:1:3"], "unknown parameter 'mu'"),
    (["--grid", "e=0.5:0.9:x"], "whole number"),
    (["--grid", "e=0.5,nan"], "not a finite number"),
    (["--grid", "e=0.5,0.8", "--set", "e=0.7"], "already given"),
    (["--grid", "e=0.5,0.8", "--grid", "y0=1,2", "--grid", "m=1,2", "--plot", "x.png"], "one or two parameters"),
    (["--grid", "e=0.5,0.8", "--metric", "speed"], "not a column"),
    (["--grid", "e=0.5,0.8", "--metric", "max:speed"], "no signal 'speed'"),
    (["--grid", "e=0.5,0.8", "--workers", "0"], "at least 1"),
])
def test_hbg_sweep_rejects_bad_input_before_anything_runs(args, message, tmp_path, capsys):
    status = main(["sweep", "bouncing-ball", *args, "--csv", str(tmp_path / "out.csv")])
    assert status == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out.csv").exists()


def test_a_second_parameter_of_few_values_is_a_family_of_lines_with_units():
    """Two values of a second parameter drew a heat map of two stretched rows; the axes had no units."""
    from bondgraph.drawing import pyplot

    frame = pd.DataFrame({"e": [0.5, 0.6, 0.7, 0.8, 0.9] * 2, "y0": [1.0] * 5 + [2.0] * 5, "status": ["ok"] * 10,
                          "max:v": [1.0, 2.0, 3.0, 4.0, 5.0, 2.0, 3.0, 4.0, 5.0, 6.0]})
    units = {"v": "m/s", "y0": "m", "e": "1"}.get
    ax = plot_sweep(frame, "max:v", ["e", "y0"], unit=units)
    lines = [line for line in ax.get_lines() if line.get_label().startswith("y0 = ")]
    assert [line.get_label() for line in lines] == ["y0 = 1", "y0 = 2"]
    np.testing.assert_array_equal(lines[1].get_ydata(), [2.0, 3.0, 4.0, 5.0, 6.0])
    assert ax.get_ylabel() == "max:v [m/s]" and ax.get_xlabel() == "e [1]"
    pyplot().close(ax.figure)


def test_grid_values_print_as_written():
    from models.cli.sweep import grid_axis

    assert grid_axis("e=0.1:0.5:5", {"e": 0.8})[1] == [0.1, 0.2, 0.3, 0.4, 0.5]
