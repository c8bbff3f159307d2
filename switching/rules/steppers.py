"""The fixed-step steppers' arithmetic: Euler's step and the classical
Runge–Kutta combination.

For ``y' = f(t, y)`` and a step ``h`` from ``(t, y)``:

* Euler: ``y₁ = y + h·f(t, y)`` (order 1; the paper's Alg. 1);
* classical RK4 (order 4): the stages ``k₁ = f(t, y)``, ``k₂ = f(t + h/2,
  y + (h/2)·k₁)``, ``k₃ = f(t + h/2, y + (h/2)·k₂)``, ``k₄ = f(t + h, y +
  h·k₃)`` — their arguments are Euler steps (:func:`euler_step` with ``h/2``,
  ``h/2``, ``h``) — and ``y₁ = y + (h/6)·(k₁ + 2·k₂ + 2·k₃ + k₄)``
  (:func:`rk4_combine`).

Between the ends of a step, event location evaluates the step's interpolant:
for Euler the step itself (``euler_step(y, f, τ − t)``), for RK4 the cubic
Hermite polynomial through the ends' values and slopes (:func:`hermite_cubic`,
third order: the order of the dense output, enough to locate events on it).

A continuous extension is a sum of terms (the ends' values, and slopes or
stage combinations times powers of ``θ``), and its value carries their
round-off: where a state starts a step exactly on a guard's threshold (a
current set to 0 at an instant) and moves away, the extension may dip beyond
the step's end values by a few units of round-off of its terms — RODAS4P's
``y₁ + q₁`` is ``h·f₀`` computed as a difference of two numbers of ``y₁``'s
size — and a guard on that state holds inside the step though it holds at
neither end: a diode of a bridge turned off and on again at every step, a
divergence of time of round-off.  :func:`nearer_end`: a value beyond the
nearer end by no more than ``DENSE_ULPS·ε·Σ|terms|`` is that end's value.
The Hermite interpolant's terms are weighed at the ``θ`` evaluated (a
ball's bounce within one fixed RK4 step is a hump above both ends, near
``θ = 0`` where the terms are small, and it stays): for ``θ`` in [0, 1]
``h₁₁ ≤ 0`` and the other weights are ``≥ 0``, so their sum is
``hermite_cubic(|y0|, |f0|, |y1|, −|f1|, |h|, θ)``;
an adaptive method's coefficients (RK45's ``Q``, RODAS4P's ``q₁``, ``q₂``)
carry the round-off of the stages they were formed from, which are of the
ends' size, so theirs count whole.

The caller evaluates ``f`` (the Python path with Python objects, the kernel
through its function pointers) and calls these rules between evaluations.
Each is written component-wise, so it applies as it is to floats (the kernel
calls it for each component; numba inlines it) and to numpy arrays (the Python
path's arrays, whole): the same operations in the same order, so the same
IEEE results either way.
"""

from __future__ import annotations

__all__ = ["RULES", "DENSE_ULPS", "END_SLACK", "euler_step", "fixed_size", "hermite_cubic", "nearer_end",
           "rk4_combine"]

RULES = ("euler_step", "fixed_size", "hermite_cubic", "nearer_end", "rk4_combine")

#: a fixed-step flow whose remainder to its end after one more step ``dt`` is below ``END_SLACK·dt`` takes that
#: step to the end: the remainder is the round-off of the sum of the steps (10 000 steps of 1e-4 from 0 sum to
#: 0.9999999999999062, not 1), not a step of its own (:func:`fixed_size`)
END_SLACK = 1e-5

#: a continuous extension's value within this many units of round-off of its terms beyond the step's end
#: values is the nearer end's value (:func:`nearer_end`)
DENSE_ULPS = 8.0
_EPSILON = 2.220446049250313e-16


def euler_step(y, f, h):
    """``y + h·f``: Euler's step of size ``h`` (and RK4's stage arguments)."""
    return y + h * f


def fixed_size(dt, t, t_end):
    """The size of a fixed step ``dt`` from ``t`` in a flow that ends at ``t_end``: ``dt``, or the rest
    ``t_end − t`` where that is shorter than ``dt·(1 + END_SLACK)`` (a remainder that small is the sum's
    round-off: a run of ``n·dt`` takes ``n`` steps, not ``n + 1``)."""
    rest = t_end - t
    return rest if rest < dt + END_SLACK * dt else dt


def rk4_combine(y, k1, k2, k3, k4, h):
    """``y + (h/6)·(k₁ + 2·k₂ + 2·k₃ + k₄)``: the classical RK4 step from its
    four stages."""
    return y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


def hermite_cubic(y0, f0, y1, f1, h, theta):
    """The cubic Hermite interpolant of a step of size ``h`` from ``(y0,
    f0)`` to ``(y1, f1)`` (values and slopes) at ``t + θ·h``:
    ``h₀₀·y0 + h₁₀·h·f0 + h₀₁·y1 + h₁₁·h·f1`` with ``h₀₀ = 2θ³ − 3θ² + 1``,
    ``h₁₀ = θ³ − 2θ² + θ``, ``h₀₁ = −2θ³ + 3θ²``, ``h₁₁ = θ³ − θ²``.

    The powers are products (``θ² = θ·θ``, ``θ³ = θ²·θ``), which is what numba
    compiles ``θ**3`` to; Python's ``θ**3`` calls ``pow`` and may differ in the
    last bit."""
    theta2 = theta * theta
    theta3 = theta2 * theta
    h00 = 2 * theta3 - 3 * theta2 + 1
    h10 = theta3 - 2 * theta2 + theta
    h01 = -2 * theta3 + 3 * theta2
    h11 = theta3 - theta2
    return h00 * y0 + h10 * h * f0 + h01 * y1 + h11 * h * f1


def nearer_end(v, y0, y1, terms):
    """``v``, a continuous extension's value between the step's end values
    ``y0`` and ``y1``, with a value beyond the nearer of them by no more than
    ``DENSE_ULPS·ε·terms`` (``terms``: the sum of the magnitudes of the terms
    that formed ``v``) replaced by that end's value (module docstring).  The
    choices are products with 0 or 1, so the result is ``v``, ``y0`` or
    ``y1`` exactly (for finite ends)."""
    first_lower = y0 <= y1
    lo = y0 * first_lower + y1 * (1 - first_lower)
    hi = y1 * first_lower + y0 * (1 - first_lower)
    slack = DENSE_ULPS * _EPSILON * terms
    below = (v < lo) & (v >= lo - slack)
    above = (v > hi) & (v <= hi + slack)
    return lo * below + hi * above + v * ((1 - below) - above)
