"""Configurations seen through vanishing resistances (bondgraph/regularize.py), against hand derivations."""

import pytest
import sympy as sp

from bondgraph import BondGraph, C, One, R, Se, Zero
from bondgraph.regularize import EPSILON, floating_limit, limit

a, b, c, d = sp.symbols("a b c d", positive=True)


def test_the_limit_of_a_rational_function_of_epsilon_is_its_ratio_of_lowest_coefficients():
    assert sp.simplify(limit((a + b * EPSILON) / (d + c * EPSILON)) - a / d) == 0
    assert sp.simplify(limit((a * EPSILON + b * EPSILON**2) / (c * EPSILON + d * EPSILON**3)) - a / c) == 0
    assert limit(a * EPSILON / (b + EPSILON)) == 0
    assert limit(a) == a
    with pytest.raises(ValueError, match="without bound"):
        limit(a / EPSILON + b)


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
