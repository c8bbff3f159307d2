"""A run notices when its method creates energy (issue 30, item 4): Euler on
an undamped compliant contact multiplies its energy by 1 + (h·ω)² a step."""

import warnings

import numpy as np
import pytest

import models
from bondgraph import EnergyGainWarning
from switching.simulate.energy_watch import CREATED_TOLERANCE, energy_created

K, M = 1e4, 1.0
OMEGA = np.sqrt(2 * K / M)  # the relative motion of two balls of mass m on a spring k: reduced mass m/2


def _contact():
    """Two balls in contact from t = 0 (ball 1 at 1 m/s): an undamped spring k between them, no source."""
    return models.load("ball_chain").build(N=2, compliant=True, k=K, b=0.0, distance=0.0, gap=0.0)


def _run(method, h_omega, t_end=0.05):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        trajectory = _contact().simulate(t_end, method, dt=h_omega / OMEGA)
    return trajectory, [w for w in caught if issubclass(w.category, EnergyGainWarning)]


@pytest.mark.parametrize("method", ["euler", "euler-jit"])
@pytest.mark.parametrize("h_omega", [1.0, 1.9])
def test_euler_on_an_undamped_contact_warns_once_naming_time_mode_and_remedy(method, h_omega):
    trajectory, caught = _run(method, h_omega)
    assert len(caught) == 1
    text = str(caught[0].message)
    assert "contact1=touch" in text and "t = " in text and "smaller dt" in text
    # Euler multiplies the energy of the relative motion, E_rel = (m/2)·v0²/2 = 0.25 J, by 1 + (hω)² at each
    # step (the centre of mass's 0.25 J is kept exactly): all of that gain is created by the method
    assert trajectory.stats["energy created in flows [J]"] > CREATED_TOLERANCE * 0.5
    balance = energy_created(trajectory)
    first_step = np.flatnonzero(np.diff(trajectory.t) > 0)[0]
    assert balance.created[first_step + 1] == pytest.approx(0.25 * h_omega**2, rel=1e-9)


@pytest.mark.parametrize("method", ["rk4", "rk4-jit"])
def test_rk4_below_its_stability_limit_stays_silent(method):
    trajectory, caught = _run(method, 0.5)
    assert not caught and trajectory.stats["energy created in flows [J]"] <= 0


def test_an_accurate_run_with_sources_and_dissipation_closes_its_balance():
    """The bouncing ball (gravity a source, no dissipation in flight): rk4 at a fine step creates nothing."""
    model = models.load("bouncing_ball").build()
    with warnings.catch_warnings():
        warnings.simplefilter("error", EnergyGainWarning)
        trajectory = model.simulate(1.0, "rk4", dt=1e-3)
    assert abs(trajectory.stats["energy created in flows [J]"]) < 1e-6 * energy_created(trajectory).scale


def test_adaptive_runs_are_not_checked():
    trajectory = _contact().simulate(0.05, "RK45")
    assert "energy created in flows [J]" not in trajectory.stats
