"""A fixed-step run's estimate of its own error, by step doubling.

A method of order ``p`` makes an error ``e_h ≈ C·h^(p+1)`` in a step of
size ``h``; one step of ``h`` (``y₁``) and two of ``h/2`` (``y₂``) from the
same state differ by ``y₁ − y₂ ≈ C·h^(p+1)·(1 − 2^(−p))``, so

    e_h ≈ (y₁ − y₂) / (1 − 2^(−p)).

On :data:`SAMPLED_STEPS` steps spread over the run (a step of ``dt`` from
the state recorded at the start of a step of a flow, whether the run's step
was whole or cut short by an event) the mean ``|e_h|`` per state, times the
number of steps of the run, estimates the global error, which is compared
with the size of each state over the run (its largest ``|x|``; a state that
stays 0 is compared with the largest of all): the largest ratio is the
run's relative error estimate, kept in its stats.  An explicit step beyond
its stability limit shows as a local error of the order of the state
itself (Euler at ``|h·λ| > 2``: ``(h·λ)²·|x|``), also where the modes change
too often for the stiffness test to see a streak.  Above :data:`COARSE` it
warns (:class:`~bondgraph.CoarseStepWarning`) with the
``dt`` that would bring it to 1 %: ``dt·(0.01/estimate)^(1/p)``.  The sum
over steps is pessimistic where the flow damps its errors (a stable,
dissipative mode), and the estimate sees the flows only, not an instant
located late by a coarse step; it costs ``3·SAMPLED_STEPS`` steps.
"""

from __future__ import annotations

import warnings

import numpy as np

from bondgraph.errors import CoarseStepWarning, HybridBondGraphError

from .flow_rates import flow_functions

__all__ = ["COARSE", "SAMPLED_STEPS", "error_estimate", "warn_if_coarse"]

#: steps sampled for the estimate
SAMPLED_STEPS = 64
#: a relative error estimate above this warns (the estimate sums the local errors: pessimistic, up to ~10×,
#: where the flow damps them)
COARSE = 0.1


def error_estimate(model, trajectory, method, dt: float) -> float | None:
    """The relative global error estimate of a fixed-step run (see the
    module docstring) of ``method`` (its class: ``order``, ``integrator``) with
    step ``dt`` [s]; ``None`` when the run has no full step to sample."""
    t = np.asarray(trajectory.t, dtype=float)
    modes = trajectory.modes
    full = [k for k in range(len(t) - 1) if modes[k] == modes[k + 1] and t[k + 1] > t[k]]  # (a step from k, whole
    # or cut short by an event: the method's step of dt from that state is what is estimated)
    if not full or method.order is None:
        return None
    picked = [full[int(i)] for i in np.unique(np.linspace(0, len(full) - 1, min(SAMPLED_STEPS, len(full))).round())]
    p = method.order
    integrator = method.integrator if method.python is method else method.python.integrator  # (a compiled
    # method's steps are its Python twin's)
    n = len(model.states)
    errors = np.zeros(n)
    for k in picked:
        cm = model.compiled_mode(modes[k])
        fun, state_at, y0 = flow_functions(model, cm, np.array(trajectory.x[k], dtype=float))
        one = integrator(fun, t[k], y0, t[k] + dt, dt, True, None, False)  # (no stiffness test: a step is asked)
        halves = integrator(fun, t[k], y0, t[k] + dt, dt / 2, True, None, False)
        _, y1 = one.step()
        halves.step()
        _, y2 = halves.step()
        errors += np.abs(state_at(t[k] + dt, y1) - state_at(t[k] + dt, y2)) / (1 - 2.0 ** -p)
    steps = int(trajectory.stats.get("steps", len(full)))
    scale = np.max(np.abs(np.asarray(trajectory.x, dtype=float)), axis=0)
    scale = np.where(scale > 0, scale, np.max(scale) if np.max(scale) > 0 else 1.0)
    with np.errstate(invalid="ignore", over="ignore"):
        relative = errors / len(picked) * steps / scale
    relative = relative[np.isfinite(relative)]
    return float(np.max(relative)) if len(relative) else None


def warn_if_coarse(model, trajectory, method, dt: float) -> float | None:
    """:func:`error_estimate`, and a :class:`~bondgraph.CoarseStepWarning`
    (once) when it is above :data:`COARSE`; ``None`` when it cannot be told."""
    try:
        estimate = error_estimate(model, trajectory, method, dt)
    except (HybridBondGraphError, ArithmeticError, ValueError):
        return None
    if estimate is not None and estimate > COARSE:
        better = dt * (0.01 / estimate) ** (1.0 / method.order)
        warnings.warn(
            f"{method.name} with dt = {dt:g} s: the run's own error estimate (step doubling on a sample of its "
            f"steps) is {estimate:.2g} of the states' size; its instants and states may be far off. Take dt ≈ {better:.3g} s for about 1 %, rk4, "
            "or an adaptive method (RK45)", CoarseStepWarning, stacklevel=6)  # (the caller of HybridModel.simulate)
    return estimate
