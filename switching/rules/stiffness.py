"""The fixed-step methods' stiffness rule (:mod:`switching.simulate.integrators`):
when is an estimate of ``|h·λ|`` evidence that Euler or RK4 runs beyond its
stability limit?

Each step gives ``P ≈ (h·ρ)⁴`` (``ρ`` the spectral radius of the Jacobian,
``h`` the step in seconds: ``h·ρ`` has no unit) from differences of ``f``.
With the method's stability limit ``L`` (Euler 2, RK4 2.78):

* ``P ≤ L⁴`` (or NaN): calm, the streak of steps beyond the limit restarts
  at 0;
* otherwise the streak grows by one, and the flow is stiff when the streak
  reaches :data:`STREAK` steps, or at once when ``|h·λ| = P^¼ > c·L`` with
  ``c`` the single-step factor (1.25 for an autonomous flow: a fixed step
  that far beyond the limit diverges within a few steps; ``∞`` for a flow
  driven by inputs, which may show one such estimate at a jump of an input).
"""

from __future__ import annotations

__all__ = ["AT_ONCE", "RULES", "STREAK", "fixed_stiffness"]

RULES = ("fixed_stiffness",)

STREAK = 3  # consecutive steps beyond the limit
AT_ONCE = 1.25  # … or one step this factor beyond it (autonomous flows)


def fixed_stiffness(power4, limit, at_once, streak):
    """One step's verdict: ``power4`` the estimate of ``(h·ρ)⁴``, ``limit``
    the stability limit ``L``, ``at_once`` the single-step factor ``c``,
    ``streak`` the steps beyond the limit so far.  Returns ``(streak,
    h_lambda)``: the new streak, or −1 when the flow is stiff, and
    ``|h·λ| = power4^¼`` (0 when calm)."""
    if not power4 > (limit * limit) * (limit * limit):  # (limit**4 as numba computes it: both paths agree)
        return 0, 0.0
    streak += 1
    h_lambda = power4**0.25
    if streak >= STREAK or h_lambda > at_once * limit:
        return -1, h_lambda
    return streak, h_lambda
