"""One namespace: the fourth audit's cases of a name a user writes becoming
another quantity (issue "One namespace"), each now a right answer or a
refusal naming both owners; and the builders' value checks."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from bondgraph import BondGraph, C, One, R, Se
from bondgraph.errors import NameCollisionError, ParameterValueError, PhysicalRangeWarning
from models.circuits import PWM, Circuit
from models.mechanics import Mechanism
from switching import Automaton, HybridModel


def refused(build, name: str, *owners: str) -> str:
    """Building refuses ``name``, naming both ``owners`` (parts of their descriptions) and a fix."""
    with pytest.raises(NameCollisionError) as info:
        build()
    message = str(info.value)
    assert info.value.name == name and repr(name) in message, message
    assert all(owner in message for owner in owners), message
    assert "rename" in message or "give" in message, message
    return message


# -- the audit's cases, one by one


def pwm_circuit(load: str, period=1e-3) -> Circuit:
    c = Circuit("pwm")
    c.V("V1", "in", "0", 10.0)
    c.switch("S1", "in", "a", PWM(period, 0.5))
    c.R(load, "a", "0", 1000.0)
    return c


def test_a_resistor_named_like_a_pwm_period_is_refused_and_a_period_named_by_the_user_runs():
    refused(lambda: pwm_circuit("S1_period").build(), "S1_period", "the PWM period of switch 'S1'",
            "the resistance of R 'S1_period'")
    model = pwm_circuit("S1_period", period="T_pwm").build(parameters={"T_pwm": 1e-3})
    run = model.simulate(2e-4, "RK45", rtol=1e-9, max_step=1e-4)  # closed for the first half period
    assert run.signal("i_S1_period")[-1] == pytest.approx(0.01, rel=1e-9)


def test_a_resistor_named_like_a_diode_drop_or_gmin_is_refused():
    c = Circuit("drop")
    c.V("V1", "in", "0", 10.0)
    c.diode("D1", "in", "a", v_f=0.7)
    c.R("D1_v_f", "a", "0", 1000.0)
    refused(c.build, "D1_v_f", "the forward drop v_f of diode 'D1'", "the resistance of R 'D1_v_f'")
    c = Circuit("leak")
    c.V("V1", "in", "0", 10.0)
    c.diode("D1", "in", "a")
    c.R("gmin", "a", "0", 1000.0)
    refused(lambda: c.build(gmin=1e-12), "gmin", "the leak conductance gmin", "the resistance of R 'gmin'")


def test_a_spring_named_like_a_stops_restitution_is_refused():
    m = Mechanism("m")
    m.mass("m1", "a", 1.0, x0=1.0)
    m.force("g", "a", -9.81)
    m.stop("floor", "a", lower=0.0, e=0.5)
    m.spring("floor_e", "a", "b", 100.0)
    m.mass("m2", "b", 1.0)
    refused(m.build, "floor_e", "the restitution e of stop 'floor'", "the stiffness of spring 'floor_e'")


@pytest.mark.parametrize("resistor_first", [False, True])
def test_a_resistor_named_like_a_diodes_bond_reads_its_own_voltage(resistor_first):
    c = Circuit("bonds")
    c.V("V1", "in", "0", 10.0)
    parts = [lambda: c.diode("D1", "a", "in"), lambda: c.R("D1_in", "in", "a", 1000.0)]
    for add in (parts[::-1] if resistor_first else parts):
        add()
    c.R("RL", "a", "0", 1000.0)
    run = c.build().simulate(1e-4, "RK45", rtol=1e-10)
    assert run.signal("v_D1_in")[-1] == pytest.approx(5.0, rel=1e-12)   # the resistor's, not the diode's
    assert run.signal("v_D1")[-1] == pytest.approx(-5.0, rel=1e-12)


def clocked_graph(bond_name: str):
    """A source driven by the text parameter ``f_sw``; a resistor on a bond named ``bond_name``."""
    g = BondGraph("clocked")
    j = g.add(One("j", controlled=True))
    g.connect(Se("V", "V"), j)
    g.connect(j, R("Rs", "Rs"), name=bond_name)
    g.connect(j, C("C", "C"))
    a = Automaton("sw", {"on": {"j": True}, "off": {"j": False}}, initial="on")
    a.add_transition("on", "off", "clock < 0")
    a.add_transition("off", "on", "clock >= 0")
    return g, [a], {"clock": "sin(2*pi*f_sw*t)"}


def test_a_parameter_named_like_a_bonds_flow_is_refused_naming_the_bond():
    values = {"V": 1.0, "Rs": 1.0, "C": 1e-3, "f_sw": 50.0}
    g, automata, signals = clocked_graph("sw")
    refused(lambda: HybridModel(g, automata, values, signals=signals), "f_sw", "the flow of bond 'sw'",
            "a parameter")
    given = {k: v for k, v in values.items() if k != "f_sw"}  # no value for f_sw: the text reads the flow
    g, automata, signals = clocked_graph("sw")
    model = HybridModel(g, automata, given, signals=signals)
    assert model.namespace.owner("f_sw").kind == "bond variable" and "f_sw" not in model.namespace.names("parameter")
    g, automata, signals = clocked_graph("Rs")  # a bond of another name: f_sw is the parameter
    model = HybridModel(g, automata, values, signals=signals)
    assert {s.name for s in model.parameter_symbols} == {"V", "Rs", "C", "f_sw"}


@pytest.mark.parametrize("name, owner", [("t", "the time t"), ("f_R1", "the flow of bond 'R1'"),
                                         ("q_C1", "the state of C 'C1'")])
def test_a_component_named_like_time_a_bond_variable_or_a_state_is_refused_saying_which(name, owner):
    c = Circuit("c5")
    c.V("V1", "in", "0", 10.0)
    c.R("R1", "in", "a", 1e3)
    c.C("C1", "a", "0", 1e-6)
    c.R(name, "a", "0", 1e3)
    refused(c.build, name, owner, f"the resistance of R {name!r}")


def test_masses_and_dampers_named_like_states_or_a_motors_parameters_are_refused():
    m = Mechanism("m")
    m.mass("x_a", "a", 1.0)
    m.force("F", "a", 1.0)
    refused(m.build, "x_a", "the position of node 'a'", "the mass of mass 'x_a'")
    m = Mechanism("m")
    m.mass("m1", "a", 1.0)
    m.force("F", "a", 1.0)
    m.damper("p_m1", "a", "0", 1.0)
    refused(m.build, "p_m1", "the momentum of mass 'm1'", "the damping of damper 'p_m1'")
    m = Mechanism("m", kind="rotational")
    m.motor("M", "w", 0.1, V=12.0, R=2.0)
    m.inertia("J", "w", 1e-3)
    m.damper("M_R", "w", "0", 1e-3)
    refused(m.build, "M_R", "the armature resistance R of motor 'M'", "the damping of damper 'M_R'")


def test_a_hybrid_models_given_parameter_named_like_time_or_a_state_is_refused():
    g = BondGraph("rc")
    j = g.add(One("j"))
    g.connect(Se("V", "V"), j)
    g.connect(j, R("R", "R"))
    g.connect(j, C("C", "C"))
    for name, owner in (("t", "the time t"), ("q_C", "the state of C 'C'"), ("e_R", "the effort of bond 'R'")):
        refused(lambda: HybridModel(g, [], {"V": 1.0, "R": 1.0, "C": 1.0, name: 2.0}), name, owner)


def test_a_shared_value_is_named_by_the_user_and_a_component_number_is_not_shared_by_name():
    c = Circuit("shared")
    c.V("V1", "in", "0", 10.0)
    c.R("R1", "in", "a", 100.0)
    c.R("R2", "a", "0", "R1")  # R1 is the parameter R1's number makes: not the user's to share
    refused(c.build, "R1", "the resistance of R 'R1'", "a name the user gave")
    c = Circuit("shared")
    c.V("V1", "in", "0", 10.0)
    c.R("R1", "in", "a", "R_x")
    c.R("R2", "a", "0", "R_x")
    run = c.build(parameters={"R_x": 100.0}).simulate(1e-3, "RK45")
    assert run.signal("v_a")[-1] == pytest.approx(5.0, rel=1e-12)
    c = Circuit("text")  # a condition reads a parameter the user named, never a component's number
    c.V("V1", "in", "0", 10.0)
    c.switch("S1", "in", "a", "t >= R1")
    c.R("R1", "a", "0", 100.0)
    refused(c.build, "R1", "the resistance of R 'R1'", "a name the user gave")


@pytest.mark.parametrize("name", ["node_a", "branch_R1", "D1_drop", "D1_resistance", "D1_ground", "D1_out"])
def test_components_named_like_the_builders_own_elements_and_bonds_run_as_with_fresh_names(name):
    def circuit(resistor):
        c = Circuit("internal")
        c.V("V1", "in", "0", "10*sin(2*pi*50*t)")
        c.R("R1", "in", "a", 10.0)
        c.diode("D1", "a", "0", r_on=0.5, v_f=0.7)
        c.R(resistor, "a", "0", 100.0)
        return c.build().simulate(0.02, "RK45", rtol=1e-10)

    run, fresh = circuit(name), circuit("Zq_load")
    np.testing.assert_allclose(run.event_times, fresh.event_times, rtol=1e-12)
    np.testing.assert_allclose(run.signal(f"i_{name}"), fresh.signal("i_Zq_load"), rtol=1e-9, atol=1e-12)


# -- builder values: one check, naming the component and the argument


@pytest.mark.parametrize("add, words", [
    (lambda c: c.C("C1", "a", "0", 1e-6, v0="abc"), "initial voltage v0 of C 'C1'"),
    (lambda c: c.C("C1", "a", "0", 1e-6, v0=1j), "initial voltage v0 of C 'C1'"),
    (lambda c: c.R("R2", "a", "0", np.complex128(1 + 2j)), "resistance of R 'R2'"),
    (lambda c: c.R("R2", "a", "0", True), "resistance of R 'R2'"),
    (lambda c: c.R("R2", "a", "0", "1 kOhm"), "resistance of R 'R2'"),
    (lambda c: c.L("L2", "a", "0", None, i0=None), "initial current i0 of L 'L2'"),
    (lambda c: c.diode("D2", "a", "0", v_f=float("nan")), "forward drop v_f of diode 'D2'"),
    (lambda c: c.switch("S2", "a", "0", PWM(1e-3, 0.5, float("nan"))), "PWM delay of switch 'S2'"),
    (lambda c: c.switch("S2", "a", "0", PWM(1e-3, 1.5)), "PWM duty of switch 'S2'"),
    (lambda c: c.switch("S2", "a", "0", PWM(0.0, 0.5)), "PWM period of switch 'S2'"),
    (lambda c: c.switch("S2", "a", "0", PWM(None, 0.5)), "PWM period of switch 'S2'"),
    (lambda c: c.transformer("T2", "a", "0", "b", "0", 1j), "turns ratio of transformer 'T2'"),
])
def test_a_circuit_refuses_a_value_that_is_no_number_naming_the_component_and_argument(add, words):
    c = Circuit("values")
    c.V("V1", "in", "0", 10.0)
    c.R("R1", "in", "a", 1e3)
    with pytest.raises(ParameterValueError) as info:
        add(c)
    assert words in str(info.value)


@pytest.mark.parametrize("add, words", [
    (lambda m: m.mass("m2", "b", 1.0, v0=None), "initial velocity of mass 'm2'"),
    (lambda m: m.stop("floor", "a", lower=0.0, e=-1), "restitution e of stop 'floor'"),
    (lambda m: m.stop("floor", "a", lower=0.0, e=1.5), "restitution e of stop 'floor'"),
    (lambda m: m.stop("floor", "a", lower=0.0, v_th=-0.1), "landing speed v_th of stop 'floor'"),
    (lambda m: m.backlash("play", "a", "b", 0.0), "half-width delta of backlash 'play'"),
    (lambda m: m.spring("k", "a", "b", 1 + 1j), "stiffness of 'k'"),
    (lambda m: m.position("a", float("inf")), "position of node 'a'"),
])
def test_a_mechanism_refuses_a_value_out_of_its_range_or_no_number(add, words):
    m = Mechanism("values")
    m.mass("m1", "a", 1.0)
    with pytest.raises(ParameterValueError) as info:
        add(m)
    assert words in str(info.value)


def test_numpy_numbers_are_numbers_and_a_negative_capacitance_or_mass_is_warned():
    c = Circuit("numpy")
    c.V("V1", "in", "0", np.int64(5))
    c.R("R1", "in", "a", np.float32(1e3))
    c.C("C1", "a", "0", np.float64(1e-6), v0=np.int32(1))
    model = c.build()
    values = {s.name: v for s, v in model.parameter_values.items()}
    assert values == {"V1": 5.0, "R1": 1000.0, "C1": pytest.approx(1e-6)}
    with pytest.warns(PhysicalRangeWarning, match="C1"):
        c.build(parameters={"C1": -1e-6})
    m = Mechanism("negative")
    m.mass("m1", "a", -1.0)
    m.force("F", "a", 1.0)
    with pytest.warns(PhysicalRangeWarning, match="m1"):
        m.build()
    pwm = pwm_circuit("R_load", period="T")
    with pytest.raises(ParameterValueError, match="T = -0.001"):  # a named period's value is in range too
        pwm.build(parameters={"T": -1e-3})


def test_a_model_in_other_units_takes_the_same_names_and_instants():
    """The names and their refusals do not depend on the values: the PWM circuit in mA and kΩ units."""
    def run(scale):
        c = Circuit("units")
        c.V("V1", "in", "0", 10.0)
        c.switch("S1", "in", "a", PWM("T", 0.5))
        c.R("R1", "a", "0", 1000.0 * scale)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return c.build(parameters={"T": 1e-3}).simulate(2.5e-3, "RK45", rtol=1e-10, max_step=1e-4)

    runs = [run(scale) for scale in (1.0, 1e-3, 1e3)]
    for other in runs[1:]:
        np.testing.assert_array_equal(other.event_times, runs[0].event_times)
    assert math.isclose(runs[1].signal("i_R1")[-1], 1e3 * runs[0].signal("i_R1")[-1], rel_tol=1e-12)
