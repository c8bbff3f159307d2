"""Configurations seen through vanishing resistances (bondgraph/regularize.py), against hand derivations."""

import pytest
import sympy as sp

from bondgraph import BondGraph, One, R, Se, Zero
from bondgraph.regularize import EPSILON, floating_limit, leading_term

a, b, c, d = sp.symbols("a b c d", positive=True)


def test_leading_term_gives_the_coefficients_of_epsilon_lowest_order_first():
    """The conflict guards' split of a side into powers of ε (switching/library/conflicts.py): the order
    of the first non-zero coefficient of numerator and denominator decides impulse, value or zero."""

    def first(coefficients):
        return next((k, c) for k, c in enumerate(coefficients) if sp.simplify(c) != 0)

    numerator, denominator = leading_term((a + b * EPSILON) / (d + c * EPSILON))
    (n_order, n), (d_order, dd) = first(numerator), first(denominator)
    assert (n_order, d_order) == (0, 0) and sp.simplify(n / dd - a / d) == 0
    numerator, denominator = leading_term((a * EPSILON + b * EPSILON**2) / (c * EPSILON + d * EPSILON**3))
    (n_order, n), (d_order, dd) = first(numerator), first(denominator)
    assert n_order == d_order and sp.simplify(n / dd - a / c) == 0  # (a common ε may cancel)
    numerator, denominator = leading_term(a / EPSILON + b)  # an impulse: order −1
    assert first(numerator)[0] < first(denominator)[0]


def cut_off_pair():
    """A source V on node s; a switch from s to node m, a resistor R from m to node n, a switch from n
    to ground: with both switches off, m and n float (R ties them to each other, nothing to V)."""
    g = BondGraph("pair")
    s, m, n = g.add(Zero("s")), g.add(Zero("m")), g.add(Zero("n"))
    g.connect(Se("V", "V"), s)
    g.connect(s, R("Rs", "Rs"))
    upper, middle, lower = (g.add(One(name, controlled=True)) for name in ("upper", "middle", "lower"))
    g.connect(s, upper)
    g.connect(upper, m)
    g.connect(m, middle)
    g.connect(middle, n)
    g.connect(middle, R("R", "R"))
    g.connect(n, lower)
    g.connect(lower, Se("ground", 0))
    return g


def test_nodes_cut_off_by_two_blocking_switches_take_the_potential_even_leaks_give_them():
    """Both switches blocking: the leaks across them (1/ε each) and R in series from V to ground; as
    ε → 0 no current flows and each blocking switch takes half of V: m and n are both at V/2."""
    g = cut_off_pair()
    config = {"upper": False, "middle": True, "lower": False}
    from bondgraph.floating import floating_part

    assert floating_part(g, config) is not None  # the ideal configuration floats
    equations, jump = floating_limit(g, config, "conservation")
    V = sp.Symbol("V")
    assert sp.simplify(equations.efforts["upper__m"] - V / 2) == 0
    assert sp.simplify(equations.efforts["middle__n"] - V / 2) == 0
    assert sp.simplify(equations.flows["R"]) == 0
    assert jump.is_identity


def test_two_closed_switches_in_parallel_share_a_current_equally_in_the_limit():
    g = BondGraph("parallel")
    s, m = g.add(Zero("s")), g.add(Zero("m"))
    g.connect(Se("V", "V"), s)
    first, second = g.add(One("first", controlled=True)), g.add(One("second", controlled=True))
    for switch in (first, second):
        g.connect(s, switch)
        g.connect(switch, m)
    g.connect(m, R("R", "R"))
    equations, _ = floating_limit(g, {"first": True, "second": True}, "conservation")
    current = sp.Symbol("V") / sp.Symbol("R")
    assert sp.simplify(equations.flows["s__first"] - current / 2) == 0
    assert sp.simplify(equations.flows["s__second"] - current / 2) == 0


def test_a_matrix_is_called_singular_only_when_it_is_for_every_value_of_its_symbols():
    """Decided at random rational points, exactly: a leak of 1e-9 S beside ohms cancels to 15 digits in
    double precision, and the old float check called such well-posed networks singular."""
    from bondgraph.solving import singular

    R, g = sp.symbols("R g", positive=True)
    assert singular(sp.Matrix([[R, 2 * R], [1, 2]]), "test")
    assert not singular(sp.Matrix([[1 + g, 1], [1, 1]]), "test")
    leak = sp.Float(1e-9)
    assert not singular(sp.Matrix([[1 / R + leak, -1 / R], [-1 / R, 1 / R + leak]]), "test")
    assert singular(sp.Matrix([[sp.sin(R), sp.cos(R)], [2 * sp.sin(R), 2 * sp.cos(R)]]), "test")
    assert not singular(sp.Matrix([[sp.sin(R), 1], [1, sp.sin(R)]]), "test")


def test_a_resistive_bridge_with_line_resistance_and_leaks_derives_every_mode():
    """The audit's bridge: 0.5 Ω line resistance, diodes with r_on, gmin = 1e-9; the mode with every diode
    blocking is a resistive network with leaks, well-posed (it was called singular)."""
    from models.circuits import Circuit

    c = Circuit("bridge")
    c.V("Vs", "s", "0", "325*sin(2*pi*50*t)")
    c.R("Rs", "s", "x", 0.5)
    for name, a, b in (("D1", "x", "p"), ("D2", "0", "p"), ("D3", "n", "x"), ("D4", "n", "0")):
        c.diode(name, a, b, r_on=0.02)
    c.C("C1", "p", "n", 1e-3)
    c.R("RL", "p", "n", 100.0)
    model = c.build(gmin=1e-9)
    blocking = model.mode_equations(model.mode({f"D{k}": "off" for k in range(1, 5)}))
    q = sp.Symbol("q_C1")
    rate = blocking.f[q].subs({s: v for s, v in model.parameter_values.items()}).subs(sp.Symbol("t"), 0)
    # at t = 0 the source is 0: the capacitor discharges through RL and, in parallel, the leaks (two in series
    # each way, through the line): 1/R = 1/RL + gmin/2 · (the two leak paths in parallel) → ≈ 1/RL
    assert float(rate.subs(q, 1.0)) == pytest.approx(-1.0 / (1e-3 * 100.0), rel=1e-6)


def test_an_exponential_law_in_series_with_a_resistance_is_solved_with_lamberts_w():
    """i = Is·(exp((V − R·i)/VT) − 1) ⇒ i = (VT/R)·W₀((Is·R/VT)·exp((V + R·Is)/VT)) − Is; a residual of
    another form, or whose solution is not unique (d·c/a < 0), gets None."""
    from bondgraph.solving import lambert_solution

    i, V, Rr, Is, VT = sp.symbols("i V R I_s V_T")
    residual = i - Is * (sp.exp((V - Rr * i) / VT) - 1)
    solution = lambert_solution(residual, i)
    expected = VT / Rr * sp.LambertW(Is * Rr / VT * sp.exp((V + Rr * Is) / VT)) - Is
    assert sp.simplify(solution - expected) == 0
    numbers = {V: 0.7, Rr: 2.0, Is: 1e-12, VT: 0.025852}
    assert abs(float(residual.subs(i, solution.subs(numbers)).subs(numbers))) < 1e-15
    assert lambert_solution(i**2 - V, i) is None
    assert lambert_solution(i - Is * sp.exp(i / VT) + V, i) is None  # a·v + c·exp(d·v) not monotonic
    assert lambert_solution(i - Is * sp.exp(i**2), i) is None
