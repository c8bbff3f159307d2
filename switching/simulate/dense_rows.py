"""States between a run's rows: the cubic Hermite interpolant of each flow interval.

Between two consecutive rows ``k`` and ``k + 1`` of one flow (the same mode,
``t_k < t_{k+1}``, no instant between them) the states at ``τ`` are

    x(τ) = h₀₀(s)·x_k + h₁₀(s)·h·f_k + h₀₁(s)·x_{k+1} + h₁₁(s)·h·f_{k+1},
    s = (τ − t_k)/h,  h = t_{k+1} − t_k,
    h₀₀ = 2s³ − 3s² + 1, h₁₀ = s³ − 2s² + s, h₀₁ = −2s³ + 3s², h₁₁ = s³ − s²,

with ``f_k = f(x_k, t_k)`` the mode's flow at the row.  Its error is
``O(h⁴)`` in the row spacing ``h``, the order of the dense outputs of the
4th/5th-order methods; on a solver's steps it draws the curve the solver
followed, not the chords between its steps (a 50 Hz sine stepped 20 times a
period is a triangle wave drawn with chords).  A mode's dependent states are
completed from the interpolated independent ones (its constraints).  An
interval with an instant inside it (rows at requested times, ``t_eval``), two
modes, or a flow that is not finite at an end is not interpolated.
"""

from __future__ import annotations

import numpy as np

__all__ = ["interpolable", "hermite_states"]


def interpolable(t: np.ndarray, modes: list, event_times: np.ndarray) -> np.ndarray:
    """``usable[k]`` (``len(t) − 1`` booleans): rows ``k`` and ``k + 1`` bound one flow interval, the same
    mode at both, ``t_k < t_{k+1}`` and no instant strictly between them."""
    if len(t) < 2:
        return np.zeros(0, dtype=bool)
    same = np.fromiter((a == b for a, b in zip(modes[:-1], modes[1:])), dtype=bool, count=len(t) - 1)
    usable = same & (t[1:] > t[:-1])
    if len(event_times):
        events = np.sort(np.asarray(event_times, dtype=float))
        inside = np.searchsorted(events, t[1:], side="left") > np.searchsorted(events, t[:-1], side="right")
        usable &= ~inside
    return usable


def hermite_states(model, t: np.ndarray, x: np.ndarray, modes: list, usable: np.ndarray,
                   times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(rows, states, kept)`` at ``times`` [s] strictly inside the usable intervals (module docstring):
    ``rows[j]`` the interval's first row, ``states[j]`` the interpolated state (n,), ``kept`` the indices
    into ``times`` that were interpolated (the others fall on a row or an interval left out)."""
    times = np.asarray(times, dtype=float)
    k = np.searchsorted(t, times, side="right") - 1
    valid = (k >= 0) & (k < len(t) - 1)
    k_safe = np.clip(k, 0, max(len(t) - 2, 0))
    valid &= usable[k_safe] if len(usable) else False
    valid &= times > t[k_safe]
    kept = np.flatnonzero(valid)
    rows = k[kept]
    ends = np.unique(np.concatenate([rows, rows + 1]))
    rates = _row_rates(model, t, x, modes, ends)
    finite = np.isfinite(rates[rows]).all(axis=1) & np.isfinite(rates[rows + 1]).all(axis=1)
    kept, rows = kept[finite], rows[finite]
    h = (t[rows + 1] - t[rows])[:, None]
    s = (times[kept][:, None] - t[rows][:, None]) / h
    s2, s3 = s * s, s * s * s
    states = ((2 * s3 - 3 * s2 + 1) * x[rows] + (s3 - 2 * s2 + s) * h * rates[rows]
              + (3 * s2 - 2 * s3) * x[rows + 1] + (s3 - s2) * h * rates[rows + 1])
    _complete(model, states, times[kept], [modes[r] for r in rows])
    return rows, states, kept


def _row_rates(model, t, x, modes, rows) -> np.ndarray:
    """``f(x_k, t_k)`` in each row's mode for the ``rows`` asked, one call per mode (NaN elsewhere and
    where it cannot be evaluated)."""
    rates = np.full(x.shape, np.nan)
    by_mode: dict = {}
    for r in rows:
        by_mode.setdefault(modes[r], []).append(r)
    for mode, members in by_mode.items():
        members = np.asarray(members)
        rates[members] = model.compiled_mode(mode).rates_at(x[members], t[members])
    return rates


def _complete(model, states, times, modes) -> None:
    """The dependent states of each row from its independent ones, in place (a mode's constraints)."""
    for j, mode in enumerate(modes):
        compiled = model.compiled_mode(mode)
        if len(compiled.dependent):
            compiled.complete(states[j], float(times[j]))
