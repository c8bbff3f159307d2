"""A finished run is never lost to its energy bookkeeping (issue 45, item 8):
a storage law whose energy's closed form names a function no numeric module
prints (``fresnels``) or that plain numpy lacks (``erfi``) has its energy
computed all the same — scipy's function, else the quadrature of the law."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
from scipy.special import erfi, fresnel

from bondgraph import BondGraph, C, I, One
from bondgraph.energy import energy_function
from switching import HybridModel

Q0 = 0.5


def spring_mass(law):
    """A spring of ``law`` (of its charge q) and a mass of 1 kg on one junction, from q = 0.5 at rest:
    no dissipation, the stored energy stays that of the start."""
    g = BondGraph("spring")
    j = g.add(One("j"))
    g.connect(j, C("K", effort_law=law))
    g.connect(j, I("M", "M"))
    return HybridModel(g, [], dict(M=1.0), {"q_K": Q0, "p_M": 0.0})


def energy_exp(q):  # ∫₀^q (exp(s²) − 1) ds
    return math.sqrt(math.pi) / 2 * erfi(q) - q


def energy_sin(q):  # ∫₀^q (sin(s²) + s) ds, with S(z) = ∫₀^z sin(πt²/2) dt
    return math.sqrt(math.pi / 2) * fresnel(math.sqrt(2 / math.pi) * q)[0] + q * q / 2


LAWS = [(lambda q: sp.exp(q**2) - 1, energy_exp), (lambda q: sp.sin(q**2) + q, energy_sin)]


@pytest.mark.parametrize("law, exact", LAWS, ids=["erfi", "fresnels"])
@pytest.mark.parametrize("method, options", [("euler", {"dt": 1e-4}), ("RK45", {"rtol": 1e-11, "atol": 1e-13})])
def test_a_run_with_a_law_whose_energy_prints_badly_finishes_with_its_energy(law, exact, method, options):
    run = spring_mass(law).simulate(1.0, method, **options)  # euler: the energy watch runs at its end
    assert run.t[-1] == 1.0
    energy = run.energy()
    assert energy[0] == pytest.approx(exact(Q0), rel=1e-13)
    if method == "RK45":  # conserved by the flow, to the run's tolerance
        np.testing.assert_allclose(energy, exact(Q0), rtol=1e-8)


@pytest.mark.parametrize("law, exact", LAWS, ids=["erfi", "fresnels"])
def test_the_energy_function_against_the_closed_forms(law, exact):
    model = spring_mass(law)
    fn = energy_function(model.graph, model.states, model.parameter_values)
    q = np.array([-2.0, -0.3, 0.0, 0.1, 0.5, 1.5])
    x = np.column_stack([q, np.zeros_like(q)]) if model.states[0].name == "q_K" else np.column_stack([np.zeros_like(q), q])
    np.testing.assert_allclose(fn(x, np.zeros_like(q)), [exact(v) for v in q], rtol=1e-12, atol=1e-15)


def test_a_law_sympy_cannot_integrate_is_integrated_numerically():
    from scipy.integrate import quad

    model = spring_mass(lambda q: sp.exp(sp.sin(q)) - 1)  # no closed form: Gauss–Legendre on [0, q]
    fn = energy_function(model.graph, model.states, model.parameter_values)
    q = np.array([-1.0, 0.0, 0.5, 2.0])
    x = np.column_stack([q, np.zeros_like(q)]) if model.states[0].name == "q_K" else np.column_stack([np.zeros_like(q), q])
    exact = [quad(lambda s: math.exp(math.sin(s)) - 1, 0, v, epsabs=1e-15, epsrel=1e-14)[0] for v in q]
    np.testing.assert_allclose(fn(x, np.zeros_like(q)), exact, rtol=1e-13, atol=1e-16)
