"""The colliding-balls and ball-chain models against physics: conservation of
momentum, Newton's collision rule, the energy lost in an impact, the ideal
chain's velocity transfer (paper Figs. 13-14) and the compliant chain
(Fig. 15) against its own invariants, dimensional analysis and an
independent smooth integration."""

import importlib.util
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from bondgraph.errors import InvalidGraphError, UnknownParameterError
from codegen.cache import SourceCache
from models import ball_chain, colliding_balls


def kinetic(m, v):
    return 0.5 * float(np.sum(np.asarray(m) * np.asarray(v) ** 2))


# ---------------------------------------------------------------- colliding balls


def test_colliding_balls_module_conventions():
    assert colliding_balls.SIGNALS == ("x1", "x2", "v1", "v2")
    assert "t_end" in colliding_balls.RUN and colliding_balls.RUN.get("method", "auto") in ("auto", "RK45")
    model = colliding_balls.build()
    for name in colliding_balls.SIGNALS:
        model.signal_expression(name)
    doc = colliding_balls.__doc__
    assert "a priori" in doc and "v_th" in doc and "pinnacle" in doc
    with pytest.raises(UnknownParameterError):
        colliding_balls.build(mass=3)


@pytest.mark.parametrize("e", [0.0, 0.5, 0.8, 1.0])
@pytest.mark.parametrize("masses", [(1.0, 2.0), (1.5, 0.5), (1.0, 1.0)])
def test_collision_obeys_momentum_newton_and_energy_loss(e, masses):
    m1, m2 = masses
    v1, v2, r = 1.0, -0.5, 0.1
    model = colliding_balls.build(m1=m1, m2=m2, e=e, r1=r, r2=r, x1_0=0.0, x2_0=1.0, v1_0=v1, v2_0=v2)
    trajectory = model.simulate(1.5, "RK45", rtol=1e-10, atol=1e-13)
    assert len(trajectory.events) == 1
    (instant,) = trajectory.events
    # the balls touch when the 0.8 m between their surfaces has closed at 1.5 m/s
    assert instant.t == pytest.approx(0.8 / 1.5, abs=1e-12)
    assert instant.kinds == ["start", "pinnacle", "continuous"]
    k = trajectory.event_index[0]
    before = {s: trajectory.signal(s)[k - 1] for s in colliding_balls.SIGNALS}
    after = {s: trajectory.signal(s)[k] for s in colliding_balls.SIGNALS}
    assert before["v1"] == pytest.approx(v1, rel=1e-12) and before["v2"] == pytest.approx(v2, rel=1e-12)
    # positions do not jump, the balls touch
    assert after["x1"] == before["x1"] and after["x2"] == before["x2"]
    assert after["x2"] - after["x1"] == pytest.approx(2 * r, abs=1e-12)
    u1, u2 = after["v1"], after["v2"]
    # conservation of momentum
    assert m1 * u1 + m2 * u2 == pytest.approx(m1 * v1 + m2 * v2, abs=1e-13)
    # Newton's rule (paper Eq. 7)
    assert u2 - u1 == pytest.approx(-e * (v2 - v1), abs=1e-13)
    # the energy lost: (1 - e²)/2 · m1 m2/(m1 + m2) · (v1 - v2)²
    lost = kinetic(masses, (v1, v2)) - kinetic(masses, (u1, u2))
    expected = (1 - e**2) / 2 * m1 * m2 / (m1 + m2) * (v1 - v2) ** 2
    assert lost == pytest.approx(expected, abs=1e-13)
    if e == 1.0:
        assert lost == pytest.approx(0.0, abs=1e-13)
    # afterwards free flight: straight lines from the impact point
    t_end = trajectory.t[-1]
    x1 = trajectory.signal("x1")[-1]
    x2 = trajectory.signal("x2")[-1]
    assert x1 == pytest.approx(after["x1"] + u1 * (t_end - instant.t), abs=1e-12)
    assert x2 == pytest.approx(after["x2"] + u2 * (t_end - instant.t), abs=1e-12)


def test_equal_masses_give_the_papers_eq_9():
    e, v1, v2 = 0.6, 2.0, -1.0
    trajectory = colliding_balls.build(m1=1.0, m2=1.0, e=e, v1_0=v1, v2_0=v2).simulate(1.0, "RK45")
    k = trajectory.event_index[0]
    u1, u2 = trajectory.signal("v1")[k], trajectory.signal("v2")[k]
    assert u1 == pytest.approx((1 - e) / 2 * v1 + (1 + e) / 2 * v2, abs=1e-13)
    assert u2 == pytest.approx((1 + e) / 2 * v1 + (1 - e) / 2 * v2, abs=1e-13)


def test_plastic_collision_balls_move_on_together_without_further_events():
    """e = 0: common velocity after; the separating threshold keeps the
    touching, co-moving balls in ``free`` (no divergence of time)."""
    trajectory = colliding_balls.build(e=0.0, v_th=0.0).simulate(3.0, "RK45", rtol=1e-10, atol=1e-13)
    assert len(trajectory.events) == 1
    v_common = (1.0 * 1.0 + 2.0 * -0.5) / 3.0
    assert trajectory.signal("v1")[-1] == pytest.approx(v_common, abs=1e-14)
    assert trajectory.signal("v2")[-1] == pytest.approx(v_common, abs=1e-14)
    gap = trajectory.signal("x2")[-1] - trajectory.signal("x1")[-1]
    assert gap == pytest.approx(0.2, abs=1e-12)
    assert trajectory.modes[-1].label == "free"


def test_slower_chaser_and_separating_balls_never_collide():
    assert not colliding_balls.build(v1_0=-1.0, v2_0=0.5).simulate(2.0, "RK45").events
    # ball 1 catches up with ball 2 (both moving right), collides once
    trajectory = colliding_balls.build(m1=1.0, m2=1.0, e=1.0, v1_0=2.0, v2_0=1.0).simulate(2.0, "RK45")
    assert len(trajectory.events) == 1
    assert trajectory.events[0].t == pytest.approx(0.8 / 1.0, abs=1e-12)
    assert trajectory.signal("v1")[-1] == pytest.approx(1.0) and trajectory.signal("v2")[-1] == pytest.approx(2.0)


def test_colliding_balls_have_no_divergence_of_time_loop():
    assert colliding_balls.build().verify(samples=10).ok


# ---------------------------------------------------------------- ideal chain


def chain_velocities(trajectory, n, k=-1):
    return np.array([trajectory.signal(f"v{i}")[k] for i in range(1, n + 1)])


def cold(model):
    """The model with a private, empty code cache: every mode it visits is
    derived (a shared cache would let another test's run supply it)."""
    model.cache = SourceCache(None)
    return model


def test_ball_chain_module_conventions():
    assert ball_chain.SIGNALS == ball_chain.signals_for(4)
    assert isinstance(ball_chain.DEFAULTS["N"], int) and isinstance(ball_chain.DEFAULTS["compliant"], bool)
    model = ball_chain.build()
    for name in ball_chain.SIGNALS:
        model.signal_expression(name)
    doc = ball_chain.__doc__
    assert "a priori" in doc and "v_th" in doc and "compliant" in doc
    with pytest.raises(InvalidGraphError):
        ball_chain.build(N=2.5)
    with pytest.raises(InvalidGraphError):
        ball_chain.build(N=1)
    compliant = ball_chain.build(compliant="true", N=3)
    assert [s.name for s in compliant.states] == ["p1", "p2", "p3", "q1", "q2", "pos1", "pos2", "pos3"]


def test_four_ball_chain_transfers_all_velocity_to_the_last_ball_in_one_instant():
    v0 = 1.0
    model = cold(ball_chain.build(N=4, v0=v0))
    trajectory = model.simulate(0.5, "RK45", rtol=1e-10, atol=1e-13)
    (instant,) = trajectory.events
    assert instant.t == pytest.approx(0.1 / v0, abs=1e-12)  # `distance` closed at v0
    assert instant.kinds == ["start", "pinnacle", "pinnacle", "pinnacle", "continuous"]
    # ball 2 takes on all of ball 1's velocity, then ball 3, then ball 4 (Fig. 14)
    m = 1.0
    for j, step in enumerate(s for s in instant.steps if s.kind == "pinnacle"):
        v = step.x_after[:4] / m
        expected = np.zeros(4)
        expected[j + 1] = v0
        np.testing.assert_allclose(v, expected, atol=1e-15)
    np.testing.assert_allclose(chain_velocities(trajectory, 4), [0, 0, 0, v0], atol=1e-15)
    # only the modes visited are derived: all free, and each contact once
    assert model.derivation_count == 4
    print(f"\nN = 4 ideal chain: derived modes = {model.derivation_count}")
    # the last ball flies off; the others stay where they were hit
    x0 = [0.0, 0.2, 0.3, 0.4]  # r = 0.05, distance = 0.1, then touching
    x_end = [trajectory.signal(f"x{i}")[-1] for i in range(1, 5)]
    np.testing.assert_allclose(x_end, [0.1, 0.2, 0.3, 0.4 + v0 * (0.5 - 0.1)], atol=1e-12)
    np.testing.assert_allclose([trajectory.signal(f"x{i}")[0] for i in range(1, 5)], x0, atol=1e-15)


@pytest.mark.parametrize("e", [0.3, 0.7])
def test_inelastic_chain_each_pinnacle_is_a_newton_impact(e):
    n, v0 = 4, 1.0
    trajectory = ball_chain.build(N=n, e=e, v0=v0).simulate(2.0, "RK45", rtol=1e-10, atol=1e-13)
    energy = 0.5 * v0**2
    for instant in trajectory.events:
        for step in instant.steps:
            if step.kind != "pinnacle":
                continue
            before, after = step.x_before[:n], step.x_after[:n]
            assert after.sum() == pytest.approx(before.sum(), abs=1e-14)  # momentum
            pairs = [i for i, state in enumerate(step.mode.states) if state == "collide"]
            for i in pairs:  # Newton's rule on every pair colliding in this pinnacle
                assert after[i + 1] - after[i] == pytest.approx(-e * (before[i + 1] - before[i]), abs=1e-14)
            touched = {j for i in pairs for j in (i, i + 1)}
            for j in set(range(n)) - touched:
                assert after[j] == before[j]
            lost = kinetic(np.ones(n), before) - kinetic(np.ones(n), after)
            assert lost >= -1e-15
            energy -= lost
    v = chain_velocities(trajectory, n)
    assert v.sum() == pytest.approx(v0, abs=1e-14)
    assert np.all(np.diff(v) >= -1e-14)  # ordered: no pair approaches any more
    assert kinetic(np.ones(n), v) == pytest.approx(energy, abs=1e-14)
    assert kinetic(np.ones(n), v) < 0.5 * v0**2


def test_twelve_ball_chain_derives_only_the_modes_it_visits():
    n = 12
    model = cold(ball_chain.build(N=n))
    trajectory = model.simulate(0.3, "RK45", rtol=1e-9, atol=1e-12, output="events")
    np.testing.assert_allclose(chain_velocities(trajectory, n), [0] * (n - 1) + [1.0], atol=1e-15)
    assert trajectory.events[0].kinds.count("pinnacle") == n - 1
    assert model.derivation_count == n  # not 2^(n-1) = 2048


@pytest.mark.slow
def test_fifty_ball_chain_runs_and_derives_few_modes():
    n = 50
    model = cold(ball_chain.build(N=n))
    trajectory = model.simulate(0.3, "RK45", rtol=1e-9, atol=1e-12, output="events")
    v = chain_velocities(trajectory, n)
    np.testing.assert_allclose(v, [0] * (n - 1) + [1.0], atol=1e-15)
    assert v.sum() == pytest.approx(1.0, abs=1e-14) and kinetic(np.ones(n), v) == pytest.approx(0.5, abs=1e-14)
    assert trajectory.events[0].kinds.count("pinnacle") == n - 1
    print(f"\nN = 50 ideal chain: derived modes = {model.derivation_count} (of 2^49 possible); "
          f"wall time {trajectory.stats['wall time [s]']:.2f} s")
    assert model.derivation_count == n  # all free, and each contact's collide once


def test_plastic_chain_ends_at_the_common_velocity_within_the_threshold():
    """e = 0: the touching balls collide back and forth inside one instant
    (a chain of pinnacles) towards the common velocity v0/N; the separating
    threshold v_th ends the chain (divergence of time) with every neighbour
    pair within v_th of each other."""
    n, v0 = 4, 1.0
    for v_th in (1e-3, 1e-6, 1e-9):
        trajectory = ball_chain.build(N=n, e=0.0, v_th=v_th).simulate(0.5, "RK45", output="events")
        (instant,) = trajectory.events
        v = chain_velocities(trajectory, n)
        assert v.sum() == pytest.approx(v0, abs=1e-14)
        assert np.all(v[:-1] - v[1:] <= v_th * (1 + 1e-9))  # no pair approaches faster than v_th
        np.testing.assert_allclose(v, v0 / n, atol=n * v_th)
        print(f"\nplastic chain, v_th = {v_th:g}: {instant.kinds.count('pinnacle')} pinnacles at t = {instant.t:g}, "
              f"v - v0/N = {np.array2string(v - v0 / n, formatter={'float_kind': lambda x: f'{x:.2e}'})}")


# ---------------------------------------------------------------- compliant chain


def run_compliant(t_extra=30.0, **parameters):
    """Simulate a compliant chain until every contact has certainly ended."""
    p = {**ball_chain.DEFAULTS, **parameters}
    model = ball_chain.build(**parameters, compliant=True)
    t_end = (p["distance"] + 3 * p["N"] * p["gap"]) / p["v0"] + t_extra * math.sqrt(p["m"] / p["k"]) * p["N"]
    return model, model.simulate(t_end, "Radau", rtol=1e-10, atol=1e-13)


def compliant_energy(trajectory, n, m, k):
    p = np.column_stack([trajectory.state(f"p{i}") for i in range(1, n + 1)])
    q = np.column_stack([trajectory.state(f"q{i}") for i in range(1, n)])
    return 0.5 * np.sum(p**2, axis=1) / m + 0.5 * k * np.sum(q**2, axis=1)


def test_two_compliant_balls_exchange_velocities_in_half_a_period():
    """Equal masses on a linear spring: relative motion is a half oscillation
    at ω = sqrt(2k/m); the velocities are exchanged exactly."""
    k, m = 1e4, 1.0
    model, trajectory = run_compliant(N=2, k=k, m=m)
    np.testing.assert_allclose(chain_velocities(trajectory, 2), [0.0, 1.0], atol=1e-8)
    touch, release = trajectory.events[0].t, trajectory.events[1].t
    assert touch == pytest.approx(0.1, abs=1e-12)
    assert release - touch == pytest.approx(math.pi / math.sqrt(2 * k / m), rel=1e-8)
    # the peak compression: all relative kinetic energy in the spring, m v0²/4 = k q²/2
    assert trajectory.state("q1").max() == pytest.approx(math.sqrt(m / (2 * k)), rel=1e-4)


@pytest.mark.parametrize("k", [1e3, 1e5])
def test_compliant_chain_conserves_momentum_exactly_and_energy_to_tolerance(k):
    n, m, v0 = 4, 1.0, 1.0
    model, trajectory = run_compliant(N=n, k=k, m=m, v0=v0)
    momentum = sum(trajectory.state(f"p{i}") for i in range(1, n + 1))
    assert np.max(np.abs(momentum - m * v0)) < 1e-14  # round-off: RK methods keep linear invariants
    energy = compliant_energy(trajectory, n, m, k)
    assert np.max(np.abs(energy - 0.5 * m * v0**2)) < 1e-9  # measured ~3e-12 at rtol 1e-10
    # the springs are engaged only while the balls overlap, and q is the overlap
    for i in range(1, n):
        overlap = 2 * 0.05 - (trajectory.signal(f"x{i + 1}") - trajectory.signal(f"x{i}"))
        q = trajectory.state(f"q{i}")
        np.testing.assert_allclose(q, np.maximum(overlap, 0.0), atol=1e-10 * math.sqrt(m / k))
    assert trajectory.modes[-1].label == "free|free|free"


def test_damped_compliant_chain_conserves_momentum_and_loses_energy():
    n, m, k, b = 4, 1.0, 1e4, 5.0
    model, trajectory = run_compliant(N=n, k=k, m=m, b=b)
    momentum = sum(trajectory.state(f"p{i}") for i in range(1, n + 1))
    assert np.max(np.abs(momentum - 1.0)) < 1e-13
    energy = compliant_energy(trajectory, n, m, k)
    assert np.all(np.diff(energy) <= 1e-10)  # a damper only dissipates
    assert energy[-1] < 0.5 * 0.95


def smooth_reference(n, k, m=1.0, r=0.05, v0=1.0, distance=0.1, t_end=1.0):
    """The touching compliant chain integrated directly (force k·max(0, overlap)),
    without the hybrid machinery."""
    x0 = np.array([0.0] + [2 * r + distance + 2 * r * j for j in range(n - 1)])
    v = np.zeros(n)
    v[0] = v0

    def rhs(t, y):
        x, u = y[:n], y[n:]
        force = k * np.maximum(0.0, 2 * r - np.diff(x))
        a = np.zeros(n)
        a[:-1] -= force / m
        a[1:] += force / m
        return np.concatenate([u, a])

    solution = solve_ivp(rhs, (0, t_end), np.concatenate([x0, v]), method="DOP853", rtol=1e-12, atol=1e-14)
    return solution.y[n:, -1]


KS = np.logspace(2, 5, 7)


def test_touching_compliant_chain_does_not_approach_the_ideal_result_as_k_grows():
    """A linear contact has no length scale: with touching balls the motion in
    the time unit sqrt(m/k) is the same for every k (dimensional analysis).
    The final velocities are independent of k and differ from (0, 0, 0, v0);
    only the transfer time shrinks, as k^(-1/2)."""
    n = 4
    finals, durations = [], []
    print("\ntouching compliant chain (N = 4, m = 1, v0 = 1, gap = 0), Radau rtol 1e-10:")
    print("       k        v1          v2          v3          v4      1 - v4    transfer [s]")
    for k in KS:
        model, trajectory = run_compliant(N=n, k=k)
        v = chain_velocities(trajectory, n)
        times = [e.t for e in trajectory.events if e.t > 0]
        finals.append(v)
        durations.append(times[-1] - times[0])
        print(f"  {k:9.3g}  " + "  ".join(f"{x:10.7f}" for x in v) + f"  {1 - v[-1]:.3e}  {durations[-1]:.5g}")
    finals = np.array(finals)
    assert np.max(np.ptp(finals, axis=0)) < 1e-7  # independent of k
    assert 1 - finals[0, -1] > 0.03  # and far from the ideal chain's (0, 0, 0, 1)
    slope = np.polyfit(np.log(KS), np.log(durations), 1)[0]
    print(f"  fitted: transfer time ∝ k^{slope:.4f} (expected -1/2); deviation 1 - v4 = {1 - finals[0, -1]:.6f} for all k")
    assert slope == pytest.approx(-0.5, abs=2e-3)
    # the same numbers from a direct integration of the smooth-contact ODE
    reference = smooth_reference(n, k=1e3, t_end=1.0)
    np.testing.assert_allclose(finals[2], reference, atol=1e-7)


def test_compliant_chain_with_gaps_approaches_the_ideal_result_as_k_grows():
    """With gaps between balls 2…N the binary impacts separate as k grows: the
    result depends on k only through gap·sqrt(k/m)/v0, and becomes the ideal
    (0, 0, 0, v0) once the front ball's travel during one impact,
    π v0 sqrt(m/(2k))/2, fits in the gap (k > π² m v0²/(8 gap²))."""
    n, gap = 4, 1e-2
    k_star = math.pi**2 / (8 * gap**2)
    deviations, leftovers = [], []
    print(f"\ncompliant chain with gap = {gap} m (k* = {k_star:.4g} N/m), Radau rtol 1e-10:")
    print("       k       1 - v4     |v1..v3|")
    for k in KS:
        model, trajectory = run_compliant(N=n, k=k, gap=gap)
        v = chain_velocities(trajectory, n)
        deviations.append(1 - v[-1])
        leftovers.append(np.linalg.norm(v[:-1]))
        print(f"  {k:9.3g}  {deviations[-1]:.3e}  {leftovers[-1]:.3e}")
    deviations, leftovers = np.array(deviations), np.array(leftovers)
    below = KS < k_star
    assert np.all(np.diff(leftovers[below]) < 0)  # monotone approach
    local = np.diff(np.log(leftovers[below])) / np.diff(np.log(KS[below]))
    print("  local slopes d log|v1..v3| / d log k below k*: " + ", ".join(f"{s:.2f}" for s in local))
    # beyond k*: the ideal result to the integration tolerance
    assert np.all(leftovers[KS > 1.5 * k_star] < 1e-9)
    assert np.all(np.abs(deviations[KS > 1.5 * k_star]) < 1e-9)
    # similarity: gap 1e-3 at k = 1e4 is gap 1e-2 at k = 1e2
    _, trajectory = run_compliant(N=n, k=1e4, gap=1e-3)
    np.testing.assert_allclose(chain_velocities(trajectory, n), [
        *(chain_velocities(run_compliant(N=n, k=1e2, gap=1e-2)[1], n))], atol=1e-8)


@pytest.mark.parametrize("module, parameters", [
    (colliding_balls, {}),
    (ball_chain, {}),
    (ball_chain, {"compliant": True}),
])
def test_default_runs_and_their_error_estimates(module, parameters):
    trajectory = module.build(**parameters).simulate(**module.RUN)
    for name in (module.SIGNALS if not parameters else ball_chain.signals_for(4)):
        assert np.all(np.isfinite(trajectory.signal(name)))
    text = module.error_estimate(trajectory)
    numbers = [float(word) for word in text.replace(",", " ").split() if word[:1].isdigit() and "e" in word]
    assert numbers and max(numbers) < 1e-8, text


@pytest.mark.parametrize("N", [3, 6])
def test_a_heavily_damped_chain_gives_the_same_instants_with_every_method(N):
    """Issue 30, item 3: compliant contacts k = 1e8 at ζ = 10 only push (released when their force would
    pull), so every method passes the same instants and gives the same final velocities.  Before, a contact
    released on the geometry approached zero overlap without crossing it: Radau 4, BDF 10, LSODA 10 instants,
    RK45 5892."""
    k, m = 1e8, 1.0
    model = ball_chain.build(N=N, compliant=True, k=k, b=2 * 10 * math.sqrt(k * m / 2))
    compiled = ("rodas-jit",) if importlib.util.find_spec("numba") else ()  # (the compiled implicit method)
    runs = {method: model.simulate(0.5, method, rtol=1e-8, atol=1e-10, output="events")
            for method in ("Radau", "BDF", "LSODA", "RK45", *compiled)}
    momenta = [model.state_index[s] for s in model.states if s.name in {f"p{i}" for i in range(1, N + 1)}]
    reference = runs["Radau"]
    for method, trajectory in runs.items():
        assert [(e.mode_before, e.mode_after) for e in trajectory.events] == \
            [(e.mode_before, e.mode_after) for e in reference.events], method
        np.testing.assert_allclose(trajectory.event_times, reference.event_times, rtol=1e-7, err_msg=method)
        np.testing.assert_allclose(trajectory.x[-1][momenta], reference.x[-1][momenta], atol=1e-7, err_msg=method)
        assert sum(trajectory.x[-1][momenta]) == pytest.approx(m * 1.0, abs=1e-12)


def test_a_damped_contact_never_pulls():
    """While engaged the contact force k·q + b·(v1 − v2) is never tensile beyond round-off."""
    k, b = 1e6, 2 * 0.7 * math.sqrt(1e6 / 2)  # ζ = 0.7 with m = 1
    model = ball_chain.build(N=2, compliant=True, k=k, b=b)
    trajectory = model.simulate(0.3, "Radau", rtol=1e-10, atol=1e-13)
    engaged = np.array([mode.states[0] == "touch" for mode in trajectory.modes])
    force = k * trajectory.state("q1") + b * (trajectory.signal("v1") - trajectory.signal("v2"))
    assert engaged.any() and np.min(force[engaged]) > -1e-6 * np.max(force)
