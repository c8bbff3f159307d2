"""Periodic orbits through jumps (issue 31, item 1), against exact answers.

Boost converter (models/boost_converter.py) in continuous conduction with a
fixed duty D, period T = 1/f_sw, states x = (p_L, q_C), i_L = p_L/L, v_C = q_C/C.
Both phases are affine, ẋ = A x + b with b = (Vin, 0):

* switch on, diode off (v_A = 0):  ṗ_L = Vin − R_L p_L/L,  q̇_C = −q_C/(C R);
  ``A_on = [[−R_L/L, 0], [0, −1/(C R)]]``;
* switch off, diode on (v_A = v_C): ṗ_L = Vin − R_L p_L/L − q_C/C,
  q̇_C = p_L/L − q_C/(C R); ``A_off = [[−R_L/L, −1/C], [1/L, −1/(C R)]]``.

Over a phase of length τ, ``x(τ) = E x(0) + c`` with ``E = e^{Aτ}`` and
``c = ∫₀^τ e^{As} ds b``, both read off the exponential of the augmented
matrix ``[[A, b], [0, 0]]·τ`` (its top-left block and last column).  The
period map from t = 0 (start of the on phase) is ``x ↦ Φ x + c`` with
``Φ = E_off E_on`` (τ_on = D T, τ_off = (1 − D) T) and ``c = E_off c_on + c_off``;
the orbit starts at ``x* = (I − Φ)^{-1} c`` and its monodromy is Φ (no
saltation: the switching instants are clock events and both modes keep all
states independent, so the jumps are the identity), the multipliers its
eigenvalues.  The parameters below keep i_L > 0 all period (continuous
conduction; checked).

The same converter in discontinuous conduction (L = 0.1 mH, R_load = 200 Ω:
K = 2 L f_sw/R_load = 0.01 < D(1 − D)²): over a period the on phase maps x by
``(E_on, c_on)``; in the off phase the diode conducts until p_L reaches 0 at
``s_z`` (a *state* event, found by brentq on the exact affine solution), then
``pwm=off, diode=off`` holds p_L = 0 (dependent) while q_C decays as
``e^{−t/(C R)}`` for the rest of the period.  So ``φ(x0) = (0, q_end(x0))``, the
orbit is ``(0, q*)`` with ``q_end(0, q*) = q*`` (brentq), and the monodromy is
``[[0, 0], [∂q_end/∂p0, ∂q_end/∂q0]]`` — its multipliers 0 and ``∂q_end/∂q0`` —
which central differences of the exact map give to ~1e-10 (step 1e-6
relative: truncation ~1e-12, round-off ~1e-10).  Shooting gets it from the
saltation matrix at the diode's turn-off.

Relay (models/examples/relay.toml, one state q_C): on, v relaxes to
``v∞ = V R_load/(R + R_load)`` with ``τ_on = C R R_load/(R + R_load)``; off, to 0
with ``τ_off = C R_load``; the relay opens at v_hi and closes at v_lo, so the
autonomous period is ``τ_on ln((v∞ − v_lo)/(v∞ − v_hi)) + τ_off ln(v_hi/v_lo)``
and the orbit starts (just after the relay opens) at ``q_C = C v_hi``.  With one
state the monodromy is the trivial multiplier 1 alone.

Two tanks (models/two_tanks.py, defaults): just after the transfer valve opens
(the section) tank 1 holds ``A1 h1_high`` and tank 2 ``A2 h2_low`` (the drain
closed at h2_low and nothing flowed in since, the valve being closed): the
return map is constant, so the nontrivial multiplier is 0 and the trivial one 1.

Two tanks whose drain, once open, never closes (``h2_low = −1`` m, below any
level; ``h2_high = 0.05`` m, ``A2 = 5`` m²): just after the valve opens,
``V1 = A1 h1_high`` and ``V2 = v`` is free.  With the valve open the volumes
follow ``V̇ = A V + (Q_in, 0)``, ``A = ρg [[−1/(A1 R_v), 1/(A2 R_v)],
[1/(A1 R_v), −1/(A2 R_v) − 1/(A2 R_out)]]`` (``p_i = ρg V_i/A_i``), until
``V1 = A1 h1_low`` at ``s_open`` (brentq on the exact solution); closed, tank 1
fills for ``t_c = A1 (h1_high − h1_low)/Q_in`` while tank 2 decays by
``e^{−t_c ρg/(A2 R_out)}``.  That return map ``v ↦ P(v)`` has the fixed point
``v*`` (brentq), the period ``s_open(v*) + t_c`` and the nontrivial multiplier
``P'(v*)`` (central differences).

A comparator that watches an RC low-pass (R C = 10 s, C = 1 F) driven by
``u = sqrt(1 + (R C)²) sin t`` (T = 2π s): the orbit is ``v = sin(t − φ)``,
``tan φ = R C``, amplitude 1; the comparator (which drives a separate loop, so
v does not feel it) switches high at ``v >= 1 − δ`` and low at ``v <= 0``.  A
perturbation ``dq`` of the start decays as ``dq e^{−t/RC}``, and the crossing
of ``1 − δ`` is at ``t_c = φ + π/2 − Δ``, ``cos Δ = 1 − δ``, where ``v̇ = sin Δ``:
so ``∂t_c/∂q0 = −e^{−t_c/RC}/sin Δ`` and the grazing ratio is
``s e^{−t_c/RC}/(2π sin Δ)`` (s the largest |q_C| sampled), growing as
``δ^{−1/2}``: 0.84 at δ = 1e-2, 83 at 1e-6, 2.6e3 at 1e-9 (over the default
limit 1e3).
"""

from __future__ import annotations

import numpy as np
import pytest

import models
import switching
from models import boost_converter, two_tanks
from switching import GrazingError, ModeSequenceChangedError, OrbitConvergenceError, periodic_orbit
from switching_models import phase  # the exact affine phase: a matrix exponential

BOOST = dict(Vin=12.0, L=1e-3, R_L=0.1, C=100e-6, R_load=20.0, f_sw=10e3, D=0.4)
T = 1.0 / BOOST["f_sw"]


def boost_exact(D=BOOST["D"], R=BOOST["R_load"]):
    """The orbit's start ``x* = (p_L, q_C)`` [V·s, C] and the monodromy ``Φ = E_off·E_on`` at duty ``D`` and load ``R``."""
    L, C, R_L, V = (BOOST[k] for k in ("L", "C", "R_L", "Vin"))
    A_on = np.array([[-R_L / L, 0.0], [0.0, -1.0 / (C * R)]])
    A_off = np.array([[-R_L / L, -1.0 / C], [1.0 / L, -1.0 / (C * R)]])
    b = np.array([V, 0.0])
    E_on, c_on = phase(A_on, b, D * T)
    E_off, c_off = phase(A_off, b, (1 - D) * T)
    Phi = E_off @ E_on
    x_star = np.linalg.solve(np.eye(2) - Phi, E_off @ c_on + c_off)
    return x_star, Phi


@pytest.fixture(scope="module")
def boost_orbit():
    model = boost_converter.build(**BOOST)
    return model.periodic_orbit(T, max_step=0.3 * T)


def test_boost_orbit_start_and_monodromy_match_the_matrix_exponentials(boost_orbit):
    x_star, Phi = boost_exact()
    # rtol = 1e-10 on every run: the fixed point of the numerical map is that close
    assert np.allclose(boost_orbit.x0, x_star, rtol=1e-8, atol=0.0)
    assert np.allclose(boost_orbit.monodromy, Phi, rtol=0.0, atol=1e-8 * np.abs(Phi).max())
    exact = np.linalg.eigvals(Phi)
    got = boost_orbit.multipliers
    assert len(got) == 2 and boost_orbit.trivial_multiplier is None
    assert min(abs(got[0] - exact[0]) + abs(got[1] - exact[1]),
               abs(got[0] - exact[1]) + abs(got[1] - exact[0])) < 1e-8
    assert boost_orbit.stable and np.abs(exact).max() < 1
    assert boost_orbit.residual <= 1e-8 and boost_orbit.residuals[0] > 1e-3  # the guess was not the orbit


def test_boost_orbit_is_in_continuous_conduction_over_one_period(boost_orbit):
    tr = boost_orbit.trajectory
    assert boost_orbit.period == T and tr.t[0] == 0.0 and tr.t[-1] == pytest.approx(T, rel=1e-12)
    assert boost_orbit.mode_names == ["pwm=on, diode=off", "pwm=off, diode=on", "pwm=on, diode=off"]
    assert tr.signal("i_L").min() > 0.1
    assert np.allclose(tr.x[-1], tr.x[0], rtol=1e-8, atol=0.0)


def test_boost_newton_out_of_iterations_names_the_iterate_and_what_to_try():
    model = boost_converter.build(**BOOST)
    with pytest.raises(OrbitConvergenceError) as info:
        model.periodic_orbit(T, x0=[0.0, BOOST["C"] * 12.0], max_step=0.3 * T, max_iterations=0)
    error = info.value
    assert error.iterate == 0 and error.residual > 1e-3 and len(error.history) == 1
    assert "iterate 0" in str(error) and "warmup=" in str(error) and "max_iterations=" in str(error)


def test_boost_from_discontinuous_conduction_reports_the_changed_mode_sequence():
    # from i_L = 0 and v_C = 40 V the first period ends in discontinuous conduction
    # (the current dies in ~17 µs of the 60 µs off phase); Newton's step lands in continuous conduction
    model = boost_converter.build(**BOOST)
    with pytest.raises(ModeSequenceChangedError) as info:
        model.periodic_orbit(T, x0=[0.0, BOOST["C"] * 40.0], max_step=0.3 * T)
    error = info.value
    assert error.iterate == 1
    assert "pwm=off, diode=off" in " ".join(m.describe() for m in error.before)
    assert "pwm=off, diode=off" not in " ".join(m.describe() for m in error.after)
    assert "iterate 1" in str(error) and "warmup=" in str(error)


DCM = dict(Vin=12.0, L=1e-4, R_L=0.1, C=100e-6, R_load=200.0, f_sw=10e3, D=0.4)


def dcm_map(x0):
    """The exact period map of the converter in discontinuous conduction (see the module docstring)."""
    from scipy.optimize import brentq

    L, C, R, R_L, V, D = (DCM[k] for k in ("L", "C", "R_load", "R_L", "Vin", "D"))
    A_on = np.array([[-R_L / L, 0.0], [0.0, -1.0 / (C * R)]])
    A_off = np.array([[-R_L / L, -1.0 / C], [1.0 / L, -1.0 / (C * R)]])
    b = np.array([V, 0.0])
    E, c = phase(A_on, b, D * T)
    x1 = E @ np.asarray(x0, dtype=float) + c

    def off(s):
        E, c = phase(A_off, b, s)
        return E @ x1 + c

    s_z = brentq(lambda s: off(s)[0], 0.0, (1 - D) * T, xtol=1e-22, rtol=1e-15)
    return np.array([0.0, off(s_z)[1] * np.exp(-((1 - D) * T - s_z) / (C * R))])


def test_boost_in_discontinuous_conduction_crosses_the_diode_turn_off_with_its_saltation():
    from scipy.optimize import brentq

    C = DCM["C"]
    q_star = brentq(lambda q: dcm_map([0.0, q])[1] - q, 20 * C, 100 * C, xtol=1e-22, rtol=1e-15)
    h_q, h_p = 1e-6 * q_star, 1e-6 * DCM["Vin"] * DCM["D"] * T
    a = (dcm_map([h_p, q_star])[1] - dcm_map([-h_p, q_star])[1]) / (2 * h_p)
    b = (dcm_map([0.0, q_star + h_q])[1] - dcm_map([0.0, q_star - h_q])[1]) / (2 * h_q)
    model = boost_converter.build(**DCM)
    orbit = model.periodic_orbit(T, x0=[0.0, 50.0 * C], max_step=0.3 * T)
    assert orbit.mode_names == ["pwm=on, diode=off", "pwm=off, diode=on", "pwm=off, diode=off", "pwm=on, diode=off"]
    assert abs(orbit.x0[0]) < 1e-8 * DCM["Vin"] * DCM["D"] * T and orbit.x0[1] == pytest.approx(q_star, rel=1e-8)
    assert np.allclose(orbit.monodromy, [[0.0, 0.0], [a, b]], rtol=0.0, atol=1e-8)
    assert orbit.multipliers[0] == pytest.approx(b, abs=1e-8) and abs(orbit.multipliers[1]) < 1e-8
    assert orbit.iterations >= 2 and orbit.residuals[-1] <= 1e-8 < orbit.residuals[0]


def test_boost_orbit_from_a_start_with_a_dependent_inductor():
    # from t0 = 0.9 T, inside the phase pwm=off, diode=off (p_L dependent, held at 0), the orbit is the same
    # one shifted: q_C(0.9 T) = q* e^{0.1 T/(C R_load)} (it decays until the switch closes at T); the guess
    # p_L = 1e-4 V·s is off the constraint (its start resolution passes diode=on: one warm-up period)
    from scipy.optimize import brentq

    C = DCM["C"]
    q_star = brentq(lambda q: dcm_map([0.0, q])[1] - q, 20 * C, 100 * C, xtol=1e-22, rtol=1e-15)
    model = boost_converter.build(**DCM)
    start = switching.Mode(("off", "off"), ("pwm", "diode"))
    orbit = model.periodic_orbit(T, t0=0.9 * T, mode=start, x0=[1e-4, 50.0 * C], max_step=0.3 * T, warmup=1)
    assert orbit.modes[0] == start and orbit.x0[0] == 0.0
    assert orbit.x0[1] == pytest.approx(q_star * np.exp(0.1 * T / (C * DCM["R_load"])), rel=1e-8)
    reference = model.periodic_orbit(T, x0=[0.0, 50.0 * C], max_step=0.3 * T)
    assert np.allclose(np.sort(orbit.multipliers), np.sort(reference.multipliers), rtol=0.0, atol=1e-8)


def test_relay_autonomous_period_and_trivial_multiplier():
    model = models.load("models/examples/relay.toml")
    orbit = periodic_orbit(model, section="relay: on -> off", period=0.01)
    V, R, C, R_load, v_hi, v_lo = 10.0, 1.0, 1e-3, 20.0, 8.0, 6.0
    v_inf = V * R_load / (R + R_load)
    period = C * R * R_load / (R + R_load) * np.log((v_inf - v_lo) / (v_inf - v_hi)) + C * R_load * np.log(v_hi / v_lo)
    assert orbit.period == pytest.approx(period, rel=1e-8)
    assert orbit.x0 == pytest.approx([C * v_hi], rel=1e-9)
    assert abs(orbit.trivial_multiplier - 1.0) < 1e-6 and len(orbit.multipliers) == 0 and orbit.stable
    assert orbit.mode_names == ["relay=off", "relay=on", "relay=off"]
    assert orbit.trajectory.t[-1] == pytest.approx(period, rel=1e-8)


def test_two_tanks_autonomous_orbit_forgets_its_start():
    p = two_tanks.DEFAULTS
    model = two_tanks.build()
    orbit = model.periodic_orbit(section=("valve", "closed", "open"), period=300.0, warmup=3)
    assert np.allclose(orbit.x0, [p["A1"] * p["h1_high"], p["A2"] * p["h2_low"]], rtol=1e-9, atol=0.0)
    assert abs(orbit.trivial_multiplier - 1.0) < 1e-6
    assert len(orbit.multipliers) == 1 and abs(orbit.multipliers[0]) < 1e-8 and orbit.stable
    # the period against the spacing of the valve's openings in a long plain run
    run = model.simulate(3000.0, "RK45", rtol=1e-10, atol=1e-12)
    openings = [e.t for e in run.events if any((f.automaton, f.source, f.target) == ("valve", "closed", "open")
                                               for s in e.steps for f in s.fired)]
    assert orbit.period == pytest.approx(openings[-1] - openings[-2], rel=1e-7)


FREE_DRAIN = dict(h2_low=-1.0, h2_high=0.05, A2=5.0)


def free_drain_map(v):
    """``(P(v), s_open)``: the exact return map of the tanks with the drain always open (module docstring)."""
    from scipy.optimize import brentq

    p = {**two_tanks.DEFAULTS, **FREE_DRAIN}
    rg = p["rho"] * p["g"]
    A1, A2, R_v, R_out = p["A1"], p["A2"], p["R_v"], p["R_out"]
    A = rg * np.array([[-1 / (A1 * R_v), 1 / (A2 * R_v)], [1 / (A1 * R_v), -1 / (A2 * R_v) - 1 / (A2 * R_out)]])
    b = np.array([p["Q_in"], 0.0])
    start = np.array([A1 * p["h1_high"], v])

    def open_phase(s):
        E, c = phase(A, b, s)
        return E @ start + c

    s_open = brentq(lambda s: open_phase(s)[0] - A1 * p["h1_low"], 1e-3, 1e4, xtol=1e-13, rtol=1e-15)
    t_closed = A1 * (p["h1_high"] - p["h1_low"]) / p["Q_in"]
    return open_phase(s_open)[1] * np.exp(-t_closed * rg / (A2 * R_out)), s_open + t_closed


def test_two_tanks_autonomous_newton_with_a_free_drain():
    from scipy.optimize import brentq

    p = {**two_tanks.DEFAULTS, **FREE_DRAIN}
    v_star = brentq(lambda v: free_drain_map(v)[0] - v, 0.01, 5.0, xtol=1e-15, rtol=1e-15)
    period = free_drain_map(v_star)[1]
    h = 1e-6 * v_star
    multiplier = (free_drain_map(v_star + h)[0] - free_drain_map(v_star - h)[0]) / (2 * h)
    model = two_tanks.build(**FREE_DRAIN)
    orbit = model.periodic_orbit(section="valve: closed -> open", period=300.0, warmup=1)
    assert orbit.mode_names == ["valve=open, drain=open", "valve=closed, drain=open", "valve=open, drain=open"]
    assert np.allclose(orbit.x0, [p["A1"] * p["h1_high"], v_star], rtol=1e-8, atol=0.0)
    assert orbit.period == pytest.approx(period, rel=1e-8)
    assert abs(orbit.trivial_multiplier - 1.0) < 1e-6
    assert len(orbit.multipliers) == 1 and orbit.multipliers[0] == pytest.approx(multiplier, abs=1e-7)
    assert orbit.iterations >= 2 and orbit.residuals[0] > 1e-3 and orbit.residual <= 1e-8


def test_two_tanks_without_warmup_changes_its_mode_sequence():
    # the first return still passes the drain's opening (drain closed at the start): iterate 0 flows through
    # one more mode than the orbit
    model = two_tanks.build(**FREE_DRAIN)
    with pytest.raises(ModeSequenceChangedError) as info:
        model.periodic_orbit(section="valve: closed -> open", period=300.0)
    assert info.value.iterate == 1 and len(info.value.before) == len(info.value.after) + 1


def comparator(delta, RC=10.0):
    """The RC low-pass with a comparator at ``1 − delta`` (module docstring)."""
    import sympy as sp

    from bondgraph import BondGraph, C, One, R, Se
    from switching import Automaton, ExpressionInput, HybridModel

    g = BondGraph("comparator")
    loop = g.add(One("loop"))
    g.connect(Se("u", sp.Symbol("u")), loop)
    g.input("u")
    g.connect(loop, R("R", "R"))
    g.connect(loop, C("C", "C"))
    k = g.add(One("k", controlled=True))
    g.connect(Se("W", "W"), k)
    g.connect(k, R("R2", "R2"))
    watch = Automaton("comparator", {"low": {"k": False}, "high": {"k": True}}, "low")
    watch.add_transition("low", "high", "q_C/C >= v_th")
    watch.add_transition("high", "low", "q_C/C <= 0")
    return HybridModel(g, [watch], dict(R=RC, C=1.0, W=1.0, R2=1.0, v_th=1.0 - delta),
                       inputs={"u": ExpressionInput("V*sin(t)", {"V": float(np.sqrt(1 + RC**2))})})


def comparator_ratio(delta, scale, RC=10.0):
    phi, D = np.arctan(RC), np.arccos(1.0 - delta)
    return scale * np.exp(-(phi + np.pi / 2 - D) / RC) / (2 * np.pi * np.sin(D))


@pytest.mark.parametrize("delta, rel", [(1e-2, 1e-6), (1e-6, 1e-4)])
def test_grazing_ratio_of_a_transversal_crossing_matches_its_closed_form(delta, rel):
    phi = np.arctan(10.0)
    orbit = comparator(delta).periodic_orbit(2 * np.pi)
    assert orbit.x0 == pytest.approx([-np.sin(phi)], rel=1e-8)
    assert orbit.mode_names == ["comparator=low", "comparator=high", "comparator=low"]
    scale = np.abs(orbit.trajectory.x).max()
    assert orbit.grazing_ratio == pytest.approx(comparator_ratio(delta, scale), rel=rel)


def test_nearly_tangential_crossing_is_a_grazing_error():
    phi = np.arctan(10.0)
    with pytest.raises(GrazingError) as info:
        comparator(1e-9).periodic_orbit(2 * np.pi, x0=[-np.sin(phi)])
    error = info.value
    t_c = phi + np.pi / 2 - np.arccos(1.0 - 1e-9)
    assert error.iterate == 0 and error.t == pytest.approx(t_c, abs=1e-6)
    assert error.ratio == pytest.approx(comparator_ratio(1e-9, 1.0), rel=2e-2) and error.ratio > 1e3
    assert "iterate 0" in str(error) and "grazing_limit = 1000" in str(error) and "transversally" in str(error)


def test_grazing_limit_names_the_event_and_the_iterate():
    # the relay's closing event moves by about 3 periods per relative change of q_C: a limit of 1e-3 flags it
    model = models.load("models/examples/relay.toml")
    with pytest.raises(GrazingError) as info:
        periodic_orbit(model, section="relay: on -> off", period=0.01, grazing_limit=1e-3)
    error = info.value
    assert error.iterate == 0 and error.ratio > 1e-3 and 0 < error.t < 0.01
    assert "iterate 0" in str(error) and "transversally" in str(error)


def test_bad_section_and_missing_period_are_refused():
    model = models.load("models/examples/relay.toml")
    with pytest.raises(switching.OrbitError, match="no transition off → off"):
        periodic_orbit(model, section="relay: off -> off", period=0.01)
    with pytest.raises(switching.OrbitError, match="max_period="):
        periodic_orbit(model, section="relay: on -> off")
    with pytest.raises(switching.OrbitError, match="positive period"):
        periodic_orbit(model)
