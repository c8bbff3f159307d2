"""An initial state written as expressions of parameters (issue 29, item 6).

A model keeps each initial value as given: a number, or an expression of
parameters such as ``p = m*v0``.  A parameter only the initial state uses
(``v0``, ``theta0``) is given with the others and kept apart
(``initial_parameters``), out of the generated code; a model file writes the
expressions and those parameters, so ``--set theta0=…`` moves a saved model's
start as it moves the shipped one's.

Exact answers: the bouncing ball in flight, ``y = y0 + v0 t − g t²/2``,
``p = m (v0 − g t)``, so with ``p(0) = m v0`` the sensitivity
``∂p(t)/∂m = v0 − g t`` (with the start held fixed it would be ``−g t``)
and ``∂y(t)/∂v0``-like moves reach the model only through its parameters.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

import models
from bondgraph import BondGraph, C, One, ParameterValueError, R, Se
from bondgraph.errors import MissingParameterError, UnknownNameError
from models import bouncing_ball, falling_rod
from switching import HybridModel
from switching.files.modelfile import dumps_model, loads_model


def _rc():
    g = BondGraph("rc")
    loop = g.add(One("loop"))
    g.connect(Se("V", "V"), loop)
    g.connect(loop, R("R", "R"))
    g.connect(loop, C("C", "C"))
    return g


def test_an_initial_value_written_with_parameters_is_evaluated_and_kept_as_written():
    model = HybridModel(_rc(), [], {"V": 2.0, "R": 1.0, "C": 3.0, "v0": 0.5}, initial_state={"q_C": "C*v0"})
    assert model.given_initial_state == pytest.approx([1.5], rel=1e-15)
    (state, expr), = model.initial_expressions.items()
    assert state.name == "q_C" and sp.simplify(expr - sp.Symbol("C") * sp.Symbol("v0")) == 0
    assert model.initial_parameters == {sp.Symbol("v0"): 0.5}
    assert "v0" not in {s.name for s in model.parameter_symbols}  # not in the generated code


def test_new_parameter_values_move_the_initial_state_with_them():
    model = HybridModel(_rc(), [], {"V": 2.0, "R": 1.0, "C": 3.0, "v0": 0.5}, initial_state={"q_C": "C*v0"})
    model.set_parameter_values({"V": 2.0, "R": 1.0, "C": 4.0})
    assert model.given_initial_state == pytest.approx([2.0], rel=1e-15)
    model.set_parameter_values({"V": 2.0, "R": 1.0, "C": 4.0}, {"v0": -1.0})
    assert model.initial_state() == pytest.approx([-4.0], rel=1e-15)


def test_an_initial_value_without_its_parameter_or_not_finite_is_refused_naming_the_state():
    with pytest.raises(MissingParameterError) as info:
        HybridModel(_rc(), [], {"V": 2.0, "R": 1.0, "C": 3.0}, initial_state={"q_C": "C*v0"})
    assert info.value.missing == ("v0",) and "q_C" in str(info.value)
    with pytest.raises(ParameterValueError) as info:
        HybridModel(_rc(), [], {"V": 2.0, "R": 1.0, "C": 3.0, "v0": -1.0}, initial_state={"q_C": "C*log(v0)"})
    assert info.value.name == "q_C" and "real number" in str(info.value)
    with pytest.raises(ParameterValueError) as info:
        HybridModel(_rc(), [], {"V": 2.0, "R": 1.0, "C": 3.0, "v0": math.inf}, initial_state={"q_C": "C*v0"})
    assert info.value.name == "v0"
    with pytest.raises(UnknownNameError):
        HybridModel(_rc(), [], {"V": 2.0, "R": 1.0, "C": 3.0}, initial_state={"q_X": 1.0})


def test_the_sensitivity_to_a_parameter_the_start_is_written_with_follows_the_start():
    g, m, v0, t1 = 9.81, 2.0, 3.0, 0.25  # in flight until t = (v0 + sqrt(v0² + 2 g y0))/g ≈ 0.8 s
    model = bouncing_ball.build(m=m, v0=v0, y0=1.0)
    trajectory = model.simulate(t1, "RK45", rtol=1e-11, atol=1e-12, sensitivities=["m", "g"])
    assert trajectory.t[-1] == t1
    S = trajectory.sensitivities.S[-1]
    p, y = model.state_index[model.state("p")], model.state_index[model.state("y")]
    assert S[p, 0] == pytest.approx(v0 - g * t1, rel=1e-8)  # ∂(m (v0 − g t))/∂m: the start moves with m
    assert S[y, 0] == pytest.approx(0.0, abs=1e-10)
    assert S[p, 1] == pytest.approx(-m * t1, rel=1e-8) and S[y, 1] == pytest.approx(-t1**2 / 2, rel=1e-8)


@pytest.mark.parametrize("name, parameter, value", [
    ("bouncing_ball", "y0", 2.5), ("diode_circuit", "i0", 3.0), ("falling_rod", "theta0", 0.5),
    ("colliding_balls", "v1_0", 2.0), ("ball_chain", "distance", 0.3), ("parallel_capacitors", "V2", 3.0),
    ("boost_converter", "v_C0", 20.0), ("two_tanks", "h1_0", 0.4), ("vibrating_table", "gap0", 0.2),
    ("current_mode_converter", "v_C0", 15.0), ("rimless_wheel", "omega0", 1.2),
])
def test_a_saved_shipped_model_keeps_the_parameters_of_its_start(name, parameter, value, tmp_path):
    module = models.load(name)
    shipped = module.build(**{parameter: value})
    path = tmp_path / f"{name}.toml"
    shipped.save(path)
    loaded = models.load(path)
    np.testing.assert_array_equal(loaded.given_initial_state, shipped.given_initial_state)
    assert not np.array_equal(loaded.given_initial_state, module.build().given_initial_state)
    # and a new value moves the saved model's start as it moves the shipped one's
    moved, file_model = module.build(**{parameter: 2 * value}), models.load(path, **{parameter: 2 * value})
    np.testing.assert_array_equal(file_model.given_initial_state, moved.given_initial_state)


def test_every_shipped_model_writes_its_start_with_parameters():
    for name in models.MODELS:
        model = models.load(name).build()
        written = [e for e in model.initial_expressions.values() if e.free_symbols]
        assert written, f"{name}: its initial state is written as plain numbers; hbg save would lose its parameters"


def test_the_rod_saved_with_a_new_angle_runs_from_that_angle():
    rod = falling_rod.build(theta0=0.4)
    loaded = loads_model(dumps_model(rod))
    theta = loaded.state_index[loaded.state("rod/theta")]
    assert loaded.given_initial_state[theta] == 0.4
    assert {s.name for s in loaded.initial_parameters} == {"theta0", "y0", "x0"}


CLI_CASES = [("bouncing-ball", "y0=2.5"), ("diode-circuit", "i0=3"), ("falling-rod", "theta0=0.5"),
             ("falling-rod", "impact_law=newton-coulomb"), ("colliding-balls", "v1_0=2"),
             ("ball-chain", "distance=0.3"), ("parallel-capacitors", "V2=3"), ("boost-converter", "v_C0=20"),
             ("two-tanks", "h1_0=0.4"), ("vibrating-table", "gap0=0.2"),
             ("rimless-wheel", "omega0=1.2")]


@pytest.mark.parametrize("name, setting", CLI_CASES)
def test_hbg_save_then_run_file_writes_the_csv_of_hbg_run_model(name, setting, tmp_path, capsys):
    from models import cli

    path, shipped, saved = tmp_path / "model.toml", tmp_path / "shipped.csv", tmp_path / "saved.csv"
    assert cli.main(["save", name, "--set", setting, "-o", str(path)]) == 0
    assert cli.main(["run", name, "--set", setting, "--method", "RK45", "--csv", str(shipped)]) == 0
    assert cli.main(["run", str(path), "--method", "RK45", "--csv", str(saved)]) == 0
    assert saved.read_text() == shipped.read_text()
    parameter = setting.split("=")[0]
    if parameter != "impact_law":  # the start's parameter is the file's too: --set moves it alike
        value = f"{parameter}={2 * float(setting.split('=')[1])}"
        assert cli.main(["run", name, "--set", value, "--method", "RK45", "--csv", str(shipped)]) == 0
        assert cli.main(["run", str(path), "--set", value, "--method", "RK45", "--csv", str(saved)]) == 0
        assert saved.read_text() == shipped.read_text()
    capsys.readouterr()
