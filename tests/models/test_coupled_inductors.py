"""Coupled inductors (SPICE's K; issue 41's devices): the T-equivalent the circuit builder makes has the
coupled windings' equations, symbolically and along a run, and k = 1 is a transformer with its
magnetizing inductance."""

import math

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from models.circuits import Circuit
from switching.errors import HybridBondGraphError

L1, L2, R1, R2, F = 1e-3, 4e-3, 1.0, 50.0, 1000.0


def coupled(k, L1=L1, L2=L2, **build):
    """A 10 V, 1 kHz source through R1 into the primary; the secondary loaded by R2."""
    c = Circuit("coupled")
    c.V("V1", "a", "0", f"10*sin(2*pi*{F!r}*t)")
    c.R("R1", "a", "b", R1)
    c.coupled_inductors("K1", "b", "0", "s", "0", L1, L2, k)
    c.R("R2", "s", "0", R2)
    return c.build(**build)


def windings(k, t_end):
    """The windings' currents at ``t_end`` from ``[[L1, M], [M, L2]]·d(i₁, i₂)/dt = (v − R1·i₁, −R2·i₂)``
    (both currents into the dotted terminals: the secondary's voltage is −R2·i₂)."""
    M = k * math.sqrt(L1 * L2)
    inverse = np.linalg.inv([[L1, M], [M, L2]])

    def rates(t, i):
        return inverse @ [10 * math.sin(2 * math.pi * F * t) - R1 * i[0], -R2 * i[1]]

    return solve_ivp(rates, (0.0, t_end), [0.0, 0.0], method="Radau", rtol=1e-12, atol=1e-14).y[:, -1]


def test_the_t_equivalent_has_the_coupled_windings_equations():
    """With ``a = k·√(L1/L2)``, ``L_l = (1 − k²)·L1``, ``L_m = k²·L1`` and the fluxes ``p_l = L_l·i₁``, ``p_m =
    L_m·i_m``: the secondary's voltage ``−R2·i₂`` with ``i₂ = a·(i_m − i₁)`` is the core's over ``a``, so
    ``ṗ_m = −a²·R2·(i_m − i₁)`` and ``ṗ_l = v − R1·i₁ − ṗ_m``."""
    model = coupled("kc", parameters={"kc": 0.5})
    equations = model.mode_equations(model.mode({}))
    symbols = {s.name: s for s in model.parameter_symbols}
    k, l1, l2 = symbols["kc"], symbols["K1_L1"], symbols["K1_L2"]
    r1, r2 = symbols["R1"], symbols["R2"]
    p_l, p_m = (sp.Symbol(name) for name in ("p_K1_leakage", "p_K1_magnetizing"))
    a = k * sp.sqrt(l1 / l2)
    i1, i_m = p_l / ((1 - k**2) * l1), p_m / (k**2 * l1)
    t = model.time
    source = 10 * sp.sin(2 * sp.pi * F * t)
    core = -a**2 * r2 * (i_m - i1)
    derived = {state.name: rate for state, rate in equations.f.items()}
    assert sp.simplify(derived["p_K1_magnetizing"] - core) == 0
    assert sp.simplify(derived["p_K1_leakage"] - (source - r1 * i1 - core)) == 0


@pytest.mark.parametrize("k", [0.3, 0.9, 0.99])
def test_the_windings_currents_follow_the_coupled_equations(k):
    run = coupled(k).simulate(2e-3, "RK45", rtol=1e-10, atol=1e-13)
    i1, i2 = windings(k, 2e-3)
    assert run.signal("i_K1_p")[-1] == pytest.approx(i1, rel=1e-7)
    assert run.signal("i_K1_s")[-1] == pytest.approx(i2, rel=1e-7)
    assert run.signal("v_K1_s")[-1] == pytest.approx(-R2 * i2, rel=1e-7)
    magnetizing = run.signal("i_K1_p") + run.signal("i_K1_s") * math.sqrt(L2 / L1) / k
    np.testing.assert_allclose(run.signal("i_K1_m"), magnetizing, rtol=1e-9, atol=1e-12)


def test_the_stored_energy_is_that_of_the_coupled_windings():
    """``½·L1·i₁² + M·i₁·i₂ + ½·L2·i₂²`` at every sample."""
    k = 0.8
    run = coupled(k).simulate(1e-3, "RK45", rtol=1e-10, atol=1e-13)
    i1, i2 = run.signal("i_K1_p"), run.signal("i_K1_s")
    M = k * math.sqrt(L1 * L2)
    np.testing.assert_allclose(run.energy(), 0.5 * L1 * i1**2 + M * i1 * i2 + 0.5 * L2 * i2**2, rtol=1e-9,
                               atol=1e-15)


def test_perfect_coupling_is_a_transformer_with_its_magnetizing_inductance():
    """k = 1: no leakage, one state; the windings' voltages in the ratio √(L2/L1) at every sample."""
    model = coupled(1)
    assert [s.name for s in model.states] == ["p_K1_magnetizing"]
    run = model.simulate(1e-3, "RK45", rtol=1e-10, atol=1e-13)
    np.testing.assert_allclose(run.signal("v_K1_s"), math.sqrt(L2 / L1) * run.signal("v_K1_p"), rtol=1e-9,
                               atol=1e-12)


@pytest.mark.parametrize("k", [0.0, 1.5, -0.2])
def test_a_coupling_outside_zero_to_one_is_refused(k):
    with pytest.raises(HybridBondGraphError, match="coupling coefficient"):
        coupled(k)
