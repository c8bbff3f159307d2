"""FMUs of models (``switching.to_fmu``, ``hbg fmu``): checked by FMPy, their outputs the toolkit's run
at the communication points.

The FMU restarts the model's run at every communication point from the state and mode it kept, so it
equals *bit for bit* the toolkit's runs continued step by step with ``simulate(t0=, x0=, mode=)``, and
one run over the whole time sampled there (``t_eval``) to the integration error the method's ``rtol``
allows: both hold each step's local error to ``rtol`` relative, so they differ by a few hundred ``rtol``
at most over a run's 100 restarts (measured: 3e-10 relative for ``rtol = 1e-9``)."""

import sys

import numpy as np
import pytest

import models
from bondgraph.errors import MissingDependencyError
from models import bouncing_ball, diode_circuit
from models.circuits import Circuit, Input
from switching import ExpressionInput, to_fmu
from switching.errors import OptionValueError
from switching.files.fmu import CoSimulation, fmu_variables

REASON = "FMUs are written with pythonfmu and checked with FMPy: pip install 'hybrid-bondgraph[fmu]'"


@pytest.fixture(scope="module")
def fmpy():
    """FMPy, and pythonfmu with its FMI library for this platform (Linux x86-64, Windows 64-bit)."""
    builder = pytest.importorskip("pythonfmu.builder", reason=REASON)
    if not builder.FmuBuilder.has_binary():
        import platform

        pytest.skip(f"pythonfmu ships its FMI library for Linux x86-64 and Windows 64-bit only, not for "
                    f"{platform.system()} {platform.machine()}: FMUs cannot be built here")
    fmpy = pytest.importorskip("fmpy", reason=REASON)
    pytest.importorskip("fmpy.validation", reason=REASON)
    return fmpy


def problems(fmpy, path) -> list:
    from fmpy.validation import validate_fmu

    return validate_fmu(str(path))


@pytest.fixture(scope="module")
def ball_fmu(fmpy, tmp_path_factory):
    return to_fmu(bouncing_ball.build(), tmp_path_factory.mktemp("fmu") / "ball.fmu", rtol=1e-10, atol=1e-12,
                  t_end=1.0)


def continued(model, times, method="RK45", **options):
    """The states at ``times`` of runs continued from one communication point to the next, as the FMU runs."""
    x = model.initial_state()
    instant = model.resolve(x, model.starting_mode(x, times[0]), times[0])
    x, mode, rows = instant.x_after, instant.mode_after, [instant.x_after]
    for a, b in zip(times[:-1], times[1:]):
        run = model.simulate(b, method, t0=a, x0=x, mode=mode, output="events", **options)
        x, mode = run.x[-1], run.modes[-1]
        rows.append(x)
    return np.array(rows)


def test_an_fmu_of_the_diode_circuit_is_valid_and_its_outputs_are_the_run_at_the_communication_points(fmpy, tmp_path):
    model = diode_circuit.build()
    path = to_fmu(model, tmp_path / "diode.fmu", rtol=1e-9, atol=1e-12, t_end=1.0)
    assert problems(fmpy, path) == []
    result = fmpy.simulate_fmu(str(path), stop_time=1.0, output_interval=0.01)
    times = result["time"]
    assert len(times) == 101 and times[-1] == pytest.approx(1.0)
    run = model.simulate(1.0, "RK45", rtol=1e-9, atol=1e-12, t_eval=times)
    for name in ("p_L", "i_L", "v_L", "i_D", "v_D"):  # i_L ≤ 10 A, v ≤ 10 V: 1e-7 is 100 rtol of the scale
        np.testing.assert_allclose(result[name], run.signal(name), rtol=0, atol=1e-7, err_msg=name)
    labels = [m.states for m in run.modes]
    switch, diode = ([["closed", "open"][k] for k in result["mode.switch"]],
                     [["off", "on"][k] for k in result["mode.diode"]])
    assert list(zip(switch, diode)) == labels  # the switch opens at 0.5 s, the diode conducts, then blocks
    assert {"on", "off"} <= set(diode) and {"closed", "open"} <= set(switch)
    x = continued(model, times, rtol=1e-9, atol=1e-12)  # the FMU's arithmetic, step by step
    np.testing.assert_array_equal(result["p_L"], x[:, 0])


def test_an_fmu_declares_parameters_inputs_outputs_and_units():
    variables = {v.name: v for v in fmu_variables(diode_circuit.build(V=5.0))}
    assert (variables["V"].causality, variables["V"].variability, variables["V"].start) == ("parameter", "tunable", 5.0)
    assert variables["i0"].variability == "fixed"  # read by the initial state alone
    assert (variables["i_L"].causality, variables["i_L"].unit, variables["i_L"].start) == ("output", "A", None)
    assert variables["mode.diode"].kind == "mode" and variables["mode.diode"].variability == "discrete"
    assert "0 = off, 1 = on" in variables["mode.diode"].description
    tank = {v.name: v for v in fmu_variables(models.load(models.EXAMPLES / "check_valve_tank.toml"))}
    assert tank["Q_in"].causality == "input" and tank["Q_in"].start == 0.0  # Q0 (1 − exp(−t/tau)) at t = 0
    assert "Q0" not in tank and "tau" not in tank  # the input's own parameters: the master drives it


def test_a_parameter_set_as_a_start_value_changes_the_fmu_as_build_does(fmpy, ball_fmu):
    assert problems(fmpy, ball_fmu) == []
    default = fmpy.simulate_fmu(str(ball_fmu), stop_time=1.0, output_interval=0.01)
    changed = fmpy.simulate_fmu(str(ball_fmu), stop_time=1.0, output_interval=0.01,
                                start_values={"e": 0.6, "y0": 0.5})  # tunable and fixed
    for result, model in ((default, bouncing_ball.build()), (changed, bouncing_ball.build(e=0.6, y0=0.5))):
        run = model.simulate(1.0, "RK45", rtol=1e-10, atol=1e-12, t_eval=result["time"])
        for name in ("y", "v"):  # a free flight is a parabola RK45 integrates exactly: round-off apart
            np.testing.assert_allclose(result[name], run.signal(name), rtol=0, atol=1e-9, err_msg=name)
    assert changed["y"][0] == 0.5 and np.max(np.abs(changed["y"] - default["y"])) > 0.1
    assert np.count_nonzero(np.diff(changed["v"]) > 0) == 3  # bounces at 0.319, 0.702 and 0.932 s


def test_a_step_that_fails_is_discarded_where_it_began(fmpy, ball_fmu):
    """With e = 0.5 the bounces pile up at t∞ = t₁(1 + e)/(1 − e) = 1.3546 s: the run of the step across it
    raises the ZenoError, and the FMU answers fmi2Discard with the state where the step began."""
    messages = []
    result = fmpy.simulate_fmu(str(ball_fmu), stop_time=1.5, output_interval=0.01, start_values={"e": 0.5},
                               debug_logging=True, logger=lambda *a: messages.append(a[4].decode()))
    assert result["time"][-1] == pytest.approx(1.35) and 0 <= result["y"][-1] < 1e-4
    assert any("failed: Zeno behaviour" in m and "1.35457" in m for m in messages)


def peak_detector(u):
    """A source driven by the declared input ``u`` charging a capacitor through a resistor and a diode."""
    c = Circuit("peak_detector")
    c.V("Vs", "in", "0", Input("u"))
    c.R("R1", "in", "a", 100.0)
    c.diode("D1", "a", "out")
    c.C("C1", "out", "0", 1e-4, v0=0.0)
    c.R("Rload", "out", "0", 1e3)
    return c.build(inputs={"u": u})


def test_an_input_driven_by_fmpy_is_held_over_each_step(fmpy, tmp_path):
    model = peak_detector(lambda t: 0.0)  # an input given as a Python function: the FMU's start value is its u(0)
    path = to_fmu(model, tmp_path / "peak.fmu", rtol=1e-9, atol=1e-12)
    assert problems(fmpy, path) == []
    signal = np.array([(0.0, 0.0), (0.01, 0.0), (0.01, 5.0), (0.03, 5.0), (0.03, 2.0), (0.06, 2.0)],
                      dtype=[("time", float), ("u", float)])  # 5 V from 10 ms, 2 V from 30 ms
    result = fmpy.simulate_fmu(str(path), stop_time=0.06, output_interval=0.001, input=signal)
    times = result["time"]
    run = peak_detector(ExpressionInput("5*step(t - 0.01) - 3*step(t - 0.03)")).simulate(
        0.06, "RK45", rtol=1e-9, atol=1e-12, t_eval=times)
    np.testing.assert_allclose(result["q_C1"], run.signal("q_C1"), rtol=0, atol=1e-11)  # q ≤ 4e-4 C
    # at 10 and 30 ms the outputs are read before the master sets the input's new value: the run's just after
    later = ~np.isclose(times, 0.01) & ~np.isclose(times, 0.03)
    for name in ("v_out", "i_D1", "v_in"):
        np.testing.assert_allclose(result[name][later], run.signal(name)[later], rtol=0, atol=1e-7, err_msg=name)
    states = list(model.automata[model.automaton_index["D1"]].states)
    diode = [states[k] for k in result["mode.D1"]]  # the run's modes (at the input's steps: the ones before)
    assert [d for d, keep in zip(diode, later) if keep] == [m.state_of("D1") for m, keep in zip(run.modes, later) if keep]
    assert (diode[0], diode[15], diode[-1]) == ("blocking", "conducting", "blocking")


def test_hbg_fmu_writes_an_fmu_with_the_run_settings(fmpy, tmp_path, capsys):
    from models.cli import main

    path = tmp_path / "diode.fmu"
    assert main(["fmu", "diode-circuit", "-o", str(path), "--rtol", "1e-9", "--set", "V=5"]) == 0
    assert "wrote" in capsys.readouterr().out and problems(fmpy, path) == []
    description = fmpy.read_model_description(str(path))
    assert description.coSimulation.modelIdentifier == "diode_circuit"
    assert (description.defaultExperiment.stopTime, description.defaultExperiment.tolerance) == ("1.0", "1e-09")
    variables = {v.name: v for v in description.modelVariables}
    assert float(variables["V"].start) == 5.0 and variables["i_L"].unit == "A"
    assert main(["fmu", "diode-circuit", "-o", str(tmp_path / "x.fmu"), "--method", "auto"]) == 2
    assert main(["fmu", "diode-circuit", "-o", str(tmp_path / "x.zip")]) == 2
    assert "auto" in capsys.readouterr().err


def test_the_settings_are_checked_before_anything_is_written(tmp_path):
    with pytest.raises(OptionValueError, match="one method"):
        to_fmu(diode_circuit.build(), tmp_path / "d.fmu", method="auto")
    with pytest.raises(OptionValueError, match="holds its inputs"):
        to_fmu(peak_detector(lambda t: 0.0), tmp_path / "p.fmu", method="RK45-jit")
    with pytest.raises(OptionValueError, match="dt"):
        to_fmu(diode_circuit.build(), tmp_path / "d.fmu", method="rk4")
    with pytest.raises(OptionValueError, match="rtol"):
        to_fmu(diode_circuit.build(), tmp_path / "d.fmu", rtol=-1.0)
    assert not list(tmp_path.iterdir())


def test_without_pythonfmu_the_error_names_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pythonfmu", None)  # import pythonfmu → ImportError
    monkeypatch.setitem(sys.modules, "pythonfmu.builder", None)
    with pytest.raises(MissingDependencyError, match=r"hybrid-bondgraph\[fmu\]"):
        to_fmu(diode_circuit.build(), tmp_path / "d.fmu")


def test_a_co_simulation_holds_its_inputs_and_applies_a_parameter_from_the_next_step():
    from switching.files.modelfile import dumps_model, loads_model

    stepped = peak_detector(ExpressionInput("5*step(t - 1)"))  # read into the source's law: another fingerprint
    text = dumps_model(stepped, inputs={"u": ExpressionInput(0.0)})  # as to_fmu writes it: the start value
    assert 'u = "0.0"' in text and "step" not in text
    cosim = CoSimulation(loads_model(text), "RK45", {"rtol": 1e-9, "atol": 1e-12})  # a model of its own, as an FMU's
    states = list(cosim.model.automata[cosim.model.automaton_index["D1"]].states)
    blocking, conducting = states.index("blocking"), states.index("conducting")
    cosim.start(0.0)
    assert cosim.outputs()["mode.D1"] == blocking and cosim.outputs()["v_out"] == 0.0  # C1 empty
    cosim.set_input("u", 5.0)
    assert cosim.outputs()["v_in"] == 5.0  # the source follows its input at once (outputs read after the set)
    cosim.step(0.0, 0.01)
    charged = cosim.outputs()["v_out"]
    assert cosim.outputs()["mode.D1"] == conducting and 0 < charged < 5.0
    reference = peak_detector(lambda t: 5.0).simulate(0.01, "RK45", rtol=1e-9, atol=1e-12)
    assert charged == pytest.approx(reference.signal("v_out")[-1], abs=1e-7)
    cosim.set_parameter("Rload", 10.0)  # a heavy load from now on: C1 discharges below what it was
    assert {s.name: v for s, v in cosim.model.parameter_values.items()}["Rload"] == 1e3  # until the next step
    cosim.set_input("u", 0.0)
    cosim.step(0.01, 0.01)
    assert cosim.outputs()["v_out"] < 0.2 * charged and cosim.outputs()["mode.D1"] == blocking
