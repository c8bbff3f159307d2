"""Inputs that fix dependent storage (issue 19, item 2): the input's time
derivative enters the equations as the symbol ``du/dt``, which the simulator
supplies (exactly for an ExpressionInput, by a central difference for a
function).

Hand-derived: a mass m with a damper b on a 1-junction driven by a prescribed
velocity u(t) (a flow source) has p_m = m·u (dependent), dp_m/dt = m·du/dt,
and the source delivers the force e = b·u + m·du/dt.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from bondgraph import BondGraph, I, One, R, Sf, Zero
from switching import Automaton, ExpressionInput, HybridModel


def driven_mass(clutch=False):
    g = BondGraph("drive")
    u = g.input("u")
    v = g.add(One("v"))
    g.connect(v, I("m", "m"))
    g.connect(v, R("b", "b"))
    if clutch:  # a controlled 0-junction: off, no force passes; on, the mass moves at u
        c = g.add(Zero("clutch", controlled=True))
        g.connect(c, v)
        g.connect(Sf("drive", u), c)
    else:
        g.connect(Sf("drive", u), v)
    return g


def test_driven_mass_equations_hold_the_input_derivative():
    g = driven_mass()
    eq = g.equations()
    u, m, b = sp.symbols("u m b")
    du = eq.input_rates[u]
    assert du.name == "du/dt" and list(eq.input_rates) == [u]
    p = sp.Symbol("p_m")
    assert sp.simplify(eq.constraints[p] - m * u) == 0
    assert sp.simplify(eq.rate(p) - m * du) == 0
    assert sp.simplify(eq.effort("drive", resolved=True) - (b * u + m * du)) == 0
    assert du not in eq.parameters


def test_open_port_flow_into_a_mass_gives_m_times_its_derivative():
    h = BondGraph("port")
    w = h.add(One("w"))
    h.connect(w, I("m", "m"))
    h.port("A", w)
    eq = h.equations(port_causality={"A": "flow"})
    f_a, m = sp.Symbol("f_A"), sp.Symbol("m")
    (rate,) = eq.input_rates.values()
    symbol, effort = eq.port_outputs["A"]
    assert symbol == sp.Symbol("e_A")
    assert sp.simplify(eq.resolve(effort) - m * rate) == 0
    assert rate == sp.Symbol("df_A/dt") and eq.input_rates == {f_a: rate}


@pytest.mark.parametrize("exact", [True, False])
def test_force_of_a_prescribed_velocity_is_m_du_dt_plus_damping(exact):
    u = ExpressionInput("sin(2*t)") if exact else (lambda t: math.sin(2 * t))
    model = HybridModel(driven_mass(), [], {"m": 2.0, "b": 0.5}, inputs={"u": u})
    tr = model.simulate(3.0, "RK45", rtol=1e-10)
    t = tr.t
    force = 2.0 * 2 * np.cos(2 * t) + 0.5 * np.sin(2 * t)
    # exact derivative: round-off; central difference with h = 6e-6: h²·|u'''|/6 ≈ 5e-11 relative
    assert np.max(np.abs(tr.signal("e_drive") - force)) <= (1e-12 if exact else 1e-9) * 4.5
    assert np.max(np.abs(tr.state("p_m") - 2.0 * np.sin(2 * t))) <= 1e-12


def test_clutch_engaging_jumps_to_the_prescribed_momentum_then_follows_it():
    """Free until t = 1 (p = p0·e^{−bt/m}); the clutch closes: conservation of
    state gives p⁺ = m·u(1); then p = m·u(t) and the force is m·u̇ + b·u."""
    clutch = Automaton("clutch", {"open": {"clutch": False}, "closed": {"clutch": True}}, "open")
    clutch.add_transition("open", "closed", "t >= 1")
    m, b, p0 = 2.0, 0.5, 3.0
    model = HybridModel(driven_mass(clutch=True), [clutch], {"m": m, "b": b}, initial_state={"p_m": p0},
                        inputs={"u": ExpressionInput("1 + t/2")})
    tr = model.simulate(2.0, "RK45", rtol=1e-11, atol=1e-12)
    (event,) = tr.events
    assert abs(event.t - 1.0) <= 1e-12
    assert abs(event.x_before[0] - p0 * math.exp(-b / m)) <= 1e-9
    assert abs(event.x_after[0] - m * 1.5) <= 1e-12
    after = tr.t > 1.0
    assert np.allclose(tr.state("p_m")[after], m * (1 + tr.t[after] / 2), rtol=1e-12)
    assert np.allclose(tr.signal("e_drive")[after], m * 0.5 + b * (1 + tr.t[after] / 2), rtol=1e-12)


def test_compiled_run_takes_the_exact_input_derivative():
    pytest.importorskip("numba")
    model = HybridModel(driven_mass(), [], {"m": 2.0, "b": 0.5}, inputs={"u": ExpressionInput("sin(2*t)")})
    plain = model.simulate(3.0, "RK45", rtol=1e-10, t_eval=np.linspace(0, 3, 7))
    compiled = model.simulate(3.0, "RK45-jit", rtol=1e-10, t_eval=np.linspace(0, 3, 7))
    np.testing.assert_allclose(compiled.signal("e_drive"), plain.signal("e_drive"), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(compiled.state("p_m"), 2.0 * np.sin(2 * compiled.t), rtol=0, atol=1e-12)


@pytest.mark.parametrize("text, before", [("v0*step(t - 1)", 0.0), ("v0*sign(t - 1)", -1.0)])
def test_a_prescribed_velocity_that_steps_jumps_the_momentum_at_its_instant(text, before):
    """``u = v0·step(t − 1)`` (or ``v0·sign(t − 1)``) of a mass: the step is an instant at t = 1 (a law
    switch of the source, :mod:`switching.model.stepped_inputs`) whose jump sets ``p = m·u⁺``; between
    steps ``du/dt = 0`` (the pulse of the step dropped) and the force is ``b·u``."""
    m, b, v0 = 2.0, 0.5, 3.0
    model = HybridModel(driven_mass(), [], {"m": m, "b": b}, initial_state={"p_m": m * v0 * before},
                        inputs={"u": ExpressionInput(text, {"v0": v0})})
    assert model.input_signals.rate("u", 0.5) == 0.0 == model.input_signals.rate("u", 1.5)
    tr = model.simulate(2.0, "RK45", rtol=1e-10)
    (event,) = tr.events
    assert event.t == 1.0 and event.x_before[0] == m * v0 * before and event.x_after[0] == m * v0
    u = np.where(tr.t < 1.0, v0 * before, v0)
    np.testing.assert_array_equal(tr.state("p_m")[tr.t != 1.0], m * u[tr.t != 1.0])
    np.testing.assert_allclose(tr.signal("e_drive")[tr.t != 1.0], b * u[tr.t != 1.0], rtol=1e-15)
