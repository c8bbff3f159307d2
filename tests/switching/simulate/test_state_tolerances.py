"""Each state's absolute tolerance (:mod:`switching.simulate.state_tolerances`): a run without ``atol``
holds ``rtol`` whatever the storage's size, the same steps at every scale."""

import math

import numpy as np
import pytest

from models.circuits import Circuit
from switching.simulate.state_tolerances import DEFAULT_ATOL, state_tolerances


def rc(capacitance: float, inductor: bool = False):
    """10 V through ``R = 1 ms/C`` into ``capacitance`` (the time constant 1 ms whatever the charges' scale);
    ``inductor``: besides, 1 mH and 1 Ω across the source."""
    c = Circuit("rc")
    c.V("V1", "in", "0", 10.0)
    c.R("R1", "in", "out", 1e-3 / capacitance)
    c.C("C1", "out", "0", capacitance)
    if inductor:
        c.L("L1", "in", "x", 1e-3)
        c.R("R2", "x", "0", 1.0)
    return c.build()


def test_a_storage_state_gets_its_capacity_times_the_tolerance_in_its_output_s_units():
    model = rc(1e-8, inductor=True)
    tolerances = state_tolerances(model, model.initial_state())
    index = {str(s): k for k, s in enumerate(model.states)}
    assert tolerances[index["q_C1"]] == pytest.approx(DEFAULT_ATOL * 1e-8, rel=1e-15)  # 1e-9 V
    assert tolerances[index["p_L1"]] == pytest.approx(DEFAULT_ATOL * 1e-3, rel=1e-15)  # 1e-9 A
    assert np.all(state_tolerances(model, model.initial_state(), 1e-6) == 1e-6)  # given: the states' units


@pytest.mark.parametrize("method", ["RK45", "RK45-jit", "rodas-jit", "Radau"])
def test_an_rc_at_its_time_constant_holds_rtol_at_every_capacitance_with_the_same_steps(method):
    steps = set()
    for capacitance in (1e-3, 1e-6, 1e-9, 1e-12):
        run = rc(capacitance).simulate(1e-3, method, rtol=1e-8)
        exact = 10.0 * (1.0 - math.exp(-1.0))
        assert run.signal("v_C1")[-1] == pytest.approx(exact, rel=2e-8), capacitance
        steps.add(run.stats["steps"])
    assert len(steps) == 1


def test_an_atol_given_is_in_the_states_units_as_before():
    """1e-9 C on a 1 nF capacitor (10 nC at 10 V) is a tenth of its charge: the error control is loose,
    as asked — the reason the default is each state's own."""
    run = rc(1e-9).simulate(1e-3, "RK45", rtol=1e-8, atol=1e-9)
    assert abs(run.signal("v_C1")[-1] / (10.0 * (1.0 - math.exp(-1.0))) - 1.0) > 1e-6


def test_storage_of_one_form_shares_one_slope_function_and_keeps_its_own_tolerance():
    """A scene's masses of one parameter share the slope function of their form (one made, not one a
    ball), each state still its own tolerance: ``m`` for a momentum, ``1/k`` (the spring's capacity) for
    a compression."""
    from models import ball_chain
    from switching.simulate.state_tolerances import _slopes

    model = ball_chain.build(N=12, compliant=True, m=0.3, k=2e4)
    functions = [function for _, function in _slopes(model).functions]
    assert len(functions) == 23 and len(set(map(id, functions))) == 2
    tolerances = state_tolerances(model, model.initial_state())
    for k, state in enumerate(model.states):  # (a position is no storage's: the tolerance in metres)
        capacity = {"p": 0.3, "q": 1 / 2e4, "pos": 1.0}[state.name.rstrip("0123456789")]
        assert tolerances[k] == pytest.approx(DEFAULT_ATOL * capacity, rel=1e-15), state
