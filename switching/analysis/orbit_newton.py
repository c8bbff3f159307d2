"""Newton's step on the period map, the error of an orbit's start, and what
an iteration that does not converge means (:mod:`switching.analysis.orbits`).

**The step and the error.**  At an iterate ``x`` with ``F = φ(x) − x`` and
``J = M − I`` (autonomous: ``DP − I``), Newton's step is ``δx = −J⁺ F``
(least squares).  Near a regular fixed point ``x*`` Newton converges
quadratically, so ``x − x* ≈ −δx``: the size of one more step,
``max_i |δx_i| / s_i`` (``s_i`` the amplitude of state i over the period, as
the residual's scale), estimates the relative error of ``x``.  A second
estimate is ``residual / min |1 − μ|``, ``μ`` the eigenvalues of ``M`` (of
``DP``): ``x − x* = −J⁻¹ F`` and ``‖J⁻¹‖ = 1/min|1 − μ|`` for a normal ``J``;
it is large near a fold (``μ → 1``), where a small residual does not mean a
small error.  An autonomous orbit's period moves with its start,
``δT = τ_x·δx`` (``τ_x`` the section event's time gradient), so its relative
error ``|τ_x·δx| / T`` is estimated too (the rimless wheel's gait: 1.4e-8 on
the period for 4.6e-9 on the start).  An orbit's ``error`` is the largest of
them; the iteration has converged when it and the residual are at most
``tol``.

**Singular** ``J``: where ``|1 − μ|`` is round-off, at most
``SINGULAR_ULPS·eps·max(1, max|μ|)``, the map has slope 1 along an
eigenvector ``v`` — a piece of it where the state is not restored (a switch
that stays on all period, a free integrator: ``M`` has an exact 1) — and
Newton's step along ``v`` is undetermined (least squares leaves it out, so
every step would be the same): the iteration stops at once, naming ``v``.
A multiplier merely near 1 (near a fold) is no reason to stop: the error
estimate ``residual / |1 − μ|`` says how well the start is determined.

**No convergence** in ``max_iterations`` steps is told apart by the steps'
sizes: still shrinking (the last three each below 0.8 of the one before, the
last below 0.8 of all earlier ones: more iterations would do), or not.  When
they do not shrink, the closest iterate (smallest residual) decides.  A
residual at most ``rtol`` is within the runs' accuracy; a larger one is run
again with ``rtol`` and ``atol`` 100 times smaller: if it falls by 10 or more
it was the runs' round-off too (in both cases the orbit's start is limited by
the integration's accuracy, ``residual / min|1 − μ|``); one that stays is the
map's own: it has no fixed point near the guess, as beyond a fold
(``F(x) ≈ a (x − x_f)² + ε`` with ``ε > 0``: Newton's steps wander at the
scale ``sqrt(ε/a)`` while the residual stays near ``ε``), and
:class:`~switching.errors.NoOrbitError` says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["NewtonStep", "newton_step", "is_singular", "shrinking", "SINGULAR_ULPS", "FINER"]

#: ``|1 − μ|`` at most this many ``eps·max(1, max|μ|)`` is a multiplier 1 up to round-off
SINGULAR_ULPS = 64.0
#: the closest iterate of a failed iteration is run again with ``rtol`` and ``atol`` divided by this
FINER = 100.0


@dataclass(frozen=True)
class NewtonStep:
    """Newton's step at one iterate: ``step`` (n,) ``δx = −J⁺F`` [the states' units]; ``size``: its
    relative size ``max_i |δx_i| / s_i``; ``gap``: ``min |1 − μ|`` (the smallest |eigenvalue| of ``J``);
    ``direction`` (n,): that eigenvalue's eigenvector (unit length, real part); ``residual_error``:
    ``residual / gap``; ``radius``: ``max |μ|``; ``period_error``: ``|τ_x·δx| / T`` (autonomous orbits; 0
    for a fixed period)."""

    step: np.ndarray
    size: float
    gap: float
    direction: np.ndarray
    residual_error: float
    radius: float = 0.0
    period_error: float = 0.0

    @property
    def error(self) -> float:
        """The estimated relative error of the iterate: the largest of ``size``, ``residual_error`` and
        ``period_error``."""
        return max(self.size, self.residual_error, self.period_error)


def newton_step(F, J, scale, residual: float, tau_x=None, period: float | None = None) -> NewtonStep:
    """The Newton step at an iterate (module docstring); ``scale`` (n,) the states' amplitudes; ``tau_x``
    (n,) and ``period`` [s]: an autonomous orbit's section time gradient and period."""
    F, J = np.asarray(F, dtype=float), np.asarray(J, dtype=float)
    n = len(F)
    if n == 0:
        return NewtonStep(np.zeros(0), 0.0, np.inf, np.zeros(0), 0.0, 0.0)
    finite = np.all(np.isfinite(J)) and np.all(np.isfinite(F))
    step = np.linalg.lstsq(J, -F, rcond=None)[0] if finite else np.full(n, np.nan)
    values, vectors = np.linalg.eig(J) if finite else (np.full(n, np.nan), np.eye(n))
    k = int(np.argmin(np.abs(values))) if finite else 0
    gap = float(np.abs(values[k])) if finite else float("nan")
    direction = np.real(vectors[:, k])
    norm = np.linalg.norm(direction)
    direction = direction / norm if norm > 0 else direction
    size = float(np.max(np.abs(step) / scale))
    residual_error = residual / gap if gap > 0 else (0.0 if residual == 0 else np.inf)
    radius = float(np.max(np.abs(values + 1.0)))
    period_error = 0.0 if tau_x is None else float(abs(np.dot(tau_x, step)) / period)
    return NewtonStep(step, size, gap, direction, float(residual_error), radius, period_error)


def is_singular(newton: NewtonStep) -> bool:
    """``J`` is singular up to round-off: ``min|1 − μ| ≤ SINGULAR_ULPS·eps·max(1, max|μ|)``."""
    return bool(newton.gap <= SINGULAR_ULPS * np.finfo(float).eps * max(1.0, newton.radius))


def shrinking(sizes, count: int = 3, ratio: float = 0.8) -> bool:
    """Newton still converging: the last ``count`` step sizes each below ``ratio`` times the one before, and
    the last below ``ratio`` times every earlier one (steps that wander may shrink a few times by chance,
    but they do not reach below all they took before)."""
    sizes = list(sizes)
    if len(sizes) < count + 1:
        return False
    tail = sizes[-count - 1:]
    return all(b < ratio * a for a, b in zip(tail, tail[1:])) and sizes[-1] < ratio * min(sizes[:-1])
