"""The parallel-capacitors model against circuit physics: charge conservation,
equal voltages after charge sharing, the energy lost
ΔE = C1 C2 / (2 (C1 + C2)) ΔV², the current pulse, and with a series
resistance the RC exchange reaching the same state with ΔE dissipated in R."""

import math

import numpy as np
import pytest
from scipy.integrate import simpson

from bondgraph.errors import InvalidGraphError, UnknownParameterError
from models import parallel_capacitors

CASES = [
    (1e-3, 2e-3, 5.0, 1.0),
    (4.7e-6, 1e-6, -3.0, 12.0),
    (1.0, 1.0, 2.0, 0.0),
]


def shared(C1, C2, V1, V2):
    """(common voltage, charge moved 1 → 2, energy lost) of ideal charge sharing."""
    v = (C1 * V1 + C2 * V2) / (C1 + C2)
    return v, C1 * (V1 - v), C1 * C2 / (2 * (C1 + C2)) * (V1 - V2) ** 2


def test_module_conventions():
    assert parallel_capacitors.SIGNALS == ("v1", "v2", "q_total", "energy")
    model = parallel_capacitors.build()
    for name in parallel_capacitors.SIGNALS:
        model.signal_expression(name)
    assert "a priori" in parallel_capacitors.__doc__
    with pytest.raises(UnknownParameterError):
        parallel_capacitors.build(C3=1.0)
    with pytest.raises(InvalidGraphError):
        parallel_capacitors.build(R=-1.0)
    with pytest.raises(InvalidGraphError):
        parallel_capacitors.build(C1=0.0)


@pytest.mark.parametrize("C1, C2, V1, V2", CASES)
def test_ideal_switch_shares_charge_in_a_jump_and_loses_the_right_energy(C1, C2, V1, V2):
    t_close = 0.01
    model = parallel_capacitors.build(C1=C1, C2=C2, V1=V1, V2=V2, t_close=t_close)
    trajectory = model.simulate(0.05, "RK45", rtol=1e-10, atol=1e-14 * max(C1, C2))
    (instant,) = trajectory.events
    assert instant.t == pytest.approx(t_close, abs=1e-14)
    assert instant.kinds == ["start", "continuous"]  # the closed mode jumps and then flows
    v, moved, lost = shared(C1, C2, V1, V2)
    k = trajectory.event_index[0]
    signal = {name: trajectory.signal(name) for name in parallel_capacitors.SIGNALS}
    # before: untouched
    assert signal["v1"][k - 1] == pytest.approx(V1, rel=1e-14) and signal["v2"][k - 1] == pytest.approx(V2, rel=1e-14)
    # total charge conserved at the switching and at every sample
    q0 = C1 * V1 + C2 * V2
    np.testing.assert_allclose(signal["q_total"], q0, rtol=1e-14, atol=1e-16 * max(C1, C2))
    # equal voltages after, at the charge-sharing value, and held there
    np.testing.assert_allclose(signal["v1"][k:], v, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(signal["v2"][k:], v, rtol=1e-13, atol=1e-13)
    # the energy lost in the jump
    E0 = 0.5 * C1 * V1**2 + 0.5 * C2 * V2**2
    assert signal["energy"][k - 1] == pytest.approx(E0, rel=1e-14)
    assert signal["energy"][k - 1] - signal["energy"][k] == pytest.approx(lost, rel=1e-12, abs=1e-15 * E0)
    assert signal["energy"][-1] == pytest.approx(0.5 * (C1 + C2) * v**2, rel=1e-12)
    # the current is a Dirac pulse carrying the moved charge (same through both bonds of the switch)
    assert instant.impulse("f_i1") == pytest.approx(moved, rel=1e-12, abs=1e-15 * max(C1, C2))
    assert instant.impulse("f_i2") == pytest.approx(moved, rel=1e-12, abs=1e-15 * max(C1, C2))


@pytest.mark.parametrize("C1, C2, V1, V2", CASES[:2])
def test_series_resistance_exchanges_charge_continuously_and_dissipates_the_same_energy(C1, C2, V1, V2):
    R_ = 10.0
    t_close = 0.002
    tau = R_ * C1 * C2 / (C1 + C2)
    t_end = t_close + 40 * tau
    model = parallel_capacitors.build(C1=C1, C2=C2, V1=V1, V2=V2, R=R_, t_close=t_close)
    times = np.concatenate([[0.0], t_close + tau * np.linspace(0, 40, 4001)])
    trajectory = model.simulate(t_end, "RK45", rtol=1e-11, atol=1e-15 * max(C1, C2), t_eval=times)
    (instant,) = trajectory.events
    assert instant.t == pytest.approx(t_close, abs=1e-14)
    assert np.array_equal(instant.x_before, instant.x_after)  # nothing jumps: the flow is continuous
    v, moved, lost = shared(C1, C2, V1, V2)
    t = trajectory.t
    v1, v2 = trajectory.signal("v1"), trajectory.signal("v2")
    q_total, energy = trajectory.signal("q_total"), trajectory.signal("energy")
    q0 = C1 * V1 + C2 * V2
    np.testing.assert_allclose(q_total, q0, rtol=1e-12, atol=1e-15 * max(C1, C2))
    # the closed form: v1 - v2 decays as exp(-(t - t_close)/tau) towards the shared voltage
    after = t >= t_close
    decay = np.exp(-(t[after] - t_close) / tau)
    np.testing.assert_allclose(v1[after], v + (V1 - v) * decay, rtol=0, atol=1e-8 * abs(V1 - V2))
    np.testing.assert_allclose(v2[after], v + (V2 - v) * decay, rtol=0, atol=1e-8 * abs(V1 - V2))
    # the same final state as the ideal switch
    assert v1[-1] == pytest.approx(v, abs=1e-9 * abs(V1 - V2))
    assert v2[-1] == pytest.approx(v, abs=1e-9 * abs(V1 - V2))
    # energy dissipated in R, ∫ R i² dt over the exchange, equals the ideal switch's jump loss
    unique = np.concatenate([[True], np.diff(t) > 0])  # drop the duplicate sample at the switching
    ts, current = t[unique & after], ((v1 - v2) / R_)[unique & after]
    dissipated = simpson(R_ * current**2, x=ts)
    print(f"\nC1={C1:g} C2={C2:g} ΔV={V1 - V2:g}: ∫R i² dt = {dissipated:.12g} J, "
          f"C1C2/(2(C1+C2))ΔV² = {lost:.12g} J (relative difference {dissipated / lost - 1:.2e})")
    assert dissipated == pytest.approx(lost, rel=1e-6)
    # and the energy balance along the way: stored + dissipated so far = initial
    E0 = 0.5 * C1 * V1**2 + 0.5 * C2 * V2**2
    assert energy[-1] == pytest.approx(E0 - lost, rel=1e-9)
    assert np.all(np.diff(energy[unique]) <= 1e-15 * E0)


def test_small_resistance_tends_to_the_ideal_jump():
    """As R → 0 the exchange gets faster (τ ∝ R) and the state shortly after
    closing tends to the charge-sharing jump's."""
    C1, C2, V1, V2 = 1e-3, 2e-3, 5.0, 1.0
    v, _, _ = shared(C1, C2, V1, V2)
    errors = []
    for R_ in (1.0, 0.1, 0.01):
        trajectory = parallel_capacitors.build(R=R_).simulate(0.0101, "Radau", rtol=1e-10, atol=1e-15)
        errors.append(abs(trajectory.signal("v1")[-1] - v))
    # 0.1 ms after closing: |v1 - v| = (V1 - v) e^{-1e-4/τ}, τ = R·2/3 ms
    for R_, err in zip((1.0, 0.1, 0.01), errors):
        assert err == pytest.approx((V1 - v) * math.exp(-1e-4 / (R_ * C1 * C2 / (C1 + C2))), abs=1e-8)
    assert errors[0] > errors[1] > errors[2]


@pytest.mark.parametrize("R_", [0.0, 10.0])
def test_default_run_and_its_error_estimate(R_):
    trajectory = parallel_capacitors.build(R=R_).simulate(**parallel_capacitors.RUN)
    text = parallel_capacitors.error_estimate(trajectory)
    assert "closed form" in text and float(text.split()[0]) < 1e-8, text
