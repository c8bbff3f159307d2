"""Measurements on the command line (issue 42): ``hbg run … --measure SIGNAL:KIND`` over a window,
``hbg orbit … --measure`` over one period with dense files, ``hbg sweep … --metric KIND:SIGNAL``."""

import csv
import re

import pytest

from models import boost_converter, cli
from switching.sweep.frame import SignalMetrics

RUN = ["run", "boost-converter", "--t-end", "0.005", "--quiet"]


def printed(out: str, signal: str, kind: str) -> float:
    found = re.search(rf"^\s+{re.escape(signal)} {kind}: (\S+)", out, re.M)
    assert found, out
    return float(found.group(1))


def test_a_run_prints_the_measurements_python_gives(capsys):
    code = cli.main([*RUN, "--measure", "v_C:mean,ripple", "--measure", "R_load:efficiency", "--period", "1e-4",
                     "--periods", "5"])
    out = capsys.readouterr().out
    assert code == cli.EXIT_OK and "measurements over [0.0045, 0.005] s (the last 5 period(s) of 0.0001 s)" in out
    run = boost_converter.build().simulate(0.005, "auto", **{k: v for k, v in boost_converter.RUN.items()
                                                            if k != "t_end"})
    window = dict(periods=5, period=1e-4)
    assert printed(out, "v_C", "mean") == pytest.approx(run.measure("v_C", "mean", **window), rel=1e-8)
    assert printed(out, "v_C", "ripple") == pytest.approx(run.measure("v_C", "ripple", **window), rel=1e-8)
    assert printed(out, "R_load", "efficiency") == pytest.approx(run.measure("R_load", "efficiency", **window),
                                                                 rel=1e-8)
    assert re.search(r"v_C mean: \S+ V$", out, re.M)  # (its unit)


@pytest.mark.parametrize("extra, said", [
    (["--measure", "v_C:mean", "--samples", "500"], "--samples 0"),
    (["--period", "1e-4"], "give --measure"),
    (["--measure", "v_C:average"], "unknown measurement 'average'"),
    (["--measure", "v_X:mean"], "'v_X' is none of the model's"),
    (["--measure", "v_C:power_factor"], "needs an element"),
    (["--measure", "v_C"], "write SIGNAL:KIND"),
    (["--measure", "v_C:mean", "--periods", "3"], "give --period too"),
    (["--measure", "v_C:mean", "--window", "0.001"], "write FROM:TO"),
])
def test_what_cannot_be_measured_is_refused_before_the_run(extra, said, capsys):
    assert cli.main([*RUN, *extra]) == cli.EXIT_USAGE
    assert said in capsys.readouterr().err


def test_a_window_outside_the_run_fails_after_it_with_the_summary_kept(capsys):
    assert cli.main([*RUN, "--measure", "v_C:mean", "--window", "0.004:0.009"]) == cli.EXIT_FAILED
    out, err = capsys.readouterr()
    assert "instants:" in out and "not inside the run" in err


def test_an_orbit_prints_its_measurements_and_writes_every_signal_at_dense_samples(tmp_path, capsys):
    path = tmp_path / "orbit.csv"
    code = cli.main(["orbit", "boost-converter", "--period", "1e-4", "--measure", "i_L:mean",
                     "--signal", "v_C,i_L", "--samples", "201", "--csv", str(path)])
    out = capsys.readouterr().out
    assert code == cli.EXIT_OK and "(one period of the orbit)" in out
    with open(path) as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 201 and {"v_C", "i_L", "p_L", "q_C"} <= set(rows[0])
    mean = sum(float(r["i_L"]) for r in rows[:-1]) / 200  # (a rectangle rule: near the exact mean)
    assert printed(out, "i_L", "mean") == pytest.approx(mean, rel=1e-3)


def test_sweep_metrics_measure_over_a_window():
    metrics = SignalMetrics("ripple:v_C", "mean:v_C", "max:v_C", "final:v_C", periods=2, period=1e-4)
    model = boost_converter.build()
    metrics.check(model)
    run = model.simulate(0.005, max_step=1e-5)
    found = metrics(run)
    window = dict(periods=2, period=1e-4)
    assert found["ripple:v_C"] == run.measure("v_C", "ripple", **window)
    assert found["max:v_C"] == run.measure("v_C", "max", **window)  # (a window: max is measured, exact)
    assert found["final:v_C"] == run.signal("v_C")[-1]
    assert SignalMetrics("max:v_C")(run)["max:v_C"] == run.signal("v_C").max()  # (no window: over the samples)
