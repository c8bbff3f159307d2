"""The ``hbg`` command through a subprocess: output and bad-input handling."""

import subprocess
import sys

import pytest


def hbg(*args):
    return subprocess.run(
        [sys.executable, "-m", "models.cli", *args], capture_output=True, text=True, timeout=120
    )


def test_graphs_lists_the_shipped_graphs():
    out = hbg("graphs")
    assert out.returncode == 0
    assert "pivoting_rod" in out.stdout and "series_rlc" in out.stdout


def test_equations_prints_the_derived_equations():
    out = hbg("equations", "pivoting_rod")
    assert out.returncode == 0, out.stderr
    assert "dependent (derivative causality): rod/p_x, rod/p_y" in out.stdout
    assert "drod/p_J/dt = -J*g*l*m*cos(rod/theta)/(J + l**2*m)" in out.stdout


def test_equations_of_a_configuration_and_a_size():
    out = hbg("equations", "switched_rl", "--off", "switch")
    assert out.returncode == 0 and "dp_L/dt = -R_fw*p_L/L" in out.stdout
    out = hbg("equations", "msd_chain", "--n", "2", "--latex")
    assert out.returncode == 0 and out.stdout.startswith(r"\begin{aligned}")


@pytest.mark.parametrize(
    "args, message",
    [
        (("equations", "nope"), "unknown graph 'nope'"),
        (("equations", "series_rlc", "--off", "i"), "not a controlled junction"),
        (("equations", "series_rlc", "--n", "3"), "takes no size"),
        (("equations", "msd_chain", "--n", "0"), "at least 1"),
    ],
)
def test_bad_input_is_one_clear_line(args, message):
    out = hbg(*args)
    assert out.returncode == 2
    assert message in out.stderr and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
