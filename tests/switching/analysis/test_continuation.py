"""Continuation of periodic orbits in one parameter (issue 31, item 2), against exact answers.

Boost converter in continuous conduction (the parameters of test_orbits.py): at
every point of a continuation along the duty D (the model's own parameter) or
the load R_load (a build argument), the orbit's start and multipliers are those
of the exact period map ``x ↦ Φ x + c``, ``Φ = e^{A_off (1−D) T} e^{A_on D T}``
(test_orbits.py's ``phase``: the exponential of the augmented matrix).

Period doubling in closed form: a current-mode controlled converter with an
ideal inductor L between a source Vin and an output held at Vout (a source).
A clock turns the switch on at ``t = kT + 0.2 T`` (a guard true during
``[kT + 0.2T, kT + 0.3T]``, left at its start); the switch turns off when
``i_L = p_L/L`` reaches ``i_ref``.  The current rises at ``m1 = Vin/L`` while on,
falls at ``m2 = (Vout − Vin)/L`` while off, so over a period from one turn-on
``i ↦ i_ref − m2 (T − (i_ref − i)/m1)``: an affine map of slope ``−m2/m1``.
The one multiplier is ``μ = −(Vout − Vin)/Vin`` (the saltation of the turn-off
is all of it: both flows have constant rates), and passes through −1 at
``Vout = 2 Vin`` exactly — the classical sub-harmonic instability of peak
current-mode control at duty 1/2.  The orbit's current at the turn-on is
``i* = i_ref − T m1 m2/(m1 + m2)``, at ``t = 0`` (while off) ``i* + 0.2 T m2``.
With a resistance of voltage ``k i²`` in the inductor's loop the map is
nonlinear and the multiplier depends on the orbit (:func:`quadratic_map`,
exact to round-off): the flip moves to Vout = 23.2914271... V.

A fold (a multiplier through +1): :func:`leaky`, ``μ = e^{−G}`` through +1 at G = 0.
"""

from __future__ import annotations

import numpy as np
import pytest

from bondgraph import BondGraph, I, One, Se, Zero
from models import boost_converter
from switching import Automaton, ContinuationError, HybridModel, continue_orbit

from test_orbits import BOOST, T, boost_exact  # the exact two-phase answers


def same_multipliers(got, exact) -> float:
    """The smaller sum of distances over the two pairings of two multipliers."""
    return min(abs(got[0] - exact[0]) + abs(got[1] - exact[1]), abs(got[0] - exact[1]) + abs(got[1] - exact[0]))


def test_boost_continuation_in_the_duty_matches_the_matrix_exponentials_at_every_point():
    model = boost_converter.build(**BOOST)
    duties = [0.3, 0.35, 0.4, 0.45, 0.5]
    result = continue_orbit(model, "D", duties, period=T, max_step=0.2 * T)
    assert [p.value for p in result.points] == duties
    for point in result.points:
        x_star, Phi = boost_exact(D=point.value)
        assert np.allclose(point.x0, x_star, rtol=1e-8, atol=0.0)
        assert same_multipliers(point.multipliers, np.linalg.eigvals(Phi)) < 1e-8
        assert point.stable and point.orbit.mode_names[1] == "pwm=off, diode=on"
    # the secant predictor: from the third point on Newton starts nearer than the previous orbit
    assert all(p.orbit.residuals[0] < 0.2 for p in result.points[2:])
    assert result.bifurcations == []
    # the model's own value of D is back
    assert {s.name: v for s, v in model.parameter_values.items()}["D"] == BOOST["D"]
    assert model.parameter_array[[s.name for s in model.parameter_symbols].index("D")] == BOOST["D"]


def test_boost_continuation_in_a_build_argument_and_its_table():
    pandas = pytest.importorskip("pandas")
    fixed = {k: v for k, v in BOOST.items() if k != "R_load"}
    loads = [10.0, 15.0, 20.0]
    result = continue_orbit(boost_converter.build, "R_load", loads, period=lambda value: T, fixed=fixed,
                            max_step=0.2 * T, signals=["v_C"])
    table = result.table()
    assert isinstance(table, pandas.DataFrame) and list(table["R_load"]) == loads
    for row, R in zip(table.itertuples(index=False), loads):
        x_star, Phi = boost_exact(R=R)
        assert np.allclose([getattr(row, "_2"), getattr(row, "_3")], x_star, rtol=1e-8, atol=0.0)
        assert same_multipliers([row.multiplier_1, row.multiplier_2], np.linalg.eigvals(Phi)) < 1e-8
    # the recorded range of v_C is the range of q_C / C
    for point in result.points:
        low, high = point.ranges["q_C"]
        assert point.ranges["v_C"] == pytest.approx((low / BOOST["C"], high / BOOST["C"]), rel=1e-12)
    assert list(table.columns[:4]) == ["R_load", "period", "x0:p_L", "x0:q_C"]
    assert "min:v_C" in table.columns and table["stable"].all()


def current_mode(Vin=12.0, L=1e-3, i_ref=1.0, f_sw=10e3, Vout=18.0, k=None):
    """The current-mode controlled converter of the module docstring (with ``k``: and a resistance whose
    voltage is ``k i_L²``, see :func:`quadratic_map`)."""
    import sympy as sp

    from bondgraph import R

    g = BondGraph("current_mode")
    loop = g.add(One("iL"))
    a = g.add(Zero("A"))
    if k is not None:
        g.connect(loop, R("Rk", effort_law=lambda f: sp.Symbol("k") * f**2))
    switch, diode = g.add(One("S", controlled=True)), g.add(One("D", controlled=True))
    g.connect(Se("Vin", "Vin"), loop)
    g.connect(loop, I("L", "L"))
    g.connect(loop, a, name="node")
    g.connect(a, switch, name="switch")
    g.connect(switch, Se("ground", 0))
    g.connect(a, diode, name="diode")
    g.connect(diode, Se("Vout", "Vout"))
    pwm = Automaton("pwm", {"on": {"S": True, "D": False}, "off": {"S": False, "D": True}}, initial="off")
    pwm.add_transition("on", "off", "p_L/L > i_ref", "a priori")
    pwm.add_transition("off", "on", "cos(2*pi*(f_sw*t - 0.25)) > cos(2*pi*0.05)", "a priori")
    values = dict(Vin=Vin, L=L, i_ref=i_ref, f_sw=f_sw, Vout=Vout, **({} if k is None else {"k": k}))
    return HybridModel(g, [pwm], values, initial_state={"p_L": 0.0})


CM_T = 1e-4


def current_mode_x0(Vout, Vin=12.0, L=1e-3, i_ref=1.0):
    m1, m2 = Vin / L, (Vout - Vin) / L
    return L * (i_ref - CM_T * m1 * m2 / (m1 + m2) + 0.2 * CM_T * m2)


def test_period_doubling_of_current_mode_control_is_located_at_twice_the_input_voltage():
    model = current_mode()
    values = np.linspace(15.0, 29.0, 6)  # 15, 17.8, ..., 29: 24 V falls between 23.4 and 26.2
    result = continue_orbit(model, "Vout", values, period=CM_T, x0=[0.8e-3], max_step=0.02 * CM_T)
    for point in result.points:
        assert point.multipliers == pytest.approx([-(point.value - 12.0) / 12.0], abs=1e-8)
        assert point.x0 == pytest.approx([current_mode_x0(point.value)], rel=1e-8)
        assert point.stable == (point.value < 24.0)
    assert len(result.bifurcations) == 1
    flip = result.bifurcations[0]
    assert flip.kind == "period doubling" and flip.bracket == (values[3], values[4])
    assert abs(flip.value - 24.0) < 1e-6 and flip.multiplier == pytest.approx(-1.0, abs=1e-6)
    assert flip.orbit.x0 == pytest.approx([current_mode_x0(flip.value)], rel=1e-8)
    assert "period doubling at 24" in str(flip)


def test_continuation_without_locating_reports_the_bracket_and_going_down_works_too():
    result = continue_orbit(current_mode(), "Vout", [27.0, 25.0, 23.0], period=CM_T, x0=[0.64e-3],
                            max_step=0.02 * CM_T, locate=False)
    assert [(b.kind, b.bracket, b.multiplier) for b in result.bifurcations] == [("period doubling", (25.0, 23.0), None)]


def test_a_point_without_orbit_names_the_parameter_value_and_keeps_the_points_before():
    # at Vout = 11 V < Vin the current rises in both phases: the switch never turns off again
    model = current_mode()
    with pytest.raises(ContinuationError) as info:
        continue_orbit(model, "Vout", [18.0, 14.0, 11.0], period=CM_T, x0=[0.8e-3], max_step=0.02 * CM_T)
    error = info.value
    assert error.value == 11.0 and "Vout = 11" in str(error) and "Vout = 14" in str(error)
    assert "smaller steps" in str(error)
    assert [p.value for p in error.result.points] == [18.0, 14.0]
    stopped = continue_orbit(model, "Vout", [18.0, 14.0, 11.0], period=CM_T, x0=[0.8e-3], max_step=0.02 * CM_T,
                             on_error="stop")
    assert len(stopped.points) == 2 and "Vout = 11" in stopped.stopped
    assert {s.name: v for s, v in model.parameter_values.items()}["Vout"] == 18.0


def test_bad_requests_are_refused_with_what_to_do():
    model = current_mode()
    with pytest.raises(ContinuationError, match="not a parameter of model 'current_mode'.*build function"):
        continue_orbit(model, "V_out", [18.0], period=CM_T)
    with pytest.raises(ContinuationError, match="give period=T"):
        continue_orbit(model, "Vout", [18.0])
    with pytest.raises(ContinuationError, match="finite values"):
        continue_orbit(model, "Vout", [18.0, float("nan")], period=CM_T)


def test_bifurcation_diagram_draws_stable_solid_unstable_dashed_and_marks_the_flip():
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    result = continue_orbit(current_mode(), "Vout", [20.0, 22.0, 25.0, 27.0], period=CM_T, x0=[0.7e-3],
                            max_step=0.02 * CM_T)
    ax = result.plot("p_L")
    # the min curve: 20-22 solid, 22-25-27 dashed (one line each), then the max curve
    lines = [(line.get_linestyle(), list(line.get_xdata())) for line in ax.lines[:4]]
    assert lines == [("-", [20.0, 22.0]), ("--", [22.0, 25.0, 27.0])] * 2
    marks = [line for line in ax.lines if line.get_marker() == "o"]
    assert len(marks) == 1 and marks[0].get_xdata()[0] == pytest.approx(24.0, abs=1e-6)
    with pytest.raises(ContinuationError, match="signals="):
        result.plot("v_C")
    matplotlib.pyplot.close("all")


def leaky(G=0.5):
    """A capacitor (C = 1 F) driven by ``u = sin 2πt`` through a conductance G (which may be negative: an
    active element), beside a clocked switch in a separate loop (so the model has an automaton and events
    that do not touch q_C).  ``q̇_C = G (u − q_C)``: the multiplier over T = 1 s is ``μ = e^{−G}``, through
    +1 at G = 0 (a fold of the fixed-period orbit, stable for G > 0)."""
    import sympy as sp

    from bondgraph import C, R
    from switching import ExpressionInput

    g = BondGraph("leaky")
    loop = g.add(One("loop"))
    g.connect(Se("u", sp.Symbol("u")), loop)
    g.input("u")
    g.connect(loop, R("R", 1 / sp.Symbol("G")))
    g.connect(loop, C("C", "C"))
    k = g.add(One("k", controlled=True))
    g.connect(Se("W", "W"), k)
    g.connect(k, R("R2", "R2"))
    clock = Automaton("clock", {"low": {"k": False}, "high": {"k": True}}, "low")
    clock.add_transition("low", "high", "sin(2*pi*t) > 0.5")
    clock.add_transition("high", "low", "sin(2*pi*t) < -0.5")
    return HybridModel(g, [clock], dict(G=G, C=1.0, W=1.0, R2=1.0), inputs={"u": ExpressionInput("sin(2*pi*t)", {})})


def test_a_multiplier_through_plus_one_is_a_fold_located_where_the_conductance_vanishes():
    result = continue_orbit(leaky(), "G", [0.3, 0.1, -0.1, -0.3], period=1.0)
    for point in result.points:
        assert point.multipliers == pytest.approx([np.exp(-point.value)], abs=1e-8)
        assert point.stable == (point.value > 0)
    assert [(b.kind, b.bracket) for b in result.bifurcations] == [("fold", (0.1, -0.1))]
    fold = result.bifurcations[0]
    assert abs(fold.value) < 1e-6 and fold.multiplier == pytest.approx(1.0, abs=1e-6)


def quadratic_map(i0, Vout, Vin=12.0, L=1e-3, k=2.0, i_ref=1.0):
    """The exact map from one turn-on current to the next with a resistance of voltage ``k i²`` in the
    inductor's loop: on, ``L di/dt = Vin − k i²`` gives ``i = a tanh(artanh(i0/a) + a k t/L)``, ``a² = Vin/k``,
    so the switch opens after ``t_on = L (artanh(i_ref/a) − artanh(i0/a))/(a k)``; off,
    ``L di/dt = −(Vout − Vin + k i²)`` gives ``i = b tan(atan(i_ref/b) − b k t/L)``, ``b² = (Vout − Vin)/k``,
    for ``CM_T − t_on``.  Its slope at a fixed point ``i*`` is ``μ = −(Vout − Vin + k i*²)/(Vin − k i*²)`` (the
    rates just after and just before the turn-off's ratio, times the on-flow's transport from the turn-on):
    the flip ``μ = −1`` is at ``Vout = 2 (Vin − k i*²)``, with ``i*`` the fixed point there."""
    a, b = np.sqrt(Vin / k), np.sqrt((Vout - Vin) / k)
    t_on = L / (a * k) * (np.arctanh(i_ref / a) - np.arctanh(i0 / a))
    return b * np.tan(np.arctan(i_ref / b) - b * k / L * (CM_T - t_on))


def test_period_doubling_with_a_state_dependent_multiplier_matches_the_exact_map():
    from scipy.optimize import brentq

    def fixed(Vout):
        return brentq(lambda i: quadratic_map(i, Vout) - i, -2.0, 0.999, xtol=1e-15)

    def mu(Vout):
        i = fixed(Vout)
        return -(Vout - 12.0 + 2.0 * i**2) / (12.0 - 2.0 * i**2)

    flip = brentq(lambda V: mu(V) + 1.0, 16.0, 26.0, xtol=1e-13)  # 23.2914271...
    model = current_mode(k=2.0)
    values = [18.0, 20.0, 22.0, 24.0, 26.0]
    result = continue_orbit(model, "Vout", values, period=CM_T, x0=[0.7e-3], max_step=0.02 * CM_T)
    for point in result.points:
        assert point.multipliers == pytest.approx([mu(point.value)], abs=1e-7)
    assert [(b.kind, b.bracket) for b in result.bifurcations] == [("period doubling", (22.0, 24.0))]
    assert abs(result.bifurcations[0].value - flip) < 1e-6


def two_cycle(V):
    """The exact two-cycle of :func:`quadratic_map` at ``Vout = V``: turn-on currents ``i1 < i* < i2``."""
    from scipy.optimize import brentq

    i_star = brentq(lambda i: quadratic_map(i, V) - i, -2.0, 0.999, xtol=1e-15)

    def g(i):
        return quadratic_map(quadratic_map(i, V), V) - i

    return [brentq(g, lo, hi, xtol=1e-15) for lo, hi in ((i_star - 0.5, i_star - 1e-4), (i_star + 1e-4, 0.999))]


def test_the_doubled_branch_of_a_subcritical_flip_is_the_exact_maps_two_cycle():
    # quadratic_map's flip is subcritical: the two-cycle (an unstable orbit of period 2T around the stable one)
    # lives below the flip and grows as sqrt(Vout* − Vout) until its upper turn-on current reaches i_ref
    # (the switch then opens at once: another mode sequence), a little above 23.13 V
    result = continue_orbit(current_mode(k=2.0), "Vout", [18.0, 20.0, 22.0, 24.0, 26.0], period=CM_T, x0=[0.7e-3],
                            max_step=0.02 * CM_T, switch_branch=True)
    flip = result.bifurcations[0]
    assert len(result.branches) == 1
    branch = result.branches[0]
    assert branch.origin is flip
    # from p* − δ (δ = 0.02, a hundredth of the bracket) through p* − 2δ, p* − 4δ, ...
    assert [p.value for p in branch.points] == pytest.approx([flip.value - 0.02 * 2**k for k in range(3)], abs=1e-12)
    assert "no orbit at Vout = 23.13" in branch.stopped and branch.bifurcations == []
    for point in branch.points:
        V = point.value
        assert point.period == 2 * CM_T and not point.stable
        cycle = two_cycle(V)
        assert cycle[1] == pytest.approx(quadratic_map(cycle[0], V), abs=1e-9)
        # the orbit starts at t = 0, 0.2 T before a turn-on, in the off phase: i(0) = b tan(atan(i_on/b) + 0.2 b k T/L)
        b = np.sqrt((V - 12.0) / 2.0)
        starts = [1e-3 * b * np.tan(np.arctan(i / b) + 0.2 * b * 2.0 * CM_T / 1e-3) for i in cycle]

        def slope(i):
            return -(V - 12.0 + 2.0 * quadratic_map(i, V) ** 2) / (12.0 - 2.0 * i**2)

        mu = slope(cycle[0]) * slope(cycle[1])
        assert point.multipliers == pytest.approx([mu], rel=1e-6)
        # Newton stops at a residual tol = 1e-8 (relative): near the flip μ is near 1, and the start is then
        # only pinned to about tol/|μ − 1| (1e-6 at the first point, 160 times the residual)
        assert min(abs(point.x0[0] - s) for s in starts) < 2e-8 / abs(mu - 1.0) * max(abs(s) for s in starts)
