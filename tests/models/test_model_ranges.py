"""Every shipped model across its documented range (issue 12, item 4).

For each model in :data:`models.MODELS`, a grid over its main parameters,
spanning orders of magnitude where that is physical.  Each run either reaches
``t_end`` (with the events the physics predicts) or stops with a *genuine,
documented* error: an error the physics has (the diode's holding current above
the current, Zeno bounces without a resting rule, infinitely many plastic
pinnacles at one instant) or that the chosen method has (an explicit method on
a stiff mode), of the exact class the module docstring's "Valid range"
paragraph names.  A loop that exists only in round-off is never acceptable.

The default set stays fast (each rod build derives modes symbolically, a few
seconds); the larger grids are marked ``slow`` (``pytest -m slow`` or
``HBG_SLOW=1``).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from models import (
    MODELS,
    ball_chain,
    boost_converter,
    bouncing_ball,
    colliding_balls,
    current_mode_converter,
    diode_circuit,
    falling_rod,
    load,
    parallel_capacitors,
    rimless_wheel,
    two_tanks,
    vibrating_table,
)
from bondgraph.errors import ParameterValueError
from switching import DivergenceOfTimeError, StepSizeError, StiffnessError, ZenoError
from test_model_rimless_wheel import fixed_point, passes_vertical, stance_time, steady_level  # closed forms


def grid(*axes) -> list:
    """Every combination of the axes' values (parameters of a grid test)."""
    return list(itertools.product(*axes))


def run(model, t_end, method="RK45", **options):
    """Simulate; an unexpected error fails the test with its first lines."""
    try:
        return model.simulate(t_end, method, **options)
    except Exception as exc:  # noqa: BLE001 - shown in full in the failure
        head = "\n".join(str(exc).splitlines()[:6])
        pytest.fail(f"{model.name} did not reach t = {t_end:g}: {type(exc).__name__}: {head}", pytrace=False)


def reaches_end(trajectory, t_end):
    assert trajectory.stopped is None
    assert trajectory.t[-1] == pytest.approx(t_end, rel=1e-12)
    assert np.all(np.isfinite(trajectory.x))


def documented(module, error_class):
    """The module docstring's "Valid range" paragraph names the error class."""
    doc = module.__doc__
    assert "Valid range" in doc, f"{module.__name__} has no 'Valid range' paragraph"
    assert error_class.__name__ in doc[doc.index("Valid range"):], (
        f"{module.__name__}'s 'Valid range' paragraph does not name {error_class.__name__}")


@pytest.mark.parametrize("name", MODELS)
def test_every_model_documents_its_valid_range(name):
    doc = load(name).__doc__
    assert "Valid range" in doc
    paragraph = doc[doc.index("Valid range"):]
    assert "test_model_ranges" in paragraph  # where the range is exercised


# ================================================================== bouncing ball

G = 9.81


def _ball_times(y0, e, g=G):
    t1 = math.sqrt(2 * y0 / g)
    return t1, t1 * (1 + e) / (1 - e) if e < 1 else math.inf


def _check_ball_with_rest(e, y0, m, g):
    t1, t_inf = _ball_times(y0, e, g)
    v1 = math.sqrt(2 * g * y0)
    v_rest = 0.05 * v1
    model = bouncing_ball.build(e=e, y0=y0, m=m, g=g, v_rest=v_rest)
    t_end = 1.2 * t_inf
    trajectory = run(model, t_end, "RK45", rtol=1e-9, atol=1e-12 * m * v1)
    reaches_end(trajectory, t_end)
    assert trajectory.modes[-1].label == "rest"
    # the impacts faster than v_rest bounce (the first at t1, each e times slower; a plastic one
    # leaves the ball on the floor at v = 0), the next landing is the rest event
    bounces = 1 if e == 0 else math.ceil(math.log(v_rest / v1) / math.log(e))
    assert len(trajectory.events) == bounces + 1
    assert trajectory.events[0].t == pytest.approx(t1, rel=1e-8)
    times = [t1 + 2 * t1 * sum(e**j for j in range(1, k + 1)) for k in range(bounces + 1)]
    np.testing.assert_allclose(trajectory.event_times, times, rtol=1e-7)
    assert trajectory.state("y").min() >= -1e-9 * y0


@pytest.mark.parametrize("e", [0.0, 0.5, 0.9])
@pytest.mark.parametrize("y0, m", [(1e-3, 1e-3), (1.0, 1.0), (1e3, 1e3)])
def test_bouncing_ball_comes_to_rest(e, y0, m):
    _check_ball_with_rest(e, y0, m, G)


@pytest.mark.slow
@pytest.mark.parametrize("e, y0, m, g", grid([0.0, 0.3, 0.8, 0.95], [1e-4, 1.0, 1e4],
                                                           [1e-6, 1.0, 1e6], [1.62, 9.81, 274.0]))
def test_bouncing_ball_comes_to_rest_full_grid(e, y0, m, g):
    _check_ball_with_rest(e, y0, m, g)


@pytest.mark.parametrize("e", [0.0, 0.5, 0.8])
@pytest.mark.parametrize("y0", [1e-3, 1e3])
def test_bouncing_ball_without_resting_rule_is_zeno(e, y0):
    """Documented: with ``v_rest = 0`` the bounces accumulate at ``t∞ = t₁ (1 + e)/(1 − e)``."""
    documented(bouncing_ball, ZenoError)
    t1, t_inf = _ball_times(y0, e)
    model = bouncing_ball.build(e=e, y0=y0, v_rest=0.0)
    with pytest.raises(ZenoError) as info:
        model.simulate(2 * t_inf, "RK45", rtol=1e-9, atol=1e-12 * math.sqrt(y0))
    assert info.value.accumulation_time == pytest.approx(t_inf, rel=1e-6)


@pytest.mark.parametrize("y0", [1e-3, 1.0, 1e3])
def test_elastic_ball_bounces_for_ever(y0):
    t1, _ = _ball_times(y0, 1.0)
    t_end = 7.5 * t1  # impacts at t1, 3 t1, 5 t1, 7 t1
    model = bouncing_ball.build(e=1.0, y0=y0)
    trajectory = run(model, t_end, "RK45", rtol=1e-10, atol=1e-13 * math.sqrt(y0))
    reaches_end(trajectory, t_end)
    np.testing.assert_allclose(trajectory.event_times, [t1, 3 * t1, 5 * t1, 7 * t1], rtol=1e-8)
    assert trajectory.state("y").max() == pytest.approx(y0, rel=1e-8)


# ================================================================== colliding balls


@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
@pytest.mark.parametrize("m2", [1e-3, 2.0, 1e3])
@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_colliding_balls_collide_once(e, m2, scale):
    m1, v1, v2 = 1.0, 1.0 * scale, -0.5 * scale
    model = colliding_balls.build(m1=m1, m2=m2, e=e, r1=0.1 * scale, r2=0.1 * scale, x1_0=0.0, x2_0=scale,
                                  v1_0=v1, v2_0=v2, v_th=1e-6 * scale)
    trajectory = run(model, 1.5, "RK45", rtol=1e-10, atol=1e-13 * scale * min(m1, m2))
    reaches_end(trajectory, 1.5)
    (instant,) = trajectory.events
    assert instant.t == pytest.approx(0.8 / 1.5, rel=1e-9)
    assert instant.kinds == ["start", "pinnacle", "continuous"]
    u1, u2 = trajectory.signal("v1")[-1], trajectory.signal("v2")[-1]
    assert m1 * u1 + m2 * u2 == pytest.approx(m1 * v1 + m2 * v2, rel=1e-12, abs=1e-12 * scale * max(m1, m2))
    assert u2 - u1 == pytest.approx(-e * (v2 - v1), rel=1e-9, abs=1e-12 * scale)


@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_colliding_balls_without_approach_threshold(e):
    """``v_th = 0``: the plain ``v1 > v2``; a plastic impact leaves them moving together, no loop."""
    model = colliding_balls.build(e=e, v_th=0.0)
    trajectory = run(model, 1.5, "RK45", rtol=1e-10, atol=1e-13)
    reaches_end(trajectory, 1.5)
    assert len(trajectory.events) == 1


# ================================================================== ball chain


def _check_ideal_chain(N, e, v0, v_th_ratio, m=1.0):
    r = 0.05
    model = ball_chain.build(N=N, e=e, v0=v0, v_th=v_th_ratio * v0, m=m, r=r, distance=0.1)
    t_end = 0.3 / v0 if v0 else 0.3
    trajectory = run(model, t_end, "RK45", rtol=1e-10, atol=1e-13 * m * v0)
    reaches_end(trajectory, t_end)
    (instant, *later) = trajectory.events
    assert instant.t == pytest.approx(0.1 / v0, rel=1e-9)
    p = np.array([trajectory.state(f"p{i}")[-1] for i in range(1, N + 1)])
    assert p.sum() == pytest.approx(m * v0, rel=1e-12)
    v = p / m
    if e == 1.0:
        expected = np.zeros(N)
        expected[-1] = v0
        np.testing.assert_allclose(v, expected, atol=1e-9 * v0)
    # no pair still approaches faster than the threshold after the instant
    assert np.all(v[:-1] - v[1:] <= v_th_ratio * v0 * (1 + 1e-9) + 1e-12 * v0)


@pytest.mark.parametrize("N", [2, 4, 8])
@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_ideal_ball_chain(N, e):
    _check_ideal_chain(N, e, 1.0, 1e-6)


@pytest.mark.slow
@pytest.mark.parametrize("N, e, v0, v_th_ratio, m", grid([2, 3, 5, 8], [0.0, 0.3, 0.9, 1.0],
                                                                       [1e-3, 1.0, 1e3], [1e-9, 1e-6, 1e-3],
                                                                       [1e-3, 1e3]))
def test_ideal_ball_chain_full_grid(N, e, v0, v_th_ratio, m):
    _check_ideal_chain(N, e, v0, v_th_ratio, m)


@pytest.mark.parametrize("N", [3, 4, 5])
def test_plastic_chain_without_threshold_ends_at_its_limit_or_diverges(N):
    """Documented: ``e = 0`` with ``v_th = 0`` needs infinitely many pinnacles at
    the impact; the run ends the instant at the limit (every ball at ``v0/N``)
    once the relative velocities are inside the bands, or reports the
    divergence of time when a pinnacle repeats its state first."""
    documented(ball_chain, DivergenceOfTimeError)
    model = ball_chain.build(N=N, e=0.0, v_th=0.0)
    try:
        trajectory = model.simulate(0.3, "RK45", rtol=1e-10, atol=1e-13)
    except DivergenceOfTimeError as exc:
        assert exc.trajectory is None or exc.trajectory.t[-1] == pytest.approx(0.1, rel=1e-9)
        return
    (instant,) = trajectory.events
    assert instant.t == pytest.approx(0.1, rel=1e-9)
    v0 = ball_chain.DEFAULTS["v0"]
    velocities = [instant.x_after[model.state_index[model.state(f"p{i}")]] / ball_chain.DEFAULTS["m"]
                  for i in range(1, N + 1)]
    np.testing.assert_allclose(velocities, v0 / N, rtol=1e-9)


def _check_compliant_chain(N, k, b, gap, method):
    m, v0 = 1.0, 1.0
    model = ball_chain.build(N=N, compliant=True, k=k, b=b, gap=gap, m=m, v0=v0)
    t_end = 0.1 + 0.2 + N * gap + 10 * math.sqrt(m / k)
    trajectory = run(model, t_end, method, rtol=1e-9, atol=1e-12)
    reaches_end(trajectory, t_end)
    assert trajectory.events  # the contacts engage (an overdamped one may never release: no count asserted)
    p = np.column_stack([trajectory.state(f"p{i}") for i in range(1, N + 1)])
    np.testing.assert_allclose(p.sum(axis=1), m * v0, rtol=1e-8)
    q = np.column_stack([trajectory.state(f"q{i}") for i in range(1, N)])
    energy = 0.5 * np.sum(p**2, axis=1) / m + 0.5 * k * np.sum(q**2, axis=1)
    if b == 0:  # an elastic spring: the energy is kept
        np.testing.assert_allclose(energy, energy[0], rtol=1e-6)
    else:  # a damper only dissipates
        assert energy[-1] <= energy[0] * (1 + 1e-9)


@pytest.mark.parametrize("k, b", [(1e2, 0.0), (1e4, 0.0), (1e4, 5.0), (1e6, 0.0)])
@pytest.mark.parametrize("gap", [0.0, 0.01])
def test_compliant_ball_chain(k, b, gap):
    _check_compliant_chain(3, k, b, gap, "RK45")


@pytest.mark.slow
@pytest.mark.parametrize("N, k, b, gap", grid([2, 4], [1e2, 1e4, 1e6, 1e8], [0.0, 1.0, 50.0],
                                                           [0.0, 0.01]))
def test_compliant_ball_chain_full_grid(N, k, b, gap):
    # a damper relaxes the free spring at the rate k/b: stiff for an explicit method when k/b is large
    _check_compliant_chain(N, k, b, gap, "Radau" if b > 0 and k / b > 1e5 else "RK45")


def test_stiff_damped_contact_needs_an_implicit_method():
    """Documented: with ``b > 0`` a free spring relaxes at the rate ``k/b``; RK45 stops with StiffnessError."""
    documented(ball_chain, StiffnessError)
    model = ball_chain.build(N=3, compliant=True, k=1e8, b=1.0)
    with pytest.raises(StiffnessError):
        model.simulate(0.4, "RK45", rtol=1e-9, atol=1e-12)
    reaches_end(run(ball_chain.build(N=3, compliant=True, k=1e8, b=1.0), 0.4, "Radau", rtol=1e-9, atol=1e-12), 0.4)


# ================================================================== diode circuit


def _diode_expectations(V, R, L, V_th, t_open, I_th):
    i_open = V / R * (1 - math.exp(-t_open * R / L))
    if I_th >= i_open:
        return i_open, t_open
    return i_open, t_open + L / R * math.log((i_open + V_th / R) / (I_th + V_th / R))


def _diode_method(L, R):
    return "Radau" if L / R < 1e-3 else "RK45"  # RK45 meets StiffnessError when L/R ≪ the run


def _check_diode(V, R, L):
    V_th, t_open, t_end = 0.07 * V, 0.5, 1.0
    model = diode_circuit.build(V=V, R=R, L=L, V_th=V_th, t_open=t_open, I_th=0.0)
    trajectory = run(model, t_end, _diode_method(L, R), rtol=1e-10, atol=1e-13 * V)
    reaches_end(trajectory, t_end)
    i_open, t_zero = _diode_expectations(V, R, L, V_th, t_open, 0.0)
    opening, *rest = trajectory.events
    assert opening.t == pytest.approx(t_open, rel=1e-12)
    assert [(s.mode.label, s.kind) for s in opening.steps] == [
        ("closed|off", "start"), ("open|off", "mythical"), ("open|on", "continuous")]
    if t_zero < t_end:  # the current decays through the diode to zero, then the diode turns off
        (off,) = rest
        assert off.t == pytest.approx(t_zero, rel=1e-7)
        assert off.mode_after.label == "open|off"
        assert abs(trajectory.signal("i_L")[-1]) <= 1e-9 * i_open
    else:
        assert rest == []


@pytest.mark.parametrize("V, R, L", [(10.0, 1.0, 0.1), (10.0, 1.0, 1e-6), (10.0, 1e2, 1.0), (1e-2, 1.0, 0.1),
                                     (1e4, 1e-2, 1e-3), (10.0, 1e-2, 10.0)])
def test_diode_circuit_freewheels_and_turns_off(V, R, L):
    _check_diode(V, R, L)


@pytest.mark.slow
@pytest.mark.parametrize("V, R, L", grid([1e-2, 10.0, 1e4], [1e-2, 1.0, 1e2], [1e-6, 1e-3, 0.1, 10.0]))
def test_diode_circuit_full_grid(V, R, L):
    _check_diode(V, R, L)


@pytest.mark.parametrize("fraction", [1e-6, 0.5, 2.0])
@pytest.mark.parametrize("R, L", [(1.0, 0.1), (1e2, 1.0)])
def test_diode_holding_current_above_zero_diverges_when_the_current_reaches_it(fraction, R, L):
    """Documented: any ``I_th > 0`` is reached by the decaying current (or exceeds
    it at the opening): the diode turns off, the inductor's flux would vanish,
    the diode turns on — the paper's divergence of time."""
    documented(diode_circuit, DivergenceOfTimeError)
    V, V_th, t_open = 10.0, 0.7, 0.5
    i_open, _ = _diode_expectations(V, R, L, V_th, t_open, 0.0)
    I_th = fraction * i_open
    _, t_stop = _diode_expectations(V, R, L, V_th, t_open, I_th)
    model = diode_circuit.build(V=V, R=R, L=L, V_th=V_th, t_open=t_open, I_th=I_th)
    with pytest.raises(DivergenceOfTimeError) as info:
        model.simulate(1.0, "RK45", rtol=1e-10, atol=1e-13)
    assert "diode" in str(info.value) and "i_D <= I_th" in str(info.value)
    assert info.value.trajectory.t[-1] == pytest.approx(t_stop, rel=1e-7)


# ================================================================== falling rod

#: documented points of the module docstring (the paper's Figs. 19-20) and the
#: other impact law; t_end covers the impact and the later friction transitions
ROD_POINTS = [
    dict(),  # mu = 0.005: sticks at the impact
    dict(mu=0.002),  # slides through a mythical stuck mode
    dict(mu=0.004),
    dict(mu=0.002, l=10.0, y0=23.0),  # slides for a point in time and lifts off
    dict(mu=0.002, impact_law="newton-coulomb"),
]


def _painleve_factor(model, trajectory) -> float:
    """``m·k_σ = 1 + m l² cos θ (cos θ + σ μ sin θ)/J`` at the last sample, sliding
    with ``σ = ±1``: the normal force of the sliding contact is ``(…)/k_σ``."""
    p = dict(zip((s.name for s in model.parameter_symbols), model.parameter_array))
    theta = trajectory.state("rod/theta")[-1]
    sigma = {"slide_pos": 1.0, "slide_neg": -1.0}[trajectory.modes[-1].state_of("friction")]
    return 1 + p["m"] * p["l"] ** 2 * math.cos(theta) * (math.cos(theta) + sigma * p["mu"] * math.sin(theta)) / p["J"]


def _check_rod(parameters, t_end):
    model = falling_rod.build(**parameters)
    try:
        trajectory = model.simulate(t_end, "RK45", rtol=1e-9, atol=1e-12)
    except StepSizeError as exc:
        # documented: sliding into Painlevé's singularity (k_σ → 0) the normal force grows without bound
        documented(falling_rod, StepSizeError)
        assert exc.trajectory.modes[-1].state_of("contact") == "contact"
        assert abs(_painleve_factor(model, exc.trajectory)) < 0.05, str(exc)
        return
    reaches_end(trajectory, t_end)
    l = parameters.get("l", falling_rod.DEFAULTS["l"])
    y0 = parameters.get("y0", falling_rod.DEFAULTS["y0"])
    theta0 = falling_rod.DEFAULTS["theta0"]
    assert trajectory.events[0].t == pytest.approx(falling_rod.impact_time(y0, theta0, l), rel=1e-9)
    # never through the floor (in contact the tip's velocity is held, its height drifts by the integration error)
    assert trajectory.signal("tip_y").min() >= -1e-8 * y0
    in_contact = np.array([m.state_of("contact") == "contact" for m in trajectory.modes])
    assert np.all(trajectory.signal("normal_force")[in_contact] >= -1e-9)  # the floor only pushes


@pytest.mark.parametrize("parameters", ROD_POINTS, ids=lambda p: ",".join(f"{k}={v}" for k, v in p.items()) or "defaults")
def test_falling_rod_documented_points(parameters):
    _check_rod(parameters, 2.0)


@pytest.mark.slow
@pytest.mark.parametrize("mu, l, law", grid([1e-4, 1e-3, 0.002, 0.004, 0.005, 0.01, 0.1, 1.0],
                                                         [0.1, 1.0, 10.0], ["paper", "newton-coulomb"]))
def test_falling_rod_full_grid(mu, l, law):
    # the same geometry at every size: y0 = 2.3 l, the run about as long in units of the fall time
    _check_rod(dict(mu=mu, l=l, y0=2.3 * l, impact_law=law), 1.5 * math.sqrt(l / 0.1) + 0.5)


# ================================================================== parallel capacitors


def _check_capacitors(C1, C2, R, V1=5.0, V2=1.0):
    t_close, t_end = 0.01, 0.05
    tau = R * C1 * C2 / (C1 + C2)
    method = "Radau" if 0 < tau < 1e-3 * (t_end - t_close) else "RK45"
    model = parallel_capacitors.build(C1=C1, C2=C2, R=R, V1=V1, V2=V2, t_close=t_close)
    scale = max(abs(V1), abs(V2))
    if 0 < tau < 1e-11 * t_close and V1 != V2:
        # documented: a transient at the round-off of the time variable cannot be stepped at all
        documented(parallel_capacitors, StepSizeError)
        with pytest.raises(StepSizeError):
            model.simulate(t_end, method, rtol=1e-10, atol=1e-13 * min(C1, C2) * scale)
        return
    trajectory = run(model, t_end, method, rtol=1e-10, atol=1e-13 * min(C1, C2) * scale)
    reaches_end(trajectory, t_end)
    (instant,) = trajectory.events
    assert instant.t == pytest.approx(t_close, rel=1e-12)
    q = trajectory.signal("q_total")
    np.testing.assert_allclose(q, C1 * V1 + C2 * V2, rtol=1e-9, atol=1e-12 * (C1 + C2) * scale)
    v = (C1 * V1 + C2 * V2) / (C1 + C2)
    decay = math.exp(-(t_end - t_close) / tau) if tau > 0 else 0.0
    assert trajectory.signal("v1")[-1] == pytest.approx(v + (V1 - v) * decay, rel=1e-6, abs=1e-7 * scale)
    assert trajectory.signal("v2")[-1] == pytest.approx(v + (V2 - v) * decay, rel=1e-6, abs=1e-7 * scale)


@pytest.mark.parametrize("C1, ratio", [(1e-9, 2.0), (1e-3, 1e-3), (1e-3, 2.0), (1.0, 1e3)])
@pytest.mark.parametrize("R", [0.0, 1e-3, 1.0, 1e3])
def test_parallel_capacitors_share_charge(C1, ratio, R):
    _check_capacitors(C1, C1 * ratio, R)


@pytest.mark.slow
@pytest.mark.parametrize("C1, ratio, R, volts", grid([1e-12, 1e-9, 1e-3, 1.0], [1e-3, 1.0, 1e3],
                                                                  [0.0, 1e-3, 1.0, 1e3, 1e6],
                                                                  [(5.0, 1.0), (1e-6, 0.0), (1e6, -1e6), (3.0, 3.0)]))
def test_parallel_capacitors_full_grid(C1, ratio, R, volts):
    _check_capacitors(C1, C1 * ratio, R, *volts)


def test_fast_rc_needs_an_implicit_method():
    """Documented: a time constant far below the run stops RK45 with StiffnessError."""
    documented(parallel_capacitors, StiffnessError)
    model = parallel_capacitors.build(R=1e-3)
    with pytest.raises(StiffnessError):
        model.simulate(0.05, "RK45", rtol=1e-9, atol=1e-12)


# ================================================================== boost converter


def _check_boost(D, R_load, L, C, f_sw, periods=20):
    t_end = periods / f_sw
    model = boost_converter.build(D=D, R_load=R_load, L=L, C=C, f_sw=f_sw)
    trajectory = run(model, t_end, "RK45", rtol=1e-8, atol=1e-10, max_step=0.1 * min(D, 1 - D) / f_sw)
    reaches_end(trajectory, t_end)
    pwm = [e.t for e in trajectory.events if e.mode_before.state_of("pwm") != e.mode_after.state_of("pwm")]
    assert abs(len(pwm) - 2 * periods) <= 1
    # every edge at k/f_sw (on) or (k + D)/f_sw (off)
    phase = np.mod(np.array(pwm) * f_sw, 1.0)
    distance = np.minimum.reduce([np.abs(phase), np.abs(phase - 1), np.abs(phase - D)])
    assert np.all(distance < 1e-7)
    # the ideal diode never lets the inductor current reverse
    i_L = trajectory.signal("i_L")
    assert i_L.min() >= -1e-9 * max(1.0, np.abs(i_L).max())


@pytest.mark.parametrize("D, R_load, L", [(0.1, 20.0, 1e-3), (0.5, 20.0, 1e-3), (0.9, 20.0, 1e-3),
                                          (0.5, 2000.0, 1e-5), (0.5, 2.0, 1e-5)])
def test_boost_converter(D, R_load, L):
    _check_boost(D, R_load, L, 100e-6, 10e3)


@pytest.mark.slow
@pytest.mark.parametrize("D, R_load, L, C, f_sw", grid([0.1, 0.5, 0.9], [2.0, 20.0, 2000.0],
                                                                    [1e-5, 1e-3], [1e-6, 1e-4, 1e-2], [1e3, 1e5]))
def test_boost_converter_full_grid(D, R_load, L, C, f_sw):
    _check_boost(D, R_load, L, C, f_sw)


# ================================================================== two tanks


def _check_tanks(Q_in, A1, R_v):
    p = dict(two_tanks.DEFAULTS, Q_in=Q_in, A1=A1, A2=A1 / 2, R_v=R_v)
    t_open = A1 * (p["h1_high"] - p["h1_0"]) / Q_in
    t_end = 4 * t_open
    model = two_tanks.build(**{k: p[k] for k in ("Q_in", "A1", "A2", "R_v")})
    trajectory = run(model, t_end, "RK45", rtol=1e-9, atol=1e-12 * A1)
    reaches_end(trajectory, t_end)
    assert trajectory.events and trajectory.events[0].t == pytest.approx(t_open, rel=1e-8)
    h1, h2 = trajectory.signal("h1"), trajectory.signal("h2")
    # the hysteresis: each valve moves on its own level thresholds, alternately
    for automaton, level, low, high in (("valve", h1, "h1_low", "h1_high"), ("drain", h2, "h2_low", "h2_high")):
        moves = [(k, e) for k, e in zip(trajectory.event_index, trajectory.events)
                 if e.mode_before.state_of(automaton) != e.mode_after.state_of(automaton)]
        states = [e.mode_after.state_of(automaton) for _, e in moves]
        assert all(a != b for a, b in zip(states, states[1:]))
        for k, e in moves:
            threshold = p[high] if e.mode_after.state_of(automaton) == "open" else p[low]
            assert level[k] == pytest.approx(threshold, rel=1e-7)
    assert h1.min() >= -1e-12 and h2.min() >= -1e-12


@pytest.mark.parametrize("Q_in, A1, R_v", [(1e-2, 1.0, 5e5), (1e-3, 0.1, 5e4), (1e-2, 0.1, 5e6), (1e-1, 10.0, 5e5)])
def test_two_tanks(Q_in, A1, R_v):
    _check_tanks(Q_in, A1, R_v)


@pytest.mark.slow
@pytest.mark.parametrize("Q_in, A1, R_v", grid([1e-3, 1e-2, 1e-1], [0.1, 1.0, 10.0], [5e4, 5e5, 5e6]))
def test_two_tanks_full_grid(Q_in, A1, R_v):
    _check_tanks(Q_in, A1, R_v)


# ================================================================== vibrating table


def _check_table(gamma, A, e, m, gap0, periods=12):
    """The ball on the table ``s = A sin(ω t)`` with ``A ω²/g = gamma``, from rest on the table
    (``gap0 = 0``) or dropped from ``gap0`` with the table's velocity, over ``periods`` periods."""
    omega = math.sqrt(gamma * G / A)
    T = 2 * math.pi / omega
    model = vibrating_table.build(A=A, omega=omega, e=e, m=m, gap0=gap0, v_stick=1e-3 * A * omega)
    t_end = periods * T
    trajectory = run(model, t_end, "RK45", rtol=1e-9, atol=1e-12 * A * min(1.0, m * omega))  # y [m] and p [kg·m/s]
    reaches_end(trajectory, t_end)
    # the ball never goes through the table
    assert trajectory.signal("gap").min() >= -1e-7 * A
    momentum = [s.name for s in model.states].index("p")
    for event in trajectory.events:
        before, after = event.mode_before.state_of("contact"), event.mode_after.state_of("contact")
        table_v = A * omega * math.cos(omega * event.t)
        v_minus, v_plus = (x[momentum] / m for x in (event.x_before, event.x_after))
        if any(step.mode.state_of("contact") == "impact" for step in event.steps):
            # Newton's restitution relative to the table
            assert v_plus - table_v == pytest.approx(-e * (v_minus - table_v), abs=1e-9 * A * omega)
        if after == "stick":
            assert v_plus == pytest.approx(table_v, abs=1e-9 * A * omega)
        if before == "stick" and after == "flight":
            # the table lets go where its acceleration passes -g
            assert A * omega**2 * math.sin(omega * event.t) == pytest.approx(G, rel=1e-7)
    if gap0 == 0:
        assert trajectory.events[0].t == 0 and trajectory.events[0].mode_after.state_of("contact") == "stick"
        if gamma <= 1:  # the table never accelerates down faster than g: the ball rides it
            assert len(trajectory.events) == 1
        else:
            assert trajectory.events[1].t == pytest.approx(math.asin(1 / gamma) / omega, rel=1e-8)
    return trajectory


@pytest.mark.parametrize("gamma, A, e, gap0", [(0.5, 1e-2, 0.5, 0.0), (1.5, 1e-2, 0.5, 0.0), (1.2, 1e-4, 0.9, 1e-3),
                                               (4.0, 1.0, 0.0, 0.0), (2.0, 1e2, 0.5, 50.0)])
def test_vibrating_table(gamma, A, e, gap0):
    _check_table(gamma, A, e, 1.0, gap0)


@pytest.mark.slow
@pytest.mark.parametrize("gamma, A, e, m, gap0", grid([0.5, 1.5, 4.0], [1e-4, 1.0, 1e2], [0.0, 0.5, 0.9], [1e-3, 1e3],
                                                      [0.0, 10.0]))
def test_vibrating_table_full_grid(gamma, A, e, m, gap0):
    _check_table(gamma, A, e, m, gap0 * A)


@pytest.mark.parametrize("A", [1e-2, 1.0])
def test_vibrating_table_without_sticking_rule_is_zeno(A):
    """Documented: with ``v_stick = 0`` and ``0 < e < 1`` a ball dropped on a table that always
    pushes (``A ω²/g = 0.5 < 1``) chatters, its impacts accumulating in finite time."""
    documented(vibrating_table, ZenoError)
    omega = math.sqrt(0.5 * G / A)
    T = 2 * math.pi / omega
    model = vibrating_table.build(A=A, omega=omega, e=0.5, gap0=2 * A, v_stick=0.0)
    with pytest.raises(ZenoError) as info:
        model.simulate(20 * T, "RK45", rtol=1e-9, atol=1e-12 * A * omega)
    t_inf = info.value.accumulation_time
    assert 0 < t_inf < 20 * T
    stopped = model.simulate(20 * T, "RK45", rtol=1e-9, atol=1e-12 * A * omega, on_zeno="stop")
    assert stopped.stopped == "zeno" and stopped.t[-1] == pytest.approx(t_inf, rel=1e-6)
    # with the sticking rule the same drop ends on the table, riding it
    sticking = vibrating_table.build(A=A, omega=omega, e=0.5, gap0=2 * A, v_stick=1e-3 * A * omega)
    ride = sticking.simulate(20 * T, "RK45", rtol=1e-9, atol=1e-12 * A * omega)
    assert ride.modes[-1].state_of("contact") == "stick" and ride.events[-1].t < t_inf
# ================================================================== current-mode converter


def _check_current_mode(Vin, L, i_ref, m_c, R_load=20.0, C=100e-6, f_sw=10e3, w=0.05, load="rc", v_C0=None,
                        periods=20) -> dict:
    """Every turn-on at a clock edge ``k/f_sw``, and never off over an edge; every turn-off where ``i_L`` meets
    ``i_ref − m_c (t mod T)`` after the clock's pulse, or at the pulse's end (the current already above the
    reference); ``i_L`` never reverses.  Returns the regimes met: ``dcm`` (intervals with the switch and the
    diode off), ``skipped`` (clock edges with the switch still on), ``blanked`` (turn-offs at the pulse's end),
    each counted over the second half of the run (after the start-up from ``i_L = 0``)."""
    T = 1 / f_sw
    t_end = periods * T
    model = current_mode_converter.build(Vin=Vin, L=L, i_ref=i_ref, m_c=m_c, R_load=R_load, C=C, f_sw=f_sw,
                                         w_clock=w, load=load, v_C0=v_C0 or Vin, Vout=2.5 * Vin)
    trajectory = run(model, t_end, "RK45", rtol=1e-9, atol=1e-12, max_step=0.5 * w * T)
    reaches_end(trajectory, t_end)
    k = model.state_names.index("p_L")
    moves = [e for e in trajectory.events if e.mode_before.state_of("switch") != e.mode_after.state_of("switch")]
    states = [e.mode_after.state_of("switch") for e in moves]
    assert all(a != b for a, b in zip(states, states[1:]))  # alternate: off, on, off, ...
    ons = np.array([e.t for e in moves if e.mode_after.state_of("switch") == "on"]) / T
    assert np.all(np.abs(ons - np.round(ons)) < 1e-9)  # none when the current never reaches the reference
    # the switch is never off over a clock edge: a turn-off is followed by the turn-on at the next edge
    for off, on in zip(moves, moves[1:]):
        if off.mode_after.state_of("switch") == "off":
            assert on.t / T == pytest.approx(math.floor(off.t / T + 1e-9) + 1, abs=1e-9)
    blanked, settled = 0, periods // 2 * T
    for e in moves:
        if e.mode_after.state_of("switch") == "off":
            phase = e.t / T - math.floor(e.t / T + 1e-9)
            i_L = e.x_before[k] / L
            at_pulse_end = phase == pytest.approx(w, abs=1e-9)
            assert phase >= w - 1e-9, e.t
            assert at_pulse_end or i_L == pytest.approx(i_ref - m_c * phase * T, rel=1e-6, abs=1e-6 * i_ref), e.t
            blanked += at_pulse_end and e.t >= settled
    i_L = trajectory.signal("i_L")
    assert i_L.min() >= -1e-9 * max(1.0, np.abs(i_L).max())
    edges = sum(1 for on in ons if periods // 2 <= round(on) < periods)
    return {"dcm": sum(1 for e in trajectory.events if e.mode_after.label == "off|off" and e.t >= settled),
            "skipped": periods - periods // 2 - edges, "blanked": blanked}


@pytest.mark.parametrize("Vin, L, i_ref, m_c, R_load, v_C0, regimes", [
    (12.0, 1e-3, 2.0, 0.0, 20.0, 20.5, set()),  # the defaults near their steady state: continuous conduction, D ≈ 0.41
    (12.0, 1e-3, 0.5, 0.0, 200.0, 24.0, {"dcm"}),  # a low reference: discontinuous conduction
    (12.0, 1e-4, 20.0, 6e4, 2.0, 20.0, set()),  # a heavy load and a large ripple, compensated
    (1.0, 1e-5, 1.0, 0.0, 2000.0, 5.0, {"dcm"}),  # a light load, a fast inductor
    (100.0, 1e-2, 5.0, 1e4, 20.0, 100.0, {"blanked"}),  # v_out ≈ Vin: the current hardly falls, above the reference
])
def test_current_mode_converter(Vin, L, i_ref, m_c, R_load, v_C0, regimes):
    met = _check_current_mode(Vin, L, i_ref, m_c, R_load, v_C0=v_C0)
    assert {name for name, count in met.items() if count} == regimes


@pytest.mark.parametrize("i_ref, m_c, regimes", [(2.0, 0.0, {"skipped"}), (2.0, 9e3, set()), (0.2, 0.0, {"dcm"})])
def test_current_mode_converter_with_the_output_held(i_ref, m_c, regimes):
    # Vout = 2.5 Vin: D = 0.6, unstable without compensation (irregular, with skipped turn-offs), stable with
    # m_c > (m2 − m1)/2 = 3000 A/s
    met = _check_current_mode(12.0, 1e-3, i_ref, m_c, load="source")
    assert {name for name, count in met.items() if count} == regimes


@pytest.mark.slow
@pytest.mark.parametrize("Vin, L, C, R_load, f_sw, i_ref, m_c, w", grid(
    [1.0, 100.0], [1e-5, 1e-2], [1e-6, 1e-3], [2.0, 2000.0], [1e3, 1e5], [0.1, 10.0], [0.0, 1e5], [0.01, 0.2]))
def test_current_mode_converter_full_grid(Vin, L, C, R_load, f_sw, i_ref, m_c, w):
    _check_current_mode(Vin, L, i_ref, m_c, R_load, C, f_sw, w)


# ================================================================== rimless wheel


def _check_wheel(alpha, gamma, l, g):
    """Started at the steady gait (``θ = −α``, ``ω⁺*``): every stance lasts the closed-form
    ``T(ω⁺*)`` and every impact returns ``ω⁺*``; a gait whose spoke would pull is refused
    (ParameterValueError); one too slow to pass the vertical rocks back to a Zeno accumulation."""
    omega_plus = fixed_point(alpha, gamma, l, g)[1]
    if l * steady_level(alpha, gamma, l, g) >= 3 * g * math.cos(alpha + gamma):
        documented(rimless_wheel, ParameterValueError)
        with pytest.raises(ParameterValueError, match="leave the ground"):
            rimless_wheel.build(alpha=alpha, gamma=gamma, l=l, g=g, omega0=omega_plus)
        return
    model = rimless_wheel.build(alpha=alpha, gamma=gamma, l=l, g=g, omega0=omega_plus)
    atol = 1e-12 * math.sqrt(g * l)  # momenta m l ω ~ sqrt(g l) (m = 1)
    if not passes_vertical(omega_plus, alpha, gamma, l, g):
        documented(rimless_wheel, ZenoError)
        with pytest.raises(ZenoError):
            model.simulate(100 * math.sqrt(l / g), "RK45", rtol=1e-10, atol=atol)
        return
    T = stance_time(omega_plus, alpha, gamma, l, g)
    t_end = 3.5 * T
    trajectory = run(model, t_end, "RK45", rtol=1e-10, atol=atol)
    reaches_end(trajectory, t_end)
    np.testing.assert_allclose(trajectory.event_times, [T, 2 * T, 3 * T], rtol=1e-8)
    instants = trajectory.at_instants()
    after = [rimless_wheel.stance(x, mode, l, 1.0)[1] for x, mode in zip(instants.x_after, instants.modes_after)]
    np.testing.assert_allclose(after, omega_plus, rtol=1e-8)
    assert trajectory.signal("normal_force").min() > 0


@pytest.mark.parametrize("alpha, gamma, l, g", [(math.pi / 8, 0.08, 1.0, 9.81), (math.pi / 12, 0.2, 1e-3, 9.81),
                                                (math.pi / 5, 0.2, 1e3, 1.62), (math.pi / 8, 0.01, 1.0, 274.0),
                                                (math.pi / 20, 0.2, 1.0, 9.81)])
def test_rimless_wheel(alpha, gamma, l, g):
    _check_wheel(alpha, gamma, l, g)


@pytest.mark.slow
@pytest.mark.parametrize("alpha, gamma, l, g", grid([math.pi / 20, math.pi / 12, math.pi / 8, math.pi / 5],
                                                    [0.01, 0.08, 0.2, 0.3], [1e-3, 1.0, 1e3], [1.62, 9.81, 274.0]))
def test_rimless_wheel_full_grid(alpha, gamma, l, g):
    _check_wheel(alpha, gamma, l, g)
