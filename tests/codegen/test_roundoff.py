"""Round-off scales of guard sides (issue 12): bands that follow the size of
the terms a quantity was formed from, not the size of the result."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp

from codegen.roundoff import roundoff_scale
from codegen.runtime import Comparison, Hyper, decide

a, b, c, x, y = sp.symbols("a b c x y")
A, B, C, X, Y = (sp.Abs(s, evaluate=False) for s in (a, b, c, x, y))


@pytest.mark.parametrize(
    "expr, expected",
    [
        (a - b, A + B),
        (a * b - c, 3 * A * B + C),  # R(a)|b| + |a|R(b) + one rounding |ab|; a sign is exact: R(−c) = |c|
        (2 * a * b, 2 * 3 * A * B + 2 * A * B),  # a numeric coefficient: |2|·R(ab) + one rounding
        (a / b, 4 * A / B),  # R(a)|b⁻¹| + |a|R(b⁻¹) + |a b⁻¹| with R(b⁻¹) = |−1|·|b|⁻²·R(b) + |b⁻¹| = 2/|b|
        (x**2, 2 * X * X + sp.Abs(x**2)),
        (sp.cos(x), sp.Abs(sp.sin(x)) * X + sp.Abs(sp.cos(x))),
        (sp.Abs(a - b), A + B),
        (sp.Max(a, b - c), sp.Max(A, B + C)),
        (sp.Integer(-3), 3),
    ],
)
def test_rules_against_hand_derived_scales(expr, expected):
    derived = roundoff_scale(expr)
    assert sp.simplify((derived - expected).rewrite(sp.Abs)) == 0 or _agree_numerically(derived, expected)


def _agree_numerically(derived, expected) -> bool:
    rng = np.random.default_rng(1)
    symbols = sorted(derived.free_symbols | sp.sympify(expected).free_symbols, key=str)
    for _ in range(20):
        values = {s: float(v) for s, v in zip(symbols, rng.uniform(-3, 3, len(symbols)))}
        if not math.isclose(float(derived.subs(values)), float(sp.sympify(expected).subs(values)), rel_tol=1e-12):
            return False
    return True


def test_functions_without_a_derivative_fall_back_to_their_size():
    for expr in (sp.sign(x), sp.Heaviside(x), sp.Piecewise((x, x > 0), (0, True))):
        scale = roundoff_scale(expr)
        for value in (-2.0, 0.5):
            assert float(scale.subs(x, value)) == pytest.approx(abs(float(expr.subs(x, value))))


def _rod_tip_velocity():
    p_y, p_J, m, J, l, theta = sp.symbols("p_y p_J m J l theta")
    return p_y / m - l * p_J * sp.cos(theta) / J, (p_y, p_J, m, J, l, theta)


def test_scale_bounds_the_value_and_the_rounding_error():
    """R ≥ |e| everywhere, and the float evaluation of a cancelling expression
    errs by at most a few ε·R (exact reference in rationals)."""
    expr, symbols = _rod_tip_velocity()
    scale = roundoff_scale(expr)
    f = sp.lambdify(symbols, expr, "math")
    r = sp.lambdify(symbols, scale, "math")
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(200):
        m, J, l, theta = rng.uniform(0.1, 3, 4)
        p_J = rng.uniform(-5, 5)
        # p_y chosen so that the two terms cancel to round-off
        p_y = m * l * p_J * math.cos(theta) / J
        value, bound = f(p_y, p_J, m, J, l, theta), r(p_y, p_J, m, J, l, theta)
        assert bound >= abs(value)
        exact = (Fraction(p_y) / Fraction(m)
                 - Fraction(l) * Fraction(p_J) * Fraction(math.cos(theta)) / Fraction(J))
        worst = max(worst, abs(value - float(exact)) / (2.0**-52 * bound))
    assert worst <= 8  # a handful of roundings on the longest path


def test_scale_is_homogeneous_so_decisions_do_not_depend_on_units():
    """Rescaling momenta by k rescales the side and R by k: the band and the decision follow."""
    expr, symbols = _rod_tip_velocity()
    scale = sp.lambdify(symbols, roundoff_scale(expr), "math")
    side = sp.lambdify(symbols, expr, "math")
    base = (2.7990098546491664, 0.4883113413458165, 1.0, 1 / 12, 0.5, 0.3)
    for k in (1e-6, 1e-3, 1.0, 1e3, 1e6):
        args = (base[0] * k, base[1] * k, *base[2:])
        assert scale(*args) == pytest.approx(k * scale(*base), rel=1e-14)
        assert side(*args) == pytest.approx(k * side(*base), rel=1e-9, abs=1e-14 * k * scale(*base))


def test_a_quantity_zero_to_round_off_of_large_terms_compares_as_zero():
    """The issue's loop: tip_vy = −1.8e-15 from terms of size ≈ 3 is not
    'moving down'; measured on the result alone (scale 0) it was."""
    rtol, atol = 1e-13, 1e-15
    assert decide("<", -1.8e-15, 0.0, rtol, atol)  # the old band: round-off decides
    assert not decide("<", -1.8e-15, 0.0, rtol, atol, scale=3.0)
    assert decide("<=", -1.8e-15, 0.0, rtol, atol, scale=3.0)
    # a genuinely small quantity of a small-scale model still counts
    assert decide("<", -1.8e-15, 0.0, rtol, 0.0, scale=2e-15)
    # a non-finite scale is ignored, never a NaN band
    assert decide("<", -1.0, 0.0, rtol, atol, scale=math.nan) and decide("<", -1.0, 0.0, rtol, atol, scale=math.inf)
    # a pulse still dominates any finite part and any band
    assert decide(">", Hyper(1e-3, -5.0), 0.0, rtol, atol, scale=1e6)


def test_comparison_record_reports_its_margin_in_ulps():
    rtol, atol = 1e-13, 0.0
    located = Comparison.of("y <= 0", "<=", 3e-13, 0.0, rtol, atol, scale=3.0)
    assert located.result and located.edge_ulps < 2
    clear = Comparison.of("y <= 0", "<=", -1.0, 0.0, rtol, atol, scale=3.0)
    assert clear.result and clear.edge_ulps > 1e12
    pulse = Comparison.of("F < 0", "<", Hyper(-1.0, 2.0), 0.0, rtol, atol)
    assert pulse.result and pulse.edge_ulps == math.inf and pulse.margin is None
    for comparison in (located, clear, pulse):
        assert comparison.result == decide(comparison.op, comparison.left, comparison.right, rtol, atol,
                                           comparison.scale)
    text, left, right, result = located  # the record unpacks as the 4-tuples of earlier versions
    assert (text, result) == ("y <= 0", True)


@pytest.mark.parametrize("op", ["<", "<=", ">", ">=", "==", "!="])
def test_numbers_are_decided_as_the_hyper_values_without_impulse_they_stand_for(op):
    """decide() on plain numbers (the finite sides of a flow's guards) skips making Hyper values of
    them: the same decision, at and off the band's edge, for floats, numpy floats and non-finite sides."""
    rng = np.random.default_rng(7)
    values = [0.0, -0.0, 1.0, 1.0 + 1e-13, 1.0 - 1e-13, 3e-13, -3e-13, math.inf, -math.inf, math.nan,
              *rng.normal(size=6)]
    for left in values:
        for right in values[:8]:
            for scale in (0.0, 3.0, math.nan):
                expected = decide(op, Hyper(0.0, left), Hyper(0.0, right), 1e-13, 1e-300, scale)
                assert decide(op, left, right, 1e-13, 1e-300, scale) == expected
                assert decide(op, np.float64(left), right, 1e-13, 1e-300, np.float64(scale)) == expected


def test_divergence_message_tells_physics_from_round_off():
    """Item 5: the diode's holding current above the actual current is a loop
    of the physics (every comparison far from its band); the four-ball chain
    with neither restitution nor a separating-velocity threshold repeats on
    velocities equal to round-off (decided at the edge of their bands)."""
    from models import ball_chain, diode_circuit
    from switching import DivergenceOfTimeError

    with pytest.raises(DivergenceOfTimeError) as physics:
        diode_circuit.build(I_th=100.0).simulate(1.0, "RK45")
    assert "Round-off: none" in str(physics.value)
    assert all(not fired.near_edge for step in physics.value.loop for fired in step.fired)

    with pytest.raises(DivergenceOfTimeError) as roundoff:
        ball_chain.build(N=4, e=0.0, v_th=0.0).simulate(0.5, "RK45", output="events")
    text = str(roundoff.value)
    assert "Round-off: possibly" in text and "ulps from its edge" in text
    assert any(fired.near_edge for step in roundoff.value.loop for fired in step.fired)
