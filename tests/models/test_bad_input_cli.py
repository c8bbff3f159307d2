"""Bad input and failing runs through ``hbg`` (issue 20): one case per finding.

The command never loses computed work and never prints a raw traceback: a run
that fails or is interrupted writes the files asked for with what it computed,
prints the whole error message and exits non-zero (1 failed run, 2 bad input,
130 Ctrl-C).  Most cases call :func:`models.cli.main` in the test process
(faster than a subprocess); only Ctrl-C needs a real process to signal.
"""

import csv
import os
import re
import signal
import subprocess
import sys
import time

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import models  # noqa: E402
from models import cli  # noqa: E402
from checkout import ROOT

ROOT = str(ROOT)


class _Hung(BaseException):
    """Raised by the alarm: a BaseException, so that no handler of the CLI swallows it."""


@pytest.fixture(autouse=True)
def _no_hang():
    """Every case here ends within 30 s (no pytest-timeout in the environment)."""
    def alarm(signum, frame):
        raise _Hung("the case took more than 30 s")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, 30.0)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def hbg(capsys, *args):
    """``hbg args`` in this process: (exit status, stdout, stderr)."""
    status = cli.main([str(a) for a in args])
    out = capsys.readouterr()
    assert "Traceback" not in out.err and "Traceback" not in out.out
    return status, out.out, out.err


def read_csv(path):
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    return rows[0], rows[1:]


# ------------------------------------------------------------ 1. failing runs


def test_divergence_of_time_prints_the_whole_loop_and_saves_the_partial_run(capsys, tmp_path):
    data, arrays, plot = tmp_path / "diode.csv", tmp_path / "diode.npz", tmp_path / "diode.png"
    status, out, err = hbg(capsys, "run", "diode-circuit", "--set", "I_th=100",
                           "--csv", data, "--npz", arrays, "--plot", plot)
    assert status == 1
    # the whole message, not only its first line "…; the loop:"
    assert "divergence of time at t = 0.5" in err and "the loop:" in err
    assert "step 2:" in err and "step 3:" in err and "i_D <= I_th" in err and "v_D >= V_th" in err
    assert "the files hold the partial run up to t = 0.5 s" in err
    header, rows = read_csv(data)
    assert header[0] == "t" and "i_D" in header  # the model's signals too
    times = np.array([float(r[0]) for r in rows])
    assert len(rows) > 100 and times[-1] == pytest.approx(0.5) and np.all(np.diff(times) >= 0)
    assert np.load(arrays)["t"][-1] == pytest.approx(0.5)
    assert plot.stat().st_size > 10_000
    assert "partial trajectory" in out and f"csv: {data}" in out


def test_zeno_error_saves_the_partial_run_and_names_the_option(capsys, tmp_path):
    data = tmp_path / "ball.csv"
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--set", "e=0.5", "--t-end", "2", "--csv", data)
    assert status == 1
    assert "Zeno behaviour" in err and "1.35457" in err and "on_zeno='stop'" in err
    assert "the files hold the partial run up to t = " in err
    _, rows = read_csv(data)
    t_inf = np.sqrt(2 / 9.81) * 3  # t1 (1 + e) / (1 - e)
    assert float(rows[-1][0]) == pytest.approx(t_inf, rel=1e-6)  # the last state, where the run stopped
    assert len(rows) <= 500  # --samples (default 500) stays a cap on a partial run


def test_a_run_failing_before_any_sample_writes_no_file_and_says_so(capsys, tmp_path, monkeypatch):
    from models import bouncing_ball
    from switching.errors import StepSizeError

    def fails(*args, **kwargs):
        raise StepSizeError("step size underflow at t = 0\nsecond line of the message")

    real = bouncing_ball.build

    def build(**parameters):
        model = real(**parameters)
        monkeypatch.setattr(model, "simulate", fails)
        return model

    monkeypatch.setattr(bouncing_ball, "build", build)
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--csv", tmp_path / "x.csv")
    assert status == 1
    assert "step size underflow" in err and "second line of the message" in err
    assert "nothing was computed" in err and not (tmp_path / "x.csv").exists()


def test_ctrl_c_during_a_run_saves_the_partial_run_and_exits_130(tmp_path):
    data = tmp_path / "boost.csv"
    process = subprocess.Popen(
        [sys.executable, "-m", "models.cli", "run", "boost-converter", "--t-end", "1", "--csv", str(data),
         "--method", "RK45"],  # (a Python run, interrupted inside its flow)
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
        env={**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": ROOT},
        # Ctrl-C as a terminal delivers it, also when the tests run in the background
        # (a shell without job control starts them with SIGINT ignored, and the child would inherit that)
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    # wait until the run has begun: imports and derivation take about 1.5 s of CPU, the run about 25 s
    stat = f"/proc/{process.pid}/stat"
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and process.poll() is None:
        if not os.path.exists(stat):
            time.sleep(4.0)
            break
        with open(stat) as handle:
            fields = handle.read().rsplit(")", 1)[1].split()
        if (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK") >= 3.0:
            break
        time.sleep(0.1)
    process.send_signal(signal.SIGINT)
    try:
        out, err = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == 130, err
    assert "Traceback" not in err and "interrupted" in err
    assert "the files hold the partial run up to t = " in err
    header, rows = read_csv(data)
    assert header[0] == "t" and len(rows) >= 2
    assert 0 < float(rows[-1][0]) < 1


def test_ctrl_c_before_the_run_is_one_line_and_exit_130(capsys, monkeypatch):
    from models import bouncing_ball

    def interrupted(**parameters):
        raise KeyboardInterrupt

    monkeypatch.setattr(bouncing_ball, "build", interrupted)
    status, out, err = hbg(capsys, "run", "bouncing-ball")
    assert status == 130 and err.strip() == "hbg: interrupted (Ctrl-C)"


def test_an_unexpected_error_is_reported_without_a_traceback(capsys, monkeypatch):
    from models import bouncing_ball

    def broken(**parameters):
        raise ValueError("something internal")

    monkeypatch.setattr(bouncing_ball, "build", broken)
    monkeypatch.delenv("HBG_TRACEBACK", raising=False)
    status, out, err = hbg(capsys, "run", "bouncing-ball")
    assert status == 1 and "internal error: ValueError: something internal" in err


# ------------------------------------------------- 2. --on-zeno, --keep-instants


def test_on_zeno_stop_ends_the_run_at_the_accumulation_point(capsys, tmp_path):
    data = tmp_path / "ball.csv"
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--set", "e=0.5", "--t-end", "2",
                           "--on-zeno", "stop", "--csv", data)
    assert status == 0, err
    assert "stopped early (zeno)" in out
    _, rows = read_csv(data)
    assert float(rows[-1][0]) == pytest.approx(np.sqrt(2 / 9.81) * 3, rel=1e-6)
    status, _, err = hbg(capsys, "run", "bouncing-ball", "--on-zeno", "ignore")
    assert status == 2 and "--on-zeno" in err and "'ignore'" in err


def test_keep_instants_options(capsys, tmp_path):
    kept, dropped = tmp_path / "kept.npz", tmp_path / "dropped.npz"
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--npz", kept)
    assert status == 0, err
    assert len(np.load(kept)["event_times"]) == 4
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--no-keep-instants", "--npz", dropped)
    assert status == 0, err
    assert len(np.load(dropped)["event_times"]) == 0 and "4" in out  # still counted
    np.testing.assert_allclose(np.load(dropped)["x"], np.load(kept)["x"], rtol=1e-9, atol=1e-12)
    status, _, err = hbg(capsys, "run", "bouncing-ball", "--no-keep-instants", "--with-instants")
    assert status == 2 and "--with-instants" in err and "--no-keep-instants" in err


# --------------------------------------------------- 3. output files on their own


def test_an_unwritable_output_directory_is_a_usage_error_before_the_run(capsys, tmp_path):
    missing = tmp_path / "no" / "such" / "x.png"
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--plot", missing, "--csv", tmp_path / "ok.csv")
    assert status == 2 and out == ""
    assert f"--plot {missing}" in err and "does not exist" in err
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--csv", tmp_path)
    assert status == 2 and "--csv" in err and "is a directory" in err


def test_an_unsupported_plot_format_is_a_usage_error_listing_the_formats(capsys, tmp_path):
    for command in (("run", "bouncing-ball", "--plot"), ("draw", "bouncing-ball", "-o")):
        status, out, err = hbg(capsys, *command, tmp_path / "x.jpgg")
        assert status == 2 and out == ""
        assert "'jpgg'" in err and "png" in err and "pdf" in err and "svg" in err
        assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("bad", ["plot", "csv"])
def test_a_file_that_cannot_be_written_does_not_stop_the_others(capsys, tmp_path, monkeypatch, bad):
    """The directory vanishes during the run (the check before it passed)."""
    monkeypatch.setattr("models.cli.outputs.check_output", lambda *args, **kwargs: None)
    paths = {kind: tmp_path / f"ok.{kind}" for kind in ("csv", "npz", "png")}
    broken = tmp_path / "gone" / ("x.png" if bad == "plot" else "x.csv")
    paths["png" if bad == "plot" else "csv"] = broken
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--set", "e=0.5", "--t-end", "1.2",
                           "--plot", paths["png"], "--csv", paths["csv"], "--npz", paths["npz"])
    assert status == 1
    assert f"could not write {bad} {broken}" in err and "No such file or directory" in err
    for kind, path in paths.items():
        if path != broken:
            assert path.stat().st_size > 1000, kind
    assert not broken.exists()


# ------------------------------------------------------------ 4. --samples cap


def test_samples_is_a_cap_and_instants_come_only_when_asked(capsys, tmp_path):
    capped, full = tmp_path / "capped.csv", tmp_path / "full.csv"
    status, out, err = hbg(capsys, "run", "boost-converter", "--samples", "50", "--csv", capped)
    assert status == 0, err
    _, rows = read_csv(capped)
    np.testing.assert_allclose([float(r[0]) for r in rows], np.linspace(0, 0.02, 50), rtol=0, atol=1e-15)
    status, out, err = hbg(capsys, "run", "boost-converter", "--samples", "50", "--with-instants", "--csv", full)
    assert status == 0, err
    _, rows = read_csv(full)
    # 200 switching periods, two instants each; the last edge is at t_end = 200·T to round-off: inside the run
    # (400 instants) or not; exactly at t_end, the time t_end still has its row (the state after that instant)
    instants = int(re.search(r"^\s*instants: (\d+)$", out, re.MULTILINE).group(1))
    assert instants in (399, 400)
    assert len(rows) == 50 + 2 * instants
    for samples in ("1", "-3"):
        status, _, err = hbg(capsys, "run", "bouncing-ball", "--samples", samples)
        assert status == 2 and "--samples" in err and samples in err


def test_hbg_run_writes_the_rows_of_simulate_with_samples(capsys, tmp_path):
    """One sampling for Python and the command line: ``hbg run --samples N
    --with-instants`` writes exactly the rows of ``simulate(..., samples=N)``
    (the N times and every instant's pair), and without ``--with-instants``
    exactly the N times of ``simulate(..., t_eval=linspace(0, t_end, N))``."""
    from models import bouncing_ball

    both, times = tmp_path / "both.npz", tmp_path / "times.npz"
    method = model_run_method()  # (named: hbg run's default, auto, chooses by what is cached)
    status, _, err = hbg(capsys, "run", "bouncing-ball", "--t-end", "2", "--samples", "40", "--with-instants",
                         "--npz", both, "--method", method)
    assert status == 0, err
    status, _, err = hbg(capsys, "run", "bouncing-ball", "--t-end", "2", "--samples", "40", "--npz", times,
                         "--method", method)
    assert status == 0, err
    model = bouncing_ball.build()
    run = model.simulate(2.0, model_run_method(), samples=40, **model_run_options())
    written = np.load(both)
    assert len(run.events) == 3 and len(written["t"]) == 40 + 2 * 3
    np.testing.assert_array_equal(written["t"], run.t)
    np.testing.assert_allclose(written["x"], run.x, rtol=1e-12, atol=1e-12)
    assert list(written["modes"]) == run.mode_labels
    requested = model.simulate(2.0, model_run_method(), t_eval=np.linspace(0.0, 2.0, 40), **model_run_options())
    written = np.load(times)
    np.testing.assert_array_equal(written["t"], np.linspace(0.0, 2.0, 40))
    np.testing.assert_array_equal(written["t"], requested.t)
    np.testing.assert_allclose(written["x"], requested.x, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(run.without_instants().x, requested.x)


def model_run_method():
    from models import bouncing_ball

    return bouncing_ball.RUN.get("method", "RK45")


def model_run_options():
    from models import bouncing_ball

    return {k: v for k, v in bouncing_ball.RUN.items() if k in ("rtol", "atol", "max_step")}


@pytest.mark.parametrize("samples", ["0", "-1"])
def test_verify_needs_at_least_one_sample(capsys, samples):
    status, out, err = hbg(capsys, "verify", "diode-circuit", "--set", "I_th=100", "--samples", samples)
    assert status == 2 and out == ""
    assert "--samples" in err and "at least 1" in err and samples in err


# ------------------------------------------------------- 5. numbers on the line


@pytest.mark.parametrize(
    "args, named",
    [
        (("--t-end", "inf"), ("--t-end", "inf")),
        (("--t-end", "nan"), ("--t-end", "nan")),
        (("--t-end", "-1"), ("--t-end", "-1")),
        (("--t-end", "0"), ("--t-end", "0")),
        (("--rtol", "inf"), ("--rtol", "inf")),
        (("--rtol", "0"), ("--rtol", "0")),
        (("--rtol=-1e-3",), ("--rtol", "-0.001")),
        (("--method", "rk4", "--dt", "nan"), ("--dt", "nan")),
        (("--method", "rk4", "--dt=-0.1"), ("--dt", "-0.1")),
        (("--set", "e=nan"), ("--set", "'e'", "nan")),
        (("--set", "g=inf"), ("--set", "'g'", "inf")),
        (("--set", "e=1e400"), ("--set", "'e'", "1e400", "overflows")),
        (("--set", "m=-inf"), ("--set", "'m'", "-inf")),
    ],
)
def test_non_finite_or_non_positive_numbers_are_usage_errors(capsys, args, named):
    started = time.perf_counter()
    status, out, err = hbg(capsys, "run", "bouncing-ball", *args)
    assert status == 2 and out == ""
    assert all(word in err for word in named), err
    assert len(err.strip().splitlines()) == 1
    assert time.perf_counter() - started < 5  # rejected before anything is built or run


# ------------------------------------------------------ 6. the drawn bond graph


@pytest.mark.parametrize("name", models.MODELS)
def test_draw_keeps_every_element_on_the_canvas(name):
    from switching.simulate.plotting import draw_bond_graph

    model = models.load(name).build()
    ax = draw_bond_graph(model.graph, model.configuration_of(model.initial_mode))
    try:
        fig = ax.figure
        fig.draw_without_rendering()
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        frame = ax.get_window_extent()
        labels = [t for t in ax.texts if (t.get_gid() or "").startswith("element:")]
        assert sorted(t.get_gid()[len("element:"):] for t in labels) == sorted(model.graph.elements)
        assert len(labels) == len(model.graph.elements)
        for text in labels:
            x, y = text.get_position()
            assert x0 < x < x1 and y0 < y < y1, text.get_text()
            box = text.get_bbox_patch().get_window_extent()
            assert frame.x0 <= box.x0 and box.x1 <= frame.x1, text.get_text()
            assert frame.y0 <= box.y0 and box.y1 <= frame.y1, text.get_text()
    finally:
        matplotlib.pyplot.close(ax.figure)


def test_hbg_draw_writes_the_diode_circuit(capsys, tmp_path):
    target = tmp_path / "diode.png"
    status, out, err = hbg(capsys, "draw", "diode-circuit", "-o", target)
    assert status == 0, err
    assert target.stat().st_size > 10_000 and f"wrote {target}" in out
