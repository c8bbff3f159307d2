"""Progress on request in Python (issue 29, item 4): simulate(..., progress=True)."""

import io

import pytest

from models import bouncing_ball
from switching.errors import OptionTypeError
from switching.simulate import progress as progress_module
from switching.simulate.progress import ProgressBar


def test_the_bar_shows_the_fraction_of_the_span_and_clears_its_line():
    stream = io.StringIO()
    bar = ProgressBar(1.0, 3.0, stream=stream, after=0.0)
    bar(2.0)
    assert "[###############               ]  50.0 %  t = 2 s" in stream.getvalue()
    bar.close()
    assert stream.getvalue().endswith("\r")


def test_a_terminal_only_bar_draws_nothing_into_a_file():
    stream = io.StringIO()
    bar = ProgressBar(0.0, 1.0, stream=stream, terminal_only=True, after=0.0)
    bar(0.5)
    bar.close()
    assert stream.getvalue() == ""


def test_simulate_with_progress_true_draws_a_bar_on_stderr(monkeypatch, capsys):
    monkeypatch.setattr(progress_module, "REDRAW", 0.0)
    monkeypatch.setattr(ProgressBar.__init__, "__defaults__", (None, False, 0.0))  # (stream, terminal_only, after)
    trajectory = bouncing_ball.build().simulate(2.5, "RK45", progress=True)
    err = capsys.readouterr().err
    assert "%  t = " in err and "100.0 %" in err and len(trajectory.events) == 4


def test_progress_must_be_true_none_or_a_function():
    with pytest.raises(OptionTypeError, match="progress"):
        bouncing_ball.build().simulate(0.1, "RK45", progress="yes")


def test_the_bar_says_the_rate_and_the_time_left(monkeypatch):
    """Simulated seconds per second of computing and the time the rest takes at that rate."""
    clock = iter([100.0, 104.0])  # (the bar's start, then its call: 4 s of computing)
    monkeypatch.setattr(progress_module.time, "perf_counter", lambda: next(clock))
    stream = io.StringIO()
    bar = ProgressBar(0.0, 10.0, stream=stream, after=0.0)
    bar(2.0)  # 2 s simulated in 4 s: 0.5 s/s, 8 s left: 16 s
    assert stream.getvalue().endswith("t = 2 s  0.5 s/s  ETA 16 s")
    assert progress_module._duration(200.0) == "3 min 20 s" and progress_module._duration(7500.0) == "2 h 05 min"


def test_the_command_line_shows_the_bar_in_a_log_when_asked_and_never_when_quiet(monkeypatch, capsys):
    """stderr here is no terminal: no bar by default, a bar with --progress, none with --quiet."""
    from models import cli

    monkeypatch.setattr(progress_module, "REDRAW", 0.0)
    monkeypatch.setattr(ProgressBar.__init__, "__defaults__", (None, False, 0.0))  # (stream, terminal_only, after)
    shown = {}
    for flag in ("--progress", "--quiet", None):
        assert cli.main(["run", "bouncing-ball", "--t-end", "2.5", "--method", "RK45"] + ([flag] if flag else [])) == 0
        shown[flag] = "%  t = " in capsys.readouterr().err
    assert shown == {"--progress": True, "--quiet": False, None: False}
