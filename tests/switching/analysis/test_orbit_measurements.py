"""Measurements on a periodic orbit (one exact period) and its dense samples, against the exact orbit of a
buck converter in continuous conduction (its phases' matrix exponentials)."""

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import minimize_scalar

from models.circuits import PWM, Circuit
from switching import periodic_orbit

VIN, L, C, R, D, F_SW = 24.0, 100e-6, 20e-6, 5.0, 0.5, 50e3
T = 1.0 / F_SW
A = np.array([[0.0, -1.0 / C], [1.0 / L, -1.0 / (R * C)]])  # x = (p_L, q_C): ṗ = v_sw − q/C, q̇ = p/L − q/(RC)


def buck():
    c = Circuit("buck")
    c.V("Vin", "in", 0, VIN)
    c.switch("S", "in", "sw", PWM(T, D))
    c.diode("D1", 0, "sw")
    c.L("L", "sw", "out", L)
    c.C("C", "out", 0, C)
    c.R("Rl", "out", 0, R)
    return c.build()


def flow(x, source, tau):
    """``x`` after ``tau`` [s] of ``ẋ = A x + (source, 0)``."""
    block = np.zeros((3, 3))
    block[:2, :2], block[0, 2] = A, source
    return (expm(block * tau) @ np.append(x, 1.0))[:2]


def exact_orbit():
    """``x*`` at the start of the on-phase: the fixed point of the two phases' affine maps."""
    on = np.array([flow(e, VIN, D * T) - flow(np.zeros(2), VIN, D * T) for e in np.eye(2)]).T
    off = np.array([flow(e, 0.0, (1 - D) * T) for e in np.eye(2)]).T
    return np.linalg.solve(np.eye(2) - off @ on, off @ flow(np.zeros(2), VIN, D * T))


def exact_v(tau, x0):
    """``v_C`` at ``tau`` ∈ [0, T] along the exact orbit from ``x0``."""
    if tau <= D * T:
        return flow(x0, VIN, tau)[1] / C
    return flow(flow(x0, VIN, D * T), 0.0, tau - D * T)[1] / C


def exact_extreme(x0, sign):
    found = minimize_scalar(lambda tau: -sign * exact_v(tau, x0), bounds=(0.0, T), method="bounded",
                            options={"xatol": 1e-16})
    ends = [exact_v(0.0, x0), exact_v(D * T, x0)]
    return sign * max([-found.fun] + [sign * v for v in ends])  # (found.fun is −sign·v at its extreme)


@pytest.fixture(scope="module")
def orbit():
    x0 = exact_orbit()
    return periodic_orbit(buck(), period=T, x0=x0 * (1 + 1e-3), max_step=0.05 * T), x0


def test_the_orbit_s_ripple_is_the_exact_orbit_s_and_near_the_textbook_s(orbit):
    found, x0 = orbit
    np.testing.assert_allclose(found.x0, x0, rtol=1e-8)
    v_max, v_min = exact_extreme(x0, +1), exact_extreme(x0, -1)
    ripple = found.measure("v_C", "ripple")
    assert ripple == pytest.approx(v_max - v_min, rel=1e-7)
    mean = found.measure("v_C", "mean")
    textbook = (1 - D) * mean * T**2 / (8 * L * C)  # constant output, the inductor's ripple all into C
    assert ripple == pytest.approx(textbook, rel=0.05)
    assert mean == pytest.approx(D * VIN, rel=1e-9)  # volt-second balance of L: the mean of v_sw, exactly


def test_the_orbit_s_mean_of_the_inductor_current_is_the_load_s(orbit):
    """Charge balance of C over a period: the mean of i_L is the mean of v_C/R, exactly on the orbit."""
    found, _ = orbit
    assert found.measure("i_L", "mean") == pytest.approx(found.measure("v_C", "mean") / R, rel=1e-8)


def test_the_dense_orbit_holds_every_signal_at_its_samples(orbit):
    found, x0 = orbit
    dense = found.sampled(401)
    assert dense.sampling == "samples" and len(dense.without_instants().t) == 401
    assert dense.t[0] == pytest.approx(0.0) and dense.t[-1] == pytest.approx(T)
    rows = dense.without_instants()
    exact = np.array([exact_v(tau, x0) for tau in rows.t])
    np.testing.assert_allclose(rows.signal("v_C"), exact, rtol=1e-8)


@pytest.fixture(scope="module")
def smooth_buck_orbit():
    """A buck with little ripple (100 µF into 2 Ω at 100 kHz: 0.06 % of its output), its duty the parameter
    ``S_duty``: the averaged model's regime."""
    c = Circuit("smooth_buck")
    c.V("Vin", "in", 0, VIN)
    c.switch("S", "in", "sw", PWM(1e-5, D))
    c.diode("D1", 0, "sw")
    c.L("L", "sw", "out", L)
    c.C("C", "out", 0, 100e-6)
    c.R("Rl", "out", 0, 2.0)
    model = c.build()
    warm = model.simulate(0.01, "RK45-jit")
    return periodic_orbit(model, period=1e-5, x0=warm.x[-1], max_step=5e-7)


@pytest.mark.parametrize("f", [10.0, 100.0, 1000.0])
def test_the_period_map_s_duty_to_output_gain_is_the_averaged_model_s_at_low_frequency(smooth_buck_orbit, f):
    """The orbit's small-signal period map with the duty as input, ``H(z) = C (zI − A)⁻¹ B``, at
    ``z = e^(jωT)`` against the textbook's averaged model ``Vin / (LC s² + (L/R) s + 1)``: the same gain
    (to the ripple's share, the map sampling the output at the period's start) and the half period of
    delay of that sampling (``e^(−jωT/2)``)."""
    system = smooth_buck_orbit.small_signal(inputs=["S_duty"], outputs=["v_C"])
    period = 1e-5
    z = np.exp(2j * np.pi * f * period)
    mapped = (system.C @ np.linalg.solve(z * np.eye(len(system.A)) - system.A, system.B) + system.D)[0, 0]
    s = 2j * np.pi * f
    averaged = VIN / (L * 100e-6 * s**2 + L / 2.0 * s + 1)
    assert abs(mapped) == pytest.approx(abs(averaged), rel=1e-3)
    assert np.angle(mapped / averaged) == pytest.approx(-np.pi * f * period, abs=1e-3)
