"""``hbg orbit``: a periodic orbit, or its continuation in one parameter, from the command line.

The relay's autonomous period and start, and the boost converter's (continuous conduction, as in
tests/switching/analysis/test_orbits.py) start and multipliers against the matrix exponentials, are
the exact answers of tests/switching/analysis/test_orbits.py and test_continuation.py.
"""

import csv
import subprocess
import sys

import numpy as np
import pytest

from test_orbits import boost_exact  # the exact two-phase answers (tests/switching/analysis)


def hbg(*args):
    return subprocess.run([sys.executable, "-m", "models.cli", *args], capture_output=True, text=True, timeout=300,
                          env={**__import__("os").environ, "MPLBACKEND": "Agg"})


def value_after(text, label):
    line = next(line for line in text.splitlines() if line.strip().startswith(label))
    return line.split(label, 1)[1].strip()


def test_orbit_of_the_relay_prints_its_period_start_and_trivial_multiplier():
    out = hbg("orbit", "models/examples/relay.toml", "--section", "relay: on -> off", "--period", "0.01")
    assert out.returncode == 0, out.stderr
    V, R, C, R_load, v_hi, v_lo = 10.0, 1.0, 1e-3, 20.0, 8.0, 6.0
    v_inf = V * R_load / (R + R_load)
    period = C * R * R_load / (R + R_load) * np.log((v_inf - v_lo) / (v_inf - v_hi)) + C * R_load * np.log(v_hi / v_lo)
    assert float(value_after(out.stdout, "period:").split()[0]) == pytest.approx(period, rel=1e-8)
    assert float(value_after(out.stdout, "x0: q_C =")) == pytest.approx(C * v_hi, rel=1e-9)
    assert "(none besides the trivial one)" in out.stdout and "stable: yes" in out.stdout
    assert float(value_after(out.stdout, "trivial multiplier (along the flow):")) == pytest.approx(1.0, abs=1e-6)


def boost_multipliers(D):
    """The boost converter's orbit start and multipliers at duty ``D`` from its two phases' matrix exponentials."""
    x_star, Phi = boost_exact(D=D)
    return x_star, np.linalg.eigvals(Phi)


def test_orbit_of_the_boost_converter_with_a_fixed_period(tmp_path):
    plot = tmp_path / "orbit.png"
    out = hbg("orbit", "boost-converter", "--set", "R_L=0.1", "--set", "D=0.4", "--period", "1e-4",
              "--plot", str(plot))
    assert out.returncode == 0, out.stderr
    x_star, exact = boost_multipliers(0.4)
    assert float(value_after(out.stdout, "period:").split()[0]) == 1e-4
    start = dict(item.split(" = ") for item in value_after(out.stdout, "x0:").split(", "))
    assert [float(start["p_L"]), float(start["q_C"])] == pytest.approx(x_star, rel=1e-9)
    got = [complex(m.replace(" ", "")) for m in value_after(out.stdout, "multipliers:").split(", ")]
    assert sorted(got, key=lambda z: z.imag) == pytest.approx(sorted(exact, key=lambda z: z.imag), abs=1e-7)
    assert "stable: yes" in out.stdout and plot.stat().st_size > 5_000
    # the orbit's estimated error, within the default tol = 1e-8
    assert float(value_after(out.stdout, "Newton:").split("estimated relative error of x0 ")[1].split(",")[0]) <= 1e-8


def test_continuation_of_the_boost_converter_prints_and_writes_its_table(tmp_path):
    table, plot = tmp_path / "d.csv", tmp_path / "d.png"
    out = hbg("orbit", "boost-converter", "--set", "R_L=0.1", "--period", "1e-4", "--continue", "D=0.3:0.5:3",
              "--csv", str(table), "--plot", str(plot), "--signal", "v_C")
    assert out.returncode == 0, out.stderr
    assert "no multiplier crossed -1 or +1" in out.stdout and "3 orbit(s)" in out.stdout
    rows = list(csv.DictReader(table.open()))
    assert [float(r["D"]) for r in rows] == [0.3, 0.4, 0.5]
    for row in rows:
        x_star, exact = boost_multipliers(float(row["D"]))
        assert [float(row["x0:p_L"]), float(row["x0:q_C"])] == pytest.approx(x_star, rel=1e-8)
        got = [complex(row["multiplier_1"]), complex(row["multiplier_2"])]
        assert sorted(got, key=lambda z: z.imag) == pytest.approx(sorted(exact, key=lambda z: z.imag), abs=1e-7)
        assert row["stable"] == "True" and float(row["max:v_C"]) > float(row["min:v_C"])
    assert plot.stat().st_size > 5_000


@pytest.mark.parametrize("args, message", [
    (("--continue", "D=0.3:0.5"), "name=start:stop:count"),
    (("--continue", "D=0.3:0.5:1"), "whole number from 2"),
    (("--continue", "Q=0.3:0.5:3"), "'Q' is not a numeric parameter"),
    (("--continue", "D=0.3:x:3"), "'x' is not a number"),
    (("--continue", "D=0.3:0.5:3", "--set", "D=0.4"), "also given with --set"),
    ((), "give --period T"),
])
def test_bad_orbit_requests_are_usage_errors(args, message):
    extra = () if message == "give --period T" else ("--period", "1e-4")
    out = hbg("orbit", "boost-converter", *extra, *args)
    assert out.returncode == 2 and out.stderr.startswith("hbg: error: ") and message in out.stderr, out.stderr


def test_an_orbit_not_found_is_an_error_of_the_run():
    # a section naming an automaton the relay does not have is refused before any run (exit 2) ...
    out = hbg("orbit", "models/examples/relay.toml", "--section", "valve: on -> off", "--period", "0.01")
    assert out.returncode == 2 and "hbg: error: periodic_orbit: section automaton 'valve'" in out.stderr
    # ... while Newton out of its depth is a failed computation (exit 1) that says what to try
    out = hbg("orbit", "boost-converter", "--period", "1e-4", "--set", "R_L=0.1", "--set", "v_C0=40")
    assert out.returncode == 1 and "hbg: error: periodic_orbit: iterate 1" in out.stderr and "warmup=" in out.stderr


def test_doubled_needs_a_continuation():
    out = hbg("orbit", "boost-converter", "--period", "1e-4", "--doubled")
    assert out.returncode == 2 and "--doubled" in out.stderr and "--continue" in out.stderr


def test_continuation_of_the_relay_in_its_threshold_follows_the_closed_form_period(tmp_path):
    table = tmp_path / "relay.csv"
    out = hbg("orbit", "models/examples/relay.toml", "--section", "relay: on -> off", "--period", "0.01",
              "--continue", "v_hi=7.5:8.5:5", "--csv", str(table))
    assert out.returncode == 0, out.stderr
    V, R, C, R_load, v_lo = 10.0, 1.0, 1e-3, 20.0, 6.0
    v_inf = V * R_load / (R + R_load)
    rows = list(csv.DictReader(table.open()))
    assert [float(r["v_hi"]) for r in rows] == [7.5, 7.75, 8.0, 8.25, 8.5]
    for row in rows:
        v_hi = float(row["v_hi"])
        period = (C * R * R_load / (R + R_load) * np.log((v_inf - v_lo) / (v_inf - v_hi))
                  + C * R_load * np.log(v_hi / v_lo))
        assert float(row["period"]) == pytest.approx(period, rel=1e-8)
        assert float(row["x0:q_C"]) == pytest.approx(C * v_hi, rel=1e-9)
