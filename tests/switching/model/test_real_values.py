"""Real numbers only (issue 33, item 2; issue 32's imaginary restitution):
complex element constants, laws, parameters, initial values and restitution
coefficients are refused where they are given, naming them; a law that
leaves the reals during a run is an error naming the element, the mode,
the time and the state."""

import numpy as np
import pytest
import sympy as sp

import models.colliding_balls as colliding_balls
from bondgraph import TF, BondGraph, C, I, One, ParameterValueError, R, Se
from switching import Automaton, ComplexValueError, HybridModel, NonFiniteStateError
from switching.files.modelfile import dumps_model, loads_model
from switching.files.errors import ModelFileError


def _rc(cap="C", res="R", source="V", law=None):
    """Se V → 1 → R and C (a capacitor charged through a resistor)."""
    g = BondGraph("rc")
    j = g.add(One("j"))
    g.connect(Se("V", source), j)
    g.connect(j, R("R", res))
    g.connect(j, C("C", cap) if law is None else C("C", effort_law=law))
    return g


@pytest.mark.parametrize("build, culprit", [
    (lambda: C("C", 1j), "capacitance of C 'C'"),
    (lambda: C("C", sp.I), "capacitance of C 'C'"),
    (lambda: C("C", 2 * sp.I * sp.Symbol("C0")), "capacitance of C 'C'"),
    (lambda: I("m", 1.5 + 0.5j), "inertance of I 'm'"),
    (lambda: R("R", 2 + 3j), "resistance of R 'R'"),
    (lambda: R("R", effort_law=lambda f: sp.I * f), "effort_law of R 'R'"),
    (lambda: C("C", effort_law=lambda q: q / sp.sqrt(-2)), "law of C 'C'"),
    (lambda: Se("V", sp.sqrt(-2)), "value of Se 'V'"),
    (lambda: TF("lever", np.complex128(2 + 1j)), "modulus of TF 'lever'"),
])
def test_complex_element_constants_and_laws_are_refused_naming_the_element(build, culprit):
    with pytest.raises(ParameterValueError) as info:
        build()
    message = str(info.value)
    assert culprit in message and "real" in message


def test_a_complex_number_with_no_imaginary_part_is_its_real_part():
    g = _rc(cap=2 + 0j)
    assert sp.simplify(g.elements["C"].law - sp.Symbol("q_C") / 2) == 0
    model = HybridModel(_rc(), [], {"V": 1, "R": 1 + 0j, "C": np.complex128(2)})
    assert model.parameter_values[sp.Symbol("R")] == 1.0 and model.parameter_values[sp.Symbol("C")] == 2.0


@pytest.mark.parametrize("value", [1j, sp.I, np.complex128(1 + 1e-3j), 2 * sp.I])
def test_complex_parameter_values_are_refused_naming_the_parameter(value):
    with pytest.raises(ParameterValueError) as info:
        HybridModel(_rc(), [], {"V": 1, "R": 1, "C": value})
    assert info.value.name == "C" and "real" in str(info.value) and "'C'" in str(info.value)


def test_complex_initial_values_are_refused_naming_the_state():
    with pytest.raises(ParameterValueError) as info:
        HybridModel(_rc(), [], {"V": 1, "R": 1, "C": 1}, initial_state={"q_C": 0.5j})
    assert info.value.name == "q_C" and "real" in str(info.value)


def test_an_imaginary_restitution_is_refused_in_code_in_a_model_and_in_a_model_file():
    with pytest.raises(ParameterValueError) as info:
        Automaton("contact", {"free": {}, "collide": {}}, initial="free", restitution={"collide": sp.I})
    assert "restitution of contact=collide" in str(info.value) and "real" in str(info.value)
    for e in (sp.I, 0.5j, np.complex128(0.8 + 0.1j)):
        with pytest.raises(ParameterValueError) as info:
            colliding_balls.build(e=e)
        assert info.value.name == "e" and "real" in str(info.value)
    text = dumps_model(colliding_balls.build()).replace('collide = "e"', 'collide = "e*sqrt(-1)"')
    with pytest.raises(ModelFileError) as info:
        loads_model(text)
    assert "restitution of contact=collide" in str(info.value) and "imaginary unit" in str(info.value)


def test_a_law_in_a_model_file_with_the_imaginary_unit_is_refused_naming_the_element():
    text = dumps_model(colliding_balls.build()).replace('inertance = "m1"', 'inertance = "m1*sqrt(-1)"')
    with pytest.raises(ModelFileError) as info:
        loads_model(text)
    assert "I 'ball1'" in str(info.value) and "imaginary unit" in str(info.value)


def test_a_law_that_leaves_the_reals_mid_run_is_an_error_naming_the_element_mode_time_and_state():
    """``e = sqrt(q)`` of a capacitor discharged below zero by a negative source:
    ``dq/dt = −1 − √q`` (V = −1, R = 1) from ``q0 = 0.5`` reaches ``q = 0`` at
    ``t* = 2(√q0 − ln(1 + √q0)) = 0.3447``; a step beyond it takes ``sqrt`` of a
    negative charge."""
    model = HybridModel(_rc(law=lambda q: sp.sqrt(q)), [], {"V": -1, "R": 1}, initial_state={"q_C": 0.5})
    with pytest.raises(ComplexValueError) as info:
        model.simulate(2.0, "RK45")
    error = info.value
    assert error.elements == ("C",) and error.x[0] < 0
    message = str(error)
    assert "'C': e_C = sqrt(q_C)" in message and "q_C = -" in message and "real numbers" in message
    t_star = 2 * (np.sqrt(0.5) - np.log(1 + np.sqrt(0.5)))
    named = float(message.split("at t = ")[1].split(" s")[0])
    assert abs(named - t_star) < 1e-2
    assert isinstance(error, NonFiniteStateError) and error.trajectory is not None


def test_a_flow_that_starts_where_a_law_is_not_real_names_the_element():
    model = HybridModel(_rc(law=lambda q: sp.sqrt(q)), [], {"V": -1, "R": 1}, initial_state={"q_C": -0.1})
    with pytest.raises(NonFiniteStateError) as info:
        model.simulate(1.0, "RK45")
    message = str(info.value)
    assert "'C': e_C = sqrt(q_C)" in message and "q_C = -0.1" in message
