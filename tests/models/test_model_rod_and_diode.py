"""The falling rod and the diode circuit (the paper's examples) against physics."""

import math

import numpy as np
import pytest

from models import diode_circuit, falling_rod
from switching import DivergenceOfTimeError

RUN = dict(rtol=1e-9, atol=1e-12)


@pytest.fixture(scope="module")
def rods():
    return {mu: falling_rod.build(mu=mu).simulate(0.5, "RK45", **RUN) for mu in (0.002, 0.004, 0.005)}


def impact(trajectory):
    (first, *_) = trajectory.events
    return first


@pytest.mark.parametrize("mu", [0.002, 0.004])
def test_small_mu_slides_right_after_impact_through_a_mythical_stuck_mode(rods, mu):
    instant = impact(rods[mu])
    assert [(s.mode.label, s.kind) for s in instant.steps] == [
        ("free|stuck", "start"),
        ("contact|stuck", "mythical"),
        ("contact|slide_neg", "continuous"),
    ]


def test_large_mu_sticks(rods):
    instant = impact(rods[0.005])
    assert [(s.mode.label, s.kind) for s in instant.steps][-1] == ("contact|stuck", "continuous")


def test_impact_time_is_the_free_fall_time(rods):
    expected = math.sqrt(2 * (0.23 - 0.1 * math.sin(0.862)) / 9.81)
    for trajectory in rods.values():
        assert impact(trajectory).t == pytest.approx(expected, abs=1e-10)


def test_stuck_impact_stops_the_tip_and_conserves_angular_momentum_about_it(rods):
    trajectory = rods[0.005]
    m, J, l = 1.0, 1.0, 0.1
    k = trajectory.event_index[0]
    th = trajectory.signal("theta")[k]
    vx, vy, w = (trajectory.signal(n) for n in ("vx", "vy", "omega"))
    assert trajectory.signal("tip_vx")[k] == pytest.approx(0, abs=1e-14)
    assert trajectory.signal("tip_vy")[k] == pytest.approx(0, abs=1e-14)
    L = J * w + m * l * (np.cos(th) * vy - np.sin(th) * vx)  # about the tip, which does not move
    assert L[k] == pytest.approx(L[k - 1], rel=1e-12)
    # the normal impulse equals the change of vertical momentum; the friction one, of horizontal
    instant = impact(trajectory)
    assert instant.impulse("normal_force") == pytest.approx(m * (vy[k] - vy[k - 1]), rel=1e-12)
    assert instant.impulse("friction_force") == pytest.approx(m * (vx[k] - vx[k - 1]), rel=1e-10, abs=1e-14)
    # and it sticks because Coulomb allows it: |P_x| <= mu P_n
    assert abs(instant.impulse("friction_force")) <= 0.005 * instant.impulse("normal_force")


def test_forces_while_in_contact(rods):
    for mu, trajectory in rods.items():
        in_contact = np.array([m.state_of("contact") == "contact" for m in trajectory.modes])
        stuck = in_contact & np.array([m.state_of("friction") == "stuck" for m in trajectory.modes])
        N = trajectory.signal("normal_force")
        F = trajectory.signal("friction_force")
        assert in_contact.sum() > 5
        assert np.all(N[in_contact] >= -1e-9), "the floor only pushes"
        assert np.all(np.abs(F[stuck]) <= mu * N[stuck] * (1 + 1e-9))
        sliding = in_contact & ~stuck
        if sliding.any():  # Coulomb: |F| = mu N against the motion
            np.testing.assert_allclose(np.abs(F[sliding]), mu * N[sliding], rtol=1e-9, atol=1e-12)
            assert np.all(F[sliding] * trajectory.signal("tip_vx")[sliding] <= 1e-12)


def test_long_rod_slides_for_a_point_in_time_and_lifts_off():
    trajectory = falling_rod.build(mu=0.002, l=10.0, y0=23.0).simulate(2.0, "RK45", **RUN)
    instant = impact(trajectory)
    assert [(s.mode.label, s.kind) for s in instant.steps] == [
        ("free|stuck", "start"),
        ("contact|stuck", "mythical"),
        ("contact|slide_neg", "pinnacle"),
        ("free|slide_neg", "continuous"),
    ]
    k = trajectory.event_index[0]
    assert trajectory.signal("tip_vy")[k] == pytest.approx(0, abs=1e-12)  # a plastic impact, then lift-off
    assert trajectory.signal("tip_y")[-1] > 0


def test_diode_current_is_continuous_at_opening_and_decays_as_rl():
    model = diode_circuit.build()
    trajectory = model.simulate(1.0, "RK45", **RUN)
    opening = trajectory.events[0]
    assert [(s.mode.label, s.kind) for s in opening.steps] == [
        ("closed|off", "start"),
        ("open|off", "mythical"),
        ("open|on", "continuous"),
    ]
    i = trajectory.signal("i_L")
    k = trajectory.event_index[0]
    V, R, L, V_th, t_open = 10.0, 1.0, 0.1, 0.7, 0.5
    i0 = V / R * (1 - math.exp(-t_open * R / L))
    assert i[k - 1] == i[k] == pytest.approx(i0, rel=1e-8)
    decaying = (trajectory.t > t_open) & np.array([m.label == "open|on" for m in trajectory.modes])
    tau = trajectory.t[decaying] - t_open
    np.testing.assert_allclose(i[decaying], (i0 + V_th / R) * np.exp(-R * tau / L) - V_th / R, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(trajectory.signal("i_D")[decaying], i[decaying], rtol=1e-12)
    np.testing.assert_allclose(trajectory.signal("v_D")[decaying], V_th, rtol=1e-12)


def test_diode_holding_current_above_the_inductor_current_diverges():
    model = diode_circuit.build(I_th=200.0)
    with pytest.raises(DivergenceOfTimeError) as info:
        model.simulate(1.0, "RK45", **RUN)
    assert "diode=off" in str(info.value) and "i_D <= I_th" in str(info.value)
    assert info.value.trajectory.t[-1] == pytest.approx(0.5)
