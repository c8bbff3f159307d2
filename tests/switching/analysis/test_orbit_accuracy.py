"""Periodic orbits that are right or refused (issue 45, items 1–3), against exact answers.

**A clock edge at the period's end.**  The current-mode converter (models/current_mode_converter.py,
its defaults: RC load, ``m_c = 0``) turns its switch on at the clock's rising edge, where
``cos(2π f t − π w) − cos(π w)`` crosses 0: at ``t = 1/f`` that is located one or two ulps after
``T`` at 50, 70 and 100 kHz.  The edge belongs to the period, so the next iterate starts with the
switch on; it used to start off (the run to ``T`` ended before the edge) and Newton stopped with a
changed mode sequence.  Exact orbit: from a clock edge in continuous conduction the current rises at
``m1 = Vin/L`` while ``q_C`` decays as ``e^{−t/(R C)}`` until ``i_L = i_ref`` at
``t_on = (i_ref − i_L0)/m1``, then the affine off phase ``ẋ = A x + b`` (``A = [[0, −1/C], [1/L,
−1/(R C)]]``, ``b = (Vin, 0)``) for ``T − t_on`` (its matrix exponential); the fixed point of that map
by Newton (Jacobian by central differences; the map is smooth there).  A buck converter drawn with
the same kind of clock (``Circuit``: the switch closes in the pulse ``cos(2π f t − π w) − cos(π w) > 0``
and opens where ``cos(2π f t − π D) − cos(π D) < 0``, at ``D T``; an ideal freewheeling diode) met the
same edge at 50, 70 and 100 kHz.  In continuous conduction its two phases are affine, ``ṗ_L = v_sw −
q_C/C``, ``q̇_C = p_L/L − q_C/(R C)`` with ``v_sw = Vin`` for ``D T`` and 0 for ``(1 − D) T``: the orbit
``x* = (I − E_off E_on)⁻¹ (E_off c_on + c_off)`` from the phases' matrix exponentials.

**The error of the start near a fold.**  The ball on the vibrating table (models/vibrating_table.py,
tests/models/test_model_vibrating_table.py for the closed forms): the period-1 orbit exists for
``Γ = A ω²/g ≥ Γ_min = π (1 − e)/(1 + e)``, its apex at ``y0 = A sin θ + g T²/8`` with
``cos θ = Γ_min/Γ``, ``v = 0``; its multiplier nearest 1 tends to 1 as ``Γ → Γ_min`` (a fold).  At
``A = A_min (1 + 1e-8)`` (``|1 − μ| ≈ 4e-4``) a residual of 1e-8 leaves the start off by about
``1e-8 / 4e-4``: the old residual test returned ``y0`` 9.5e-6 off.  At ``A = A_min (1 − 1e-9)`` there
is no orbit (the map's smallest residual is about 1e-9, no round-off): it must be refused.

**The period of an autonomous orbit.**  The rimless wheel's gait (models/rimless_wheel.py,
tests/models/test_model_rimless_wheel.py for the closed forms): two stances of the closed-form
time ``t_s(ω⁺*)``.  The period moves with the start, ``δT = τ_x·δx``: a start within 4.6e-9 left the
period 1.4e-8 off; the error estimate covers it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_model_rimless_wheel import fixed_point, stance_time  # the closed forms (tests/models)
from test_model_vibrating_table import G, OMEGA, apex, gamma_min, state

from models import current_mode_converter, rimless_wheel, vibrating_table
from models.circuits import Circuit
from switching import NoOrbitError, periodic_orbit
from switching.analysis.orbits import EDGE_ULPS
from switching_models import phase  # the exact affine phase: a matrix exponential

CMC = current_mode_converter.DEFAULTS
TABLE_T = 2 * math.pi / OMEGA


def cmc_map(x, T):
    """The converter's exact period map from a clock edge (module docstring), ``x = (p_L, q_C)``."""
    L, C, R, Vin = CMC["L"], CMC["C"], CMC["R_load"], CMC["Vin"]
    t_on = (CMC["i_ref"] - x[0] / L) / (Vin / L)
    assert CMC["w_clock"] * T < t_on < T  # the comparator turns the switch off, after the pulse
    on = np.array([x[0] + Vin * t_on, x[1] * math.exp(-t_on / (R * C))])
    E, c = phase(np.array([[0.0, -1.0 / C], [1.0 / L, -1.0 / (R * C)]]), np.array([Vin, 0.0]), T - t_on)
    return E @ on + c


def cmc_orbit(T):
    """The fixed point of :func:`cmc_map` (Newton, central differences)."""
    x = np.array([CMC["L"] * 1.9, CMC["C"] * 21.6])
    for _ in range(8):
        h = 1e-6 * np.abs(x)
        J = np.column_stack([(cmc_map(x + dx, T) - cmc_map(x - dx, T)) / (2 * dx[j])
                             for j, dx in enumerate(np.diag(h))])
        x = x - np.linalg.solve(J - np.eye(2), cmc_map(x, T) - x)
    return x


@pytest.mark.parametrize("f_sw", [50e3, 70e3, 100e3])
def test_a_clock_edge_ulps_after_the_period_belongs_to_it(f_sw):
    T = 1.0 / f_sw
    exact = cmc_orbit(T)
    model = current_mode_converter.build(f_sw=f_sw)
    orbit = periodic_orbit(model, period=T, x0=exact * (1 + 1e-3), max_step=0.02 * T)
    np.testing.assert_allclose(orbit.x0, exact, rtol=1e-8)
    assert orbit.error <= 1e-8 and orbit.iterations >= 1
    # the period ends just after the clock's own instant, located a few ulps after T: the next one starts on
    edge = orbit.trajectory.events[-1]
    assert T < edge.t <= T + EDGE_ULPS * np.spacing(T)
    assert edge.mode_after.state_of("switch") == "on" and orbit.modes[-1] == orbit.modes[0]
    assert orbit.trajectory.t[-1] == edge.t and np.allclose(orbit.trajectory.x[-1], orbit.x0, rtol=1e-8)


def test_without_an_instant_after_it_the_period_ends_at_t0_plus_T():
    # the 10 kHz clock's edge is located at T itself: the run ends there, on the period's end exactly
    T = 1e-4
    model = current_mode_converter.build(f_sw=1.0 / T)
    orbit = periodic_orbit(model, period=T, x0=cmc_orbit(T) * (1 + 1e-3), max_step=0.02 * T)
    np.testing.assert_allclose(orbit.x0, cmc_orbit(T), rtol=1e-8)
    assert orbit.trajectory.t[-1] == T


BUCK = dict(Vin=12.0, L=1e-3, C=1e-4, R=10.0, D=0.4, w=0.05)


def clocked_buck(f_sw):
    """The buck converter switched by a clock (module docstring)."""
    pulse, duty = "cos(2*pi*f_sw*t - pi*w) - cos(pi*w)", "cos(2*pi*f_sw*t - pi*D) - cos(pi*D)"
    c = Circuit("buck")
    c.V("Vin", "in", "0", BUCK["Vin"])
    c.switch("S", "in", "sw", closed_when=f"{pulse} > 0", open_when=f"{duty} < 0")
    c.diode("D1", "0", "sw")
    c.L("L", "sw", "out", BUCK["L"])
    c.C("C", "out", "0", BUCK["C"])
    c.R("Rl", "out", "0", BUCK["R"])
    return c.build(parameters={"f_sw": f_sw, "D": BUCK["D"], "w": BUCK["w"]})


def buck_orbit(T):
    """``x* = (p_L, q_C)`` of the buck in continuous conduction (module docstring)."""
    L, C, R, D = BUCK["L"], BUCK["C"], BUCK["R"], BUCK["D"]
    A = np.array([[0.0, -1.0 / C], [1.0 / L, -1.0 / (R * C)]])
    E_on, c_on = phase(A, np.array([BUCK["Vin"], 0.0]), D * T)
    E_off, c_off = phase(A, np.zeros(2), (1 - D) * T)
    return np.linalg.solve(np.eye(2) - E_off @ E_on, E_off @ c_on + c_off)


@pytest.mark.parametrize("f_sw", [50e3, 70e3, 100e3])
def test_a_clocked_buck_takes_its_edge_at_the_period_end(f_sw):
    T = 1.0 / f_sw
    exact = buck_orbit(T)
    model = clocked_buck(f_sw)
    orbit = periodic_orbit(model, period=T, x0=exact * (1 + 1e-3), mode="S=closed, D1=off", max_step=0.05 * T)
    np.testing.assert_allclose(orbit.x0, exact, rtol=1e-8)
    assert orbit.error <= 1e-8 and orbit.trajectory.signal("i_L").min() > 0  # continuous conduction
    assert orbit.mode_names == ["S=closed, D1=blocking", "S=open, D1=conducting", "S=closed, D1=blocking"]
    edge = orbit.trajectory.events[-1]
    assert T <= edge.t <= T + EDGE_ULPS * np.spacing(T) and orbit.trajectory.t[-1] == edge.t


def table_orbit(relative, guess_error=0.01):
    """The vibrating table at ``A = A_min (1 + relative)`` (e = 0.5), shot from its apex's closed form at
    ``A_min (1 + |relative|)``, the guess ``guess_error`` off in height and velocity."""
    e = 0.5
    A_min = gamma_min(e) * G / OMEGA**2
    model = vibrating_table.build(A=A_min * (1 + relative), e=e)
    t0, y0 = apex(A_min * (1 + abs(relative)), e)
    guess = state(model, p=guess_error * G * TABLE_T / 2, y=(1 + guess_error) * y0)
    return model, y0, lambda **options: periodic_orbit(model, period=TABLE_T, t0=t0, x0=guess, rtol=1e-10,
                                                       atol=1e-13, **options)


def test_near_a_fold_the_default_tolerance_holds_on_the_start_not_only_on_the_residual():
    model, y0, shoot = table_orbit(1e-8)
    orbit = shoot()
    y = orbit.x0[[s.name for s in model.states].index("y")]
    assert abs(y - y0) / y0 <= 1e-8  # the residual test alone left it 9.5e-6 off
    assert orbit.error <= 1e-8 and orbit.residual <= 1e-8
    # the estimate is honest: no state further off than it says (relative to the amplitudes)
    assert abs(y - y0) / y0 <= max(10 * orbit.error, 1e-12)
    gap = min(abs(1 - mu) for mu in orbit.multipliers)
    assert gap < 1e-3 and orbit.residual_error == pytest.approx(orbit.residual / gap, rel=1e-6)
    assert orbit.x0_error.shape == (2,) and orbit.error == max(orbit.step_error, orbit.residual_error)


def test_beyond_the_fold_the_non_orbit_is_refused():
    _, _, shoot = table_orbit(-1e-9)
    with pytest.raises(NoOrbitError, match="no orbit: the map has no fixed point near x0; closest residual") as info:
        shoot()
    error = info.value
    assert 1e-10 < error.residual < 1e-8 and len(error.history) == 21
    assert error.residual == min(error.history) and "as beyond a fold" in str(error)


def test_a_residual_at_round_off_is_not_called_a_missing_orbit():
    # tol below what rtol = 1e-10 can give near the fold: the residual stalls at the runs' round-off
    _, _, shoot = table_orbit(1e-8)
    with pytest.raises(Exception) as info:
        shoot(tol=1e-16)
    assert type(info.value).__name__ == "OrbitConvergenceError"
    assert "round-off" in str(info.value) and "lower rtol/atol" in str(info.value)


def test_an_autonomous_period_is_within_tol_too():
    gait = periodic_orbit(rimless_wheel.build(), section="stance: even -> odd", period=2.0, rtol=1e-10, atol=1e-12)
    assert gait.period == pytest.approx(2 * stance_time(fixed_point()[1]), rel=1e-8)  # was 1.4e-8 off
    assert gait.period_error <= gait.error <= 1e-8
