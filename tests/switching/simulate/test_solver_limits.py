"""Runs that the solvers must finish (issue 45, items 5-9): the step limit
counts the steps a run takes, and a fixed-step run of ``n·dt`` takes ``n``."""

from __future__ import annotations

import pytest

from switching_models import rc_relay


@pytest.mark.parametrize("method", ["euler", "rk4", "euler-jit", "rk4-jit"])
def test_a_run_of_n_fixed_steps_fits_max_steps_n(method):
    # 10 000 steps of 1e-4 from 0 sum to 0.9999999999999062: the remainder is round-off, not a 10 001st step
    trajectory = rc_relay().simulate(1.0, method, dt=1e-4, max_steps=10_000)
    assert trajectory.t[-1] == 1.0
