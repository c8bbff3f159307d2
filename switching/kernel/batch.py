"""Many runs of one model in one kernel call: :func:`run_many`.

A batch (:mod:`switching.sweep.kernel_batch`) gives each of its ``R`` runs
the same model record ``M`` (modes, tables, compiled functions) with its own
parameter values ``P[r]``, input parameters ``U[r]`` and state tolerances
``ATOL[r]``, its own settings (``ints[r]``, ``floats[r]``: those of
:func:`.loop.run`) and initial state ``X0[r]``.  :func:`run_many` calls
:func:`.loop.run` for each, exactly as a single run's first kernel call
makes it, into the run's own rows of the output arrays; the runs are cut
into ``C`` interleaved chunks (run ``r`` in chunk ``r mod C``), one
workspace each, run in parallel (numba's ``prange``: a thread per chunk,
as many as ``numba.get_num_threads()`` allows).  A run's results do not
depend on the chunk or thread it ran in: each call of :func:`.loop.run`
starts from its own inputs and a freshly carved workspace.

Shapes (``n`` states, ``N`` samples a run, ``E`` events a run, ``T``
requested times):

* ``P`` (R, parameters), ``U`` (R, input parameters), ``ATOL`` (R, n),
  ``X0`` (R, n); ``ints`` (R, 8) int64, ``floats`` (R, 11) [s and -];
* ``te`` (T,) [s]: the requested times, the same for every run;
* ``outs = (out_t (R, N), out_x (R, N, n), out_m (R, N), ev_f (R, E, 1 + 2n),
  ev_i (R, E, 4), info (R, 5 + n))``: each run's ``out`` of :func:`.loop.run`;
* ``works = (wf (C, ·), wi (C, ·), wb (C, ·))``: a workspace per chunk, each
  at least :func:`.loop.workspace_sizes`;
* ``ends`` (R, 6) int64: each run's ``(status, n_saved, n_events, mode,
  steps, n_te)``; ``t_stop`` (R,) [s]: where it stopped.
"""

from __future__ import annotations

from numba import njit, prange

from .calls import Model
from .compiler import stamp_with_rules
from .loop import run

__all__ = ["run_many", "run_many_serial"]


@njit(cache=True, error_model="numpy")
def _one_run(M, P, U, ATOL, ints, floats, X0, te, outs, work, ends, t_stop, implicit, r):
    """Run ``r`` of the batch in the workspace ``work``."""
    out_t, out_x, out_m, ev_f, ev_i, info = outs
    model = Model(M.fns, P[r], U[r], M.tables, M.lengths, M.mstates, M.radix, M.codes, M.n_sides, M.at_once, M.jfns,
                  M.implicit, M.driven, ATOL[r])
    status, n_saved, n_ev, t, m, steps, n_te = run(model, ints[r], floats[r], X0[r], te,
                                                   (out_t[r], out_x[r], out_m[r], ev_f[r], ev_i[r], info[r]), work,
                                                   implicit)
    ends[r, 0] = status
    ends[r, 1] = n_saved
    ends[r, 2] = n_ev
    ends[r, 3] = m
    ends[r, 4] = steps
    ends[r, 5] = n_te
    t_stop[r] = t


@njit(cache=True, error_model="numpy", parallel=True)
def run_many(M, P, U, ATOL, ints, floats, X0, te, outs, works, ends, t_stop, implicit):
    """Run ``r`` of the batch for every ``r`` (see the module docstring); ``implicit`` as for :func:`.loop.run`."""
    wf, wi, wb = works
    runs = X0.shape[0]
    chunks = wf.shape[0]
    for c in prange(chunks):
        work = (wf[c], wi[c], wb[c])
        for r in range(c, runs, chunks):
            _one_run(M, P, U, ATOL, ints, floats, X0, te, outs, work, ends, t_stop, implicit, r)


@njit(cache=True, error_model="numpy")
def run_many_serial(M, P, U, ATOL, ints, floats, X0, te, outs, works, ends, t_stop, implicit):
    """:func:`run_many` on the calling thread alone, in the first workspace: for one thread, and where the
    threading layer cannot start (a process forked from one whose GNU OpenMP pool ran:
    :mod:`switching.sweep.kernel_batch`).  A function of its own, so that numba's disk cache keeps it
    apart from :func:`run_many` (it keys a function's entries by its signature, not its options)."""
    wf, wi, wb = works
    work = (wf[0], wi[0], wb[0])
    for r in range(X0.shape[0]):
        _one_run(M, P, U, ATOL, ints, floats, X0, te, outs, work, ends, t_stop, implicit, r)


stamp_with_rules(globals(), __name__)
