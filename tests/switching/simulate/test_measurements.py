"""Measurements over a window (switching/simulate/measurements.py) against closed forms."""

import math

import numpy as np
import pytest

from models import bouncing_ball
from models.circuits import PWM, Circuit
from switching.simulate.measurements import MeasurementError


def pwm_wave(duty, V=10.0, r_on=None, period=1e-3):
    """A source switched onto a resistor: ``v_b`` is V while the switch is closed, 0 while open."""
    c = Circuit("pwm_wave")
    c.V("V1", "a", 0, V)
    c.switch("S1", "a", "b", PWM(period, duty), r_on=r_on)
    c.R("R1", "b", 0, 5.0)
    return c.build()


@pytest.mark.parametrize("duty", [0.3, 0.5, 0.77])
def test_a_pwm_square_wave_has_mean_d_v_and_rms_v_root_d(duty):
    run = pwm_wave(duty).simulate(0.01)
    found = run.measure("v_b", ["mean", "rms", "ac_rms", "ripple", "peak", "min", "max"], periods=5, period=1e-3)
    assert found["mean"] == pytest.approx(duty * 10.0, rel=1e-12)
    assert found["rms"] == pytest.approx(10.0 * math.sqrt(duty), rel=1e-12)
    assert found["ac_rms"] == pytest.approx(10.0 * math.sqrt(duty * (1 - duty)), rel=1e-10)
    assert (found["min"], found["max"], found["ripple"], found["peak"]) == (0.0, 10.0, 10.0, 10.0)


def test_a_square_wave_has_thd_root_of_pi_squared_over_8_minus_1_and_odd_harmonics_2v_over_pi_k():
    run = pwm_wave(0.5).simulate(0.01)
    assert run.measure("v_b", "thd", periods=5, period=1e-3) == pytest.approx(math.sqrt(math.pi**2 / 8 - 1),
                                                                              rel=1e-8)
    amplitudes = run.spectrum("v_b", 1e3, 9, periods=5, period=1e-3)
    expected = [5.0] + [20 / (math.pi * k) if k % 2 else 0.0 for k in range(1, 10)]
    np.testing.assert_allclose(amplitudes, expected, rtol=1e-8, atol=1e-7)


def test_a_full_wave_rectified_sine_has_mean_2vm_over_pi_and_rms_vm_over_root_2():
    c = Circuit("bridge")
    Vm = 325.0
    c.V("Vs", "s", 0, f"{Vm}*sin(2*pi*50*t)")
    for name, a, b in (("D1", "s", "p"), ("D2", 0, "p"), ("D3", "n", "s"), ("D4", "n", 0)):
        c.diode(name, a, b)
    c.R("RL", "p", "n", 10.0)
    run = c.build().simulate(0.1, rtol=1e-10, atol=1e-12)
    found = run.measure("v_RL", ["mean", "rms", "peak", "crest"], periods=4, period=0.02)
    assert found["mean"] == pytest.approx(2 * Vm / math.pi, rel=1e-9)
    assert found["rms"] == pytest.approx(Vm / math.sqrt(2), rel=1e-9)
    assert found["peak"] == pytest.approx(Vm, rel=1e-12)
    assert found["crest"] == pytest.approx(math.sqrt(2), rel=1e-9)


def test_the_power_factor_of_an_rl_load_is_its_cosine_phi():
    R, L, f = 10.0, 20e-3, 50.0
    c = Circuit("rl")
    c.V("Vs", "s", 0, f"325*sin(2*pi*{f}*t)")
    c.R("R1", "s", "x", R)
    c.L("L1", "x", 0, L)
    run = c.build().simulate(0.2, rtol=1e-10, atol=1e-12)  # the transient, e^(−t R/L), has decayed
    expected = R / math.hypot(R, 2 * math.pi * f * L)
    assert run.measure("Vs", "power_factor", periods=5, period=1 / f) == pytest.approx(expected, rel=1e-8)


def test_the_efficiency_of_a_switch_with_on_resistance_is_the_conduction_loss_ratio():
    """A source switched onto a load through ``r_on``: the load takes ``R/(R + r_on)`` of what the
    source supplies, whatever the duty."""
    run = pwm_wave(0.4, r_on=0.5).simulate(0.01)
    assert run.measure("R1", "efficiency", periods=5, period=1e-3) == pytest.approx(5.0 / 5.5, rel=1e-12)


def test_the_apex_of_a_flight_between_two_rows_is_found():
    """A ball's highest point after its first bounce lies inside a flight interval, between steps:
    ``y_max = v⁺²/(2g)`` with ``v⁺`` the run's own velocity after the bounce."""
    model = bouncing_ball.build()
    run = model.simulate(2.5, rtol=1e-10, atol=1e-12)
    first, second = run.events[0], run.events[1]
    values = {symbol.name: value for symbol, value in model.parameter_values.items()}
    v_after = first.x_after[run.state_names.index("p")] / values["m"]
    top = run.measure("y", "max", t_from=first.t, t_to=second.t)
    assert top == pytest.approx(v_after**2 / (2 * values["g"]), rel=1e-12)
    assert top > run.x[(run.t > first.t) & (run.t < second.t), run.state_names.index("y")].max()


def test_windows_by_time_and_by_periods_agree():
    run = pwm_wave(0.3).simulate(0.01)
    assert run.measure("v_b", "mean", t_from=0.006, t_to=0.01) == run.measure("v_b", "mean", periods=4,
                                                                              period=1e-3)
    assert run.measure("v_b", "mean", t_from=0.0001, t_to=0.0002) == pytest.approx(10.0, rel=1e-12)


@pytest.mark.parametrize("window, argument", [
    (dict(periods=20, period=1e-3), "window"),
    (dict(t_from=0.005, t_to=0.004), "window"),
    (dict(periods=3), "period"),
    (dict(t_from=0.001, periods=2, period=1e-3), "t_from"),
])
def test_a_window_outside_the_run_or_half_given_is_refused(window, argument):
    run = pwm_wave(0.3).simulate(0.01)
    with pytest.raises(MeasurementError) as caught:
        run.measure("v_b", "mean", **window)
    assert caught.value.argument == argument


def test_what_cannot_be_measured_is_refused_saying_why():
    run = pwm_wave(0.3).simulate(0.01)
    with pytest.raises(MeasurementError, match="unknown measurement 'average'.*mean, rms"):
        run.measure("v_b", "average")
    with pytest.raises(MeasurementError, match="no component at the fundamental"):
        run.measure("v_a", "thd", periods=5, period=1e-3)  # (a constant source)
    with pytest.raises(MeasurementError, match="elements"):
        run.measure("v_b", "power_factor")
    no_instants = pwm_wave(0.3).simulate(0.01, keep_instants=False)
    with pytest.raises(MeasurementError, match="keep_instants"):
        no_instants.measure("v_b", "mean")
    at_times = pwm_wave(0.3).simulate(0.01, t_eval=np.linspace(0, 0.01, 7))
    with pytest.raises(MeasurementError, match="rows at requested times"):
        at_times.measure("v_b", "mean")


def test_a_measurement_does_not_depend_on_the_units():
    """The same PWM wave in millivolts and microseconds: the same figures, scaled."""
    volts = pwm_wave(0.3).simulate(0.01).measure("v_b", ["mean", "rms"], periods=5, period=1e-3)
    scaled = pwm_wave(0.3, V=10e3, period=1e-3).simulate(0.01).measure("v_b", ["mean", "rms"], periods=5,
                                                                       period=1e-3)
    assert scaled["mean"] == pytest.approx(1e3 * volts["mean"], rel=1e-12)
    assert scaled["rms"] == pytest.approx(1e3 * volts["rms"], rel=1e-12)


def test_a_forward_drop_is_a_loss_and_a_controller_s_states_supply_nothing():
    """Through ``r_on`` and a diode's 0.7 V drop into R: the load takes ``R·I²`` of the ``V·I`` the source
    gives (``I = (V − v_f)/(R + r_on)``); the drop (a source in the bond graph) is counted as the sink it
    is, and a controller's signal states beside the circuit are not counted at all."""
    c = Circuit("drop")
    c.V("V1", "a", 0, 10.0)
    c.switch("S1", "a", "b", PWM(1e-3, 0.3), r_on=0.5)
    c.diode("D1", "b", "c", v_f=0.7)
    c.R("R1", "c", 0, 5.0)
    c.pi("PI1", "v_c", 1.0, kp=1.0, ki=10.0)
    run = c.build().simulate(0.01)
    current = (10.0 - 0.7) / 5.5
    assert run.measure("R1", "efficiency", periods=5, period=1e-3) == pytest.approx(5.0 * current / 10.0,
                                                                                    rel=1e-10)
