"""Jump maps into a configuration from conservation of state (bondgraph.jump)."""

import numpy as np
import pytest
import sympy as sp

from bondgraph import BondGraph, C, I, One, Se, Sf, Zero
from models.graphs import parallel_capacitors, pivoting_rod


def test_rigid_join_of_two_masses_takes_the_common_velocity():
    g = BondGraph("join")
    v = g.add(One("v"))
    g.connect(v, I("m1", "m1"))
    g.connect(v, I("m2", "m2"))
    jm = g.jump_map()
    m1, m2, p1, p2 = sp.symbols("m1 m2 p_m1 p_m2")
    common = (p1 + p2) / (m1 + m2)
    assert sp.simplify(jm.expressions[p1] - m1 * common) == 0
    assert sp.simplify(jm.expressions[p2] - m2 * common) == 0
    assert jm.participating == (p1,) and jm.dependent == (p2,)


def test_jump_is_the_identity_on_the_constraint():
    jm = pivoting_rod().jump_map()
    x = np.array([0.0, 0.0, 0.3, 1.0, 2.0, 0.7])  # p_x, p_y, p_J, x, y, theta
    params = {sp.Symbol(n): v for n, v in dict(m=1.0, J=0.1, l=0.5, g=9.81).items()}
    on = jm.apply(x, 0.0, params)
    assert np.allclose(jm.apply(on, 0.0, params), on, rtol=1e-15, atol=1e-16)


def test_mass_caught_by_a_moving_belt_takes_the_belt_velocity():
    """A dependent state fixed by a non-zero source: p⁺ = m v_belt."""
    g = BondGraph("belt")
    v = g.add(Zero("grip"))
    g.connect(Sf("belt", "u"), v)
    g.connect(v, One("mass"))
    g.connect("mass", I("m", "m"))
    jm = g.jump_map()
    assert sp.simplify(jm.expressions[sp.Symbol("p_m")] - sp.Symbol("m") * sp.Symbol("u")) == 0


def test_capacitor_switched_onto_a_source_charges_instantly():
    g = BondGraph("src")
    n = g.add(Zero("n"))
    g.connect(Se("V", "V"), n)
    g.connect(n, C("C", "C"))
    jm = g.jump_map()
    assert sp.simplify(jm.expressions[sp.Symbol("q_C")] - sp.Symbol("C") * sp.Symbol("V")) == 0


def test_charge_sharing_symbolic():
    jm = parallel_capacitors().jump_map({"switch": True})
    q1, q2, C1, C2 = sp.symbols("q_C1 q_C2 C1 C2")
    assert sp.simplify(jm.expressions[q1] + jm.expressions[q2] - (q1 + q2)) == 0
    assert sp.simplify(jm.expressions[q1] / C1 - jm.expressions[q2] / C2) == 0


def nonlinear_capacitor_pair() -> BondGraph:
    """C1 (effort q + k q³) and C2 (linear), joined by the switch ``sw``."""
    g = BondGraph("nl_caps")
    n1, n2, sw = g.add(Zero("n1")), g.add(Zero("n2")), g.add(One("sw", controlled=True))
    k, C2 = sp.symbols("k C2")
    g.connect(n1, C("C1", effort_law=lambda q: q + k * q**3))
    g.connect(n2, C("C2", C2))
    g.connect(n1, sw)
    g.connect(sw, n2)
    return g


def test_nonlinear_capacitor_jump_is_solved_numerically():
    g = nonlinear_capacitor_pair()
    k, C2 = sp.symbols("k C2")
    jm = g.jump_map({"sw": True})
    assert not jm.linear and jm.expressions is None
    params = {k: 0.5, C2: 2.0}
    x = np.array([1.2, -0.3])
    plus = jm.apply(x, 0.0, params)
    assert plus.sum() == pytest.approx(x.sum(), rel=1e-12)  # charge conserved
    e1 = plus[0] + 0.5 * plus[0] ** 3
    assert e1 == pytest.approx(plus[1] / 2.0, rel=1e-10)  # equal voltages after
    assert np.allclose(jm.apply(plus, 0.0, params), plus, rtol=1e-10)


def test_a_hold_capacitor_charged_by_a_source_that_reads_another_takes_its_value_and_leaves_it():
    """An ideal buffer (an effort source whose value is the measured capacitor's voltage ``q_M/M``)
    switched onto a hold capacitor ``H``: the buffer takes the impulse, so ``q_H⁺ = H·q_M/M`` and the
    measured charge stays — not the charge sharing ``(q_M + q_H)``-conserving projection."""
    M, H = sp.symbols("M H")
    q_M, q_H = sp.symbols("q_M q_H")
    g = BondGraph("sample_and_hold")
    measured, hold, switch = g.add(Zero("measured")), g.add(Zero("hold")), g.add(One("sample", controlled=True))
    g.connect(measured, C("M", M))
    g.connect(Sf("i_in", "i_in"), measured)
    g.connect(Se("buffer", q_M / M), switch)
    g.connect(switch, hold)
    g.connect(hold, C("H", H))
    jm = g.jump_map({"sample": True})
    assert jm.participating == ()
    assert sp.simplify(jm.expressions[q_H] - H * q_M / M) == 0
    assert jm.expressions[q_M] == q_M


def test_the_projection_of_one_state_onto_one_constraint_is_that_of_the_matrices():
    """Two point masses meeting (one participating state, one dependent: a scene's every pinnacle) are
    projected without sympy's 1 × 1 matrices: the same expressions, not only equal ones, for slopes and
    metrics of every kind, so a mode's generated code is the same to the byte."""
    from bondgraph.jump import _projection, _scalar_projection

    x1, x2, m1, m2, r, a = sp.symbols("p1 p2 m1 m2 r a", real=True)
    t = sp.Symbol("t")
    for k in (sp.Integer(1), sp.Integer(-1), r, -r / 2, m1 / m2, sp.Rational(3, 7)):
        for constraint in (k * x1, k * x1 + a, k * x1 + a * t - 2, k * x1 + r * t):
            for mi, md in ((m1, m2), (m2, m1), (m1, m1), (1 / m1, r), (sp.Integer(2), sp.Rational(1, 3))):
                phi = sp.Matrix([constraint])
                K = phi.jacobian([x1])
                metrics = {x1: mi, x2: md}
                matrices = _projection((x1,), (x2,), phi, K, metrics)
                numbers = _scalar_projection(x1, x2, constraint, K[0, 0], metrics)
                assert (matrices[0][0], matrices[1][0]) == (numbers[0][0], numbers[1][0])
                # the projection itself: momentum conserved in the metric, the constraint met
                xi_plus, xd_plus = numbers[0][0], numbers[1][0]
                assert sp.simplify(xd_plus - constraint.subs(x1, xi_plus)) == 0
                assert sp.simplify((xi_plus - x1) / mi - k * (x2 - xd_plus) / md) == 0
