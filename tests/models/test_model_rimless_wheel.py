"""The rimless wheel (models.rimless_wheel) against its closed forms.

Notation: ``θ`` the planted spoke's angle from the slope normal (positive
downhill), ``ω = dθ/dt``, ``ω∓`` just before / after an impact, ``c = cos 2α``,
``K = (4g/l) sin α sin γ``.

* Impact (plastic, angular momentum about the new foot conserved):
  ``ω⁺ = c ω⁻`` — from the derived jump map symbolically, and at every
  impact of a run.
* Stance (energy ``½ m l² ω² + m g l cos(θ + γ)`` conserved from ``θ = −α``
  to ``θ = α``): ``ω⁻² = ω⁺² + (2g/l)(cos(γ − α) − cos(γ + α)) = ω⁺² + K``;
  the stance time ``T(ω⁺) = ∫_{−α}^{α} dθ / sqrt(ω⁺² + (2g/l)(cos(γ − α) −
  cos(θ + γ)))``.
* Stride map: with ``E = ω⁺²``, ``E_{k+1} = c² (E_k + K)``, affine with slope
  ``c²``; fixed point ``ω⁻*² = K/(1 − c²)``, ``ω⁺* = c ω⁻*``.
* Periodic orbit: the stance parity flips at each impact, so the state
  ``(p_x, p_y, ψ)`` returns after *two* strides; the shooting's monodromy
  (3 × 3) has the trivial multiplier 1 (along the flow: a shift of the
  start along the orbit), the nontrivial ``c⁴`` (the energy map over two
  strides, ``(c²)²``), and 0 (the radial momentum: a start off the stance
  constraint is projected onto it, so that direction is forgotten at once).
* Rocking: a wheel too slow to pass the vertical swings back onto the
  previous spoke; each half-swing starts and ends at the same speed on its
  spoke, each impact multiplies it by ``c``, and the half-swing times sum to
  the accumulation time of the impacts.

Tolerances: the jump is exact arithmetic at the located impact (ratio to
round-off); quantities from integrated flows carry the run's ``rtol`` (1e-10),
checked at 1e-8.
"""

import math

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import quad

from bondgraph import TF, BondGraph, I, One, Se, Sf, Zero
from bondgraph.errors import InvalidGraphError, ParameterValueError
from models import rimless_wheel
from switching import Automaton, HybridModel, ZenoError
from switching.analysis.continuation import continue_orbit
from switching.analysis.orbits import periodic_orbit

OPTIONS = {"rtol": 1e-10, "atol": 1e-12}
P = rimless_wheel.DEFAULTS
ALPHA, GAMMA, L, G, M = P["alpha"], P["gamma"], P["l"], P["g"], P["m"]


# ------------------------------------------------------------------ closed forms


def gain(alpha=ALPHA, gamma=GAMMA, l=L, g=G):
    """``K = (4g/l) sin α sin γ`` [1/s²]: what a stance adds to ``ω²``."""
    return 4 * g / l * math.sin(alpha) * math.sin(gamma)


def fixed_point(alpha=ALPHA, gamma=GAMMA, l=L, g=G):
    """``(ω⁻*, ω⁺*)`` [rad/s] of the steady gait: ``ω⁻*² = K/(1 − cos² 2α)``."""
    before = math.sqrt(gain(alpha, gamma, l, g) / (1 - math.cos(2 * alpha) ** 2))
    return before, math.cos(2 * alpha) * before


def stance_time(omega_plus, alpha=ALPHA, gamma=GAMMA, l=L, g=G):
    """``∫_{−α}^{α} dθ / ω(θ)`` [s] for a stance started at ``θ = −α`` with ``ω⁺ > 0`` that
    passes the vertical."""
    def rate(theta):
        return math.sqrt(omega_plus**2 + 2 * g / l * (math.cos(gamma - alpha) - math.cos(theta + gamma)))
    value, _ = quad(lambda theta: 1 / rate(theta), -alpha, alpha, epsabs=0, epsrel=1e-13, limit=200)
    return value


def passes_vertical(omega_plus, alpha=ALPHA, gamma=GAMMA, l=L, g=G):
    """Whether a stance started at ``θ = −α`` with ``ω⁺`` carries the hub over ``θ = −γ``."""
    return gamma >= alpha or omega_plus**2 > 2 * g / l * (1 - math.cos(gamma - alpha))


def swing_back_time(w, edge, alpha=ALPHA, gamma=GAMMA, l=L, g=G):
    """The time [s] of a half-swing that leaves the edge ``θ = edge`` (``±α``) inward at speed ``w``
    and falls back to it: ``2 ∫ dθ / ω(θ)`` from the edge to the turning point ``θ_t``, where
    ``ω(θ)² = w² − (2g/l)(cos(θ + γ) − cos(edge + γ)) = (4g/l) sin(θ_t + γ + d/2) sin(d/2)``,
    ``d = θ − θ_t`` (the product form keeps its digits near the turn); substituted
    ``θ = θ_t ± s²`` towards the edge, the integrand ``2s/ω`` is finite at the turning point."""
    turn = -gamma + math.copysign(math.acos(math.cos(edge + gamma) + l * w**2 / (2 * g)), edge)

    def integrand(s):
        d = math.copysign(s * s, edge)
        return 2 * s / math.sqrt(4 * g / l * math.sin(turn + gamma + d / 2) * math.sin(d / 2))
    value, _ = quad(integrand, 0, math.sqrt(abs(edge - turn)), epsabs=0, epsrel=1e-13, limit=200)
    return 2 * value


def lift_off_speed(alpha=ALPHA, gamma=GAMMA, l=L, g=G):
    """The ``ω0`` [rad/s] at ``θ0 = −α`` whose first stance's push vanishes at ``θ = α``:
    ``l C₁ = 3 g cos(α + γ)`` with ``C₁ = ω0² + (2g/l) cos(γ − α)``."""
    return math.sqrt((3 * g * math.cos(alpha + gamma) - 2 * g * math.cos(gamma - alpha)) / l)


def steady_level(alpha=ALPHA, gamma=GAMMA, l=L, g=G):
    """``C*`` [1/s²] of the steady gait's stance."""
    return fixed_point(alpha, gamma, l, g)[1] ** 2 + 2 * g / l * math.cos(gamma - alpha)


# ------------------------------------------------------------------ helpers


def impacts(trajectory, l=L, m=M):
    """``(t, θ⁻, ω⁻, θ⁺, ω⁺)`` of every impact after the start, from the run's instants."""
    instants = trajectory.at_instants()
    rows = []
    for k, t in enumerate(instants.t):
        if t > trajectory.t[0]:
            before = rimless_wheel.stance(instants.x_before[k], instants.modes_before[k], l, m)
            after = rimless_wheel.stance(instants.x_after[k], instants.modes_after[k], l, m)
            rows.append((t, *before, *after))
    return np.array(rows)


def first_stance(trajectory):
    """The rows of the first stance, up to the state just before the first impact (an instant
    keeps two rows at its time, before and after)."""
    end = int(np.searchsorted(trajectory.t, trajectory.events[0].t, side="left"))
    return np.arange(len(trajectory.t)) <= end


@pytest.fixture(scope="module")
def model():
    return rimless_wheel.build()


@pytest.fixture(scope="module")
def rolling(model):
    """The default wheel (from ``ω = 1 rad/s`` at ``θ = −α``) over 6 s: five forward impacts."""
    return model.simulate(6.0, "RK45", **OPTIONS)


# ------------------------------------------------------------------ (a) the impact law


@pytest.mark.parametrize("parity, edge", [("even", 1), ("even", -1), ("odd", 1), ("odd", -1)])
def test_derived_jump_map_is_the_plastic_impact_law(model, parity, edge):
    """Into the other parity at the edge ``θ⁻ = edge·α`` (forward: +1, backward: −1), the jump map
    derived by conservation of state gives ``ω⁺ = cos 2α · ω⁻`` and ``θ⁺ = −θ⁻``, symbolically."""
    m, l, alpha, w = sp.symbols("m l alpha omega_minus")
    sigma = 1 if parity == "even" else -1
    theta = edge * alpha
    psi = sigma * theta
    # before: the hub's velocity l ω (cos θ, −sin θ), perpendicular to the planted spoke
    before = {sp.Symbol("p_x"): m * l * w * sp.cos(theta), sp.Symbol("p_y"): -m * l * w * sp.sin(theta),
              sp.Symbol("psi"): psi}
    target = "odd" if parity == "even" else "even"
    jump = model.mode_equations(target).jump.vector()
    p_x, p_y, psi_after = (sp.sympify(e).xreplace(before) for e in jump)
    theta_after = -sigma * psi_after  # the new parity is −σ
    omega_after = (p_x * sp.cos(theta_after) - p_y * sp.sin(theta_after)) / (m * l)
    assert sp.simplify(psi_after - psi) == 0  # positions do not jump
    assert sp.simplify(theta_after + theta) == 0  # the new spoke is the mirror of the old
    assert sp.simplify(omega_after - sp.cos(2 * alpha) * w) == 0
    # and nothing moves along the new spoke: p⁺ · u_new = 0
    radial = p_x * sp.sin(theta_after) + p_y * sp.cos(theta_after)
    assert sp.simplify(radial) == 0


def test_every_impact_of_a_run_follows_the_plastic_law(rolling):
    rows = impacts(rolling)
    assert len(rows) == 5
    t, theta_minus, omega_minus, theta_plus, omega_plus = rows.T
    # forward impacts at the edge, the new spoke at the mirror angle
    np.testing.assert_allclose(theta_minus, ALPHA, rtol=1e-12)
    np.testing.assert_allclose(theta_plus, -ALPHA, rtol=1e-12)
    assert np.all(omega_minus > 0)
    np.testing.assert_allclose(omega_plus / omega_minus, math.cos(2 * ALPHA), rtol=1e-12)
    assert "impact ratios" in rimless_wheel.error_estimate(rolling)


# ------------------------------------------------------------------ the release of the old foot


def two_feet_wheel(**parameters):
    """The wheel as two alternating foot contacts, each a controlled 0-junction with its own
    automaton (``planted``/``lifted``): touchdown a priori as in the shipped model, release
    a posteriori when the spoke's push (impulses included) would be ``<= 0`` while the other foot
    is planted.  Its junction structure has loops (two radial constraints on the same two
    velocities), which is why the shipped model switches one contact's geometry instead."""
    p = {**P, **parameters}
    m, l, g, gamma, psi = sp.symbols("m l g gamma psi")
    sigma = sp.Symbol("planted_even") - sp.Symbol("planted_odd")
    graph = BondGraph("two_feet_wheel")
    vx, vy = graph.add(One("vx")), graph.add(One("vy"))
    graph.connect(vx, I("I_x", m, state="p_x"))
    graph.connect(vy, I("I_y", m, state="p_y"))
    graph.connect(Se("gravity_x", m * g * sp.sin(gamma)), vx)
    graph.connect(Se("gravity_y", -m * g * sp.cos(gamma)), vy)
    for foot, sign in (("even", 1), ("odd", -1)):
        leg = graph.add(Zero(f"leg_{foot}"))
        for source, name, modulus in ((vx, f"ux_{foot}", sign * sp.sin(psi)), (vy, f"uy_{foot}", sp.cos(psi))):
            graph.connect(source, TF(name, modulus))
            graph.connect(name, leg)
        contact = graph.add(Zero(f"foot_{foot}", controlled=True))
        graph.connect(leg, contact, name=f"radial_{foot}")
        graph.connect(contact, Sf(f"ground_{foot}", 0))
    graph.connect(vx, TF("spin", sigma / (l * sp.cos(psi))))
    graph.connect("spin", Se("free_spin", 0))
    graph.displacement("psi", of="free_spin")
    automata = []
    for foot, other in (("even", "odd"), ("odd", "even")):
        automaton = Automaton(f"foot_{foot}", {"planted": {f"foot_{foot}": True}, "lifted": {f"foot_{foot}": False}},
                              "planted" if foot == "even" else "lifted",
                              values={"planted": {f"planted_{foot}": 1}, "lifted": {f"planted_{foot}": 0}})
        automaton.add_transition("lifted", "planted", "psi >= alpha and dpsi > 0 or psi <= -alpha and dpsi < 0")
        automaton.add_transition("planted", "lifted", f"N_{foot} <= 0 and planted_{other} > 0", "a posteriori")
        automata.append(automaton)
    theta0 = p["phase0"] * p["alpha"]
    speed = p["m"] * p["l"] * p["omega0"]
    return HybridModel(graph, automata, {k: p[k] for k in ("m", "l", "g", "alpha", "gamma")},
                       initial_state={"psi": theta0, "p_x": speed * math.cos(theta0),
                                      "p_y": -speed * math.sin(theta0)},
                       signals={"N_even": "-e_radial_even", "N_odd": "-e_radial_odd", "dpsi": "f_free_spin"},
                       name="two_feet_wheel")


def test_double_support_would_need_the_old_spoke_to_pull():
    """Both feet held at a forward impact on the even spoke (``ψ = θ = α``): conservation of state
    stops the hub, with the impulses ``P_old = −m l ω⁻ cot 2α`` (a pull for ``α < π/4``) and
    ``P_new = m l ω⁻ / sin 2α`` through the spokes — so the old foot lifts (a posteriori)."""
    model = two_feet_wheel()
    m, l, alpha, w = sp.symbols("m l alpha omega_minus")
    both = model.mode_equations(model.mode({"foot_even": "planted", "foot_odd": "planted"}))
    states = [sp.Symbol(name) for name in ("p_x", "p_y", "psi")]
    before = dict(zip(states, (m * l * w * sp.cos(alpha), -m * l * w * sp.sin(alpha), alpha)))
    after = [sp.sympify(e).xreplace(before) for e in both.jump.vector()]
    assert sp.simplify(after[0]) == 0 and sp.simplify(after[1]) == 0  # the hub stops

    def impulse(name):
        """The pulse area ``a(x)ᵀ (x⁺ − x)`` of a signal at the jump [N·s]."""
        coefficients = both.signal(name).impulse
        assert set(coefficients) <= set(states) and coefficients  # the push pulses at this jump
        return sum(sp.sympify(coefficients.get(x, 0)).xreplace(before) * (x_after - before[x])
                   for x, x_after in zip(states, after))
    assert sp.simplify(impulse("N_even") + m * l * w * sp.cot(2 * alpha)) == 0
    assert sp.simplify(impulse("N_odd") - m * l * w / sp.sin(2 * alpha)) == 0


def test_two_feet_with_the_a_posteriori_release_walk_as_the_shipped_wheel(rolling):
    """The two-contact wheel passes double support as a mythical mode at each impact and then
    flows exactly as the shipped one: the same instants and states."""
    trajectory = two_feet_wheel().simulate(6.0, "RK45", **OPTIONS)
    assert len(trajectory.events) == len(rolling.events) == 5
    for event in trajectory.events:
        kinds = [step.kind for step in event.steps]
        assert kinds == ["start", "mythical", "continuous"]
        assert event.steps[1].mode.state_of("foot_even") == event.steps[1].mode.state_of("foot_odd") == "planted"
    np.testing.assert_allclose(trajectory.event_times, rolling.event_times, rtol=1e-12)
    np.testing.assert_allclose(trajectory.at_instants().x_after, rolling.at_instants().x_after, rtol=1e-10,
                               atol=1e-12)


# ------------------------------------------------------------------ (b) the stance phase


def test_each_stance_gains_the_closed_form_energy_and_lasts_the_quadrature(rolling):
    """``ω⁻²_{k+1} − ω⁺²_k = (4g/l) sin α sin γ`` and the stance lasts ``T(ω⁺_k)``."""
    rows = impacts(rolling)
    t, _, omega_minus, _, omega_plus = rows.T
    starts = np.concatenate([[0.0], t[:-1]])
    speeds = np.concatenate([[P["omega0"]], omega_plus[:-1]])
    np.testing.assert_allclose(omega_minus**2 - speeds**2, gain(), rtol=1e-8)
    np.testing.assert_allclose(t - starts, [stance_time(w) for w in speeds], rtol=1e-8)


def test_stride_map_is_affine_with_slope_cos_squared_2alpha(rolling):
    """``E⁺_{k+1} − E⁺* = cos² 2α (E⁺_k − E⁺*)`` exactly (``E = ω²``): the stride map's multiplier."""
    omega_plus = impacts(rolling)[:, 4]
    energy = np.concatenate([[P["omega0"] ** 2], omega_plus**2])
    steady = fixed_point()[1] ** 2
    deviation = energy - steady
    np.testing.assert_allclose(deviation[1:] / deviation[:-1], math.cos(2 * ALPHA) ** 2, rtol=1e-7)


def test_normal_force_in_closed_form_least_at_the_edge():
    """``N = m (3 g cos(θ + γ) − l C)``, ``C = ω² + (2g/l) cos(θ + γ)``, least at ``θ = α``.  A
    wheel started a little below the lift-off speed keeps a small push there."""
    omega0 = math.sqrt(0.95) * lift_off_speed()
    level = omega0**2 + 2 * G / L * math.cos(GAMMA - ALPHA)
    assert level > steady_level()  # the first stance is the fastest
    trajectory = rimless_wheel.build(omega0=omega0).simulate(1.2 * stance_time(omega0), "RK45", **OPTIONS,
                                                            max_step=1e-3)
    first = first_stance(trajectory)
    force, theta = trajectory.signal("normal_force")[first], trajectory.signal("theta")[first]
    np.testing.assert_allclose(force, M * (3 * G * np.cos(theta + GAMMA) - L * level), rtol=1e-8,
                               atol=1e-9 * M * G)
    assert theta[-1] == pytest.approx(ALPHA, rel=1e-12) and np.argmin(force) == len(force) - 1
    assert force[-1] == pytest.approx(0.05 * M * L * lift_off_speed() ** 2, rel=1e-6)


# ------------------------------------------------------------------ (c) the periodic gait


@pytest.fixture(scope="module")
def gait(model):
    return periodic_orbit(model, section="stance: even -> odd", period=2.0, tol=1e-10, **OPTIONS)


def test_gait_fixed_point_in_closed_form(gait):
    """Just after the section's impact (odd spoke, ``θ = −α``, i.e. ``ψ = α``) the hub moves at
    ``l ω⁺*``, perpendicular to the new spoke."""
    _, omega_plus = fixed_point()
    p_x, p_y, psi = gait.x0
    assert psi == pytest.approx(ALPHA, rel=1e-12)
    theta, omega = rimless_wheel.stance(gait.x0, gait.modes[0], L, M)
    assert gait.modes[0].state_of("stance") == "odd" and theta == pytest.approx(-ALPHA, rel=1e-12)
    assert omega == pytest.approx(omega_plus, rel=1e-8)
    assert math.hypot(p_x, p_y) == pytest.approx(M * L * omega_plus, rel=1e-8)
    assert [m.state_of("stance") for m in gait.modes] == ["odd", "even", "odd"]


def test_gait_period_is_two_closed_form_stances(gait):
    assert gait.period == pytest.approx(2 * stance_time(fixed_point()[1]), rel=1e-8)


def test_gait_multipliers_trivial_energy_and_zero(gait):
    """Monodromy over two strides: trivial 1 (along the flow), ``cos⁴ 2α`` (the energy map
    ``E ↦ cos² 2α (E + K)`` twice), 0 along the radial momentum (projected onto the constraint)."""
    c2 = math.cos(2 * ALPHA) ** 2
    assert gait.trivial_multiplier == pytest.approx(1.0, abs=1e-6)
    first, second = gait.multipliers
    assert first == pytest.approx(c2**2, rel=1e-6)
    assert abs(second) < 1e-6
    assert gait.stable
    # the zero multiplier's direction: the momentum along the new spoke u = (−sin α, cos α)
    radial = np.array([-math.sin(ALPHA), math.cos(ALPHA), 0.0])
    assert np.linalg.norm(gait.monodromy @ radial) < 1e-6


def test_gait_continued_in_the_slope_keeps_its_multiplier():
    """Along ``γ`` the gait speeds up (``ω⁻*² ∝ sin γ``) and its period follows the quadrature, but
    the multiplier ``cos⁴ 2α`` depends on the spokes only: no fold, no flip.  Each point is built
    anew (the build function), so each passes the lift-off check."""
    slopes = np.linspace(0.08, 0.2, 3)
    result = continue_orbit(rimless_wheel.build, "gamma", slopes, section="stance: even -> odd", period=2.0,
                            tol=1e-10, **OPTIONS)
    assert not result.bifurcations and len(result.points) == len(slopes)
    for gamma, point in zip(slopes, result.points):
        assert point.value == pytest.approx(gamma, rel=1e-15)
        assert point.orbit.period == pytest.approx(2 * stance_time(fixed_point(gamma=gamma)[1], gamma=gamma),
                                                   rel=1e-8)
        assert point.orbit.multipliers[0] == pytest.approx(math.cos(2 * ALPHA) ** 4, rel=1e-6)


# ------------------------------------------------------------------ (d) too slow: rocking


def test_slow_wheel_rocks_back_and_its_impacts_accumulate():
    """From ``θ = −α`` at ``ω0 = 0.5 rad/s`` the hub does not reach the vertical ``θ = −γ``: it
    falls back onto the previous spoke, and rocks between the two with speeds ``c^k ω0``;
    the impacts accumulate at the sum of the half-swing times (a ZenoError, not a wrong answer)."""
    omega0 = 0.5
    assert not passes_vertical(omega0)
    model = rimless_wheel.build(omega0=omega0)
    with pytest.raises(ZenoError) as info:
        model.simulate(5.0, "RK45", **OPTIONS)
    trajectory = info.value.trajectory
    rows = impacts(trajectory)
    assert trajectory.signal("theta")[first_stance(trajectory)].max() < -GAMMA  # never over the vertical
    # the first impact is backward: onto the previous spoke, at θ = +α on it
    t, theta_minus, omega_minus, theta_plus, omega_plus = rows[0]
    assert theta_minus == pytest.approx(-ALPHA, rel=1e-12) and omega_minus == pytest.approx(-omega0, rel=1e-8)
    assert theta_plus == pytest.approx(ALPHA, rel=1e-12)
    assert omega_plus == pytest.approx(-math.cos(2 * ALPHA) * omega0, rel=1e-8)
    # the half-swings alternate between the two spokes (edges −α, +α) at speeds c^k ω0
    c = math.cos(2 * ALPHA)
    swings = [swing_back_time(c**k * omega0, -ALPHA if k % 2 == 0 else ALPHA) for k in range(100)]
    times = np.cumsum(swings)
    n = min(len(rows), 12)
    np.testing.assert_allclose(rows[:n, 0], times[:n], rtol=1e-8)
    assert info.value.accumulation_time == pytest.approx(times[-1], rel=1e-6)


def test_slow_wheel_stops_at_the_accumulation_on_request():
    trajectory = rimless_wheel.build(omega0=0.5).simulate(5.0, "RK45", on_zeno="stop", **OPTIONS)
    assert trajectory.stopped == "zeno"
    assert trajectory.t[-1] < 5.0


# ------------------------------------------------------------------ units and refusals


def test_the_same_wheel_in_millimetres_has_the_same_impact_instants(rolling):
    """``l`` and ``g`` scaled by 1000 (mm, mm/s²): the angles and times are unchanged."""
    model = rimless_wheel.build(l=1e3 * L, g=1e3 * G)
    trajectory = model.simulate(6.0, "RK45", rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(trajectory.event_times, rolling.event_times, rtol=1e-9)
    rows = impacts(trajectory, l=1e3 * L)
    np.testing.assert_allclose(rows[:, 4], impacts(rolling)[:, 4], rtol=1e-8)


def test_a_wheel_that_would_hop_is_refused_with_its_reason():
    with pytest.raises(ParameterValueError, match="leave the ground in its first stance") as info:
        rimless_wheel.build(omega0=1.01 * lift_off_speed())
    assert info.value.name == "omega0"
    rimless_wheel.build(omega0=0.99 * lift_off_speed())  # just inside: built


def test_a_steep_slope_whose_steady_gait_would_hop_is_refused():
    """``l C* >= 3 g cos(α + γ)``: the gait the wheel converges to would lift off, whatever ``ω0``."""
    gamma = 0.3
    alpha = math.pi / 5
    assert L * steady_level(alpha, gamma) > 3 * G * math.cos(alpha + gamma)
    with pytest.raises(ParameterValueError, match="leave the ground in its steady gait") as info:
        rimless_wheel.build(alpha=alpha, gamma=gamma, omega0=0.0)
    assert info.value.name == "gamma"
    assert L * steady_level(alpha, 0.2) < 3 * G * math.cos(alpha + 0.2)
    rimless_wheel.build(alpha=alpha, gamma=0.2, omega0=0.0)


@pytest.mark.parametrize("parameters, error", [({"phase0": 1.5}, InvalidGraphError),
                                               ({"alpha": math.pi / 4}, InvalidGraphError),
                                               ({"alpha": 0.0}, InvalidGraphError)])
def test_out_of_range_geometry_is_refused(parameters, error):
    with pytest.raises(error):
        rimless_wheel.build(**parameters)


def test_fixed_point_helper_matches_the_closed_form():
    assert rimless_wheel.fixed_point(ALPHA, GAMMA, L, G) == pytest.approx(fixed_point(), rel=1e-15)
