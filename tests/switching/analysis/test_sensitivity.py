"""Forward sensitivities through instants (issue 18, item 1), against exact answers.

Bouncing ball (models/bouncing_ball.py), released from rest at height h, gravity
g, restitution e.  By hand:

* first impact at ``t₁ = sqrt(2h/g)`` with speed ``v₁ = g·t₁ = sqrt(2gh)``; after
  bounce k it leaves at ``e^k·v₁`` and flies ``2 e^k v₁/g``, so the k-th impact is at
  ``t_k = t₁·c_k``, ``c_k = 1 + 2 Σ_{j=1}^{k-1} e^j``;
* hence ``∂t_k/∂e = 2 t₁ Σ_{j=1}^{k-1} j e^{j-1}`` (0 for the first impact, ``2t₁``
  for the second, ``2t₁(1 + 2e)`` for the third), ``∂t_k/∂g = −t_k/(2g)`` and
  ``∂t_k/∂h = t_k/(2h)`` (every time scales as ``sqrt(h/g)``);
* in the flight after bounce k, with ``s = t − t_k``:
  ``y = e^k v₁ s − g s²/2`` and ``v = e^k v₁ − g s``.  At fixed t, ``∂s/∂· = −∂t_k/∂·``
  and ``∂y/∂s = v``, ``∂v₁/∂g = v₁/(2g)``, ``∂v₁/∂h = v₁/(2h)``, so

  ``∂y/∂e = k e^{k−1} v₁ s − v ∂t_k/∂e``
  ``∂y/∂g = e^k v₁ s/(2g) + v t_k/(2g) − s²/2``
  ``∂y/∂h = e^k v₁ s/(2h) − v t_k/(2h)``
  ``∂v/∂e = k e^{k−1} v₁ + g ∂t_k/∂e``
  ``∂v/∂g = e^k v₁/(2g) − s − t_k/2``

  (before the first impact, k = 0: ``y = h − g t²/2``, ``∂y/∂e = 0``,
  ``∂y/∂g = −t²/2``, ``∂y/∂h = 1``).

Diode circuit (models/diode_circuit.py): the switch opens at ``t_o`` (a time guard),
the diode takes the current (a mythical mode), and the current decays as
``L di/dt = −V_th − R i`` until it reaches 0 at ``t_off``, where the diode turns off
(the inductor then becomes dependent: ``p_L = 0``).  With ``i₀ = (V/R)(1 − e^{−R t_o/L})``,
``i = (i₀ + V_th/R) e^{−R(t−t_o)/L} − V_th/R``, so ``∂p_L/∂t_o = (V + V_th) e^{−R(t−t_o)/L}``
(the jump of the rate, ``f⁻ − f⁺ = V + V_th``, carried by the flow), and from
``i(t_off) = 0``: ``∂t_off/∂t_o = (V + V_th)/(R i₀ + V_th)``; after ``t_off`` every
sensitivity of ``p_L`` is 0.

Falling rod: the tip of a rod released at rest reaches the floor at
``t = sqrt(2(y₀ − l sin θ₀)/g)``, so ``∂t/∂θ₀ = −l cos θ₀/(g t)``, ``∂t/∂y₀ = 1/(g t)``,
``∂t/∂l = −sin θ₀/(g t)``; the sliding that follows (mu = 0.002) is checked against
central differences of runs with the same modes and instants.
"""

from __future__ import annotations

import contextlib
import math
import pickle

import numpy as np
import pytest
import sympy as sp

from bondgraph import BondGraph, I, One, R, Se, Zero
from bondgraph.errors import UnknownNameError
from models import bouncing_ball, diode_circuit, falling_rod
from switching import Automaton, HybridModel, SimulationError, sample_indices
from switching.sweep.batch import shared_model

TIGHT = dict(rtol=1e-11, atol=1e-13)


# ------------------------------------------------------------------ bouncing ball


def ball_exact(t, e, g, h):
    """Closed form (module docstring): y, v and their derivatives at times ``t`` (before the 4th impact)."""
    t1 = math.sqrt(2 * h / g)
    v1 = g * t1
    impacts = [t1 * (1 + 2 * sum(e**j for j in range(1, k))) for k in range(1, 5)]
    dimpact_de = [2 * t1 * sum(j * e ** (j - 1) for j in range(1, k)) for k in range(1, 5)]
    out = {key: np.empty(len(t)) for key in ("y", "v", "y_e", "y_g", "y_h", "v_e", "v_g")}
    for i, ti in enumerate(t):
        k = sum(1 for tk in impacts if tk < ti)
        if k == 0:
            values = dict(y=h - g * ti**2 / 2, v=-g * ti, y_e=0.0, y_g=-ti**2 / 2, y_h=1.0, v_e=0.0, v_g=-ti)
        else:
            tk, dtk = impacts[k - 1], dimpact_de[k - 1]
            s = ti - tk
            v = e**k * v1 - g * s
            values = dict(
                y=e**k * v1 * s - g * s**2 / 2,
                v=v,
                y_e=k * e ** (k - 1) * v1 * s - v * dtk,
                y_g=e**k * v1 * s / (2 * g) + v * tk / (2 * g) - s**2 / 2,
                y_h=e**k * v1 * s / (2 * h) - v * tk / (2 * h),
                v_e=k * e ** (k - 1) * v1 + g * dtk,
                v_g=e**k * v1 / (2 * g) - s - tk / 2,
            )
        for key, value in values.items():
            out[key][i] = value
    return out, impacts, dimpact_de


@pytest.fixture(scope="module")
def ball_run():
    e, g, h = 0.8, 9.81, 1.0
    # samples before the first impact (0.4515 s), after one bounce and after two (until 1.7519 s)
    times = np.array([0.2, 0.4, 0.5, 0.8, 1.1, 1.2, 1.5, 1.7])
    model = bouncing_ball.build(e=e, g=g, y0=h)
    run = model.simulate(1.7, "RK45", t_eval=times, sensitivities=["e", "g", "x0:y", "m"], **TIGHT)
    return run, times, (e, g, h)


@pytest.mark.parametrize("signal, parameter, key", [
    ("y", "e", "y_e"), ("y", "g", "y_g"), ("y", "x0:y", "y_h"), ("v", "e", "v_e"), ("v", "g", "v_g"),
])
def test_ball_sensitivities_after_one_and_two_bounces(ball_run, signal, parameter, key):
    run, times, (e, g, h) = ball_run
    exact, _, _ = ball_exact(times, e, g, h)
    at = sample_indices(run, times)
    assert len(run.events) == 2  # one and two bounces among the samples
    np.testing.assert_allclose(run.signal(signal)[at], exact[signal], rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(run.sensitivity(signal, parameter)[at], exact[key], rtol=1e-7, atol=1e-8)


def test_ball_event_time_sensitivities(ball_run):
    run, _, (e, g, h) = ball_run
    _, impacts, dimpact_de = ball_exact([], e, g, h)
    for k in range(len(run.events)):
        assert run.event_times[k] == pytest.approx(impacts[k], rel=1e-10)
        assert run.event_time_sensitivity(k, "e") == pytest.approx(dimpact_de[k], rel=1e-8, abs=1e-12)
        assert run.event_time_sensitivity(k, "g") == pytest.approx(-impacts[k] / (2 * g), rel=1e-8)
        assert run.event_time_sensitivity(k, "x0:y") == pytest.approx(impacts[k] / (2 * h), rel=1e-8)


def test_signal_sensitivity_by_the_chain_rule(ball_run):
    """``v = p/m`` with ``ṗ = −m g``: ``p`` scales with ``m`` and ``v`` does not, so
    ``∂p/∂m = p/m`` and the signal's ``∂v/∂m = (∂p/∂m)/m − p/m² = 0``."""
    run, _, _ = ball_run
    p = run.state("p")
    np.testing.assert_allclose(run.sensitivity("p", "m"), p / 1.0, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(run.sensitivity("v", "m"), 0.0, atol=1e-7)


def test_sensitivities_at_an_instant_are_taken_at_fixed_time():
    """An impact's two samples hold ∂x/∂p just before and just after it (rows
    of every output but ``t_eval``, whose rows are the requested times only).
    The first impact's time does not depend on e, and ``v⁺ = −e·v⁻``: so
    ``∂v⁻/∂e = 0`` and ``∂v⁺/∂e = −v⁻``."""
    run = bouncing_ball.build(e=0.8, g=9.81, y0=1.0).simulate(1.7, "RK45", output="events", sensitivities=["e"],
                                                               **TIGHT)
    after = run.event_index[0]
    assert run.t[after - 1] == run.t[after] == run.events[0].t
    v_minus = run.signal("v")[after - 1]
    assert run.sensitivity("v", "e")[after - 1] == pytest.approx(0.0, abs=1e-9)
    assert run.sensitivity("v", "e")[after] == pytest.approx(-v_minus, rel=1e-9)


def test_signal_with_a_branch_in_its_gradient():
    """``speed = |v|`` differentiates to ``sign(v)·∂v/∂e`` (evaluated sample by sample)."""
    ball = bouncing_ball.build()
    model = HybridModel(ball.graph, ball.automata, {s.name: v for s, v in ball.parameter_values.items()},
                        initial_state={"y": 1.0}, signals={"v": "p/m", "speed": "abs(p/m)"})
    run = model.simulate(1.0, "RK45", sensitivities=["e"], **TIGHT)
    np.testing.assert_allclose(run.sensitivity("speed", "e"), np.sign(run.signal("v")) * run.sensitivity("v", "e"))
    assert np.max(np.abs(run.sensitivity("speed", "e"))) > 1.0


def test_sensitivities_survive_pickling_without_the_model(ball_run):
    run, _, _ = ball_run
    copy = pickle.loads(pickle.dumps(run))
    np.testing.assert_array_equal(copy.sensitivity("y", "e"), run.sensitivity("y", "e"))
    assert copy.event_time_sensitivity(1, "e") == run.event_time_sensitivity(1, "e")


# ------------------------------------------------------------------ diode circuit: a time guard, a mythical mode


def test_diode_time_guard_mythical_mode_and_dependent_state():
    V, R_, L, V_th, t_o = 10.0, 1.0, 0.1, 0.7, 0.5
    times = np.array([0.3, 0.55, 0.6, 0.7, 0.9])
    run = diode_circuit.build().simulate(1.0, "RK45", t_eval=times, sensitivities=["t_open"], **TIGHT)
    assert [len(e.mythical) for e in run.events] == [1, 0]
    i0 = V / R_ * (1 - math.exp(-R_ * t_o / L))
    t_off = t_o + L / R_ * math.log((i0 + V_th / R_) / (V_th / R_))
    assert run.event_times[1] == pytest.approx(t_off, rel=1e-9)
    assert run.event_time_sensitivity(0, "t_open") == pytest.approx(1.0, rel=1e-9)
    assert run.event_time_sensitivity(1, "t_open") == pytest.approx((V + V_th) / (R_ * i0 + V_th), rel=1e-7)
    exact = np.where(times < t_o, 0.0, np.where(times < t_off, (V + V_th) * np.exp(-R_ * (times - t_o) / L), 0.0))
    at = sample_indices(run, times)
    np.testing.assert_allclose(run.sensitivity("p_L", "t_open")[at], exact, rtol=1e-7, atol=1e-10)
    # the jump of the rate at the opening, carried over the instant: S⁺ − S⁻ = f⁻ − f⁺ = V + V_th (read on
    # the instant's two rows: a run with samples=N holds them, besides its N times)
    run = diode_circuit.build().simulate(1.0, "RK45", samples=11, sensitivities=["t_open"], **TIGHT)
    after = run.event_index[0]
    assert run.t[after - 1] == run.t[after] == run.events[0].t
    jump = run.sensitivity("p_L", "t_open")[after] - run.sensitivity("p_L", "t_open")[after - 1]
    assert jump == pytest.approx(V + V_th, rel=1e-9)


# ------------------------------------------------------------------ falling rod


ROD_TIMES = np.array([0.1, 0.2, 0.25, 0.3, 0.35, 0.4])
ROD_SIGNALS = ("x_cm", "theta", "tip_vx", "normal_force")


def rod_samples(sensitivities=None, **parameters):
    """Signals of a rod run at ROD_TIMES (runs share one model's derived modes)."""
    with shared_model(falling_rod.build, {"mu": 0.002, **parameters}) as model:
        options = dict(t_eval=ROD_TIMES, rtol=1e-12, atol=1e-14)
        if sensitivities:
            options["sensitivities"] = sensitivities
        run = model.simulate(0.4, "RK45", **options)
        at = sample_indices(run, ROD_TIMES)
        values = {name: run.signal(name)[at] for name in ROD_SIGNALS}
        if sensitivities:
            values["d"] = {(name, p): run.sensitivity(name, p)[at] for name in ROD_SIGNALS for p in sensitivities}
            values["dt"] = {p: run.event_time_sensitivity(0, p) for p in sensitivities}
        values["modes"] = [e.modes for e in run.events]
        values["events"] = run.event_times
        return values


@pytest.fixture(scope="module")
def rod_run():
    return rod_samples(["mu", "x0:rod/theta", "x0:rod/y", "l"])


def test_rod_impact_time_sensitivity_closed_form(rod_run):
    l, g, theta0 = 0.1, 9.81, 0.862
    t = rod_run["events"][0]
    assert t == pytest.approx(falling_rod.impact_time(0.23, theta0, l, g), rel=1e-10)
    assert rod_run["dt"]["x0:rod/theta"] == pytest.approx(-l * math.cos(theta0) / (g * t), rel=1e-8)
    assert rod_run["dt"]["x0:rod/y"] == pytest.approx(1 / (g * t), rel=1e-8)
    assert rod_run["dt"]["l"] == pytest.approx(-math.sin(theta0) / (g * t), rel=1e-8)
    assert rod_run["dt"]["mu"] == 0.0  # friction plays no part before the impact


@pytest.mark.parametrize("parameter, build_argument, value", [("mu", "mu", 0.002), ("x0:rod/theta", "theta0", 0.862)])
def test_rod_sensitivity_against_central_differences(rod_run, parameter, build_argument, value):
    h = 1e-4 * value
    up, down = rod_samples(**{build_argument: value + h}), rod_samples(**{build_argument: value - h})
    assert up["modes"] == down["modes"] == rod_run["modes"]  # the same mode sequence: differences are smooth
    for name in ROD_SIGNALS:
        central = (up[name] - down[name]) / (2 * h)
        scale = np.max(np.abs(central)) + 1e-12
        np.testing.assert_allclose(rod_run["d"][(name, parameter)], central, rtol=0, atol=1e-6 * scale,
                                   err_msg=f"∂{name}/∂{parameter}")
    assert np.max(np.abs(rod_run["d"][("x_cm", "mu")])) > 0.1  # friction moves the rod after the impact


# ------------------------------------------------------------------ an initial state projected onto a constraint


def clutch_model():
    """Two masses m1, m2 locked together by a clutch (a controlled 0-junction:
    in the locked mode p2 is dependent, ``p2 = m2 p1/m1``), pushed by a force F
    on the first, released at ``t_release``."""
    g = BondGraph("clutch")
    v1, v2 = g.add(One("v1")), g.add(One("v2"))
    g.connect(Se("F", "F"), v1)
    g.connect(v1, I("m1", "m1", state="p1"))
    g.connect(v2, I("m2", "m2", state="p2"))
    clutch = g.add(Zero("clutch", controlled=True))
    g.connect(v1, clutch)
    g.connect(clutch, v2)
    automaton = Automaton("clutch", {"locked": {"clutch": True}, "free": {"clutch": False}}, "locked")
    automaton.add_transition("locked", "free", "t >= t_release")
    return HybridModel(g, [automaton], {"F": 1.0, "m1": 1.0, "m2": 2.0, "t_release": 0.5},
                       initial_state={"p1": 1.0})


@pytest.mark.parametrize("given", ["model", "simulate"])
def test_an_initial_state_projected_onto_the_initial_modes_constraint(given):
    """Given ``p1 = P``, ``p2 = 0`` in the locked mode, the state starts at the
    common velocity ``P/M`` (``M = m1 + m2``): ``∂p1/∂P = m1/M``, ``∂p2/∂P = m2/M``
    for ever (after the release p2 keeps its value).  Locked, ``p1 = m1 (P + F t)/M``,
    so ``∂p1/∂m2 = −m1 (P + F t)/M²``; after the release the first mass alone
    accelerates: ``∂p1/∂t_release = m1 F/M − F = −F m2/M`` and ``∂p2/∂t_release = F m2/M``
    (the saltation ``(f⁻ − f⁺)τ`` of an identity jump).  The initial state is the
    model's (projected by ``model.initial_state()``) or given to ``simulate(x0=...)``
    (projected by the resolution at t = 0)."""
    F, m1, m2, t_r, P = 1.0, 1.0, 2.0, 0.5, 1.0
    M = m1 + m2
    times = np.array([0.2, 0.4, 0.7, 1.0])
    options = dict(t_eval=times, sensitivities=["x0:p1", "m2", "t_release"], **TIGHT)
    if given == "simulate":
        options["x0"] = [P, 0.0]
    with pytest.warns(UserWarning, match="projected") if given == "model" else contextlib.nullcontext():
        run = clutch_model().simulate(1.0, "RK45", **options)
    at = sample_indices(run, times)
    d = {(s, p): run.sensitivity(s, p)[at] for s in ("p1", "p2") for p in ("x0:p1", "m2", "t_release")}
    np.testing.assert_allclose(d["p1", "x0:p1"], m1 / M, rtol=1e-9)
    np.testing.assert_allclose(d["p2", "x0:p1"], m2 / M, rtol=1e-9)
    held = np.minimum(times, t_r)
    np.testing.assert_allclose(d["p1", "m2"], -m1 * (P + F * held) / M**2, rtol=1e-8)
    np.testing.assert_allclose(d["p2", "m2"], m1 * (P + F * held) / M**2, rtol=1e-8)
    np.testing.assert_allclose(d["p1", "t_release"], np.where(times > t_r, -F * m2 / M, 0.0), atol=1e-9)
    np.testing.assert_allclose(d["p2", "t_release"], np.where(times > t_r, F * m2 / M, 0.0), atol=1e-9)
    assert run.event_time_sensitivity(0, "t_release") == pytest.approx(1.0, rel=1e-9)


# ------------------------------------------------------------------ a friction law that sticks (Filippov sliding)


def test_coulomb_stop_on_a_sign_law():
    """A block (mass m, momentum p0) slowed by a damper c and Coulomb friction
    ``μN·sign(v)`` stops at ``t* = (m/c) ln(1 + c p0/(μ N m))`` and stays
    there (sliding on the law's surface): ``∂t*/∂μ`` and, after the stop,
    ``∂x/∂μ = ∂x*/∂μ`` and ``∂x/∂p0`` from the closed form of ``x*``."""
    mu, N, c, m, p0 = sp.symbols("mu N c m p0", positive=True)
    g = BondGraph("block")
    v = g.add(One("v"))
    g.connect(v, I("m", "m"))
    g.connect(v, R("fr", effort_law=lambda f: mu * N * sp.sign(f)))
    g.connect(v, R("damper", "c"))
    g.displacement("x", "m")
    values = {mu: 0.5, N: 9.81, c: 0.7, m: 1.0, p0: 2.0}
    model = HybridModel(g, [], {str(k): v for k, v in values.items() if k != p0}, initial_state={"p_m": 2.0})
    run = model.simulate(1.0, "RK45", t_eval=[0.9, 1.0], sensitivities=["mu", "x0:p_m"], **TIGHT)
    t_stop = m / c * sp.log(1 + c * p0 / (mu * N * m))
    x_stop = m / c * (p0 / m + mu * N / c) * (1 - sp.exp(-c * t_stop / m)) - mu * N * t_stop / c
    assert run.event_times[0] == pytest.approx(float(t_stop.subs(values)), rel=1e-10)
    assert run.event_time_sensitivity(0, "mu") == pytest.approx(float(sp.diff(t_stop, mu).subs(values)), rel=1e-8)
    after = sample_indices(run, [0.9, 1.0])
    np.testing.assert_allclose(run.sensitivity("x", "mu")[after], float(sp.diff(x_stop, mu).subs(values)), rtol=1e-8)
    np.testing.assert_allclose(run.sensitivity("x", "x0:p_m")[after], float(sp.diff(x_stop, p0).subs(values)),
                               rtol=1e-8)
    np.testing.assert_allclose(run.sensitivity("p_m", "mu")[after], 0.0, atol=1e-12)


# ------------------------------------------------------------------ what is not supported, and bad names


def test_compiled_methods_say_they_are_not_supported_yet():
    with pytest.raises(SimulationError, match="not supported on the compiled method 'RK45-jit'"):
        bouncing_ball.build().simulate(1.0, "RK45-jit", sensitivities=["e"])


def test_numerical_jump_maps_say_they_are_not_supported_yet():
    """Charge sharing onto a nonlinear capacitor (its jump map is solved numerically)."""
    from test_jump import nonlinear_capacitor_pair

    switch = Automaton("switch", {"open": {"sw": False}, "closed": {"sw": True}}, "open")
    switch.add_transition("open", "closed", "t >= 0.1")
    model = HybridModel(nonlinear_capacitor_pair(), [switch], {"k": 0.5, "C2": 2.0},
                        initial_state={"q_C1": 1.2, "q_C2": -0.3})
    with pytest.raises(SimulationError, match="numerical jump maps are not supported yet") as caught:
        model.simulate(0.2, "RK45", sensitivities=["k"])
    assert caught.value.trajectory is not None  # the run itself is kept


def test_unknown_names_are_listed():
    model = bouncing_ball.build()
    with pytest.raises(UnknownNameError, match="no parameter 'y'.*x0:y"):
        model.simulate(0.1, "RK45", sensitivities=["y"])
    with pytest.raises(UnknownNameError, match="no state 'z'"):
        model.simulate(0.1, "RK45", sensitivities=["x0:z"])
    run = model.simulate(0.1, "RK45", sensitivities=["e"])
    with pytest.raises(UnknownNameError, match="with respect to 'g'"):
        run.sensitivity("y", "g")
    with pytest.raises(UnknownNameError, match="no signal 'w'"):
        run.sensitivity("w", "e")


def test_a_run_without_sensitivities_says_how_to_ask():
    run = bouncing_ball.build().simulate(0.1, "RK45")
    with pytest.raises(Exception, match=r"simulate with sensitivities=\[\.\.\.\]"):
        run.sensitivity("y", "e")


def test_sensitivities_need_the_instants():
    with pytest.raises(SimulationError, match="keep_instants=False"):
        bouncing_ball.build().simulate(1.0, "RK45", sensitivities=["e"], keep_instants=False)


def test_fixed_step_methods_and_given_initial_state():
    """euler/rk4 runs get sensitivities too (of the exact flow between their
    located instants); ``x0=`` given to simulate is differentiated as is."""
    model = bouncing_ball.build()
    run = model.simulate(0.8, "rk4", dt=1e-3, x0=[0.0, 1.0], sensitivities=["x0:y", "e"])
    t1 = math.sqrt(2 / 9.81)
    assert run.event_time_sensitivity(0, "x0:y") == pytest.approx(t1 / 2, rel=1e-6)
    assert run.sensitivity("y", "x0:y")[0] == 1.0


def test_sensitivities_through_the_initial_projection_of_a_mode_with_restitution():
    """Two balls that start stuck together (mode ``collide``, restitution ``e``):
    the given momenta are projected onto the common velocity
    ``v = (p1 + p2)/(m1 + m2)`` (the plastic projection: the restitution
    belongs to impacts, not to the start), so ``∂v/∂m1 = −(p1 + p2)/(m1 + m2)²``."""
    from switching import Automaton, HybridModel

    g = BondGraph("stuck_balls")
    for i in (1, 2):
        g.connect(g.add(One(f"v{i}")), I(f"ball{i}", f"m{i}", state=f"p{i}"))
    joint = g.add(Zero("contact", controlled=True))
    g.connect("v1", joint, name="push1")
    g.connect(joint, "v2", name="push2")
    contact = Automaton("contact", {"free": {"contact": False}, "collide": {"contact": True}}, initial="collide",
                        restitution={"collide": "e"})
    contact.add_transition("collide", "free", "p1/m1 > 100", "a priori")
    m1, m2, p1, p2 = 2.0, 3.0, 4.0, -1.0
    with pytest.warns(UserWarning):  # the given state is projected
        model = HybridModel(g, [contact], {"m1": m1, "m2": m2, "e": 0.5}, initial_state={"p1": p1, "p2": p2},
                            signals={"v1": "p1/m1", "v2": "p2/m2"})
        run = model.simulate(0.5, "RK45", sensitivities=["m1"], **TIGHT)
    v = (p1 + p2) / (m1 + m2)
    np.testing.assert_allclose(run.signal("v1"), v, rtol=1e-12)
    np.testing.assert_allclose(run.sensitivity("v1", "m1"), -(p1 + p2) / (m1 + m2) ** 2, rtol=1e-9)
    np.testing.assert_allclose(run.sensitivity("v2", "m1"), -(p1 + p2) / (m1 + m2) ** 2, rtol=1e-9)
