"""The record of a run: the samples kept (every step, the instants, or the
requested times ``t_eval`` [s] read from the steps' interpolants), the
instants, and the time [s] spent in each mode; it makes the
:class:`~switching.simulate.trajectory.Trajectory`.

The record holds every sample the run made, each with its kind (a state of
the run — its start, a step, its end, where it failed —, a requested time,
or an instant's state before or after it); the trajectory's rows are chosen
from it by the run's sampling (:meth:`Recorder.rows`):

* ``"steps"``/``"events"`` (no requested times): every sample recorded;
* ``"times"`` (``t_eval``): the requested times only, exactly as asked;
* ``"samples"`` (``samples=N``): the requested times and every instant's
  before and after rows, in time order.

A requested time ``τ`` at an instant's time ``t_k`` gets the state after
the instant (the trajectory is right-continuous there, as scipy's
``solve_ivp`` samples a restarted solution): its row follows the instant's
pair.  A run that did not reach ``t_end`` (a failure, ``on_zeno="stop"``)
ends its rows with the state where it stopped.
"""

from __future__ import annotations

import numpy as np

from .trajectory import Trajectory

__all__ = ["Recorder", "STATE", "REQUESTED", "BEFORE", "AFTER"]

#: the kinds of a recorded sample: a state of the run (its start, a step, its end, where it stopped),
#: a requested time, an instant's state just before it, just after it
STATE, REQUESTED, BEFORE, AFTER = 0, 1, 2, 3


class Recorder:
    """The samples of a run as it goes: ``output="steps"`` keeps every step,
    ``"events"`` only what is forced (the start, the instants, the end);
    ``t_eval`` [s] adds the states at those times (:meth:`dense`, or
    :meth:`requested` for a sample the kernel made); ``with_instants``: the
    trajectory's rows are the requested times and the instants' pairs
    (``samples=N``), else only the requested times; ``keep_instants=False``
    keeps only the instants' count; ``projection`` ``(t0, given,
    projected)``: the start was the given state projected onto the initial
    mode's constraints (the energy ledger records it)."""

    def __init__(self, model, output, t_eval, keep_instants=True, projection=None, with_instants=False):
        self.model = model
        self.projection = projection
        self.output = output
        self.keep_instants = keep_instants
        self.n_events = 0
        self.last_instant = None
        self.mode_time: dict = {}  # flow time per mode [s], whatever samples are kept
        self.boundary = None  # the time of the last instant (or the start)
        self.t_eval = None if t_eval is None else np.asarray(sorted(t_eval), dtype=float)
        self.sampling = "steps" if t_eval is None else "samples" if with_instants else "times"
        self.eval_pos = 0
        self.t: list = []
        self.x: list = []
        self.modes: list = []
        self.kinds: list = []
        self.events: list = []
        self.event_index: list = []

    def _append(self, t, x, mode, kind):
        self.t.append(float(t))
        self.x.append(x)
        self.modes.append(mode)
        self.kinds.append(kind)

    def sample(self, t, x, mode, force=False):
        """A state of the run (a step, or with ``force`` its start, end or where it stopped)."""
        if force or self.output == "steps":
            self._append(t, np.array(x, dtype=float), mode, STATE)

    def requested(self, t, x, mode):
        """The state at a requested time ``t`` [s] (sampled by the kernel on its dense output)."""
        self._append(t, np.array(x, dtype=float), mode, REQUESTED)

    def dense(self, t0, t1, evaluate, mode):
        """Samples at requested times in ``[t0, t1]`` [s] from the step interpolant ``evaluate(τ)``."""
        if self.t_eval is None:
            return
        te = self.t_eval
        while self.eval_pos < len(te) and te[self.eval_pos] <= t1:
            tau = te[self.eval_pos]
            if tau >= t0:
                self._append(tau, evaluate(tau), mode, REQUESTED)
            self.eval_pos += 1

    def finish(self, t, x, mode):
        """The requested times not sampled yet up to ``t`` [s], where the run
        ended in state ``x``: a run that ends with an instant (at ``t_end``, or
        stopped at a Zeno accumulation) has flowed no further, and the state
        after that instant is its state at ``t`` (right-continuous)."""
        if self.t_eval is None:
            return
        te = self.t_eval
        while self.eval_pos < len(te) and te[self.eval_pos] <= t:
            self._append(te[self.eval_pos], np.array(x, dtype=float), mode, REQUESTED)
            self.eval_pos += 1

    def start(self, t):
        self.boundary = float(t)

    def event(self, instant):
        self.n_events += 1
        self.last_instant = instant
        self._flowed(instant.t, instant.mode_before)
        if not self.keep_instants:
            return
        self._append(instant.t, instant.x_before.copy(), instant.mode_before, BEFORE)
        self._append(instant.t, instant.x_after.copy(), instant.mode_after, AFTER)
        self.events.append(instant)
        self.event_index.append(len(self.t) - 1)

    def _flowed(self, t, mode):
        if self.boundary is not None and t > self.boundary:
            self.mode_time[mode] = self.mode_time.get(mode, 0.0) + (t - self.boundary)
        self.boundary = max(self.boundary if self.boundary is not None else t, t)

    def rows(self, complete: bool = True) -> tuple:
        """``(rows, event_index)``: the indices of the recorded samples that
        are the trajectory's rows under the run's sampling (see the module
        docstring), and the row of each kept instant's "after" state among
        them (empty when the rows hold no instants: ``t_eval``).  A run that
        is not ``complete`` (it stopped before ``t_end``) also keeps its last
        recorded state when it is later than the last row."""
        n = len(self.t)
        if self.sampling == "steps":
            return list(range(n)), list(self.event_index)
        wanted = (REQUESTED,) if self.sampling == "times" else (REQUESTED, BEFORE, AFTER)
        rows = [k for k in range(n) if self.kinds[k] in wanted]
        if not complete and n and (not rows or self.t[n - 1] > self.t[rows[-1]]):
            rows.append(n - 1)
        if self.sampling == "times":
            return rows, []
        position = {k: j for j, k in enumerate(rows)}
        return rows, [position[k] for k in self.event_index]

    def trajectory(self, stopped=None, stats=None, complete=False, all_rows=False):
        """The :class:`Trajectory` of the run so far: the rows of its sampling
        (:meth:`rows`; every recorded sample with ``all_rows``); ``complete``:
        the run reached ``t_end``."""
        stats = dict(stats or {})
        stats["instants"] = self.n_events
        n = len(self.model.states)
        if all_rows or self.sampling == "steps":  # every sample recorded: the lists as they are
            times, xs, modes, event_index = self.t, self.x, self.modes, list(self.event_index)
        else:
            rows, event_index = self.rows(complete)
            times, xs, modes = [self.t[k] for k in rows], [self.x[k] for k in rows], [self.modes[k] for k in rows]
        x = np.array(xs).reshape(len(xs), n) if xs else np.zeros((0, n))
        mode_time = dict(self.mode_time)
        if self.t and self.boundary is not None and self.t[-1] > self.boundary:
            mode_time[self.modes[-1]] = mode_time.get(self.modes[-1], 0.0) + (self.t[-1] - self.boundary)
        return Trajectory(self.model, times, x, modes, self.events, event_index, stopped, stats,
                          mode_time=mode_time, instants_kept=self.keep_instants, initial_projection=self.projection,
                          sampling=self.sampling)
