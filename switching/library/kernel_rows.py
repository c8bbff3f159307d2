"""A kernel call's samples and its instants' states merged into rows in time order, in compiled code.

The kernel saves a call's samples (``out_t``, ``out_x``, ``out_m``) apart from its events (``ev_f``:
the time, the state before, the state after; ``ev_i``: the modes before and after, the samples saved
before the event: :func:`switching.kernel.loop.run`).  A run's record wants them as rows in time
order, each instant's pair of rows where it falls (:meth:`switching.simulate.recorder.Recorder.block`).
With numpy that took some 25 small operations a call, most of what a warm call spent recording; one
compiled loop (:func:`fill_rows`, compiled once per installation and kept by numba's disk cache)
does it in a few microseconds, into arrays :func:`merged_rows` makes.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from codegen.jit import guard_cache

__all__ = ["fill_rows", "merged_rows"]


def merged_rows(out_t, out_x, out_m, ev_f, ev_i, n_saved, n_events, lead, kind, before, after):
    """``(t (N,), x (N, n), mode numbers (N,), kinds (N,), the rows of the states after the instants (E,))``
    of ``N = lead + n_saved + 2·n_events`` rows: ``lead`` rows left for the caller, then the ``n_saved``
    samples (each of ``kind``) with every one of the ``n_events`` instants' rows, of ``before`` and
    ``after``, after the samples saved before it (``n_events = 0``: the samples alone).  The arrays are
    made here and filled by :func:`fill_rows` (made in compiled code, they would have the compiled path's
    load import ``numba.np.arrayobj``, with some twenty modules, in every new process)."""
    size = lead + n_saved + 2 * n_events
    rows = (np.empty(size), np.empty((size, out_x.shape[1])), np.empty(size, np.int64), np.empty(size, np.int64),
            np.empty(n_events, np.int64))
    fill_rows(out_t, out_x, out_m, ev_f, ev_i, n_saved, n_events, lead, kind, before, after, *rows)
    return rows


@njit(cache=True)
def fill_rows(out_t, out_x, out_m, ev_f, ev_i, n_saved, n_events, lead, kind, before, after, t, x, numbers, kinds,
              after_rows):
    """The rows of :func:`merged_rows` written into ``t, x, numbers, kinds, after_rows`` (sized as it says)."""
    n = out_x.shape[1]
    row = lead
    saved = 0
    for event in range(n_events + 1):
        stop = ev_i[event, 2] if event < n_events else n_saved
        while saved < stop:
            t[row] = out_t[saved]
            for i in range(n):
                x[row, i] = out_x[saved, i]
            numbers[row] = out_m[saved]
            kinds[row] = kind
            row += 1
            saved += 1
        if event < n_events:
            for side in range(2):
                t[row] = ev_f[event, 0]
                for i in range(n):
                    x[row, i] = ev_f[event, 1 + side * n + i]
                numbers[row] = ev_i[event, side]
                kinds[row] = after if side else before
                row += 1
            after_rows[event] = row - 1


guard_cache(__name__, fill_rows)
