"""The falling rod against an independent reference (issue 12, item 3).

``tests/rod_reference.py`` simulates the rod on a floor with numpy/scipy only
(single tip contact; Coulomb friction in flight, stick and slide; paper and
Newton–Coulomb impact laws; lift-off when the normal force would go
negative).  Here:

* self-tests of the reference: closed-form free fall, a stuck rod against
  the hand-derived pendulum about the tip, energy and momentum balances,
  the impact laws' impulses;
* the toolkit (``models.falling_rod``) against the reference: every case runs
  to the time ``t_B`` the far end reaches the floor without error, lives the
  same continuous modes in the same order, and ends in the same state
  (``<= 1e-6`` in every state).

The default set (18 tests, ~40 s, nearly all of it the toolkit deriving and
generating the code of each mode it visits for the first time) holds the
self-tests and 8 named cases: the issue's example, a sticking impact followed
at once by slip, a sliding impact followed at once by lift-off (both impact
laws), the paper's rod sticking and sliding, a slide that reverses, a slide
that sticks again.  Marked ``slow`` (``pytest -m slow
tests/models/test_rod_reference.py`` or ``HBG_SLOW=1``; ~1 min): the full grid —
θ0 in [0.2, 1.4] (7 values) × μ in [0.01, 5] (9 log-spaced values) × two rod
lengths (l = 0.1 m dropped 0.01 m, l = 0.5 m dropped 0.5 m) × both impact
laws = 252 cases — two more named Newton–Coulomb cases and a check that the
shared-model shortcut of :func:`run_toolkit` equals a plain run.

The Newton–Coulomb law differs from the paper's only at sliding impacts; the
grid runs it on every point anyway (where no impact slides it must give the
paper law's result, which is a check too).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import rod_reference as rr

STATE_TOL = 1e-6
#: modes living less than this [s] are not counted (instants only)
MIN_DURATION = 1e-12

# ---------------------------------------------------------------- the cases


def rod(l, theta0, mu, impact_law="paper", drop=None, y0=None, m=1.0):
    """Parameters of a uniform rod (``J = m (2l)²/12``) released at rest with its
    tip ``drop`` [m] above the floor (or its centre at ``y0``)."""
    if y0 is None:
        y0 = l * math.sin(theta0) + drop
    return dict(m=m, J=m * (2 * l) ** 2 / 12, l=l, mu=float(mu), theta0=float(theta0), y0=float(y0),
                impact_law=impact_law)


#: the grid's rod lengths [m] with the tip's drop height [m]: a short rod dropped from 0.1 l
#: (impacts that stick, slides that stick again) and a long one from l (impacts that lift off)
LENGTHS = ((0.1, 0.01), (0.5, 0.5))
THETAS = np.round(np.linspace(0.2, 1.4, 7), 6)
MUS = np.round(np.geomspace(0.01, 5.0, 9), 6)
LAWS = ("paper", "newton-coulomb")

GRID = [
    pytest.param(rod(l, th, mu, law, drop=h), id=f"l={l}-theta0={th:g}-mu={mu:g}-{law}")
    for law in LAWS
    for l, h in LENGTHS
    for th in THETAS
    for mu in MUS
]

#: named cases: id → (parameters, in the default set?)
CASES = {
    # the issue's example: the impact sticks (|P_t| <= mu P_n), but the stuck mode would need a
    # pulling floor (N < 0) while a free tip would accelerate into it: the tip slides (+x) at once
    "issue-example": (dict(m=1.0, J=1 / 12, l=0.5, mu=5.0, theta0=0.3, y0=1.0, impact_law="paper"), True),
    "issue-example-newton-coulomb": (
        dict(m=1.0, J=1 / 12, l=0.5, mu=5.0, theta0=0.3, y0=1.0, impact_law="newton-coulomb"), False),
    # sticking impact followed at once by slip with N > 0: after the impact the stuck
    # forces leave the cone (F = -1.68 N, N = 2.11 N, mu N = 1.15 N)
    "stick-impact-then-slip": (rod(0.5, 0.2, 0.5433, drop=0.15), True),
    # sliding impact followed at once by lift-off (then the tip rises past y_lift, and lands again)
    "slide-impact-then-liftoff": (rod(0.5, 0.8, 0.05, y0=1.0), True),
    "slide-impact-then-liftoff-newton-coulomb": (rod(0.5, 0.8, 0.05, "newton-coulomb", y0=1.0), True),
    # the paper's rod (Figs. 19-20 parameters): mu = 0.005 sticks at the impact, slips much later
    "paper-stick": (dict(m=1.0, J=1.0, l=0.1, mu=0.005, theta0=0.862, y0=0.23, impact_law="paper"), True),
    # mu = 0.004 slides from the impact on (the stuck mode is mythical), sticks again at v_th
    "paper-slide": (dict(m=1.0, J=1.0, l=0.1, mu=0.004, theta0=0.862, y0=0.23, impact_law="paper"), True),
    # sliding impact, then the slide reverses
    "slide-reverse": (rod(0.5, 0.6, 0.1, drop=0.5), True),
    "slide-reverse-newton-coulomb": (rod(0.5, 0.6, 0.1, "newton-coulomb", drop=0.5), False),
    # a slide that sticks again (|v_Ax| reaches v_th with the stuck forces inside the cone)
    "slide-then-stick": (rod(0.5, 0.3, 0.5433, drop=0.01), True),
}
NAMED = [
    pytest.param(params, id=name, marks=() if fast else pytest.mark.slow)
    for name, (params, fast) in CASES.items()
]


# ---------------------------------------------------------------- comparison


def toolkit_segments(trajectory):
    """``(contact, friction, t_start, t_end)`` of every continuous mode the toolkit lived."""
    starts = [(float(trajectory.t[0]), trajectory.modes[0])]
    for instant in trajectory.events:
        continuous = [s for s in instant.steps if s.kind == "continuous"]
        if continuous:
            starts.append((float(instant.t), continuous[-1].mode))
    segments = []
    for k, (t0, mode) in enumerate(starts):
        t1 = starts[k + 1][0] if k + 1 < len(starts) else float(trajectory.t[-1])
        segments.append((mode.state_of("contact"), mode.state_of("friction"), t0, t1))
    return segments


def lived(segments):
    """The continuous modes in order, zero-duration ones omitted, repeats merged."""
    modes = []
    for c, f, t0, t1 in segments:
        if t1 - t0 > MIN_DURATION and (not modes or modes[-1] != (c, f)):
            modes.append((c, f))
    return modes


def describe(segments):
    return "; ".join(f"{c}|{f} [{t0:.9g}, {t1:.9g}]" for c, f, t0, t1 in segments)


def run_toolkit(params, t_end, shared=True):
    """``models.falling_rod.build(**params).simulate(t_end, "RK45", rtol=1e-10, atol=1e-12)``.

    ``shared``: through :func:`switching.sweep.batch.shared_model`, which moves the
    run's parameter values onto a model of the same structure built earlier in
    this process (its derived modes and generated code are reused; the values
    are read at every call), so a case costs ~0.1 s instead of deriving every
    mode anew (~2–10 s); ``test_shared_model_run_is_a_plain_run`` checks that
    both give the same trajectory."""
    from models import falling_rod

    if not shared:
        return falling_rod.build(**params).simulate(t_end, "RK45", rtol=1e-10, atol=1e-12)
    from switching.sweep.batch import shared_model

    with shared_model(falling_rod.build, params) as model:
        return model.simulate(t_end, "RK45", rtol=1e-10, atol=1e-12)


def compare(params, shared=True):
    """Run both; return ``(ok, message)``."""
    ref = rr.simulate(**params)
    head = [f"parameters: {params}", f"t_B = {ref.t_B:.12g} s"]
    ref_text = f"reference modes: {describe(ref.segments)}"
    events = "reference instants: " + "; ".join(f"{t:.9g} {text}" for t, text in ref.events)
    notes = [f"reference notes: {ref.notes}"] if ref.notes else []
    try:
        trajectory = run_toolkit(params, ref.t_B, shared)
    except Exception as exc:  # noqa: BLE001 - the report names whatever the toolkit raised
        text = str(exc).splitlines() or [""]
        lines = head + [f"toolkit raised {type(exc).__name__}: {text[0]}"]
        lines += [f"    {line[:240]}{' …' if len(line) > 240 else ''}" for line in text[1:12]]
        partial = getattr(exc, "trajectory", None)
        if partial is not None and len(partial.t):
            segments = toolkit_segments(partial)
            lines.append(f"toolkit   modes (until it stopped): {describe(segments)}")
            lines.append(f"MODE SEQUENCES: toolkit (partial) {['|'.join(m) for m in lived(segments)]} vs "
                         f"reference {['|'.join(m) for m in ref.modes]}")
        lines.append("worst state difference: none (no final state)")
        return False, "\n".join(lines + [ref_text, events] + notes)
    segments = toolkit_segments(trajectory)
    tk_modes, ref_modes = lived(segments), ref.modes
    expected = ref.toolkit_state(trajectory.state_names)
    diff = np.abs(trajectory.x[-1] - expected)
    worst = int(np.argmax(diff))
    lines = head + [
        f"toolkit   modes: {describe(segments)}",
        ref_text,
        events,
        f"worst state difference: {trajectory.state_names[worst]} = {diff[worst]:.3g} "
        f"(toolkit {trajectory.x[-1][worst]:.12g}, reference {expected[worst]:.12g})",
    ] + notes
    ok = tk_modes == ref_modes and diff[worst] <= STATE_TOL and abs(trajectory.t[-1] - ref.t_B) < 1e-12
    if tk_modes != ref_modes:
        lines.insert(2, f"MODE SEQUENCES DIFFER: toolkit {['|'.join(m) for m in tk_modes]} vs "
                        f"reference {['|'.join(m) for m in ref_modes]}")
    return ok, "\n".join(lines)


@pytest.mark.parametrize("params", NAMED)
def test_named_case_matches_reference(params):
    ok, message = compare(params)
    assert ok, message


@pytest.mark.slow
@pytest.mark.parametrize("params", GRID)
def test_grid_matches_reference(params):
    ok, message = compare(params)
    assert ok, message


@pytest.mark.slow
def test_shared_model_run_is_a_plain_run():
    """The shared-model shortcut of :func:`run_toolkit` gives what a fresh
    ``build(...).simulate(...)`` gives (after an earlier run with other values)."""
    first = dict(m=1.0, J=1 / 12, l=0.5, mu=0.05, theta0=0.8, y0=1.0, impact_law="paper")
    second = dict(m=1.0, J=1 / 300, l=0.1, mu=0.3, theta0=1.1, y0=0.2, impact_law="paper")
    run_toolkit(first, 0.5)
    shared = run_toolkit(second, 0.4)
    plain = run_toolkit(second, 0.4, shared=False)
    assert np.array_equal(shared.t, plain.t) and np.array_equal(shared.x, plain.x)
    assert shared.mode_labels == plain.mode_labels


def test_named_cases_show_what_they_claim():
    """The named cases exercise the transitions they are named after (in the reference)."""
    def events(params):
        return [text for _, text in rr.simulate(**params).events]

    params = CASES["stick-impact-then-slip"][0]
    assert events(params)[0] == "impact: free|stuck -> contact|slide_pos (passed contact|stuck)"
    ref = rr.RodReference(**{k: v for k, v in params.items() if k in ("m", "J", "l", "mu")})
    s = rr.initial_state(params["theta0"], params["y0"])
    _, s_impact, _ = ref.flow(0.0, s, "free", "stuck", 5.0, 1e-12, 1e-14)
    Pt, Pn = ref.stuck_impulse(s_impact)
    F, N = ref.forces("contact", "stuck", ref.jump_stuck(s_impact))
    assert abs(Pt) <= ref.mu * Pn and N > 0 and abs(F) > ref.mu * N
    lift = events(CASES["slide-impact-then-liftoff"][0])
    assert lift[0] == "impact: free|stuck -> free|slide_neg (passed contact|slide_neg)"
    assert lift[1] == "rise: free|slide_neg -> free|stuck"
    assert any(e.startswith("reverse") for e in events(CASES["slide-reverse"][0]))
    assert any(e.startswith("stick") for e in events(CASES["slide-then-stick"][0]))
    assert any(e.startswith("stick") for e in events(CASES["paper-slide"][0]))
    issue = events(CASES["issue-example"][0])
    assert issue[0] == "impact: free|stuck -> contact|slide_pos (passed contact|stuck)"


# ---------------------------------------------------------------- the reference on its own

G = 9.81


def test_reference_free_fall_is_closed_form():
    l, th0, y0 = 0.5, 0.7, 1.3
    ref = rr.RodReference(m=2.0, J=0.3, l=l, g=G, mu=0.3)
    t, s, name = ref.flow(0.0, rr.initial_state(th0, y0, 0.25), "free", "stuck", 5.0, 1e-12, 1e-14)
    t_exact = math.sqrt(2 * (y0 - l * math.sin(th0)) / G)
    assert name == "impact"
    assert abs(t - t_exact) < 1e-12
    expected = [0.25, y0 - G * t_exact**2 / 2, th0, 0.0, -2.0 * G * t_exact, 0.0]
    assert np.allclose(s, expected, rtol=0, atol=1e-11)


def test_reference_stuck_rod_is_a_pendulum_about_the_tip():
    """Stuck, the rod turns about ``A``: ``(J + m l²) θ'' = −m g l cos θ``, and the
    floor's force is ``m a_centre + (0, m g)`` with ``a_centre`` of that rotation."""
    m, J, l, mu = 1.5, 0.2, 0.4, 50.0
    ref = rr.RodReference(m=m, J=J, l=l, g=G, mu=mu)
    th0, w0 = 1.3, -0.5
    # the centre is at A + l (cos θ, sin θ) with A at the origin, moving with the rotation
    s0 = np.array([l * math.cos(th0), l * math.sin(th0), th0,
                   -m * l * math.sin(th0) * w0, m * l * math.cos(th0) * w0, J * w0])
    assert np.allclose(ref.tip_velocity(s0), 0, atol=1e-15)
    t_end, s_end, name = ref.flow(0.0, s0, "contact", "stuck", 0.3, 1e-12, 1e-14)
    assert name is None and t_end == 0.3  # no slip, no lift-off, far end still up

    def pendulum(t, z):
        return [z[1], -m * G * l * math.cos(z[0]) / (J + m * l * l)]

    sol = solve_ivp(pendulum, (0, 0.3), [th0, w0], method="DOP853", rtol=1e-13, atol=1e-14)
    th, w = sol.y[:, -1]
    assert abs(s_end[2] - th) < 1e-9
    assert abs(s_end[5] / J - w) < 1e-9
    assert abs(s_end[0] - l * math.cos(th)) < 1e-9 and abs(s_end[1] - l * math.sin(th)) < 1e-9
    # forces
    alpha = pendulum(0, [th, w])[1]
    ax = l * (-math.sin(th) * alpha - math.cos(th) * w * w)
    ay = l * (math.cos(th) * alpha - math.sin(th) * w * w)
    F, N = ref.forces("contact", "stuck", s_end)
    assert abs(F - m * ax) < 1e-9 and abs(N - (m * ay + m * G)) < 1e-9
    assert abs(ref.energy(s_end) - ref.energy(s0)) < 1e-10


def test_reference_frictionless_rod_keeps_px_and_energy():
    """With ``μ = 0`` no horizontal force acts: ``p_x`` stays 0; energy is lost only
    at the impact (the paper law is frictionless) and kept while sliding."""
    params = rod(0.5, 1.0, 0.0, drop=0.05)
    result = rr.simulate(**params)
    # the centre falls straight down; the tip slides to and fro, never sticking (the cone is a line)
    assert result.modes[:2] == [("free", "stuck"), ("contact", "slide_neg")]
    assert set(result.modes[1:]) == {("contact", "slide_neg"), ("contact", "slide_pos")}
    assert abs(result.state_B[0]) < 1e-13
    assert abs(result.state_B[3]) < 1e-13
    ref = rr.RodReference(m=1.0, J=params["J"], l=0.5, mu=0.0)
    s = rr.initial_state(1.0, params["y0"])
    t, s_impact, name = ref.flow(0.0, s, "free", "stuck", 5.0, 1e-12, 1e-14)
    s_plus = ref.jump_slide(s_impact, -1.0)
    assert ref.energy(s_plus) < ref.energy(s_impact)
    assert abs(ref.energy(result.state_B) - ref.energy(s_plus)) < 1e-9


def test_reference_sliding_dissipates():
    """Sliding, ``dE/dt = F v_Ax = −μ N |v_Ax| ≤ 0``."""
    params = rod(0.5, 0.6, 0.3, drop=0.5)
    ref = rr.RodReference(m=1.0, J=params["J"], l=0.5, mu=0.3)
    s = rr.initial_state(0.6, params["y0"])
    _, s_impact, _ = ref.flow(0.0, s, "free", "stuck", 5.0, 1e-12, 1e-14)
    s_plus = ref.jump_slide(s_impact, -1.0)
    assert ref.tip_velocity(s_plus)[0] < 0
    energies = [ref.energy(s_plus)]
    t = 0.0
    for _ in range(5):
        t, s_plus, name = ref.flow(t, s_plus, "contact", "slide_neg", t + 0.01, 1e-12, 1e-14)
        assert name is None
        energies.append(ref.energy(s_plus))
    assert all(b < a for a, b in zip(energies, energies[1:]))


@pytest.mark.parametrize("theta", [0.2, 0.862, 1.4])
def test_reference_impacts(theta):
    """Impulses at the tip keep the angular momentum about the tip; the stuck impact
    stops the tip; the slide impacts stop its normal velocity; the Newton–Coulomb
    normal impulse is the model docstring's ``P_n = −v_Ay / (1/m + l² cos θ (cos θ +
    σ μ sin θ)/J)``; a uniform rod falling flat-out sticks iff ``μ ≥ 3 s c/(1 + 3 s²)``."""
    m, l, mu = 1.0, 0.5, 0.3
    J = m * l * l / 3
    s = np.array([0.1, l * math.sin(theta), theta, 0.2, -2.0, 0.3])
    for law in ("paper", "newton-coulomb"):
        ref = rr.RodReference(m=m, J=J, l=l, mu=mu, impact_law=law)
        L = ref.tip_angular_momentum(s)
        stuck = ref.jump_stuck(s)
        assert np.allclose(ref.tip_velocity(stuck), 0, atol=1e-14)
        assert abs(ref.tip_angular_momentum(stuck) - L) < 1e-13
        for sigma in (1.0, -1.0):
            after = ref.jump_slide(s, sigma)
            assert abs(ref.tip_velocity(after)[1]) < 1e-14
            assert abs(ref.tip_angular_momentum(after) - L) < 1e-13
            Pt, Pn = ref.slide_impulse(s, sigma)
            if law == "paper":
                assert Pt == 0 and after[3] == s[3]
            else:
                c, sn = math.cos(theta), math.sin(theta)
                vAy = ref.tip_velocity(s)[1]
                assert abs(Pn - (-vAy / (1 / m + l * l * c * (c + sigma * mu * sn) / J))) < 1e-13
                assert abs(Pt + sigma * mu * Pn) < 1e-15
    c, sn = math.cos(theta), math.sin(theta)
    Pt, Pn = ref.stuck_impulse(np.array([0.0, 1.0, theta, 0.0, -1.0, 0.0]))
    assert abs(Pt / Pn - 3 * sn * c / (1 + 3 * sn * sn)) < 1e-13


def test_reference_paper_threshold():
    """The paper's rod (m = 1, J = 1, l = 0.1, θ = 0.862): the stuck impact needs
    ``|P_t| = 0.0049 P_n``, so μ = 0.005 sticks and μ = 0.004 slides (towards −x)."""
    stuck = rr.simulate(m=1.0, J=1.0, l=0.1, mu=0.005, theta0=0.862, y0=0.23)
    slid = rr.simulate(m=1.0, J=1.0, l=0.1, mu=0.004, theta0=0.862, y0=0.23)
    assert stuck.modes[:2] == [("free", "stuck"), ("contact", "stuck")]
    assert slid.modes[:2] == [("free", "stuck"), ("contact", "slide_neg")]
    t_impact = math.sqrt(2 * (0.23 - 0.1 * math.sin(0.862)) / G)
    assert abs(stuck.events[0][0] - t_impact) < 1e-12


def test_reference_stick_jump_is_plastic():
    """The slide → stuck jump stops the tip and keeps the angular momentum about it
    (momentum along the directions the stuck constraint leaves free)."""
    ref = rr.RodReference(m=1.0, J=1 / 12, l=0.5, mu=0.5)
    th = 0.7
    w = -1.2
    s = np.array([0.5 * math.cos(th), 0.5 * math.sin(th), th, 0.0, 0.0, w / 12])
    # put the tip on the floor sliding at -v_th: v_A = (−0.0015, 0)
    vx = -0.0015 - 0.5 * math.sin(th) * w
    vy = 0.5 * math.cos(th) * w
    s[3], s[4] = vx, vy
    assert np.allclose(ref.tip_velocity(s), [-0.0015, 0.0], atol=1e-15)
    after = ref.jump_stuck(s)
    assert np.allclose(ref.tip_velocity(after), 0, atol=1e-15)
    assert abs(ref.tip_angular_momentum(after) - ref.tip_angular_momentum(s)) < 1e-15
    assert ref.energy(after) < ref.energy(s)
