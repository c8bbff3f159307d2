"""Every saved model file carries a run (switching/files/run_defaults.py): its last run, or one its time
scales suggest — never a silent 1 s."""

import numpy as np
import pytest

from models import bouncing_ball
from models.circuits import PWM, Circuit
from switching.files.modelfile import ModelFile
from switching.files.run_defaults import suggested_t_end


def buck():
    c = Circuit("buck")
    c.V("Vin", "in", 0, 24.0)
    c.switch("S", "in", "sw", PWM(1e-5, 0.5))
    c.diode("D1", 0, "sw")
    c.L("L", "sw", "out", 1e-4)
    c.C("C", "out", 0, 1e-4)
    c.R("R", "out", 0, 2.0)
    return c.build()


def run_of(path) -> dict:
    return dict(ModelFile(path).RUN)


def test_a_model_never_run_is_saved_with_the_run_its_time_scales_suggest(tmp_path):
    """The buck's clock (20 periods: 0.2 ms) and its LC filter into 2 Ω, slowest decay
    ``1/min(−Re λ)`` of ``[[−1/(RC), 1/C], [−1/L, 0]]`` (5 of them): the longer."""
    A = np.array([[-1 / (2.0 * 1e-4), 1 / 1e-4], [-1 / 1e-4, 0.0]])
    tau = 1 / min(-np.linalg.eigvals(A).real)
    t_end, why = suggested_t_end(buck())
    assert t_end == pytest.approx(max(5 * tau, 20 * 1e-5), rel=1e-6) and "time constant" in why
    path = tmp_path / "buck.toml"
    buck().save(path)
    assert "[run]" in path.read_text() and run_of(path)["t_end"] == pytest.approx(t_end, rel=1e-5)
    assert ModelFile(path).t_end_chosen is None  # (the file has its run)


def test_a_model_run_is_saved_with_that_run(tmp_path):
    model = buck()
    model.simulate(1e-3, "RK45-jit", rtol=1e-8, max_step=1e-6)
    path = tmp_path / "buck.toml"
    model.save(path)  # (no atol given: none written, each state's own when run again)
    assert run_of(path) == {"t_end": 1e-3, "method": "RK45-jit", "rtol": 1e-8, "max_step": 1e-6}
    model.simulate(1e-3, "RK45", rtol=1e-8, atol=1e-12)
    model.save(path)
    assert run_of(path) == {"t_end": 1e-3, "method": "RK45", "rtol": 1e-8, "atol": 1e-12}


def test_a_file_without_a_run_is_run_for_the_suggested_time_and_says_why(tmp_path):
    path = tmp_path / "buck.toml"
    buck().save(path, run={"signals": ["v_out"]})
    assert "t_end" not in path.read_text()
    loaded = ModelFile(path)
    assert loaded.RUN["t_end"] == pytest.approx(suggested_t_end(buck())[0], rel=1e-5)
    assert "time constant" in loaded.t_end_chosen


def test_a_model_without_a_time_scale_gets_one_second_and_is_told_so():
    t_end, why = suggested_t_end(bouncing_ball.build())
    assert t_end == 1.0 and "no time scale" in why


def test_the_command_line_says_the_t_end_it_chose(tmp_path, capsys):
    from models import cli

    path = tmp_path / "buck.toml"
    buck().save(path, run={"signals": ["v_out"]})
    assert cli.main(["run", str(path), "--quiet"]) == cli.EXIT_OK
    err = capsys.readouterr().err
    assert "gives no t_end: running 0.002 s, 5 times its slowest time constant" in err
