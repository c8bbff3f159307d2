"""Fixed-step runs estimate their own error (issue 29, item 8): step doubling
on a sample of the run's steps, in the stats, and a warning when it is large."""

import warnings

import pytest

from bondgraph import CoarseStepWarning
from models import two_tanks
from switching.simulate.step_doubling import COARSE


def _run(method, dt):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        trajectory = two_tanks.build().simulate(1000.0, method, dt=dt)
    return trajectory, [w for w in caught if issubclass(w.category, CoarseStepWarning)]


@pytest.mark.parametrize("method", ["euler", "euler-jit"])
def test_coarse_euler_on_the_two_tanks_warns_with_the_step_to_take(method):
    """Issue 29: euler at dt = 20 s gave 69 instants against 28 with no warning (|h·λ| ≈ 2.9 in one mode:
    beyond Euler's stability, with the modes changing too often for the stiffness test to see a streak)."""
    trajectory, caught = _run(method, 20.0)
    assert len(caught) == 1 and "dt ≈" in str(caught[0].message) and "rk4" in str(caught[0].message)
    assert trajectory.stats["error estimate (step doubling)"] > 10 * COARSE


def test_a_fine_step_is_silent_and_its_estimate_follows_the_methods_order():
    """Euler's global error is O(dt): halving dt halves the estimate; rk4's is O(dt⁴)."""
    fine, caught = _run("euler", 0.1)
    finer, _ = _run("euler", 0.05)
    assert not caught and fine.stats["error estimate (step doubling)"] < COARSE
    ratio = fine.stats["error estimate (step doubling)"] / finer.stats["error estimate (step doubling)"]
    assert 1.6 < ratio < 2.5
    coarse4, caught4 = _run("rk4", 5.0)
    fine4, _ = _run("rk4", 2.5)
    assert not caught4
    assert 10 < coarse4.stats["error estimate (step doubling)"] / fine4.stats["error estimate (step doubling)"] < 25


def test_adaptive_runs_carry_no_step_doubling_estimate():
    assert "error estimate (step doubling)" not in two_tanks.build().simulate(100.0, "RK45").stats
