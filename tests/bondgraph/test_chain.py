"""Large graphs built by code: a chain of N mass–spring–damper cells."""

import numpy as np
import pytest
import sympy as sp

from models.graphs import msd_chain


def hand_chain_rates(n, q, p, m, k, c, F):
    """dq_i/dt = v_{i-1} − v_i, dp_i/dt = F_i − F_{i+1}; F_i = k q_i + c (v_{i−1} − v_i), F_{n+1} = −F."""
    v = [0.0] + [pi / m for pi in p]
    force = [k * q[i] + c * (v[i] - v[i + 1]) for i in range(n)] + [-F]
    dq = [v[i] - v[i + 1] for i in range(n)]
    dp = [force[i] - force[i + 1] for i in range(n)]
    return dq, dp


@pytest.mark.parametrize("n", [5, 20, 50, 200])
def test_chain_matches_the_hand_derived_chain_at_a_random_point(n):
    graph = msd_chain(n)
    eq = graph.equations()
    rng = np.random.default_rng(n)
    m, k, c, F = rng.uniform(0.5, 2.0, size=4)
    q = rng.normal(size=n)
    p = rng.normal(size=n)
    values = {sp.Symbol("m"): m, sp.Symbol("k"): k, sp.Symbol("c"): c, sp.Symbol("F"): F}
    for i in range(n):
        values[sp.Symbol(f"q_cell{i + 1}/k")] = q[i]
        values[sp.Symbol(f"p_cell{i + 1}/m")] = p[i]
    states = list(eq.states)
    f = sp.lambdify([states, list(values)[:4]], [eq.rates[s] for s in states], "numpy")
    derived = np.array(f([values[s] for s in states], [m, k, c, F]), dtype=float)
    dq, dp = hand_chain_rates(n, q, p, m, k, c, F)
    expected = np.empty(2 * n)
    expected[0::2], expected[1::2] = dq, dp  # state order: q_1, p_1, q_2, p_2, ...
    assert [s.name for s in states[:2]] == ["q_cell1/k", "p_cell1/m"]
    np.testing.assert_allclose(derived, expected, rtol=1e-12, atol=1e-12)
    assert eq.dependent == ()
