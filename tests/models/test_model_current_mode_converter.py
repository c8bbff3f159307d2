"""The peak-current-mode controlled boost converter (models/current_mode_converter.py) against exact answers.

**Output held** (``load="source"``, ``R_L = 0``): the inductor current is
piecewise linear, rising at ``m1 = Vin/L`` with the switch on and falling at
``m2 = (Vout − Vin)/L`` with it off (``T = 1/f_sw``, ``w = w_clock``).  From
the current ``i`` at a clock edge (the switch turned on), the switch opens at
``t_on = (i_ref − i)/(m1 + m_c)`` (where ``i + m1 t = i_ref − m_c t``), but not
during the pulse (``t_on ≥ w T``: leading-edge blanking) nor after the next
edge (``t_on ≤ T``: the switch stays on, the reference's ramp restarts), and
the ideal diode stops the current at 0.  So the *edge map* is exactly

    g(i) = max(0, i + m1 τ − m2 (T − τ)),   τ = clamp((i_ref − i)/(m1 + m_c), w T, T)

(:func:`edge_map`).  On its middle piece ``g(i) = i_ref − m2 T + (m2 − m_c)(i_ref − i)/(m1 + m_c)``:
slope ``μ = −(m2 − m_c)/(m1 + m_c)`` (``−m2/m1 = −D/(1 − D)`` without
compensation, ``D = 1 − Vin/Vout``), fixed point ``i* = i_ref − m2 T (m1 + m_c)/(m1 + m2)``.
``μ`` is the one Floquet multiplier of the period-1 orbit (the comparator's
saltation: the clock edges have none).  It passes −1 at ``m2 = m1``
(``D = 1/2``, ``Vout = 2 Vin``) without compensation, and at
``m_c = (m2 − m1)/2`` with it.

**The doubled branch.**  ``g`` is piecewise affine, so beyond the flip
(``k = (m2 − m_c)/(m1 + m_c) > 1``) no 2-cycle lies on the middle piece (there
``g∘g`` has slope ``k² ≠ 1``): the 2-cycle born at the flip alternates the
middle piece (turn-on current ``a``) and the blanked piece (current ``b``, the
switch opening at the pulse's end: ``g(b) = b − c``, ``c = m2 (1 − w) T − m1 w T``).
``b = g(a)``, ``a = b − c`` give ``b = i_ref − (m2 T − k c)/(1 + k)``, and the
2-cycle's multiplier is the product of the slopes, ``−k·1 = −k``: unstable.
At ``k = 1`` (``m_c = 0``) ``b = i_ref − m1 w T``, the border of the blanked
piece: the branch leaves the flip there (at ``k = 1`` every ``i`` of the middle
piece is on a 2-cycle: the flip of a piecewise-affine map is degenerate).  It
ends where ``a`` leaves the middle piece, ``i_ref − a = (m2 T + c)/(1 + k) = m1 T``
(without compensation), i.e. ``c = m1 T``, ``m2 = m1 (1 + w)/(1 − w)``:
``Vout = 2 Vin/(1 − w)`` (25.26 V for Vin = 12 V, w = 0.05).

**RC load** (continuous conduction): with the switch on the diode is off, so
``i_L`` rises at ``m1`` exactly and ``v_C`` decays as ``e^{−t/(R C)}``: the
turn-off is at the closed-form ``t_on`` above; with the switch off,
``ẋ = A x + b`` with ``A = [[0, −1/C], [1/L, −1/(R C)]]`` on ``x = (p_L, q_C)``,
``b = (Vin, 0)``, solved by the exponential of the augmented matrix
(:func:`phase`).  The period map ``P`` composed of these is exact; its
fixed point is found by Newton on ``P`` itself and its Jacobian by central
differences (step 1e-6 relative: truncation ~1e-12, round-off ~1e-10).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from models import current_mode_converter
from switching import continue_orbit, periodic_orbit
from switching_models import phase  # the exact affine phase: a matrix exponential

T = 1e-4  # 1/f_sw [s]
#: the output held at Vout by a source; i_ref = 3 A keeps every orbit below in continuous conduction
HELD = dict(load="source", Vin=12.0, L=1e-3, f_sw=1 / T, i_ref=3.0, w_clock=0.05)


def slopes(Vout, Vin=HELD["Vin"], L=HELD["L"]):
    """``(m1, m2)`` [A/s]: the current's rise with the switch on and its fall with it off."""
    return Vin / L, (Vout - Vin) / L


def edge_map(i, Vout, m_c=0.0, Vin=HELD["Vin"], L=HELD["L"], i_ref=HELD["i_ref"], w=HELD["w_clock"]):
    """The exact map of the current at one clock edge to the next (module docstring) [A]."""
    m1, m2 = slopes(Vout, Vin, L)
    tau = min(max((i_ref - i) / (m1 + m_c), w * T), T)
    return max(0.0, i + m1 * tau - m2 * (T - tau))


def fixed_current(Vout, m_c=0.0, Vin=HELD["Vin"], i_ref=HELD["i_ref"]):
    """``i* = i_ref − m2 T (m1 + m_c)/(m1 + m2)`` [A], the period-1 orbit's current at the clock edge."""
    m1, m2 = slopes(Vout, Vin)
    return i_ref - m2 * T * (m1 + m_c) / (m1 + m2)


def multiplier(Vout, m_c=0.0, Vin=HELD["Vin"]):
    """``μ = −(m2 − m_c)/(m1 + m_c)``, the period-1 orbit's Floquet multiplier."""
    m1, m2 = slopes(Vout, Vin)
    return -(m2 - m_c) / (m1 + m_c)


def two_cycle(Vout, m_c=0.0):
    """The 2-cycle ``(a, b)`` [A] beyond the flip: ``a`` on the middle piece, ``b`` on the blanked one."""
    m1, m2 = slopes(Vout)
    k = (m2 - m_c) / (m1 + m_c)
    w = HELD["w_clock"]
    c = m2 * (1 - w) * T - m1 * w * T
    b = HELD["i_ref"] - (m2 * T - k * c) / (1 + k)
    a = b - c
    # on those pieces only (24 V < Vout < 2 Vin/(1 − w) = 25.26 V without compensation): a's turn-off between
    # the pulse's end and the next edge, b's before the pulse's end
    assert w * T <= (HELD["i_ref"] - a) / (m1 + m_c) <= T and (HELD["i_ref"] - b) / (m1 + m_c) <= w * T
    return a, b


def held(**parameters):
    return current_mode_converter.build(**{**HELD, **parameters})


def orbit(model, x0, **options):
    return periodic_orbit(model, period=T, x0=[x0], max_step=0.02 * T, **options)


# ------------------------------------------------------------------ the output held


def test_the_current_is_piecewise_linear_with_the_slopes_and_turn_offs_of_the_edge_map():
    Vout, i0 = 18.0, 2.2  # i* = 2.6 A; every turn-off by the comparator (the middle piece of the edge map)
    m1, m2 = slopes(Vout)
    model = held(Vout=Vout, i_L0=i0)
    trajectory = model.simulate(4 * T, "RK45", rtol=1e-10, atol=1e-13, max_step=0.02 * T)
    # the exact current: from each edge's i, up at m1 until t_on, then down at m2
    t = trajectory.t
    k = np.minimum(np.floor(t / T + 1e-12).astype(int), 3)
    edges = [i0]
    for _ in range(3):
        edges.append(edge_map(edges[-1], Vout))
    edges = np.array(edges)
    t_on = (HELD["i_ref"] - edges) / m1
    assert np.all((t_on > HELD["w_clock"] * T) & (t_on < T))
    s = t - k * T
    exact = np.where(s <= t_on[k], edges[k] + m1 * s, HELD["i_ref"] - m2 * (s - t_on[k]))
    scale = HELD["i_ref"]
    assert np.max(np.abs(trajectory.signal("i_L") - exact)) < 1e-8 * scale
    offs = [e.t for e in trajectory.events if e.mode_after.state_of("switch") == "off"]
    np.testing.assert_allclose(offs, np.arange(4) * T + t_on, rtol=1e-9)
    # the inductor's voltage: Vin on, Vin − Vout off; the output source's voltage and the diode's current
    on = trajectory.signal("i_sw") != 0
    np.testing.assert_allclose(trajectory.signal("v_L")[on], 12.0, rtol=1e-12)
    np.testing.assert_allclose(trajectory.signal("v_L")[~on], 12.0 - Vout, rtol=1e-12)
    np.testing.assert_allclose(trajectory.signal("i_D")[~on], trajectory.signal("i_L")[~on], rtol=1e-12)
    assert np.all(trajectory.signal("v_out") == Vout)


@pytest.mark.parametrize("Vout, m_c", [(18.0, 0.0), (20.0, 0.0), (22.0, 0.0), (30.0, 6000.0), (30.0, 9000.0),
                                       (40.0, 12000.0)])
def test_period_one_orbit_start_turn_off_and_multiplier_in_closed_form(Vout, m_c):
    i_star = fixed_current(Vout, m_c)
    assert edge_map(i_star, Vout, m_c) == pytest.approx(i_star, rel=1e-14)  # on the middle piece
    found = orbit(held(Vout=Vout, m_c=m_c), 0.9 * HELD["L"] * i_star)
    # Newton's residual tol = 1e-8 (relative to the amplitude L i_ref) pins x0 to about tol/|μ − 1|
    assert found.x0[0] == pytest.approx(HELD["L"] * i_star, rel=0, abs=1e-8 * HELD["L"] * HELD["i_ref"])
    assert found.multipliers == pytest.approx([multiplier(Vout, m_c)], abs=1e-8)
    assert found.stable == (abs(multiplier(Vout, m_c)) < 1)
    assert found.mode_names[:2] == ["switch=on, diode=off", "switch=off, diode=on"]
    # the turn-off at t_on = (i_ref − i*)/(m1 + m_c); without compensation the duty is D = 1 − Vin/Vout
    m1, _ = slopes(Vout)
    (off,) = [e.t for e in found.trajectory.events if e.mode_after.state_of("switch") == "off"]
    assert off == pytest.approx((HELD["i_ref"] - i_star) / (m1 + m_c), rel=1e-9)
    if m_c == 0:
        assert off / T == pytest.approx(1 - HELD["Vin"] / Vout, rel=1e-9)
        assert found.multipliers[0] == pytest.approx(-(off / T) / (1 - off / T), rel=1e-8)  # −D/(1 − D)


def test_the_period_doubles_at_half_duty_continued_in_the_input_voltage():
    # Vout = 24 V held; Vin from 15 V down to 9 V: D = 1 − Vin/24 passes 1/2 at Vin = 12 V
    values = [15.0, 14.0, 13.0, 11.5, 10.0, 9.0]
    result = continue_orbit(current_mode_converter.build, "Vin", values, period=T, fixed={**HELD, "Vout": 24.0},
                            x0=[HELD["L"] * 2.0], max_step=0.02 * T)
    for point in result.points:
        assert point.multipliers == pytest.approx([multiplier(24.0, Vin=point.value)], abs=1e-8)
        assert point.x0[0] == pytest.approx(HELD["L"] * fixed_current(24.0, Vin=point.value), rel=1e-8)
        assert point.stable == (point.value > 12.0)
    (flip,) = result.bifurcations
    assert flip.kind == "period doubling" and flip.bracket == (13.0, 11.5)
    assert abs(flip.value - 12.0) < 1e-6 and flip.multiplier == pytest.approx(-1.0, abs=1e-6)


def test_slope_compensation_moves_the_flip_to_half_the_slope_difference():
    # Vout = 30 V, Vin = 12 V: m1 = 12000 A/s, m2 = 18000 A/s (D = 0.6); stable for m_c > (m2 − m1)/2 = 3000 A/s
    m1, m2 = slopes(30.0)
    values = [0.0, 1000.0, 2000.0, 3500.0, 5000.0, 9000.0]
    result = continue_orbit(held(Vout=30.0), "m_c", values, period=T, x0=[HELD["L"] * 2.0], max_step=0.02 * T)
    for point in result.points:
        assert point.multipliers == pytest.approx([multiplier(30.0, point.value)], abs=1e-8)
        assert point.stable == (point.value > (m2 - m1) / 2)
    (flip,) = result.bifurcations
    assert flip.kind == "period doubling" and flip.bracket == (2000.0, 3500.0)
    assert abs(flip.value - (m2 - m1) / 2) < 1e-9 * m2 and flip.multiplier == pytest.approx(-1.0, abs=1e-6)


def test_compensation_of_half_the_largest_falling_slope_keeps_every_duty_stable():
    # Vout = 30 V held: (m2 − m1)/2 = (Vout − 2 Vin)/(2 L) < Vout/(2 L), the limit of m2/2 as Vin → 0 (D → 1);
    # with m_c = Vout/(2 L), μ = −(m2 − m_c)/(m1 + m_c) = −(Vout/2 − Vin)/(Vout/2 + Vin) > −1 for every Vin > 0
    m_c = 30.0 / (2 * HELD["L"])
    values = [24.0, 18.0, 12.0, 6.0, 3.0, 1.5]  # D from 0.2 to 0.95
    result = continue_orbit(current_mode_converter.build, "Vin", values, period=T,
                            fixed={**HELD, "Vout": 30.0, "m_c": m_c, "i_ref": 6.0}, x0=[HELD["L"] * 5.0],
                            max_step=0.02 * T)
    for point in result.points:
        mu = multiplier(30.0, m_c, Vin=point.value)
        assert mu == pytest.approx(-(15.0 - point.value) / (15.0 + point.value), rel=1e-12)
        assert point.multipliers == pytest.approx([mu], abs=1e-8)
        assert point.stable
    assert result.bifurcations == []


def test_the_doubled_branch_beyond_the_flip_is_the_edge_maps_two_cycle():
    values = [20.0, 22.0, 25.0, 27.0]
    result = continue_orbit(held(), "Vout", values, period=T, x0=[HELD["L"] * 2.5], max_step=0.02 * T,
                            switch_branch=True)
    (flip,) = result.bifurcations
    assert abs(flip.value - 24.0) < 1e-6
    (branch,) = result.branches
    # from p* + δ (δ = 0.03, a hundredth of the bracket 22–25) through p* + 2δ, 4δ, ... and the given 25 V; the
    # 2-cycle ends at 2 Vin/(1 − w) = 25.26 V (module docstring), so there is none at 27 V
    end = 2 * HELD["Vin"] / (1 - HELD["w_clock"])
    assert [p.value for p in branch.points] == pytest.approx([flip.value + 0.03 * 2**k for k in range(6)] + [25.0],
                                                            abs=1e-6)
    assert all(24.0 < p.value < end for p in branch.points) and "no orbit at Vout = 27" in branch.stopped
    for point in branch.points:
        a, b = two_cycle(point.value)
        assert edge_map(a, point.value) == pytest.approx(b, rel=1e-13)  # a 2-cycle of the exact map
        assert edge_map(b, point.value) == pytest.approx(a, rel=1e-13)
        assert point.period == 2 * T and not point.stable
        assert point.multipliers == pytest.approx([-(point.value - 12.0) / 12.0], abs=1e-7)  # −k
        start = point.x0[0] / HELD["L"]
        assert min(abs(start - a), abs(start - b)) < 1e-7 * HELD["i_ref"]


def test_a_two_cycle_found_directly_alternates_a_comparator_and_a_blanked_turn_off():
    Vout = 24.5
    a, b = two_cycle(Vout)
    found = periodic_orbit(held(Vout=Vout), period=2 * T, x0=[HELD["L"] * (a + 0.01)], max_step=0.02 * T)
    assert found.x0[0] / HELD["L"] == pytest.approx(a, abs=1e-8 * HELD["i_ref"])
    assert found.multipliers == pytest.approx([-(Vout - 12.0) / 12.0], abs=1e-8)
    m1, _ = slopes(Vout)
    offs = [e.t for e in found.trajectory.events if e.mode_after.state_of("switch") == "off"]
    assert offs == pytest.approx([(HELD["i_ref"] - a) / m1, T + HELD["w_clock"] * T], rel=1e-9)


# ------------------------------------------------------------------ the RC load

RC = dict(Vin=12.0, L=1e-3, C=100e-6, R_load=20.0, f_sw=1 / T, i_ref=2.0, m_c=3000.0, w_clock=0.05)


def rc_period(x, p=RC):
    """The exact period map ``x = (p_L, q_C) ↦ x(T)`` with the RC load, from a clock edge, and the turn-off
    time [s] (continuous conduction: on, ``i_L`` rises at m1 while ``q_C`` decays; off, the affine phase)."""
    L, C, R, Vin = p["L"], p["C"], p["R_load"], p["Vin"]
    m1 = Vin / L
    t_on = (p["i_ref"] - x[0] / L) / (m1 + p["m_c"])
    assert p["w_clock"] * T < t_on < T  # a turn-off by the comparator
    on = np.array([x[0] + Vin * t_on, x[1] * math.exp(-t_on / (R * C))])
    E, c = phase(np.array([[0.0, -1.0 / C], [1.0 / L, -1.0 / (R * C)]]), np.array([Vin, 0.0]), T - t_on)
    return E @ on + c, t_on


def test_rc_load_run_follows_the_exact_piecewise_affine_solution():
    x = np.array([RC["L"] * 1.5, RC["C"] * 20.0])
    model = current_mode_converter.build(**RC, i_L0=1.5, v_C0=20.0)
    trajectory = model.simulate(5 * T, "RK45", rtol=1e-11, atol=1e-14, max_step=0.02 * T)
    offs = [e.t for e in trajectory.events if e.mode_after.state_of("switch") == "off"]
    edges = [np.argmin(np.abs(trajectory.t - k * T)) for k in range(1, 5)]
    for k in range(4):
        x, t_on = rc_period(x)
        assert offs[k] == pytest.approx(k * T + t_on, rel=1e-9)
        assert trajectory.t[edges[k]] == pytest.approx((k + 1) * T, rel=1e-12)
        np.testing.assert_allclose(trajectory.x[edges[k]], x, rtol=1e-8)


def test_rc_load_orbit_and_multipliers_match_the_exact_period_map():
    x = np.array([RC["L"] * 1.5, RC["C"] * 20.5])
    for _ in range(8):  # Newton on the exact map, Jacobian by central differences
        h = 1e-6 * np.abs(x)
        J = np.column_stack([(rc_period(x + dx)[0] - rc_period(x - dx)[0]) / (2 * dx[j])
                             for j, dx in enumerate(np.diag(h))])
        x = x - np.linalg.solve(J - np.eye(2), rc_period(x)[0] - x)
    exact = np.sort_complex(np.linalg.eigvals(J).astype(complex))
    model = current_mode_converter.build(**RC)
    found = periodic_orbit(model, period=T, x0=[RC["L"] * 1.5, RC["C"] * 20.5], max_step=0.02 * T)
    np.testing.assert_allclose(found.x0, x, rtol=1e-8)
    got = np.sort_complex(np.asarray(found.multipliers).astype(complex))
    np.testing.assert_allclose(got, exact, atol=1e-7)
    assert found.stable


# ------------------------------------------------------------------ units


def test_the_same_converter_in_milliamperes_millihenries_and_microseconds_switches_at_the_same_instants():
    """Units V, mA, µs: resistance kΩ, inductance mH (V·µs/mA), capacitance nF (mA·µs/V), frequency MHz,
    a current slope mA/µs = 1e3 A/s.  Same circuit, so the same instants (in µs) and currents (in mA)."""
    si = dict(RC, i_L0=1.5, v_C0=20.0)
    scaled = dict(Vin=12.0, L=1.0, C=1e5, R_load=0.02, f_sw=0.01, i_ref=2000.0, m_c=3.0, w_clock=0.05,
                  i_L0=1500.0, v_C0=20.0)
    runs = []
    for parameters, t_end, atol in ((si, 4.5 * T, 1e-14), (scaled, 4.5 * T * 1e6, 1e-5)):
        model = current_mode_converter.build(**parameters)
        runs.append(model.simulate(t_end, "RK45", rtol=1e-11, atol=atol, max_step=0.02 * t_end / 4.5))
    assert len(runs[0].events) == 9  # four periods: a turn-off and a turn-on each, the fifth turn-off
    a, b = runs
    assert [e.mode_after.label for e in a.events] == [e.mode_after.label for e in b.events]
    np.testing.assert_allclose(np.array(b.event_times) * 1e-6, a.event_times, rtol=1e-9)
    np.testing.assert_allclose(b.signal("i_L")[-1] * 1e-3, a.signal("i_L")[-1], rtol=1e-8)
    np.testing.assert_allclose(b.signal("v_out")[-1], a.signal("v_out")[-1], rtol=1e-8)


# ------------------------------------------------------------------ the command line


def hbg(*args):
    import os
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-m", "models.cli", *args], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "MPLBACKEND": "Agg"})


def test_hbg_orbit_locates_the_period_doubling_of_the_held_output(tmp_path):
    import csv

    table = tmp_path / "vout.csv"
    # the first guess i_L = 2.5 A: from the default 0 A the switch stays on all period (a piece of the edge map of
    # slope 1, where the monodromy is 1 and Newton's matrix M − I vanishes)
    out = hbg("orbit", "current-mode-converter", "--set", "load=source", "--set", "i_ref=3", "--set", "i_L0=2.5",
              "--period", "1e-4", "--continue", "Vout=18:30:5", "--csv", str(table))
    assert out.returncode == 0, out.stderr
    assert "period doubling at 24" in out.stdout and "5 orbit(s)" in out.stdout
    rows = list(csv.DictReader(table.open()))
    assert [float(r["Vout"]) for r in rows] == [18.0, 21.0, 24.0, 27.0, 30.0]
    for row in rows:
        Vout = float(row["Vout"])
        assert float(row["x0:p_L"]) == pytest.approx(HELD["L"] * fixed_current(Vout), rel=1e-8)
        assert float(row["multiplier_1"]) == pytest.approx(multiplier(Vout), abs=1e-8)


def test_bad_choices_are_refused_with_the_alternatives():
    from bondgraph.errors import InvalidGraphError
    from switching import ModelDefinitionError

    with pytest.raises(ModelDefinitionError, match="unknown load 'lc'.*rc, source"):
        current_mode_converter.build(load="lc")
    with pytest.raises(InvalidGraphError, match="w_clock.*0 < the range < 1"):
        current_mode_converter.build(w_clock=0.0)
