"""Closed loops in circuits (models/controllers.py): PI/PID controllers, modulated PWM, hysteresis."""

import numpy as np
import pytest

from bondgraph.errors import HybridBondGraphError
from models.circuits import PWM, Circuit, Hysteresis
from switching import load_model, periodic_orbit

T_SW = 1e-5


def closed_loop_buck(kp=0.02, ki=200.0, reference=12.0, limits=(0.0, 0.95), R=2.0, initial=0.5):
    c = Circuit("buck_pi")
    c.V("Vin", "in", 0, 24.0)
    c.switch("S", "in", "sw", PWM(T_SW, "PI1"))
    c.diode("D1", 0, "sw")
    c.L("L", "sw", "out", 100e-6)
    c.C("C", "out", 0, 100e-6, v0=12.0)
    c.R("Rl", "out", 0, R)
    c.pi("PI1", "v_out", reference, kp=kp, ki=ki, limits=limits, initial=initial)
    return c.build()


def test_the_integral_term_is_ki_times_the_integral_of_the_error():
    """Open loop (it measures a fixed source): ``e = 12 − 24``, ``I = ki·e·t``, ``u = kp·e + I``."""
    c = Circuit("open")
    c.V("Vin", "in", 0, 24.0)
    c.R("R1", "in", 0, 10.0)
    c.pid("PI1", "v_in", 12.0, kp=0.5, ki=3.0)
    run = c.build().simulate(2.0)
    np.testing.assert_allclose(run.signal("q_PI1_I"), 3.0 * -12.0 * run.t, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(run.signal("PI1"), 0.5 * -12.0 + 3.0 * -12.0 * run.t, rtol=1e-12, atol=1e-12)


def test_a_filtered_derivative_follows_its_first_order_lag():
    """``e = 1 − t`` (a ramp measured): ``dz/dt = (e − z)/T_f`` from ``z(0) = 0`` gives
    ``z = 1 − t + T_f − (1 + T_f)·e^(−t/T_f)``, and ``D = kd·(e − z)/T_f → kd·de/dt = −kd`` once the lag
    has settled."""
    c = Circuit("ramp")
    c.V("Vr", "r", 0, "t")
    c.R("R1", "r", 0, 1.0)
    c.pid("PD", "v_r", 1.0, kp=1.0, ki=0.0, kd=0.2, derivative_filter=0.01)
    run = c.build().simulate(0.1, rtol=1e-10, atol=1e-12)
    e = 1.0 - run.t
    z = 1.0 - run.t + 0.01 - 1.01 * np.exp(-run.t / 0.01)
    np.testing.assert_allclose(run.signal("q_PD_D"), z, rtol=0, atol=1e-8)
    np.testing.assert_allclose(run.signal("PD"), e + 0.2 * (e - z) / 0.01, rtol=0, atol=1e-5)


def test_the_closed_loop_buck_s_orbit_has_the_reference_as_its_mean_exactly():
    """Integral action: on the periodic orbit of the loop (three states, the integral among them) the
    integral term returns to its start, so the error's mean over a period is 0: the output's mean is
    the reference, whatever the ripple."""
    model = closed_loop_buck()
    warm = model.simulate(0.01, "RK45-jit")
    orbit = periodic_orbit(model, period=T_SW, x0=warm.x[-1], t0=0.0, max_step=T_SW / 20)
    assert orbit.stable and orbit.error < 1e-8
    assert orbit.measure("v_out", "mean") == pytest.approx(12.0, rel=1e-9)
    assert orbit.measure("PI1", "mean") == pytest.approx(0.5, rel=1e-2)  # (the ideal buck's duty, losses none)


def test_a_saturated_controller_does_not_wind_up():
    """An unreachable reference (30 V from 24 V): the output rests at its upper limit, and the integral
    term settles where back-calculation holds it (``dI/dt = ki·e + (u − u_raw)/T_t = 0`` with
    ``T_t = kp/ki``: ``I = hi``) instead of growing with ``ki·e·t``."""
    model = closed_loop_buck(reference=30.0, initial=0.5)
    run = model.simulate(0.02, "RK45-jit")
    end = run.t > 0.019
    np.testing.assert_allclose(run.signal("PI1")[end], 0.95, rtol=1e-12)
    assert run.signal("q_PI1_I")[-1] == pytest.approx(0.95, rel=1e-3)


def test_a_sinusoidally_modulated_pwm_switches_where_the_carrier_meets_the_duty():
    c = Circuit("spwm")
    c.V("Vdc", "in", 0, 100.0)
    c.switch("S", "in", "x", PWM(1e-3, "0.5 + 0.4*sin(2*pi*50*t)"))
    c.R("R1", "x", 0, 10.0)
    run = c.build().simulate(0.02)
    times = run.event_times[run.event_times > 0]
    assert len(times) == 40  # two edges a carrier period
    carrier = np.arccos(np.cos(2 * np.pi * times / 1e-3)) / np.pi
    duty = 0.5 + 0.4 * np.sin(2 * np.pi * 50 * times)
    np.testing.assert_allclose(carrier, duty, rtol=0, atol=1e-9)
    assert run.measure("v_x", "mean", t_from=0.0, t_to=0.02) == pytest.approx(50.0, rel=1e-3)


def test_hysteresis_holds_the_current_in_its_band_switching_at_its_edges():
    c = Circuit("bang_bang")
    c.V("Vin", "in", 0, 24.0)
    c.switch("S", "in", "x", Hysteresis("i_L1", 2.0, 0.2))
    c.diode("D1", 0, "x")
    c.L("L1", "x", "y", 1e-3)
    c.R("R1", "y", 0, 5.0)
    run = c.build().simulate(0.02)
    settled = run.t > 0.005
    current = run.signal("i_L1")[settled]
    assert current.min() >= 1.9 - 1e-9 and current.max() <= 2.1 + 1e-9
    later = [e for e in run.events if e.t > 0.005]
    assert len(later) > 20
    for event in later:
        opened = "S=open" in event.mode_after.describe()
        i = event.x_before[run.state_names.index("p_L1")] / 1e-3
        assert i == pytest.approx(2.1 if opened else 1.9, abs=1e-8)


def test_a_controlled_circuit_saves_and_loads_to_the_same_run(tmp_path):
    model = closed_loop_buck()
    path = tmp_path / "buck_pi.toml"
    model.save(path)
    again = load_model(path)
    first, second = model.simulate(2e-4), again.simulate(2e-4)
    np.testing.assert_array_equal(first.x, second.x)
    assert [e.t for e in first.events] == [e.t for e in second.events]


@pytest.mark.parametrize("arguments, said", [
    (dict(limits=(1.0, 0.0)), "lo < hi"),
    (dict(measure=3.0), "as a text"),
    (dict(kp="not a name"), "parameter name"),
])
def test_a_controller_that_cannot_be_is_refused_naming_it(arguments, said):
    c = Circuit("bad")
    c.V("Vin", "in", 0, 24.0)
    c.R("R1", "in", 0, 1.0)
    options = dict(measure="v_in", reference=1.0, kp=1.0, ki=1.0)
    options.update(arguments)
    with pytest.raises(HybridBondGraphError, match=said) as caught:
        c.pid("PI1", **options)
    assert "PI1" in str(caught.value) or "kp" in str(caught.value)


def test_a_pi_without_gain_to_set_its_tracking_time_asks_for_it():
    c = Circuit("no_tracking")
    c.V("Vin", "in", 0, 24.0)
    c.R("R1", "in", 0, 1.0)
    c.pi("PI1", "v_in", 1.0, kp=0.0, ki=1.0, limits=(0.0, 1.0))
    with pytest.raises(HybridBondGraphError, match="tracking time"):
        c.build()


def test_a_source_driven_by_a_controller_holds_its_output_at_the_reference():
    """A voltage source driven by ``PI1`` through R into C ‖ R_L: at rest ``v_out = reference`` and the
    source gives ``reference·(R + R_L)/R_L`` — all of it the integral term, the error being 0."""
    c = Circuit("driven")
    c.V("Vs", "s", 0, "PI1")
    c.R("R1", "s", "out", 1.0)
    c.C("C1", "out", 0, 1e-3)
    c.R("RL", "out", 0, 4.0)
    c.pi("PI1", "v_out", 5.0, kp=0.5, ki=200.0)
    run = c.build().simulate(0.3, rtol=1e-10, atol=1e-12)
    assert run.signal("v_out")[-1] == pytest.approx(5.0, rel=1e-8)
    assert run.signal("v_Vs")[-1] == pytest.approx(5.0 * 5.0 / 4.0, rel=1e-8)
    assert run.signal("q_PI1_I")[-1] == pytest.approx(6.25, rel=1e-8)


def test_a_speed_loop_around_a_dc_motor_settles_at_its_reference_under_load():
    """``J·dω/dt = k·i − b·ω − T_l``, ``L·di/dt = u − R·i − k·ω``, ``u = PI1``: at rest ``ω = ω_ref`` and
    ``u = k·ω_ref + R·(b·ω_ref + T_l)/k``."""
    from models.mechanics import Mechanism

    k, R, b, T_l, w_ref = 0.1, 1.0, 0.001, 0.05, 100.0
    m = Mechanism("speed_loop", kind="rotational")
    m.inertia("J", "shaft", 0.01)
    m.damper("b", "shaft", 0, b)
    m.motor("M1", "shaft", k, V="PI1", R=R, L=1e-3)
    m.torque("T_load", "shaft", -T_l)
    m.pi("PI1", "omega_shaft", w_ref, kp=0.5, ki=20.0, limits=(-48.0, 48.0))
    run = m.build().simulate(12.0, rtol=1e-10, atol=1e-12)
    assert run.signal("omega_shaft")[-1] == pytest.approx(w_ref, rel=1e-8)
    assert run.signal("PI1")[-1] == pytest.approx(k * w_ref + R * (b * w_ref + T_l) / k, rel=1e-7)
