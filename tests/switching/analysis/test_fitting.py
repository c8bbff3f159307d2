"""Least-squares fits with exact Jacobians through instants (issue 18, item 2).

Synthetic measurements from a run at known parameters plus Gaussian noise of
known standard deviation σ (fixed seeds): the fit must recover the
parameters within their statistical error (3 standard errors of the
linearized covariance), and its standard errors must be those the noise
implies (σ·sqrt(diag (JᵀJ)⁻¹), J the model's sensitivities).  Noise-free
data must be fitted to the solver's precision.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from models import bouncing_ball, falling_rod
from switching import FitError, fit, sample_indices
from switching.sweep.batch import shared_model
from switching.analysis.fitting import build_derivatives

BALL_TIMES = np.linspace(0.05, 1.5, 30)  # three flights (impacts at 0.45 and 1.14 s for e = 0.7)


def ball_heights(sigma=0.0, seed=0, **parameters):
    truth = bouncing_ball.build(**parameters).simulate(1.5, "RK45", t_eval=BALL_TIMES, rtol=1e-11, atol=1e-13)
    y = truth.state("y")[sample_indices(truth, BALL_TIMES)]
    return y + np.random.default_rng(seed).normal(0.0, sigma, y.size) if sigma else y


def test_noise_free_heights_give_the_exact_restitution():
    result = fit(bouncing_ball.build, {"y": (BALL_TIMES, ball_heights(e=0.7))}, {"e": 0.6})
    assert result.success
    assert result.values["e"] == pytest.approx(0.7, abs=1e-8)
    assert result.runs < 10  # Gauss–Newton with the exact Jacobian: a few iterates
    assert np.max(np.abs(result.residuals["y"])) < 1e-8


def test_restitution_gravity_and_drop_height_within_their_statistical_error():
    """Three build arguments at once: ``e`` and ``g`` are model parameters,
    ``y0`` is the initial height (through the ``x0:y`` sensitivity)."""
    sigma, truth = 0.01, {"e": 0.7, "g": 9.81, "y0": 1.0}
    data = {"y": (BALL_TIMES, ball_heights(sigma, seed=3, **truth))}
    result = fit(bouncing_ball.build, data, {"e": 0.65, "g": 9.5, "y0": 1.05}, sigma=sigma, absolute_sigma=True)
    assert result.success
    for name, value in truth.items():
        assert abs(result.values[name] - value) < 3 * result.standard_errors[name], (name, result)
    # the error the noise implies: sqrt of (JᵀJ)⁻¹ with J the sensitivities divided by sigma
    assert 1e-4 < result.standard_errors["e"] < 1e-2
    assert result.covariance.shape == (3, 3)
    assert np.allclose(result.covariance, result.covariance.T)
    # the residuals are the noise: their spread is sigma
    assert np.std(result.residuals["y"]) == pytest.approx(sigma, rel=0.35)
    assert "e" in str(result) and "±" in str(result)


def test_errors_over_noise_draws_are_those_the_covariance_predicts():
    """Over 16 noise draws the fitted ``e`` scatters about the truth by its
    standard error: the z-scores ``(ê − e)/se`` have mean ≈ 0 (within
    3/√16) and spread ≈ 1."""
    clean = ball_heights(e=0.7)
    z = []
    for seed in range(16):
        y = clean + np.random.default_rng(100 + seed).normal(0.0, 0.01, clean.size)
        result = fit(bouncing_ball.build, {"y": (BALL_TIMES, y)}, {"e": 0.65}, sigma=0.01, absolute_sigma=True)
        z.append((result.values["e"] - 0.7) / result.standard_errors["e"])
    assert abs(np.mean(z)) < 0.75
    assert 0.6 < np.std(z, ddof=1) < 1.5


def test_estimated_sigma_scales_the_covariance():
    data = {"y": (BALL_TIMES, ball_heights(0.02, seed=5, e=0.7))}
    scaled = fit(bouncing_ball.build, data, {"e": 0.6})
    absolute = fit(bouncing_ball.build, data, {"e": 0.6}, sigma=0.02, absolute_sigma=True)
    assert scaled.values["e"] == pytest.approx(absolute.values["e"], rel=1e-6)
    ratio = scaled.standard_errors["e"] / absolute.standard_errors["e"]
    assert ratio == pytest.approx(np.std(scaled.residuals["y"], ddof=1) / 0.02, rel=0.05)
    assert abs(scaled.values["e"] - 0.7) < 3 * scaled.standard_errors["e"]


def test_the_falling_rods_friction_from_noisy_positions():
    """Positions of the centre while the rod slides after its impact
    (x moves by about 0.25 m per unit of mu at 0.4 s: micrometre noise)."""
    times = np.linspace(0.2, 0.4, 11)  # after the impact at 0.177 s: the rod slides
    sigma = 1e-5
    with shared_model(falling_rod.build, {"mu": 0.002}) as model:  # (the fit's runs then share its derived modes)
        truth = model.simulate(0.4, "RK45", t_eval=times, rtol=1e-10, atol=1e-12)
        x = truth.signal("x_cm")[sample_indices(truth, times)]
    x = x + np.random.default_rng(7).normal(0, sigma, times.size)
    result = fit(falling_rod.build, {"x_cm": (times, x)}, {"mu": 0.0015}, sigma=sigma, absolute_sigma=True,
                 bounds={"mu": (0.0, 0.0045)})
    assert result.success
    assert abs(result.values["mu"] - 0.002) < 3 * result.standard_errors["mu"]
    assert result.standard_errors["mu"] < 1e-4
    # the fitted run has its own model (the shared one moves on with later runs)
    model = result.trajectory.model
    assert model.parameter_values[sp.Symbol("mu")] == pytest.approx(result.values["mu"])


def test_build_derivatives_see_parameters_and_initial_states():
    """The ball's ``y0`` sets the initial height; a mass also sets the initial
    momentum ``p = m·v0``."""
    moved = build_derivatives(bouncing_ball.build, {"e": 0.7, "y0": 1.0, "m": 2.0, "v0": 3.0}, ["e", "y0", "m"])
    assert moved["e"] == pytest.approx({"e": 1.0})
    assert moved["y0"] == pytest.approx({"x0:y": 1.0})
    assert moved["m"] == pytest.approx({"m": 1.0, "x0:p": 3.0})


def test_bad_fits_are_refused_with_the_reason():
    data = {"y": (BALL_TIMES, ball_heights(e=0.7))}
    with pytest.raises(FitError, match="changes neither a parameter nor the initial state"):
        fit(lambda e=0.7, colour="red", shade=1.0: bouncing_ball.build(e=e), data, {"shade": 1.0})
    with pytest.raises(FitError, match="one value per time"):
        fit(bouncing_ball.build, {"y": (BALL_TIMES, [1.0])}, {"e": 0.6})
    with pytest.raises(FitError, match="both fitted and fixed"):
        fit(bouncing_ball.build, data, {"e": 0.6}, fixed={"e": 0.5})
    with pytest.raises(FitError, match=r"the run at \{'e': 0.4\} failed: Zeno"):
        fit(bouncing_ball.build, data, {"e": 0.4})  # the bounces accumulate inside the data's window
