"""Trailing-edge PWM (a varying duty against a sawtooth, :mod:`models.carriers`): each pulse begins
at a tick ``k·T + delay`` and ends where the ramp ``(t − t_k)/T`` meets the duty — checked on the
run's own instants."""

import math

import numpy as np
import pytest

from bondgraph.errors import ParameterValueError
from models.circuits import PWM, Circuit

T, DELAY = 1e-4, 2e-5


def duty(t):
    return 0.5 + 0.3 * math.sin(2 * math.pi * 500 * t)


def chopper(rule) -> Circuit:
    c = Circuit("chopper")
    c.V("V1", "in", "0", 10.0)
    c.switch("S1", "in", "a", rule)
    c.R("R1", "a", "0", 1.0)
    return c


def switch_edges(run):
    """``(closings, openings)``: the instants where ``S1`` closes and where it opens."""
    after = run.at_instants()
    closings, openings = [], []
    for t, before, now in zip(after.t, after.modes_before, after.modes_after):
        was, is_ = before.state_of("S1"), now.state_of("S1")
        if was != is_:
            (closings if is_ == "closed" else openings).append(t)
    return np.array(closings), np.array(openings)


@pytest.mark.parametrize("method", ["RK45", "RK45-jit"])
def test_pulses_begin_at_the_ticks_and_end_where_the_ramp_meets_the_duty(method):
    rule = PWM(T, "0.5 + 0.3*sin(2*pi*500*t)", delay=DELAY, carrier="sawtooth")
    run = chopper(rule).build().simulate(2e-3, method=method, rtol=1e-10, atol=1e-12)
    closings, openings = switch_edges(run)
    assert np.allclose(closings, DELAY + T * np.arange(len(closings)), rtol=0, atol=1e-15)
    assert len(closings) == 20 and len(openings) == 20
    ramp = (openings - closings) / T
    assert np.allclose(ramp, [duty(t) for t in openings], rtol=0, atol=1e-12)


def test_a_constant_duty_gives_the_fixed_schedule_and_its_mean():
    saw = chopper(PWM(T, "0.3 + 0*t", carrier="sawtooth")).build().simulate(1e-3, rtol=1e-10, atol=1e-12)
    closings, openings = switch_edges(saw)  # closed from t = 0 (a tick), so no closing is an instant there
    assert np.allclose(closings, T * np.arange(1, len(closings) + 1), rtol=0, atol=1e-15)
    assert np.allclose(openings, T * (0.3 + np.arange(len(openings))), rtol=0, atol=1e-15)
    assert saw.measure("v_R1", "mean", periods=5, period=T) == pytest.approx(3.0, rel=1e-12)


def test_a_duty_above_one_holds_the_switch_closed_through_the_ticks():
    run = chopper(PWM(T, "1.2 + 0*t", carrier="sawtooth")).build().simulate(1e-3)
    closings, openings = switch_edges(run)
    assert len(openings) == 0
    assert run.signal("i_S1").min() == pytest.approx(10.0, rel=1e-12)


def test_an_unknown_carrier_is_refused_with_the_choices():
    with pytest.raises(ParameterValueError, match="sawtooth"):
        chopper(PWM(T, "0.5 + 0*t", carrier="sine"))
