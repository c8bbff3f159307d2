"""The narrowing of an event's bracket (switching.rules.bracket.narrow_begin,
narrow_next, switching_part): the same adjacent numbers as bisection wherever
the guards change truth once, never more probes than bisection's worst case
plus one, far fewer on a smooth guide, and the same probes called and
compiled."""

import math
import random

import numpy as np
import pytest

from switching.rules.bracket import BISECTIONS, PROBES, halve, narrow_begin, narrow_next, switching_part


def _bisection(holds, lo, hi):
    """The bracket of plain bisection (GuardScan's before the narrowing) and its probes."""
    probes = 0
    for _ in range(BISECTIONS):
        more, mid = halve(lo, hi)
        if not more:
            break
        probes += 1
        if holds(mid):
            hi = mid
        else:
            lo = mid
    return (lo, hi), probes


def _worst_bisection(lo, hi):
    """Bisection's most probes to reach adjacent numbers in ``(lo, hi]`` (0 < lo: the spacing at lo the least)."""
    return math.ceil(math.log2((hi - lo) / np.spacing(lo)))


def _narrowed(holds, value, lo, hi, begin=narrow_begin, step=narrow_next):
    done, state = step(begin(lo, hi, value(lo)), True, value(hi))
    probes = 0
    while not done:
        tau = state[-1]
        assert state[0] < tau < state[1]
        probes += 1
        done, state = step(state, holds(tau), value(tau))
    return (state[0], state[1]), probes


GUIDES = {
    # name: guide of u = (τ − root)/width (within ±1 in the bracket); the guards hold from the root on (τ ≥ root)
    "linear": lambda u: u,
    "convex": lambda u: math.expm1(8.0 * u),  # regula falsi alone creeps from one end
    "concave": lambda u: -math.expm1(-8.0 * u),
    "cubic": lambda u: u**3,  # a flat root
    "kink": lambda u: max(u, 30.0 * u),
    "steep": lambda u: math.atan(1e6 * u),
}


@pytest.mark.parametrize("shape", sorted(GUIDES))
def test_the_narrowing_finds_bisections_bracket_with_at_most_one_probe_more(shape):
    rng = random.Random(31)
    counts = []
    for _ in range(200):
        lo = rng.uniform(0.0, 3.0) * 10 ** rng.randint(-3, 3)
        hi = lo + rng.uniform(1e-6, 1.0) * max(lo, 1.0)
        root = lo + rng.uniform(0.0, 1.0) * (hi - lo)

        def holds(tau):
            return tau >= root

        expected, bisections = _bisection(holds, lo, hi)
        bracket, probes = _narrowed(holds, lambda tau: GUIDES[shape]((tau - root) / (hi - lo)), lo, hi)
        assert bracket == expected
        assert probes <= _worst_bisection(lo, hi) + 1
        counts.append(probes / max(bisections, 1))
    if shape in ("linear", "convex", "concave"):  # (a triple root, a kink at the root, a step: interpolation
        # gains little there, the bound holds)
        assert np.median(counts) < 0.5


def test_the_narrowing_of_a_smooth_guide_takes_about_a_dozen_probes_where_bisection_takes_fifty():
    root = 0.45152364098573056
    (lo, hi), probes = _narrowed(lambda tau: tau >= root, lambda tau: (tau - root) * (2.0 - tau), 0.36, 0.48)
    assert (lo, hi) == _bisection(lambda tau: tau >= root, 0.36, 0.48)[0]
    assert hi == np.nextafter(lo, math.inf)
    assert probes <= 16


@pytest.mark.parametrize("value", [
    lambda tau: math.nan,  # no guide: bisection
    lambda tau: 1.0,  # a guide of the wrong sign at lo
    lambda tau: -1.0,  # … at hi
    lambda tau: math.inf if tau > 0.7 else -math.inf,
    lambda tau: 0.7 - tau,  # the guide disagrees with the guards everywhere
])
def test_a_guide_that_misleads_costs_probes_never_the_bracket(value):
    root = 0.3141592653589793

    def holds(tau):
        return tau >= root

    expected, bisections = _bisection(holds, 0.1, 1.0)
    bracket, probes = _narrowed(holds, value, 0.1, 1.0)
    assert bracket == expected
    assert probes <= _worst_bisection(0.1, 1.0) + 1


def test_where_the_guards_change_truth_more_than_once_the_bracket_is_one_of_the_changes():
    edges = [0.2, 0.25, 0.6, 0.61]  # holding on [0.2, 0.25) and from 0.6 on... and again from 0.61

    def holds(tau):
        return sum(tau >= e for e in edges) % 2 == 1 or tau >= edges[-1]

    (lo, hi), probes = _narrowed(holds, lambda tau: min(abs(tau - e) for e in edges) * (1 if holds(tau) else -1),
                                 0.0, 1.0)
    assert not holds(lo) and holds(hi) and hi == np.nextafter(lo, math.inf)
    assert probes <= PROBES


def test_the_guide_is_the_first_tracked_part_that_changes_truth():
    signs = (1, 0, -1, 1)
    assert switching_part((False, True, True, True), (True, True, True, True), signs, 4) == 0
    assert switching_part((True, True, False, True), (True, False, True, True), signs, 4) == 2  # part 1 untracked
    assert switching_part((False, True, False, True), (True, True, True, True), signs, 4) == 0  # two: the first
    assert switching_part((True,) * 4, (True,) * 4, signs, 4) == -1
    assert switching_part((True, True, True, False), (True, True, True, True), signs, 3) == -1  # beyond count


def test_the_narrowing_and_its_guide_python_and_compiled_agree_to_the_bit():
    numba = pytest.importorskip("numba")
    begin, step, compiled_part = numba.njit(narrow_begin), numba.njit(narrow_next), numba.njit(switching_part)
    rng = random.Random(5)
    for _ in range(60):
        lo = rng.uniform(-2.0, 2.0)
        hi = lo + 10 ** rng.uniform(-9, 0)
        root = lo + rng.random() * (hi - lo)
        curvature = rng.uniform(-30.0, 30.0)

        def value(tau):
            return math.expm1(curvature * (tau - root)) if curvature else tau - root

        def holds(tau):
            return tau >= root

        trace_python, trace_compiled = [], []
        for begin_, step_, trace in ((narrow_begin, narrow_next, trace_python), (begin, step, trace_compiled)):
            done, state = step_(begin_(lo, hi, value(lo)), True, value(hi))
            while not done:
                trace.append(repr(state))
                done, state = step_(state, holds(state[-1]), value(state[-1]))
            trace.append(repr(state))
        assert trace_python == trace_compiled
    for _ in range(200):
        count = rng.randrange(6)
        lo_truths = np.array([rng.random() < 0.5 for _ in range(count)])
        hi_truths = np.array([t if rng.random() < 0.7 else not t for t in lo_truths], dtype=bool)
        signs = np.array([rng.choice([-1, 0, 1]) for _ in range(count)], dtype=np.int64)
        assert compiled_part(lo_truths, hi_truths, signs, count) == switching_part(lo_truths, hi_truths, signs, count)


def test_the_python_path_locates_each_bounce_in_a_dozen_evaluations_at_bisections_times(monkeypatch):
    """The bouncing ball's four impacts (RK45, the Python path): each located in at most 16 evaluations of the
    guards (bisection took about 50), at the very times bisection finds (the guide withheld: no part to follow)."""
    from models import bouncing_ball
    from switching.simulate import events

    probes = []
    inside = []
    point = events.GuardScan.point
    locate = events.GuardScan.locate

    def counted_point(self, tau, x=None):
        if inside:
            probes[-1] += 1
        return point(self, tau, x)

    def counted_locate(self, a, b):
        probes.append(0)
        inside.append(True)
        try:
            return locate(self, a, b)
        finally:
            inside.pop()

    monkeypatch.setattr(events.GuardScan, "point", counted_point)
    monkeypatch.setattr(events.GuardScan, "locate", counted_locate)
    narrowed = bouncing_ball.build().simulate(2.5, "RK45", rtol=1e-8, output="events")
    assert len(narrowed.event_times) == 4 and len(probes) == 4
    assert max(probes) <= 16

    monkeypatch.setattr(events, "switching_part", lambda *arguments: -1)
    probes.clear()
    bisected = bouncing_ball.build().simulate(2.5, "RK45", rtol=1e-8, output="events")
    assert len(probes) == 4 and min(probes) >= 45
    assert narrowed.event_times.tolist() == bisected.event_times.tolist()
    assert narrowed.x[-1].tolist() == bisected.x[-1].tolist()
