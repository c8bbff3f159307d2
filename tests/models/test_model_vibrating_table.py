"""The ball on the vibrating table (:mod:`models.vibrating_table`) against exact answers.

Notation: the table ``s(t) = A sin(ω t)``, ``T = 2π/ω``, ``Γ = A ω²/g``; an impact at phase
``θ = ω t`` (mod 2π) with velocities ``v⁻`` before and ``v⁺`` after, Newton's law relative to
the table ``v⁺ − ṡ = −e (v⁻ − ṡ)``.

**The period-1 orbit** (one impact per table period).  The ball leaves the table at
``y = s(t_k)`` and lands on it at ``s(t_k + T) = s(t_k)``, so its flight ``v⁺ T − g T²/2 = 0``
gives ``v⁺ = g T/2`` and ``v⁻ = v⁺ − g T = −g T/2``.  The restitution law at the impact,
``g T/2 − A ω cos θ = e (g T/2 + A ω cos θ)``, gives

    cos θ = (1 − e) g T / (2 (1 + e) A ω) = π g (1 − e) / (A ω² (1 + e)) = π (1 − e) / ((1 + e) Γ),

which has solutions when ``Γ >= Γ_min = π (1 − e)/(1 + e)`` (``A >= π g (1 − e)/(ω² (1 + e))``):
two of them, ``θ = ±acos(…)``, with the same velocities.  Both are orbits (the ball is above the
table in between); which one is seen follows from the linearisation below: the root ``θ > 0``
(the table moving up, ``ṡ > 0``, and *decelerating*, ``s̈ < 0``) has multipliers of modulus < 1
near ``Γ_min``, the root ``θ < 0`` (table accelerating up) has a real multiplier > 1 for every
``Γ`` (a saddle, never observed).  The physical orbit is ``θ = +acos(…)``.

**Its multipliers.**  The impact map in ``(φ, u)`` — the impact phase and the relative
velocity after the impact — is ``(φ, u) ↦ (φ', u')`` with ``φ'`` the next root of the gap
``F = A sin φ + (u + A ω cos φ)(φ' − φ)/ω − g (φ' − φ)²/(2 ω²) − A sin φ' = 0`` and
``u' = −e (u + A ω cos φ − g (φ' − φ)/ω − A ω cos φ')``.  Linearised at the orbit (implicit
differentiation of ``F``; :func:`test_the_impact_map_linearised_at_the_orbit` does it with sympy)::

    det J = e²,        tr J = 1 + e² + (1 + e)² s̈(θ)/g = 1 + e² − (1 + e)² Γ sin θ
                            = 1 + e² − π (1 − e²) tan θ,

so the multipliers are the roots of ``μ² − tr μ + e² = 0``: their product is ``e²`` (each impact
contracts the area of the flow's section by ``e²``; the flight, a Hamiltonian flow, keeps it).
The same multipliers are the Floquet multipliers of the orbit (the stroboscopic map over one
period is conjugate to the impact map).  ``μ = +1`` needs ``tr = 1 + e²``: ``sin θ = 0``, the
existence boundary ``Γ_min`` (a fold, where the two roots ``±θ`` meet).  ``μ = −1`` needs
``tr = −(1 + e²)``: ``tan θ = 2 (1 + e²)/(π (1 − e²))``, i.e. the period doubling at

    Γ_PD² = π² (1 − e)²/(1 + e)² + 4 (1 + e²)²/(1 + e)⁴.

The orbit ``θ > 0`` is stable for ``Γ_min < Γ < Γ_PD`` and unstable beyond.

The model is forced (time is not a state), so the orbit is found with a fixed period
``periodic_orbit(model, period=T, t0=…)`` started at the orbit's apex, half a period after the
impact (``t0 = θ/ω + T/2``, ``v = 0``, ``y = A sin θ + g T²/8``): an autonomous ``section=``
would restart every return at the same ``t0`` and does not apply to a forced model.

Tolerances: the runs use ``rtol = 1e-10`` (and an ``atol`` below the states' scales); event times
states and multipliers are compared at ``1e-8`` (100 rtol; the flights are parabolas, which
RK45 integrates exactly, so the errors are those of the event location and of the sensitivities).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
from scipy.optimize import brentq

from models import vibrating_table
from switching.analysis.continuation import continue_orbit
from switching.analysis.orbits import periodic_orbit

G = 9.81
OMEGA = vibrating_table.DEFAULTS["omega"]
T = 2 * math.pi / OMEGA
RTOL = 1e-10


# ------------------------------------------------------------------ closed forms


def gamma_min(e: float) -> float:
    """``Γ = A ω²/g`` below which the period-1 orbit does not exist: ``π (1 − e)/(1 + e)``."""
    return math.pi * (1 - e) / (1 + e)


def gamma_flip(e: float) -> float:
    """``Γ`` of the period doubling of the period-1 orbit:
    ``sqrt(π² (1 − e)²/(1 + e)² + 4 (1 + e²)²/(1 + e)⁴)``."""
    return math.sqrt(gamma_min(e) ** 2 + 4 * (1 + e * e) ** 2 / (1 + e) ** 4)


def impact_phase(A: float, e: float, omega: float = OMEGA, g: float = G, root: int = 1) -> float:
    """The period-1 orbit's impact phase ``θ = ±acos(π g (1 − e)/(A ω² (1 + e)))`` [rad]."""
    return root * math.acos(math.pi * g * (1 - e) / (A * omega**2 * (1 + e)))


def exact_multipliers(A: float, e: float, omega: float = OMEGA, g: float = G, root: int = 1) -> np.ndarray:
    """The roots of ``μ² − (1 + e² − (1 + e)² Γ sin θ) μ + e² = 0``, largest modulus first."""
    theta = impact_phase(A, e, omega, g, root)
    trace = 1 + e * e - (1 + e) ** 2 * (A * omega**2 / g) * math.sin(theta)
    roots = np.roots([1.0, -trace, e * e])
    return roots[np.argsort(-np.abs(roots))]


def apex(A: float, e: float, omega: float = OMEGA, g: float = G, root: int = 1) -> tuple:
    """``(t0, y0)``: the period-1 orbit's apex, half a period after its impact: ``t0 = θ/ω + T/2``
    [s], ``y0 = A sin θ + g T²/8`` [m] (there ``v = 0``)."""
    theta = impact_phase(A, e, omega, g, root)
    period = 2 * math.pi / omega
    return theta / omega + period / 2, A * math.sin(theta) + g * period**2 / 8


def state(model, **values) -> np.ndarray:
    """A state vector of ``model`` from its states' names."""
    return np.array([values[s.name] for s in model.states], dtype=float)


def same_multipliers(found, exact) -> float:
    """The largest distance between two sets of multipliers, each sorted by modulus then value."""
    def key(values):
        return sorted(np.asarray(values, dtype=complex), key=lambda z: (-abs(z), z.real, z.imag))
    return max(abs(a - b) for a, b in zip(key(found), key(exact)))


def first_impact(y0: float, v0: float, A: float, omega: float = OMEGA, g: float = G) -> float:
    """The first root ``t > 0`` of the exact gap of a ball in free flight from ``(y0, v0)`` at
    ``t = 0`` over the table, ``y0 + v0 t − g t²/2 − A sin(ω t)`` (Brent's method on the first
    sign change on a grid of ``T/400``)."""
    def gap(t):
        return y0 + v0 * t - g * t * t / 2 - A * math.sin(omega * t)

    step = 2 * math.pi / omega / 400
    t = step
    while gap(t) > 0:
        t += step
    return brentq(gap, t - step, t, xtol=1e-15, rtol=4 * np.finfo(float).eps)


# ------------------------------------------------------------------ symbolic


def impact_map_jacobian():
    """The exact impact map of the module docstring linearised at the period-1 orbit:
    ``(J, fixed_point_residuals, symbols)``, with ``A`` eliminated by the orbit's condition
    ``A = π g (1 − e)/(ω² (1 + e) cos θ)``."""
    phi, u, phi1 = sp.symbols("phi u phi1", real=True)
    theta, omega, g, e = sp.symbols("theta omega g e", positive=True)
    A = sp.Symbol("A", positive=True)
    flight = (phi1 - phi) / omega
    F = A * sp.sin(phi) + (u + A * omega * sp.cos(phi)) * flight - g * flight**2 / 2 - A * sp.sin(phi1)
    U = -e * (u + A * omega * sp.cos(phi) - g * flight - A * omega * sp.cos(phi1))
    # implicit differentiation of F(φ, u, φ') = 0
    dphi1 = [-sp.diff(F, z) / sp.diff(F, phi1) for z in (phi, u)]
    J = sp.Matrix([[dphi1[0], dphi1[1]],
                   [sp.diff(U, phi) + sp.diff(U, phi1) * dphi1[0], sp.diff(U, u) + sp.diff(U, phi1) * dphi1[1]]])
    period = 2 * sp.pi / omega
    orbit = {phi: theta, phi1: theta + 2 * sp.pi, u: g * period / 2 - A * omega * sp.cos(theta)}
    amplitude = {A: sp.pi * g * (1 - e) / (omega**2 * (1 + e) * sp.cos(theta))}
    at = lambda expr: sp.simplify(expr.subs(orbit).subs(amplitude))  # noqa: E731
    residuals = (at(F), at(U - u))
    return J.applyfunc(at), residuals, (theta, omega, g, e)


def test_the_impact_phase_solves_the_restitution_law():
    A, omega, g, e, c = sp.symbols("A omega g e c", positive=True)
    period = 2 * sp.pi / omega
    # v⁺ − ṡ = −e (v⁻ − ṡ) with v± = ±g T/2, ṡ = A ω c (c = cos θ)
    law = sp.Eq(g * period / 2 - A * omega * c, -e * (-g * period / 2 - A * omega * c))
    (solution,) = sp.solve(law, c)
    assert sp.simplify(solution - sp.pi * g * (1 - e) / (A * omega**2 * (1 + e))) == 0


def test_the_impact_map_linearised_at_the_orbit():
    J, residuals, (theta, omega, g, e) = impact_map_jacobian()
    assert residuals == (0, 0)  # the orbit is a fixed point of the map
    assert sp.simplify(J.det() - e**2) == 0
    assert sp.simplify(J.trace() - (1 + e**2 - sp.pi * (1 - e**2) * sp.tan(theta))) == 0
    # in Γ: (1 + e)² Γ sin θ with Γ = π (1 − e)/((1 + e) cos θ)
    gamma = sp.pi * (1 - e) / ((1 + e) * sp.cos(theta))
    assert sp.simplify(J.trace() - (1 + e**2 - (1 + e) ** 2 * gamma * sp.sin(theta))) == 0


def test_the_period_doubling_amplitude():
    """``μ = −1`` ⇔ ``tr J = −(1 + e²)`` ⇔ ``tan θ = 2 (1 + e²)/(π (1 − e²))``; then
    ``Γ² = Γ_min² (1 + tan² θ)`` is the closed form of :func:`gamma_flip`."""
    e, mu = sp.symbols("e mu", positive=True)
    tan = 2 * (1 + e**2) / (sp.pi * (1 - e**2))
    trace = 1 + e**2 - sp.pi * (1 - e**2) * tan
    assert sp.simplify((mu**2 - trace * mu + e**2).subs(mu, -1)) == 0
    g_min = sp.pi * (1 - e) / (1 + e)
    closed = g_min**2 + 4 * (1 + e**2) ** 2 / (1 + e) ** 4
    assert sp.simplify(g_min**2 * (1 + tan**2) - closed) == 0


# ------------------------------------------------------------------ one impact


@pytest.mark.parametrize("e, A, gap0", [(0.5, 0.0125, 0.1), (0.8, 0.02, 0.03), (1.0, 0.005, 0.2)])
def test_one_impact_obeys_newtons_law_relative_to_the_table(e, A, gap0):
    m = 2.0
    model = vibrating_table.build(e=e, A=A, gap0=gap0, m=m)
    v0 = A * OMEGA  # at rest relative to the table at t = 0
    t_hit = first_impact(gap0, v0, A)
    run = model.simulate(t_hit + 0.01 * T, "RK45", rtol=RTOL, atol=1e-13)
    (impact,) = run.events
    assert impact.t == pytest.approx(t_hit, rel=1e-8)
    assert [s.mode.state_of("contact") for s in impact.steps] == ["flight", "impact", "flight"]
    p = [s.name for s in model.states].index("p")
    v_minus, v_plus = impact.x_before[p] / m, impact.x_after[p] / m
    table_v = A * OMEGA * math.cos(OMEGA * t_hit)
    assert v_minus == pytest.approx(v0 - G * t_hit, rel=1e-8)
    assert v_plus - table_v == pytest.approx(-e * (v_minus - table_v), rel=1e-8)
    # the table's force on the ball is a Dirac pulse of area m (v⁺ − v⁻)
    assert impact.impulse("contact_force") == pytest.approx(m * (v_plus - v_minus), rel=1e-8)


def test_a_plastic_impact_on_a_pushing_table_sticks_and_the_table_lets_go_at_minus_g():
    """``e = 0``: the ball lands, rides the table (``v = ṡ``) and leaves it where
    ``A ω² sin(ω t) = g`` first after the landing."""
    A = 0.02  # Γ = 2.01
    model = vibrating_table.build(e=0.0, A=A, gap0=0.05)
    t_hit = first_impact(0.05, A * OMEGA, A)
    run = model.simulate(t_hit + T, "RK45", rtol=RTOL, atol=1e-13)
    landing, release = run.events[:2]
    assert landing.t == pytest.approx(t_hit, rel=1e-8)
    assert A * OMEGA**2 * math.sin(OMEGA * t_hit) < G  # the table pushes there: N = m (s̈ + g) > 0
    assert landing.mode_after.state_of("contact") == "stick"
    # N turns negative where sin(ω t) rises through g/(A ω²): at the phases asin(g/(A ω²)) + 2π j
    lift = math.asin(G / (A * OMEGA**2))
    j = math.ceil((OMEGA * t_hit - lift) / (2 * math.pi))
    assert release.t == pytest.approx((lift + 2 * math.pi * j) / OMEGA, rel=1e-8)
    assert release.mode_after.state_of("contact") == "flight"
    ride = (run.t > landing.t) & (run.t < release.t)
    assert np.allclose(run.signal("vrel")[ride], 0.0, atol=1e-9)


def test_the_same_run_in_millimetres_has_the_same_instants():
    """Units: lengths in mm (``A``, ``g``, the heights and ``v_stick`` times 1000) change no
    instant, and ``y`` scales by 1000."""
    metres = vibrating_table.build()
    millimetres = vibrating_table.build(A=1e3 * vibrating_table.DEFAULTS["A"], g=1e3 * G,
                                        gap0=1e3 * vibrating_table.DEFAULTS["gap0"],
                                        v_stick=1e3 * vibrating_table.DEFAULTS["v_stick"])
    a = metres.simulate(2.0, "RK45", rtol=RTOL, atol=1e-13)
    b = millimetres.simulate(2.0, "RK45", rtol=RTOL, atol=1e-10)
    assert len(a.events) == len(b.events) >= 8
    np.testing.assert_allclose(b.event_times, a.event_times, rtol=1e-8)
    assert [e.mode_after for e in a.events] == [e.mode_after for e in b.events]
    y = [s.name for s in metres.states].index("y")
    np.testing.assert_allclose([e.x_after[y] * 1e-3 for e in b.events], [e.x_after[y] for e in a.events],
                               rtol=1e-7, atol=1e-9)


# ------------------------------------------------------------------ the period-1 orbit


def find_orbit(A, e, root=1, guess_error=0.01):
    """The period-1 orbit by fixed-period shooting from its apex, the guess ``guess_error``
    off in height and velocity."""
    model = vibrating_table.build(A=A, e=e)
    t0, y0 = apex(A, e, root=root)
    guess = state(model, p=guess_error * G * T / 2, y=(1 + guess_error) * y0)
    return model, periodic_orbit(model, period=T, t0=t0, x0=guess, rtol=RTOL, atol=1e-13, tol=1e-9)


@pytest.mark.parametrize("e, fraction", [(0.5, 0.3), (0.5, 0.8), (0.3, 0.5), (0.8, 0.5), (0.5, 1.2)])
def test_the_period_one_orbit_and_its_multipliers(e, fraction):
    """``Γ`` a ``fraction`` of the way from ``Γ_min`` to ``Γ_PD`` (beyond it for ``fraction > 1``)."""
    gamma = gamma_min(e) + fraction * (gamma_flip(e) - gamma_min(e))
    A = gamma * G / OMEGA**2
    model, orbit = find_orbit(A, e)
    t0, y0 = apex(A, e)
    theta = impact_phase(A, e)
    assert orbit.x0 == pytest.approx(state(model, p=0.0, y=y0), rel=1e-8, abs=1e-9 * G * T)
    (impact,) = orbit.trajectory.events
    assert impact.t == pytest.approx(theta / OMEGA + T, rel=1e-8)
    p = [s.name for s in model.states].index("p")
    assert impact.x_before[p] == pytest.approx(-G * T / 2, rel=1e-8)
    assert impact.x_after[p] == pytest.approx(G * T / 2, rel=1e-8)
    assert same_multipliers(orbit.multipliers, exact_multipliers(A, e)) < 1e-8
    assert np.linalg.det(orbit.monodromy) == pytest.approx(e * e, rel=1e-8)
    assert orbit.stable == (fraction < 1)


def test_the_other_root_is_a_saddle():
    """``θ = −acos(…)``: the same velocities, an impact while the table accelerates up; a real
    multiplier above 1 (the orbit exists but is never seen)."""
    e = 0.5
    A = 1.2 * gamma_min(e) * G / OMEGA**2
    model, orbit = find_orbit(A, e, root=-1)
    theta = impact_phase(A, e, root=-1)
    (impact,) = orbit.trajectory.events
    assert (impact.t - orbit.t0) == pytest.approx(T / 2, rel=1e-8)
    assert math.cos(OMEGA * impact.t) == pytest.approx(math.cos(theta), rel=1e-8)
    assert math.sin(OMEGA * impact.t) < 0
    mu = exact_multipliers(A, e, root=-1)
    assert mu[0] > 1 and same_multipliers(orbit.multipliers, mu) < 1e-8
    assert not orbit.stable


def test_at_the_period_doubling_amplitude_the_multipliers_are_minus_one_and_minus_e_squared():
    e = 0.5
    A = gamma_flip(e) * G / OMEGA**2
    _, orbit = find_orbit(A, e)
    assert same_multipliers(orbit.multipliers, [-1.0, -e * e]) < 1e-8


def test_continuation_in_the_amplitude_locates_the_period_doubling_and_follows_the_doubled_orbit():
    """The flip at ``Γ_PD`` is supercritical: beyond it the orbit of period ``2T`` (two impacts,
    each obeying the restitution law) is stable; its monodromy contracts area by ``e⁴``."""
    e = 0.5
    A_flip = gamma_flip(e) * G / OMEGA**2
    values = list(A_flip * np.array([0.9, 0.95, 1.05, 1.1]))
    model = vibrating_table.build(A=values[0], e=e)
    t0, y0 = apex(A_flip, e)  # in flight over the whole range
    result = continue_orbit(model, "A", values, period=T, t0=t0, x0=state(model, p=0.0, y=y0), rtol=RTOL,
                            atol=1e-13, tol=1e-9, parameter_tol=1e-9, switch_branch=True)
    assert [point.stable for point in result.points] == [True, True, False, False]
    for point in result.points:
        assert same_multipliers(point.multipliers, exact_multipliers(point.value, e)) < 1e-8
    (flip,) = result.bifurcations
    assert flip.kind == "period doubling"
    assert flip.value == pytest.approx(A_flip, rel=1e-8)
    assert flip.multiplier == pytest.approx(-1.0, abs=1e-8)
    (branch,) = result.branches
    assert branch.points and all(point.value > A_flip for point in branch.points)
    assert [point.value for point in branch.points][-2:] == values[-2:]
    p = [s.name for s in model.states].index("p")
    for point in branch.points:
        orbit = point.orbit
        assert orbit.period == pytest.approx(2 * T, rel=1e-12)
        assert np.prod(orbit.multipliers).real == pytest.approx(e**4, rel=1e-8)
        first, second = orbit.trajectory.events
        assert abs((second.t - first.t) - T) > 1e-3 * T  # two different flights: not the period-1 orbit
        for impact in (first, second):
            table_v = point.value * OMEGA * math.cos(OMEGA * impact.t)
            assert impact.x_after[p] - table_v == pytest.approx(-e * (impact.x_before[p] - table_v), rel=1e-8)
    assert branch.points[branch.values.tolist().index(values[2])].stable


# ------------------------------------------------------------------ from the command line


def on_orbit_at_time_zero(A: float, e: float) -> tuple:
    """``(p, y)`` of the period-1 orbit at ``t = 0`` (``m = 1``): the last impact was at
    ``θ/ω − T``, so ``τ = T − θ/ω`` into the flight ``y = A sin θ + (g T/2) τ − g τ²/2``,
    ``v = g T/2 − g τ``."""
    theta = impact_phase(A, e)
    tau = T - theta / OMEGA
    return G * T / 2 - G * tau, A * math.sin(theta) + G * T / 2 * tau - G * tau**2 / 2


def test_hbg_orbit_finds_the_period_one_orbit_and_its_flip(capsys):
    from models.cli import main

    A, e = vibrating_table.DEFAULTS["A"], vibrating_table.DEFAULTS["e"]
    p0, y0 = on_orbit_at_time_zero(A, e)
    assert main(["orbit", "vibrating-table", "--period", repr(T), "--warmup", "10"]) == 0
    out = capsys.readouterr().out
    assert "stable: yes" in out
    start = dict(part.split(" = ") for part in out.split("x0: ", 1)[1].splitlines()[0].split(", "))
    assert float(start["p"]) == pytest.approx(p0, rel=1e-9)
    assert float(start["y"]) == pytest.approx(y0, rel=1e-9)
    A_flip = gamma_flip(e) * G / OMEGA**2
    assert main(["orbit", "vibrating-table", "--period", repr(T), "--set", f"p={p0!r}", "--set", f"y={y0!r}",
                 "--continue", "A=0.013:0.017:5"]) == 0
    out = capsys.readouterr().out
    flip = float(out.split("period doubling at ", 1)[1].split()[0])
    assert flip == pytest.approx(A_flip, rel=1e-8)


def test_hbg_run_of_the_default_drop_settles_on_the_period_one_orbit(tmp_path, capsys):
    """The default run (a drop from 0.1 m) ends on the stable period-1 orbit: its last impacts at
    the phase ``θ``, with ``v⁺ → g T/2``."""
    from models.cli import main

    target = tmp_path / "table.csv"
    assert main(["run", "vibrating-table", "--method", "RK45", "--csv", str(target)]) == 0
    assert "vibrating_table" in capsys.readouterr().out and target.stat().st_size > 0
    model = vibrating_table.build()
    run = model.simulate(vibrating_table.RUN["t_end"], "RK45", rtol=vibrating_table.RUN["rtol"])
    theta = impact_phase(vibrating_table.DEFAULTS["A"], vibrating_table.DEFAULTS["e"])
    last = run.events[-1]
    assert math.remainder(OMEGA * last.t - theta, 2 * math.pi) == pytest.approx(0.0, abs=1e-3)
    p = [s.name for s in model.states].index("p")
    assert last.x_after[p] == pytest.approx(G * T / 2, rel=1e-3)
