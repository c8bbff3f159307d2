"""A closed-form inverse carries its law's range (issue 45, item 6): asked for
a value the law never takes, it gives NaN — the run stops with a non-finite
state — not a real number that is no answer (``tan(2)`` for ``atan(f) = 2``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from bondgraph import BondGraph, C, One, R, Se
from bondgraph.inverse import within_range
from switching import HybridModel
from switching.errors import NonFiniteStateError

v = sp.Symbol("v")
y = sp.Symbol("y")


def atan_rc(V):
    """``V`` across an R with ``e = atan(f)`` in series with ``C = 1``: ``q' = f = tan(V − q)``."""
    g = BondGraph("atan")
    j = g.add(One("j"))
    g.connect(Se("V", "V"), j)
    g.connect(j, R("R1", effort_law=lambda f: sp.atan(f)))
    g.connect(j, C("C", "C"))
    return HybridModel(g, [], dict(V=V, C=1.0), {"q_C": 0.0})


@pytest.mark.parametrize("method", ["RK45", "RK45-jit", "rodas-jit", "auto"])
def test_an_effort_beyond_atan_s_range_stops_the_run(method):
    # atan(f) = 2 has no solution (|atan| < pi/2): tan(2) = -2.19 would run on silently to q = -1.018
    with pytest.raises(NonFiniteStateError, match="R1") as info:
        atan_rc(2.0).simulate(2.0, method)
    assert info.value.t == 0.0


def test_within_the_range_the_inverse_is_the_closed_form():
    # q' = tan(1 − q): at t = 0 the rate is tan(1) exactly, the run stays in the range (q rises towards 1)
    run = atan_rc(1.0).simulate(0.5, "RK45", rtol=1e-10, atol=1e-12)
    q = run.x[:, 0]
    assert np.all(np.diff(q) > 0) and q[-1] < 1.0
    # the closed form of t(q): ∫ cot(1 − q) dq = −ln sin(1 − q) + ln sin 1
    np.testing.assert_allclose(math.log(math.sin(1.0)) - np.log(np.sin(1.0 - q)), run.t, rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("law, inverse, outside", [
    (sp.atan(v), sp.tan(y), [2, -2]),
    (sp.tanh(v), sp.atanh(y), []),  # atanh leaves the reals by itself beyond ±1: kept as it is
    (3 * sp.atan(v / 2), 2 * sp.tan(y / 3), [5]),
])
def test_a_closed_form_is_nan_outside_its_law_s_range(law, inverse, outside):
    carried = within_range(law, v, y, inverse)
    for value in outside:
        assert carried.xreplace({y: value}) is sp.nan
    assert carried.xreplace({y: sp.Rational(1, 2)}) == inverse.xreplace({y: sp.Rational(1, 2)})


def test_a_law_onto_the_whole_line_keeps_its_inverse():
    assert within_range(v + v**3 / 3, v, y, sp.sinh(y)) == sp.sinh(y)  # (sinh only as a stand-in inverse)
    assert within_range(sp.sinh(v), v, y, sp.asinh(y)) == sp.asinh(y)
