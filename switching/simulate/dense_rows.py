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

__all__ = ["interpolable", "hermite_states", "hermite_nodes", "row_rates", "numbered"]


def numbered(modes: list) -> tuple[np.ndarray, list]:
    """``(numbers, distinct)``: each row's mode as its place in ``distinct`` (the modes in order of first
    appearance) — the form the functions here take a run's modes in (:meth:`Trajectory.mode_numbers`)."""
    if not len(modes):
        return np.zeros(0, dtype=np.int64), []
    ids = np.fromiter(map(id, modes), dtype=np.int64, count=len(modes))  # (a run shares few mode objects)
    _, first, inverse = np.unique(ids, return_index=True, return_inverse=True)
    places: dict = {}
    order = np.argsort(first, kind="stable")
    number_of = np.empty(len(first), dtype=np.int64)
    for k in order:  # equal modes that are distinct objects share one number, in order of first appearance
        number_of[k] = places.setdefault(modes[first[k]], len(places))
    return number_of[inverse.ravel()], list(places)


def interpolable(t: np.ndarray, modes: tuple, event_times: np.ndarray) -> np.ndarray:
    """``usable[k]`` (``len(t) − 1`` booleans): rows ``k`` and ``k + 1`` bound one flow interval, the same
    mode at both (``modes``: :func:`numbered`), ``t_k < t_{k+1}`` and no instant strictly between them."""
    if len(t) < 2:
        return np.zeros(0, dtype=bool)
    numbers = modes[0]
    usable = (numbers[1:] == numbers[:-1]) & (t[1:] > t[:-1])
    if len(event_times):
        events = np.sort(np.asarray(event_times, dtype=float))
        inside = np.searchsorted(events, t[1:], side="left") > np.searchsorted(events, t[:-1], side="right")
        usable &= ~inside
    return usable


def hermite_states(model, t: np.ndarray, x: np.ndarray, modes: tuple, usable: np.ndarray,
                   times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(rows, states, kept)`` at ``times`` [s] strictly inside the usable intervals (module docstring;
    ``modes``: :func:`numbered`): ``rows[j]`` the interval's first row, ``states[j]`` the interpolated
    state (n,), ``kept`` the indices into ``times`` that were interpolated (the others fall on a row, in
    an interval left out, or beside a row whose flow is not finite)."""
    times = np.asarray(times, dtype=float)
    k = np.searchsorted(t, times, side="right") - 1
    valid = (k >= 0) & (k < len(t) - 1)
    k_safe = np.clip(k, 0, max(len(t) - 2, 0))
    valid &= usable[k_safe] if len(usable) else False
    valid &= times > t[k_safe]
    kept = np.flatnonzero(valid)
    rows = k[kept]
    needed = np.zeros(len(t), dtype=bool)
    needed[rows] = needed[rows + 1] = True
    rates = row_rates(model, t, x, modes, np.flatnonzero(needed))
    finite = np.isfinite(rates[rows]).all(axis=1) & np.isfinite(rates[rows + 1]).all(axis=1)
    kept, rows = kept[finite], rows[finite]
    s = ((times[kept] - t[rows]) / (t[rows + 1] - t[rows]))[:, None]
    return rows, hermite_nodes(model, t, x, modes, rows, s, rates), kept


def hermite_nodes(model, t: np.ndarray, x: np.ndarray, modes: tuple, rows: np.ndarray, s: np.ndarray,
                  rates: np.ndarray) -> np.ndarray:
    """The interpolant at ``k`` points of each of ``P`` intervals at once: ``rows`` (P,) the intervals'
    first rows, ``s`` (P, k) the points as fractions of each interval, ``rates`` the rows' flows
    (:func:`row_rates`) → states (P·k, n), the points of one interval together.  The cubic in Horner
    form, ``x = x_k + s·(c₁ + s·(c₂ + s·c₃))`` with ``c₁ = h·f_k``, ``c₂ = 3Δ − h·(2f_k + f_{k+1})``,
    ``c₃ = h·(f_k + f_{k+1}) − 2Δ``, ``Δ = x_{k+1} − x_k`` — the module docstring's polynomial, its
    coefficients formed once an interval; the dependent states completed as there."""
    h = (t[rows + 1] - t[rows])[:, None]
    x0, f0, f1 = x[rows], rates[rows], rates[rows + 1]
    delta = x[rows + 1] - x0
    c1, c2, c3 = h * f0, 3 * delta - h * (2 * f0 + f1), h * (f0 + f1) - 2 * delta
    points = s.shape[1]
    s = s[:, :, None]
    states = (x0[:, None, :] + s * (c1[:, None, :] + s * (c2[:, None, :] + s * c3[:, None, :]))).reshape(
        len(rows) * points, x.shape[1])
    node_rows = np.repeat(rows, points)
    for mode, members in by_mode(modes, node_rows):
        compiled = model.compiled_mode(mode)
        if len(compiled.dependent):
            times = (t[node_rows] + (t[node_rows + 1] - t[node_rows]) * s.reshape(-1))[members]
            states[members] = compiled.complete_at(states[members], times)
    return states


def by_mode(modes: tuple, rows: np.ndarray):
    """``(mode, positions)`` for each mode some of ``rows`` are in: the positions in ``rows`` of its rows."""
    numbers, distinct = modes
    chosen = numbers[rows]
    for k in np.unique(chosen):
        yield distinct[k], np.flatnonzero(chosen == k)


def row_rates(model, t, x, modes: tuple, rows) -> np.ndarray:
    """``f(x_k, t_k)`` in each row's mode (``modes``: :func:`numbered`) for the ``rows`` asked, one call per
    mode (NaN elsewhere and where it cannot be evaluated)."""
    rates = np.full(x.shape, np.nan)
    rows = np.asarray(rows, dtype=np.int64)
    for mode, members in by_mode(modes, rows):
        chosen = rows[members]
        rates[chosen] = model.compiled_mode(mode).rates_at(x[chosen], t[chosen])
    return rates
