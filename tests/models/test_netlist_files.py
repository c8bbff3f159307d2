"""Model files of netlists (models/netlist_files.py): a model built by Circuit or Mechanism saves as its
components — a [circuit] or [mechanism] table, one line a component — and loads back to the same model
(the same equations, the same run to the bit); Python-function inputs are refused, as is a bad line,
naming the file, the line and the component; ``hbg save`` of a circuit writes the netlist form."""

import pickle
import subprocess
import sys
import warnings

import numpy as np
import pytest
import sympy as sp
import tomllib
from test_controllers import closed_loop_buck
from test_spice_netlists import NETLISTS

import models
from models import cli, netlists, spice
from models.circuits import PWM, Circuit, Hysteresis, Input
from models.mechanics import Mechanism
from models.netlist_files import dumps_netlist, loads_netlist
from switching import load_model
from switching.files.errors import ModelFileError
from switching.files.modelfile import ModelFile
from switching.files.read import Reader
from switching.model.expression_input import ExpressionInput
from switching.model.hybrid_model import Tolerance

# ---------------------------------------------------------------------------------------------- the models


def spice_model(name):
    return spice.read(NETLISTS[name]).build()


def half_bridge_buck():
    c = Circuit("half_bridge")
    c.V("V1", "in", "0", 12.0)
    c.half_bridge("HB", "in", "0", "sw", 1e-5, 0.4, 1e-7, r_on=0.01)
    c.L("L1", "sw", "out", 1e-4, i0=0.5)
    c.C("C1", "out", "0", 1e-5)
    c.R("R1", "out", "0", 5.0)
    return c.build()


def machines():
    """A transformer and a DC machine (a gyrator) off one sine source, a relay with hysteresis."""
    c = Circuit("machines")
    c.V("V1", "a", "0", "10*sin(2*pi*50*t)")
    c.transformer("T1", "a", "0", "b", "0", 2.0)
    c.R("R1", "b", "0", 10.0)
    c.dc_machine("M", "a", "c", "w", "0", 0.1)
    c.R("Ra", "c", "0", 1.0)
    c.L("J", "w", "m", 1e-3)
    c.R("bw", "m", "0", 1e-3)
    c.switch("S1", "b", "d", Hysteresis("v_b", 5.0, 2.0), r_on=0.1)
    c.C("Cd", "d", "0", 1e-5)
    return c.build()


def stepped_rc():
    c = Circuit("stepped")
    c.V("Vs", "in", "0", Input("u"))
    c.R("R1", "in", "out", "R_load")
    c.C("C1", "out", "0", 1e-6, v0=1.0)
    return c.build(parameters={"R_load": 1e3}, inputs={"u": ExpressionInput("A*step(t - 1e-3)", {"A": 5.0})},
                   tolerance=Tolerance(rtol=1e-12), max_steps_per_instant=50)


def gearbox():
    box = Mechanism("gearbox", "rotational")
    box.inertia("J_m", "m", 2.0, omega0=8.0)
    box.gear("G", "m", "out", 4.0)
    box.stop("end", "out", upper=1.0, e=0.5)
    return box.build()


def drive():
    d = Mechanism("drive", "rotational")
    d.inertia("J1", "a", 2.0, omega0=10.0)
    d.clutch("K", "a", "b", engaged_when="t >= 0.5", T_max=5.0)
    d.inertia("J2", "b", 3.0)
    return d.build()


def machine():
    """Masses, a cubic spring (a law), a damper, a stop, a backlash, a motor with a text voltage, positions."""
    m = Mechanism("machine")
    m.mass("m1", "a", 2.0, x0=1.0)
    m.force("g", "a", -19.62)
    m.stop("floor", "a", lower=0.0, e=0.5)
    m.spring("k1", "a", "b", effort_law=lambda q: 100 * q + 10 * q**3)
    m.mass("m2", "b", 1.0)
    m.damper("dmp", "b", "0", 0.5)
    m.backlash("bl", "b", "c", 0.1, e=0.2)
    m.mass("m3", "c", "m_3")
    m.motor("Mo", "c", 0.1, V="10*sin(t)", R=1.0, L=1e-3, i0=0.1)
    m.position("c", 0.05)
    return m.build(parameters={"m_3": 1.5})


def digital_buck():
    """A sampled PI (a digital controller) setting a sawtooth-carrier PWM's duty."""
    c = Circuit("digital_buck")
    c.V("Vin", "in", "0", 24.0)
    c.switch("S", "in", "sw", PWM(1e-5, "PI1", carrier="sawtooth"))
    c.diode("D1", "0", "sw")
    c.L("L", "sw", "out", 100e-6)
    c.C("C", "out", "0", 100e-6, v0=12.0)
    c.R("RL", "out", "0", 12.0)
    c.pi("PI1", "v_out", 12.0, kp=0.003, ki=20.0, limits=(0.0, 0.95), initial=0.5, sample_period=1e-5,
         sample_delay=5e-6)
    return c.build()


#: name → (the model's builder, the run's end [s])
CASES = {
    "digital buck (sampled PI, sawtooth PWM)": (digital_buck, 5e-5),
    "ideal buck": (lambda: netlists.ideal_buck().build(), 5e-5),
    "bridge rectifier": (lambda: netlists.bridges(1).build(), 2e-3),
    "bridge rectifier with gmin": (lambda: netlists.bridges(1).build(gmin=1e-12), 2e-3),
    "closed-loop buck (PI, modulated PWM)": (closed_loop_buck, 1e-4),
    "half-bridge (MOSFETs, dead time)": (half_bridge_buck, 3e-5),
    "transformer, DC machine, hysteresis": (machines, 2e-3),
    "expression input, tolerance": (stepped_rc, 3e-3),
    "SPICE half-wave (exponential diode law)": (lambda: spice_model("halfwave"), 3e-3),
    "SPICE flyback (coupled inductors)": (lambda: spice_model("flyback"), 5e-5),
    "SPICE relay (switch with hysteresis)": (lambda: spice_model("relay"), 5e-4),
    "SPICE parameters": (lambda: spice_model("params"), 1e-4),
    "gearbox against a stop": (gearbox, 1.0),
    "friction clutch": (drive, 1.0),
    "masses, laws, backlash, motor": (machine, 0.3),
}


def quiet_run(model, t_end):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return model.simulate(t_end)


# ---------------------------------------------------------------------------------------------- round trips


@pytest.mark.parametrize("case", CASES)
def test_a_netlist_model_saves_as_its_components_and_loads_to_the_same_model(case, tmp_path):
    build, t_end = CASES[case]
    model = build()
    path = tmp_path / "model.toml"
    model.save(path, run={"t_end": t_end})
    text = path.read_text()
    assert {"circuit", "mechanism"} & set(tomllib.loads(text))  # (its netlist, not its bond graph)
    again = load_model(path)
    again.save(path)
    assert path.read_text() == text  # (saved again: the same text)
    assert again.fingerprint == model.fingerprint
    mode = model.initial_mode
    ours, theirs = model.mode_equations(mode), again.mode_equations(again.mode(mode.states))
    assert ours.f.keys() == theirs.f.keys()
    assert all(sp.simplify(ours.f[s] - theirs.f[s]) == 0 for s in ours.f)
    assert dict(again.parameter_values) == dict(model.parameter_values)
    first, second = quiet_run(model, t_end), quiet_run(again, t_end)
    assert np.array_equal(first.t, second.t) and np.array_equal(first.x, second.x)
    assert [e.t for e in first.events] == [e.t for e in second.events]
    # the same netlist: every component's part as built (laws, functions of one argument, by their values)
    parts = model.built_from.netlist._parts
    read = again.built_from.netlist._parts
    assert list(read) == list(parts)
    for name, part in parts.items():
        values = {k: v for k, v in part.values.items() if k != "law"}
        assert (read[name].kind, read[name].nodes) == (part.kind, part.nodes)
        assert {k: v for k, v in read[name].values.items() if k != "law"} == values, name


@pytest.mark.parametrize("case", ["ideal buck", "friction clutch", "masses, laws, backlash, motor"])
def test_the_saved_text_shows_one_line_a_component_and_no_bond_graph(case, tmp_path):
    model = CASES[case][0]()
    path = tmp_path / "model.toml"
    model.save(path)
    text = path.read_text()
    table = tomllib.loads(text)
    word = "circuit" if isinstance(model.built_from.netlist, Circuit) else "mechanism"
    components = model.built_from.netlist.components
    assert list(table[word]) == list(components)
    lines = text.splitlines()
    for name in components:
        assert sum(line.startswith(f"{name} = {{ type = ") for line in lines) == 1, name
    assert not {"elements", "bonds", "automata", "signals", "displacements"} & set(table)
    assert table["run"]["t_end"] > 0  # (model.save always writes a run)


def test_the_lines_say_the_builder_calls_in_their_words():
    text = dumps_netlist(closed_loop_buck())
    assert 'S = { type = "switch", nodes = ["in", "sw"], closed_when = { period = 1e-05, duty = "PI1" } }' in text
    assert 'C = { type = "C", nodes = ["out", "0"], value = 0.0001, v0 = 12.0 }  # value: F, v0: V' in text
    assert ('PI1 = { type = "pid", measure = "v_out", reference = 12.0, kp = 0.02, ki = 200.0, '
            'limits = { lo = 0.0, hi = 0.95 }, initial = 0.5 }') in text
    assert '[build]\ngmin = 1e-12' in dumps_netlist(netlists.bridges(1).build(gmin=1e-12))
    text = dumps_netlist(gearbox())
    assert 'J_m = { type = "inertia", nodes = ["m"], J = 2.0, omega0 = 8.0 }  # J: kg·m², omega0: rad/s' in text
    assert 'end = { type = "stop", nodes = ["out"], upper = 1.0, e = 0.5 }  # upper: rad' in text
    assert '[build]\nkind = "rotational"' in text
    text = dumps_netlist(stepped_rc())
    assert '[build]\ntolerance = { rtol = 1e-12 }\nmax_steps_per_instant = 50' in text
    assert 'u = { expression = "A*step(t - 0.001)", parameters = { A = 5.0 } }' in text
    assert '[parameters]\nR_load = 1000.0' in text


def test_a_model_built_as_a_bond_graph_keeps_the_bond_graph_form(tmp_path):
    path = tmp_path / "ball.toml"
    models.load("bouncing_ball").build().save(path)
    table = tomllib.loads(path.read_text())
    assert "elements" in table and "bonds" in table and not {"circuit", "mechanism"} & set(table)


def test_values_set_after_the_build_are_written_as_its_parameters(tmp_path):
    model = netlists.ideal_buck().build()
    model.set_parameter_values({**{s.name: v for s, v in model.parameter_values.items()}, "R1": 2.5})
    path = tmp_path / "buck.toml"
    model.save(path)
    assert "[parameters]\nR1 = 2.5" in path.read_text()
    again = load_model(path)
    assert dict(again.parameter_values) == dict(model.parameter_values)
    first, second = quiet_run(model, 3e-5), quiet_run(again, 3e-5)
    assert np.array_equal(first.t, second.t) and np.array_equal(first.x, second.x)


def test_a_model_changed_otherwise_after_its_build_is_written_as_its_bond_graph_saying_why(tmp_path):
    model = netlists.ideal_buck().build()
    model.tolerance = Tolerance(rtol=1e-10)
    path = tmp_path / "buck.toml"
    model.save(path)
    text = path.read_text()
    assert text.startswith("# Written as its bond graph, not its circuit: its tolerances differ")
    assert "[elements]" in text and load_model(path).tolerance == Tolerance(rtol=1e-10)


# ---------------------------------------------------------------------------------------------- what no file holds


def test_a_model_with_python_function_inputs_is_refused_naming_the_input(tmp_path):
    c = Circuit("driven")
    c.V("Vs", "in", "0", Input("u"))
    c.R("R1", "in", "0", 1.0)
    model = c.build(inputs={"u": np.sin})
    path = tmp_path / "driven.toml"
    with pytest.raises(ModelFileError) as caught:
        model.save(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: input 'u': is a Python function")
    assert "ExpressionInput" in message and not path.exists()


def test_a_value_no_text_can_say_is_refused_naming_the_component():
    c = Circuit("odd")
    c.V("V1", "a", "0", 1.0)
    c.R("R1", "a", "0", sp.gamma(sp.Symbol("x")) + 1)
    model = c.build(parameters={"x": 2.0})
    with pytest.raises(ModelFileError, match=r"component 'R1': its value cannot be written to a model file"):
        dumps_netlist(model)


# ---------------------------------------------------------------------------------------------- refusals

GOOD = """hbg_model_format = 1
name = "rc"

[circuit]
V1 = { type = "V", nodes = ["in", "0"], value = 10.0 }
R1 = {line}
C1 = { type = "C", nodes = ["out", "0"], value = 1e-06 }
"""


@pytest.mark.parametrize("line, said", [
    ('5.0', "a component is a table"),
    ('{ type = "R", nodes = "in", value = 1000.0 }', "R takes 2 nodes, [n1, n2], as texts; got 'in'"),
    ('{ type = "R", nodes = ["in", "out"], value = 1000.0, colour = "red" }', "unknown key 'colour'"),
    ('{ type = "R", nodes = ["in", "out"], value = [1, 2] }', "value must be a number, a text"),
    ('{ type = "resistor", nodes = ["in", "out"], value = 1000.0 }', "unknown component type 'resistor'"),
    ('{ type = ["R"], nodes = ["in", "out"], value = 1000.0 }', "unknown component type ['R']"),
    ('{ type = "R", nodes = ["in-1", "out"], value = 1000.0 }', "invalid node name 'in-1'"),
    ('{ type = "R", nodes = ["in", "out"], value = { expression = "__import__(1)" } }', "cannot be read"),
    ('{ type = "R", nodes = ["in", "out"], value = -1.0, flow_law = { of = "v", law = "eval(v)" } }',
     "cannot be read"),
])
def test_a_bad_component_line_is_refused_naming_the_file_the_line_and_the_component(line, said, tmp_path):
    path = tmp_path / "rc.toml"
    path.write_text(GOOD.replace("{line}", line))
    with pytest.raises(ModelFileError) as caught:
        models.load(path)
    error = caught.value
    assert str(error).startswith(f"{path}:6: component 'R1': ")
    assert said in str(error)
    assert error.path == str(path) and error.line == 6 and error.culprit == "component 'R1'"


def test_an_unknown_type_is_answered_with_the_types_and_the_closest():
    text = GOOD.replace("{line}", '{ type = "diod", nodes = ["in", "out"] }')
    with pytest.raises(ModelFileError, match=r"unknown component type 'diod' \(did you mean 'diode'\?\); a circuit's "
                                             r"types: R, C, L, V, I, diode, switch, transformer, gyrator, "
                                             r"coupled_inductors, pid$"):
        loads_netlist(text)


def test_a_source_that_calls_a_function_outside_the_grammar_is_refused_at_its_line(tmp_path):
    path = tmp_path / "rc.toml"
    path.write_text(GOOD.replace("{line}", '{ type = "R", nodes = ["in", "out"], value = 1000.0 }')
                    .replace("value = 10.0", 'value = "system(t)"'))
    with pytest.raises(ModelFileError) as caught:
        load_model(path)
    assert str(caught.value).startswith(f"{path}:5: component 'V1': value 'system(t)' cannot be read")


def test_what_the_builder_refuses_is_refused_at_the_components_line(tmp_path):
    path = tmp_path / "rc.toml"
    path.write_text(GOOD.replace("{line}", '{ type = "R", nodes = ["in", "in"], value = 1000.0 }'))
    with pytest.raises(ModelFileError, match=rf"^{path}:6: component 'R1': component 'R1' has both terminals"):
        models.load(path)
    text = GOOD.replace("{line}", '{ type = "R", nodes = ["in", "loose"], value = 1000.0 }')
    with pytest.raises(ModelFileError, match=r"^<text>:6: component 'R1': node 'loose' of 'R1' is connected to "
                                             r"nothing else"):
        loads_netlist(text)


def test_a_netlist_file_read_as_a_bond_graph_says_what_reads_it(tmp_path):
    path = tmp_path / "rc.toml"
    path.write_text(GOOD.replace("{line}", '{ type = "R", nodes = ["in", "out"], value = 1000.0 }'))
    with pytest.raises(ModelFileError, match=r"holds a \[circuit\] table, a Circuit's netlist, which the models "
                                             r"package reads: load it with models.load\(path\)"):
        Reader().read_path(path)


# ---------------------------------------------------------------------------------------------- the command line


def test_hbg_save_of_a_circuit_writes_its_netlist_and_hbg_runs_it(tmp_path, capsys):
    netlist = tmp_path / "buck.cir"
    netlist.write_text(NETLISTS["buck"])
    saved = tmp_path / "buck.toml"
    assert cli.main(["save", str(netlist), "-o", str(saved), "--set", "R1=4"]) == cli.EXIT_OK
    table = tomllib.loads(saved.read_text())
    assert list(table["circuit"]) == ["V1", "S1", "D1", "RS_D1", "L1", "C1", "R1"]  # (the diode's RS a resistor)
    assert table["circuit"]["S1"]["closed_when"] == {"period": 1e-05, "duty": 0.5, "delay": 5e-10}  # (edges midway)
    assert table["parameters"] == {"R1": 4.0} and table["run"]["t_end"] == 1e-3
    assert table["run"]["signals"] == ["v_in", "v_sw", "v_D1_rs", "v_out"] and "elements" not in table
    capsys.readouterr()
    assert cli.main(["run", str(saved), "--t-end", "2e-5", "--quiet"]) == cli.EXIT_OK
    original = spice.read(netlist).build(R1=4.0)
    assert models.load(saved).fingerprint == original.fingerprint
    first, second = quiet_run(original, 2e-5), quiet_run(models.load(saved), 2e-5)
    assert np.array_equal(first.t, second.t) and np.array_equal(first.x, second.x)


def test_a_netlist_file_pickled_is_read_again_in_a_process_that_never_imported_models(tmp_path):
    """A sweep's worker unpickles the ModelFile: the form's module is imported before the file is read."""
    path = tmp_path / "buck.toml"
    netlists.ideal_buck().build().save(path, run={"t_end": 1e-4})
    source = ModelFile(path)
    assert source.form_module == "models" and source.RUN == {"t_end": 1e-4}
    script = ("import pickle, sys; source = pickle.loads(sys.stdin.buffer.read()); "
              "print(sorted(sys.modules.keys() & {'models', 'models.circuits'}), source.build().fingerprint)")
    done = subprocess.run([sys.executable, "-c", script], input=pickle.dumps(source), capture_output=True, timeout=120,
                          check=False)
    assert done.returncode == 0, done.stderr.decode()
    assert done.stdout.decode().split() == ["['models',", "'models.circuits']", source.build().fingerprint]


def test_the_module_example_runs():
    import doctest

    from models import netlist_files

    result = doctest.testmod(netlist_files, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted == 9 and result.failed == 0
