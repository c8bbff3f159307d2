"""The run a model file carries when none was given: the model's own, or one read off its time scales.

``model.save()`` writes a ``[run]`` section always: the ``run`` given, else the settings of the model's
last run (``model.last_run``: ``t_end`` and the method and options it was run with), else a ``t_end`` the
model's time scales suggest (:func:`suggested_t_end`), said in a comment of the file.  A file without a
``t_end`` is run for the suggested time too, and the command line says so (never a silent 1 s: a
100 kHz converter saved without its run was simulated for 100 000 periods).

The longest of the runs its time scales suggest:

* the sinusoids of time in its sources and guards (a PWM carrier, a 50 Hz line): 20 periods of the
  slowest (:mod:`switching.model.source_periods`);
* the eigenvalues ``λ`` of the flow's Jacobian ``∂f/∂x`` in the initial mode at the initial state
  (central differences of the generated rates): 5 of the slowest decay's time constants
  ``1/min(−Re λ)``, else 10 periods ``2π/|Im λ|`` of the slowest oscillation;

else 1 s, said to have no time scale behind it (a ball falling: its flow has no eigenvalue but 0).
"""

from __future__ import annotations

import math

import numpy as np

from switching.model.source_periods import guard_periods, source_periods

__all__ = ["suggested_t_end", "default_run"]

#: periods of the slowest source or clock a suggested run covers
PERIODS = 20
#: time constants of the slowest decay a suggested run covers
TIME_CONSTANTS = 5
#: periods of the slowest oscillation a suggested run covers
OSCILLATIONS = 10


def suggested_t_end(model) -> tuple[float, str]:
    """``(t_end [s], why)``: the longest of the runs the model's time scales suggest (module docstring)."""
    candidates = []
    periods = source_periods(model) + guard_periods(model)
    if periods:
        slowest = max(periods)
        candidates.append((PERIODS * slowest, f"{PERIODS} periods of its slowest source or clock ({slowest:.6g} s)"))
    eigenvalues = _initial_eigenvalues(model)
    decays = [-value.real for value in eigenvalues if value.real < 0 and math.isfinite(value.real)]
    turns = [abs(value.imag) for value in eigenvalues if value.imag != 0 and math.isfinite(value.imag)]
    if decays:
        tau = 1.0 / min(decays)
        candidates.append((TIME_CONSTANTS * tau, f"{TIME_CONSTANTS} times its slowest time constant ({tau:.6g} s) "
                                                 "in its initial mode"))
    elif turns:
        period = 2 * math.pi / min(turns)
        candidates.append((OSCILLATIONS * period, f"{OSCILLATIONS} periods of its slowest oscillation "
                                                  f"({period:.6g} s) in its initial mode"))
    if not candidates:
        return 1.0, "1 s: no time scale in its sources, clocks or initial mode"
    return max(candidates)


def default_run(model) -> tuple[dict, str | None]:
    """``(run, why)``: the model's last run's settings (``why`` None), else the suggested ``t_end``."""
    last = getattr(model, "last_run", None)
    if last:
        return dict(last), None
    t_end, why = suggested_t_end(model)
    return {"t_end": float(f"{t_end:.6g}")}, why


def _initial_eigenvalues(model) -> np.ndarray:
    """The eigenvalues of ``∂f/∂x`` over the independent states of the initial mode at the initial state
    (empty where the flow cannot be evaluated there)."""
    try:
        mode = model.initial_mode
        compiled = model.compiled_mode(mode)
        x = np.array(model.initial_state(), dtype=float)
        independent = list(compiled.independent)
        jacobian = np.empty((len(independent), len(independent)))
        for column, k in enumerate(independent):
            h = 1e-6 * max(1.0, abs(x[k]))
            up, down = x.copy(), x.copy()
            up[k] += h
            down[k] -= h
            difference = compiled.rates(compiled.complete(up, 0.0), 0.0) - compiled.rates(compiled.complete(down, 0.0),
                                                                                         0.0)
            jacobian[:, column] = difference[independent] / (2 * h)
        if not np.all(np.isfinite(jacobian)):
            return np.zeros(0)
        return np.linalg.eigvals(jacobian)
    except Exception:  # noqa: BLE001 - a suggestion only: a flow that cannot be evaluated gives none
        return np.zeros(0)
