"""A sampled PID controller (zero-order hold, one sample of computation delay) against the exact
discrete-time loop: between ticks the plant's flow is a closed form, at each tick the update of
:mod:`models.sampled_controllers`."""

import math

import numpy as np
import pytest

from bondgraph.errors import InvalidGraphError
from models.circuits import PWM, Circuit
from models.mechanics import Mechanism


def rc_loop(kp=0.5, ki=0.5, kd=0.0, period=0.1, delay=0.05, **options) -> Circuit:
    """A voltage source driven by ``PI1`` through 1 Ω into 1 F: ``dv/dt = u − v``, ``v(0) = 0``."""
    c = Circuit("rc_loop")
    c.V("V1", "in", "0", "PI1")
    c.R("R1", "in", "out", 1.0)
    c.C("C1", "out", "0", 1.0)
    c.pid("PI1", "v_C1", 1.0, kp, ki, kd, sample_period=period, sample_delay=delay, **options)
    return c


def exact_loop(t_end, relax, kp=0.5, ki=0.5, kd=0.0, period=0.1, delay=0.05, limits=None, tracking=None):
    """The discrete loop: ``v`` relaxes towards the held ``u`` (``relax(v, u, dt)``) between ticks
    ``k·period + delay``; at each tick ``u ← w``, ``w ← clamp(kp·e + I + kd·(e − e_prev)/T)``,
    ``I ← I + T·(ki·e + (w − raw)/T_t)``.  Returns the ticks, ``v`` at each and ``v(t_end)``."""
    v = u = w = integral = e_prev = 0.0
    t, ticks, values = 0.0, [], []
    k = 0
    while k * period + delay <= t_end:
        tick = k * period + delay
        v, t = relax(v, u, tick - t), tick
        e = 1.0 - v
        u = w
        raw = kp * e + integral + kd * (e - e_prev) / period
        w = raw if limits is None else min(max(raw, limits[0]), limits[1])
        integral += period * (ki * e + (0.0 if limits is None else (w - raw) / tracking))
        e_prev = e
        ticks.append(tick)
        values.append(v)
        k += 1
    return np.array(ticks), np.array(values), relax(v, u, t_end - t)


def rc_relax(v, u, dt):
    return u + (v - u) * math.exp(-dt)


@pytest.mark.parametrize("method", ["RK45", "RK45-jit"])
def test_a_sampled_pi_loop_is_the_exact_discrete_loop(method):
    run = rc_loop().build().simulate(2.99, method=method, rtol=1e-11, atol=1e-13)
    ticks, at_ticks, v_end = exact_loop(2.99, rc_relax)
    assert np.allclose(run.event_times, ticks, rtol=0, atol=1e-14)
    after = run.at_instants()
    v_at = after.x_before[:, run.state_names.index("q_C1")]
    assert np.allclose(v_at, at_ticks, rtol=0, atol=1e-10)
    assert run.signal("v_C1")[-1] == pytest.approx(v_end, abs=1e-10)


def test_the_output_is_held_between_ticks_and_applied_a_sample_after_it_is_computed():
    run = rc_loop().build().simulate(1.0, rtol=1e-10, atol=1e-12)
    output, pending = run.signal("PI1"), run.state("q_PI1_w")
    rows = np.searchsorted(run.t, run.event_times, side="left")
    for start, stop in zip(rows[:-1], rows[1:]):  # between two instants the output does not move
        assert np.ptp(output[start + 1:stop]) == 0.0
    after = run.at_instants()
    u, w = (after.x_after[:, run.state_names.index(s)] for s in ("q_PI1_u", "q_PI1_w"))
    w_before = after.x_before[:, run.state_names.index("q_PI1_w")]
    assert np.array_equal(u, w_before)  # u_k = w_(k−1)
    assert w[0] == pytest.approx(0.5, rel=1e-15)  # kp·e_0 + I_0 with e_0 = 1
    assert output[-1] == u[-1] and pending[-1] == w[-1]


def test_a_sampled_pid_with_limits_and_a_tick_at_zero_is_the_exact_discrete_loop():
    options = {"kp": 2.0, "ki": 3.0, "kd": 0.05, "delay": 0.0}
    run = rc_loop(**options, limits=(0.0, 1.5), tracking=0.4).build().simulate(2.95, rtol=1e-11, atol=1e-13)
    ticks, at_ticks, v_end = exact_loop(2.95, rc_relax, **options, limits=(0.0, 1.5), tracking=0.4)
    assert ticks[0] == 0.0 and np.allclose(run.event_times, ticks, rtol=0, atol=1e-14)
    assert run.signal("v_C1")[-1] == pytest.approx(v_end, abs=1e-10)
    assert run.signal("PI1").max() == pytest.approx(1.5, rel=1e-15)  # saturated at first


def test_a_sampled_speed_loop_around_a_mass_with_a_damper_is_the_exact_discrete_loop():
    """``m·dv/dt = F − b·v`` with ``F = PI1`` sampled: between ticks ``v → F/b`` with rate ``b/m``."""
    m_, b = 2.0, 4.0
    mech = Mechanism("cart", kind="translational")
    mech.mass("m", "cart", m_)
    mech.damper("b", "cart", 0, b)
    mech.force("F", "cart", "PI1")
    mech.pi("PI1", "v_cart", 1.0, kp=3.0, ki=5.0, sample_period=0.05, sample_delay=0.01)
    run = mech.build().simulate(1.0, rtol=1e-11, atol=1e-13)

    def relax(v, force, dt):
        return force / b + (v - force / b) * math.exp(-b * dt / m_)

    ticks, _, v_end = exact_loop(1.0, relax, kp=3.0, ki=5.0, period=0.05, delay=0.01)
    assert np.allclose(run.event_times, ticks, rtol=0, atol=1e-14)
    assert run.signal("v_cart")[-1] == pytest.approx(v_end, abs=1e-10)


def test_a_digital_loop_regulates_a_buck_converter_on_its_samples():
    """A sampled PI sets the duty of a 100 kHz, 24 V → 12 V buck once a period, at the carrier's peak
    (the middle of the off time): the output at the ticks closes on the 12 V reference (integral
    action on the sampled error), the held duty stays within its limits."""
    c = Circuit("digital_buck")
    c.V("Vin", "in", 0, 24.0)
    c.switch("S", "in", "sw", PWM(1e-5, "PI1"), r_on=0.05)
    c.diode("D1", 0, "sw", v_f=0.4)
    c.L("L", "sw", "out", 100e-6)
    c.C("C", "out", 0, 100e-6, v0=12.0)
    c.R("R_1A", "out", 0, 12.0)
    c.pi("PI1", "v_out", 12.0, kp=0.003, ki=20.0, limits=(0.0, 0.95), initial=0.52, sample_period=1e-5,
         sample_delay=5e-6)
    run = c.build().simulate(0.04, method="RK45-jit", rtol=1e-9, atol=1e-12)
    after = run.at_instants()
    phase = (after.t - 5e-6) / 1e-5
    ticks = np.isclose(phase, np.round(phase), rtol=0, atol=1e-6)
    errors = 12.0 - after.x_before[ticks, run.state_names.index("q_C")] / 100e-6
    assert ticks.sum() == 4000
    assert abs(errors[-1]) < 3e-5 and abs(errors[-1]) < abs(errors[-1000]) < abs(errors[-2000])
    duty = run.signal("PI1")
    assert duty.min() >= 0.0 and duty.max() <= 0.95


def test_a_sampled_controller_refuses_a_clock_it_cannot_keep():
    with pytest.raises(InvalidGraphError, match="0 <= delay < sample_period"):
        rc_loop(period=0.1, delay=0.1)
    with pytest.raises(InvalidGraphError, match="period > 0"):
        rc_loop(period=-0.1, delay=0.0)
    c = Circuit("c")
    with pytest.raises(InvalidGraphError, match="without sample_period"):
        c.pi("PI1", "v_x", 1.0, 1.0, 1.0, sample_delay=0.1)
    with pytest.raises(InvalidGraphError, match="backward difference"):
        c.pid("PI1", "v_x", 1.0, 1.0, 1.0, 0.1, derivative_filter=0.01, sample_period=0.1)


def test_a_controller_s_states_and_output_are_not_labelled_as_charges():
    """Its held values are unit capacities in the output's unit (here a voltage's, elsewhere a duty's):
    the circuit's ``q_`` prefix (C) must not name them."""
    continuous = Circuit("c")
    continuous.V("V1", "in", "0", "PI2")
    continuous.R("R1", "in", "0", 1.0)
    continuous.pi("PI2", "v_in", 1.0, 0.5, 0.5)
    for model in (rc_loop().build(), continuous.build()):
        units = model.annotations.units
        assert not [name for name in units if name.startswith(("q_PI", "PI"))], units
    assert rc_loop().build().annotations.units["q_C1"] == "C"


def test_held_values_renamed_around_a_component_of_their_name_still_close_their_stages():
    """A resistor named ``PI1_u`` takes the held output's element name: the hold becomes ``PI1_u_2`` and
    its stage's guard reads that state, so the loop is still the exact discrete one."""
    c = rc_loop()
    c.R("PI1_u", "out", "0", 1e9)  # (1 nA at 1 V: the loop's answer moves by far less than the tolerance)
    run = c.build().simulate(1.0, rtol=1e-11, atol=1e-13)
    assert "q_PI1_u_2" in run.state_names
    ticks, _, _ = exact_loop(1.0, rc_relax)
    assert np.allclose(run.event_times, ticks, rtol=0, atol=1e-14)
    assert run.signal("PI1")[-1] == run.state("q_PI1_u_2")[-1]
