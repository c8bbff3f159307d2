"""Fixed-step runs estimate their own error (issue 29, item 8): step doubling
on a sample of the run's steps, in the stats, and a warning when it is large."""

import warnings

import numpy as np
import pytest

from bondgraph import CoarseStepWarning, EnergyGainWarning
from models import ball_chain, two_tanks
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


def test_a_fine_step_is_silent():
    fine, caught = _run("euler", 0.1)
    assert not caught and fine.stats["error estimate (step doubling)"] < COARSE


@pytest.mark.parametrize("method, order", [("euler", 1), ("rk4", 4)])
def test_the_estimate_follows_the_methods_order(method, order):
    """An undamped contact (a harmonic oscillator, ω = √(2k/m)) within one contact: the global error of a
    method of order p is O(dt^p), and so is the estimate (the fitted slope of log estimate against log dt)."""
    k = 1e4
    model = ball_chain.build(N=2, compliant=True, k=k, b=0.0, distance=0.0)
    omega = np.sqrt(2 * k)
    steps = np.array([0.1, 0.05, 0.025]) / omega
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CoarseStepWarning)
        warnings.simplefilter("ignore", EnergyGainWarning)  # (Euler gains energy on an undamped oscillator)
        estimates = [model.simulate(0.02, method, dt=h).stats["error estimate (step doubling)"] for h in steps]
    slope = np.polyfit(np.log(steps), np.log(estimates), 1)[0]
    assert slope == pytest.approx(order, abs=0.1)


def test_adaptive_runs_carry_no_step_doubling_estimate():
    assert "error estimate (step doubling)" not in two_tanks.build().simulate(100.0, "RK45").stats
