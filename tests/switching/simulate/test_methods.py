"""The methods of a run come from one table (issue 27 item 5): every name
of ``METHODS`` has a class that says whether it is fixed-step, compiled,
which step options it takes and how it steps a flow; a class registered
there is a method ``simulate`` runs and the errors list."""

from __future__ import annotations

import numpy as np
import pytest

import switching
from models import bouncing_ball
from switching.errors import OptionTypeError, OptionValueError
from switching.simulate import integrators
from switching.simulate.methods import (ADAPTIVE, COMPILED, FIXED_STEP, METHOD_CLASSES, METHODS, CompiledMethod,
                                        Method, RK4Method, method_class, method_names, register)

pytestmark = pytest.mark.timeout(60)

SHIPPED = ("euler", "rk4", "RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA", "euler-jit", "rk4-jit", "RK45-jit",
           "rodas-jit")
#: a compiled method's Python twin, the method its flows left to Python step with
TWIN = {"rodas-jit": "Radau"}


def test_every_name_of_methods_has_a_class_in_the_table_and_auto_comes_last():
    assert METHODS == SHIPPED and switching.METHODS is METHODS
    for name in METHODS:
        cls = METHOD_CLASSES[name]
        assert issubclass(cls, Method) and cls.name == name and not cls.chooses
    assert method_names() == SHIPPED + ("auto",) and METHOD_CLASSES["auto"].chooses
    assert FIXED_STEP == ("euler", "rk4") and COMPILED == ("euler-jit", "rk4-jit", "RK45-jit", "rodas-jit")
    assert ADAPTIVE == ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")


def test_the_classes_say_fixed_or_adaptive_compiled_or_python_and_their_step_options():
    for name in METHODS:
        cls = METHOD_CLASSES[name]
        fixed = name.removesuffix("-jit") in ("euler", "rk4")
        assert cls.fixed_step is fixed
        assert cls.compiled is name.endswith("-jit")
        assert cls.step_options() == (("dt",) if fixed else ("rtol", "atol", "max_step", "first_step"))
        # a compiled one flows as its Python twin
        assert cls.python is METHOD_CLASSES[TWIN.get(name, name.removesuffix("-jit"))]
    assert [n for n in METHODS if METHOD_CLASSES[n].stiff] == ["Radau", "BDF", "LSODA", "rodas-jit"]


@pytest.mark.parametrize("name", SHIPPED)
def test_each_class_makes_the_integrator_of_its_method(name):
    cls = METHOD_CLASSES[name]
    stepper = cls.stepper(lambda t, y: -y, 0.0, np.array([1.0]), 1.0, dt=0.1, rtol=1e-6, atol=1e-9)
    twin = TWIN.get(name, name.removesuffix("-jit"))
    expected = {"euler": integrators.Euler, "rk4": integrators.RK4}.get(twin, integrators.Adaptive)
    assert type(stepper) is expected
    if expected is integrators.Adaptive:
        assert type(stepper.solver).__name__ == twin
    t, y = stepper.step()
    assert 0 < t <= 1.0 and y[0] < 1.0


def test_an_unknown_method_lists_the_names_of_the_table():
    with pytest.raises(OptionValueError, match="unknown method 'RK99'; choose one of: euler, rk4, RK45, .*"
                                               "RK45-jit, rodas-jit, auto$"):
        method_class("RK99")
    with pytest.raises(OptionTypeError, match="unknown method 45"):
        method_class(45)
    with pytest.raises(OptionTypeError):
        method_class(["RK45"])  # not hashable: still the toolkit's error


@pytest.fixture
def registered():
    """A method registered for one test: rk4 under another name."""

    class Classic(RK4Method):
        name = "classic-rk4"

    register(Classic)
    yield Classic
    del METHOD_CLASSES["classic-rk4"]


def test_a_registered_class_is_a_method_simulate_runs_and_the_errors_list(registered):
    assert "classic-rk4" in method_names() and method_class("classic-rk4") is registered
    assert registered.python is registered and registered.fixed_step
    ball = bouncing_ball.build()
    ours = ball.simulate(1.0, "classic-rk4", dt=0.01)
    theirs = bouncing_ball.build().simulate(1.0, "rk4", dt=0.01)
    np.testing.assert_array_equal(ours.x, theirs.x)
    assert ours.stats["method"] == "classic-rk4" and len(ours.events) >= 1
    with pytest.raises(OptionValueError, match="classic-rk4 is fixed|is fixed-step"):
        ball.simulate(1.0, "classic-rk4")  # no dt: the class says it is fixed-step
    with pytest.raises(OptionValueError, match=r"choose one of: .*classic-rk4, auto$"):
        ball.simulate(1.0, "RK99")


def test_register_refuses_a_taken_name_a_nameless_class_and_what_is_no_method():
    class Again(RK4Method):
        name = "rk4"

    class Nameless(Method):
        pass

    with pytest.raises(ValueError, match="registered already"):
        register(Again)
    with pytest.raises(ValueError, match="no name"):
        register(Nameless)
    with pytest.raises(TypeError):
        register(object)


def test_register_refuses_a_method_with_no_integrator():
    class Hollow(Method):
        name = "hollow"

    with pytest.raises(TypeError, match="Hollow has no integrator: define stepper, or name the method it flows as"):
        register(Hollow)
    assert "hollow" not in METHOD_CLASSES


def test_auto_flows_in_python_as_rk45():
    """``auto`` chooses RK45 compiled or not; its flows left to Python are RK45's (scipy's solver)."""
    auto = METHOD_CLASSES["auto"]
    assert auto.python is METHOD_CLASSES["RK45"] and not auto.compiled
    stepper = auto.stepper(lambda t, y: -y, 0.0, np.array([1.0]), 1.0, rtol=1e-8, atol=1e-12)
    assert type(stepper.solver).__name__ == "RK45"
    t, y = stepper.step()
    assert y[0] == pytest.approx(np.exp(-t), rel=1e-6)
    assert METHOD_CLASSES["rk4"] is RK4Method


def test_a_compiled_class_takes_fixed_or_adaptive_from_its_python_method():
    class Compiled(CompiledMethod):
        name, python = "rk4-compiled", RK4Method

    assert Compiled.fixed_step and Compiled.compiled and Compiled.python is RK4Method
    assert "rk4-compiled" not in METHOD_CLASSES  # a class is a method once registered
