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

A kernel call's samples and instants arrive at once (:meth:`Recorder.block`) and are
kept as arrays, joined into the trajectory's columns when it is made: a warm compiled
run spends no time per row in Python.

A requested time ``τ`` at an instant's time ``t_k`` gets the state after
the instant (the trajectory is right-continuous there, as scipy's
``solve_ivp`` samples a restarted solution): its row follows the instant's
pair.  A run that did not reach ``t_end`` (a failure, ``on_zeno="stop"``)
ends its rows with the state where it stopped.
"""

from __future__ import annotations

import numpy as np

from .trajectory import Trajectory

__all__ = ["Recorder", "ModeTimes", "STATE", "REQUESTED", "BEFORE", "AFTER"]

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
        self.boundary = None  # the time of the last instant (or the start)
        self._flows_from = None  # the boundary the flows logged start from (the start)
        self._flows: list = []  # the flows up to each instant, in order (see ModeTimes), summed when asked
        self.t_eval = None if t_eval is None else np.asarray(sorted(t_eval), dtype=float)
        self.sampling = "steps" if t_eval is None else "samples" if with_instants else "times"
        self.eval_pos = 0
        self._pieces: list = []  # rows recorded at once, in order: (t (k,), x (k, n), modes [k], kinds (k,))
        self._in_pieces = 0  # how many
        self._t: list = []  # the rows recorded one at a time after the pieces
        self._x: list = []
        self._modes: list = []
        self._kinds: list = []
        self.events: list = []
        self.event_index: list = []

    @property
    def t(self) -> list:
        """The time [s] of every sample recorded."""
        self._join()
        return self._t

    @property
    def x(self) -> list:
        """The state (n,) of every sample recorded."""
        self._join()
        return self._x

    @property
    def modes(self) -> list:
        """The mode of every sample recorded."""
        self._join()
        return self._modes

    @property
    def kinds(self) -> list:
        """The kind (:data:`STATE`, :data:`REQUESTED`, :data:`BEFORE`, :data:`AFTER`) of every sample recorded."""
        self._join()
        return self._kinds

    @property
    def last_time(self) -> float | None:
        """The time [s] of the latest sample recorded (``None`` before the first), the pieces left as they are."""
        if self._t:
            return self._t[-1]
        return float(self._pieces[-1][0][-1]) if self._pieces else None

    @property
    def n_rows(self) -> int:
        """How many samples are recorded."""
        return self._in_pieces + len(self._t)

    def _append(self, t, x, mode, kind):
        self._t.append(float(t))
        self._x.append(x)
        self._modes.append(mode)
        self._kinds.append(kind)

    def _close(self) -> None:
        """The rows recorded one at a time made a piece (a block follows them)."""
        if self._t:
            n = len(self.model.states)
            self._pieces.append((np.array(self._t, dtype=float), np.array(self._x).reshape(len(self._x), n),
                                 self._modes, np.array(self._kinds, dtype=np.int64)))
            self._in_pieces += len(self._t)
            self._t, self._x, self._modes, self._kinds = [], [], [], []

    def _join(self) -> None:
        """The pieces made rows of the lists again (read one by one: a run that failed or stopped)."""
        if self._pieces:
            t, x, modes, kinds = self._columns()  # (new lists where there are several pieces, else the piece's)
            self._pieces, self._in_pieces = [], 0
            self._t, self._x, self._modes, self._kinds = t.tolist(), list(x), modes, kinds.tolist()

    def columns(self) -> tuple:
        """``(t (N,), x (N, n), modes [N], kinds (N,))`` of every sample recorded, in order."""
        t, x, modes, kinds = self._columns()
        return t, x, list(modes), kinds

    def _columns(self) -> tuple:
        """:meth:`columns`, its list of modes possibly the record's own (read it, never change it)."""
        if len(self._pieces) == 1 and self._t:
            return self._piece_and_rows()
        self._close()
        pieces = self._pieces
        if len(pieces) == 1:
            return pieces[0]
        if not pieces:
            return np.zeros(0), np.zeros((0, len(self.model.states))), [], np.zeros(0, dtype=np.int64)
        return (np.concatenate([p[0] for p in pieces]), np.concatenate([p[1] for p in pieces]),
                [mode for p in pieces for mode in p[2]], np.concatenate([p[3] for p in pieces]))

    def _piece_and_rows(self) -> tuple:
        """:meth:`columns` of one piece followed by rows recorded one at a time (an ``output="events"`` run: a
        kernel call's block, then the state where it ended), each column filled once."""
        t, x, modes, kinds = self._pieces[0]
        size, more = len(t), len(self._t)
        columns = np.empty(size + more), np.empty((size + more, x.shape[1])), np.empty(size + more, np.int64)
        for column, piece, rows in zip(columns, (t, x, kinds), (self._t, self._x, self._kinds)):
            column[:size], column[size:] = piece, rows
        return columns[0], columns[1], modes + self._modes, columns[2]

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
        """The run starts at ``t`` [s] (before anything is recorded): its first flow is counted from there."""
        self.boundary = self._flows_from = float(t)

    @property
    def mode_time(self) -> dict:
        """The time [s] flowed in each mode up to the last instant, whatever samples are kept."""
        return ModeTimes(self._flows_from, self._flows)()

    def event(self, instant):
        self.n_events += 1
        self._flowed(instant.t, instant.mode_before)
        if not self.keep_instants:
            return
        self._append(instant.t, instant.x_before.copy(), instant.mode_before, BEFORE)
        self._append(instant.t, instant.x_after.copy(), instant.mode_after, AFTER)
        self.events.append(instant)
        self.event_index.append(self.n_rows - 1)

    def block(self, merge, modes: np.ndarray, kind: int, instants, times: list, before: list) -> None:
        """One kernel call's samples and instants at once, recorded as :meth:`sample` (forced; ``kind`` STATE)
        or :meth:`requested` (``kind`` REQUESTED) of each sample and :meth:`event` of each instant would
        record them, in order.  ``merge(lead, kind, before, after, pairs)`` makes the rows
        (:meth:`~switching.library.jit_model.KernelResult.rows`): ``(t, x, mode numbers into modes, kinds,
        the rows after the instants)``, ``lead`` rows left empty, then the samples, each of ``kind``, and with
        ``pairs`` each instant's rows of kinds ``before`` and ``after`` where it falls; ``instants``
        (:class:`~switching.simulate.resolution.KernelInstants`) are its events, at ``times`` [s], from the
        modes numbered ``before``; ``modes``: the modes by number, an object array
        (:meth:`~switching.library.jit_model.CompiledModel.mode_objects`).  The rows recorded one at a time
        since the last piece (the run's start) begin the piece it makes."""
        self.n_events += len(instants)
        if instants:
            self._flows.append((times, before, modes))
            last = times[-1]  # (the latest: a call's instants come in time order)
            self.boundary = last if self.boundary is None or last > self.boundary else self.boundary  # (as _flowed)
        pairs, lead = bool(instants) and self.keep_instants, len(self._t)
        t, x, numbers, kinds, after = merge(lead, kind, BEFORE, AFTER, pairs)
        if len(t) == lead:
            return
        for row, (time, state, sort) in enumerate(zip(self._t, self._x, self._kinds)):  # (mostly the start alone)
            t[row], x[row], kinds[row] = time, state, sort
        if pairs:
            self.event_index.extend((self._in_pieces + after if self._in_pieces else after).tolist())
            self.events.append(instants)  # (made records when a trajectory's events are first read)
        self._modes.extend(modes[numbers[lead:]].tolist())
        self._pieces.append((t, x, self._modes, kinds))
        self._in_pieces += len(t)
        self._t, self._x, self._modes, self._kinds = [], [], [], []

    def _flowed(self, t, mode):
        """The run flowed in ``mode`` up to an instant at ``t`` [s] (logged; :class:`ModeTimes` sums it)."""
        self._flows.append(((t,), (0,), (mode,)))
        self.boundary = max(self.boundary if self.boundary is not None else t, t)

    def rows(self, complete: bool = True) -> tuple:
        """``(rows, event_index)``: the indices of the recorded samples that
        are the trajectory's rows under the run's sampling (see the module
        docstring), and the row of each kept instant's "after" state among
        them (empty when the rows hold no instants: ``t_eval``).  A run that
        is not ``complete`` (it stopped before ``t_end``) also keeps its last
        recorded state when it is later than the last row."""
        if self.sampling == "steps":
            return list(range(self.n_rows)), list(self.event_index)
        t, _, _, kinds = self.columns()
        rows, event_index = self._rows(t, kinds, complete)
        return rows.tolist(), event_index

    def _rows(self, t: np.ndarray, kinds: np.ndarray, complete: bool) -> tuple:
        """:meth:`rows` of the recorded columns ``t`` and ``kinds``, the rows as an array."""
        n = len(t)
        wanted = (REQUESTED,) if self.sampling == "times" else (REQUESTED, BEFORE, AFTER)
        rows = np.flatnonzero(np.isin(kinds, wanted))
        if not complete and n and (not len(rows) or t[n - 1] > t[rows[-1]]):
            rows = np.append(rows, n - 1)
        if self.sampling == "times":
            return rows, []
        return rows, np.searchsorted(rows, self.event_index).tolist()

    def trajectory(self, stopped=None, stats=None, complete=False, all_rows=False):
        """The :class:`Trajectory` of the run so far: the rows of its sampling
        (:meth:`rows`; every recorded sample with ``all_rows``); ``complete``:
        the run reached ``t_end``."""
        stats = dict(stats or {})
        stats["instants"] = self.n_events
        times, x, modes, kinds = self._columns()  # (the trajectory copies what it keeps)
        last = (float(times[-1]), modes[-1]) if len(times) else None  # (the flow since the last instant ends there)
        mode_time = ModeTimes(self._flows_from, list(self._flows), last)
        if all_rows or self.sampling == "steps":  # every sample recorded
            event_index = self.event_index
        else:
            rows, event_index = self._rows(times, kinds, complete)
            times, x, modes = times[rows], x[rows], [modes[k] for k in rows.tolist()]
        return Trajectory(self.model, times, x, modes, self.events, event_index, stopped, stats,
                          mode_time=mode_time, instants_kept=self.keep_instants, initial_projection=self.projection,
                          sampling=self.sampling)


class ModeTimes:
    """The time [s] a run flowed in each mode, summed when first asked (:meth:`Trajectory.time_in_modes
    <switching.simulate.trajectory.Trajectory.time_in_modes>`): ``flows`` are the flows up to each instant
    in order, as ``(times [s], numbers, modes)`` (flowing in ``modes[numbers[k]]`` up to ``times[k]``),
    from the boundary ``start`` [s] (``None``: from the first time); ``end`` ``(t [s], mode)``: the run's
    last row, flowed in that mode since the last instant (``None``: none).  Calling it gives ``{mode:
    seconds}``, each sum made in the order the run flowed (the operations of counting as it went)."""

    def __init__(self, start, flows: list, end=None):
        self.start, self.flows, self.end = start, flows, end
        self._made = None

    def __call__(self) -> dict:
        if self._made is None:
            self._made = self._summed()
        return self._made

    def _summed(self) -> dict:
        mode_time, boundary = {}, self.start
        for times, numbers, modes in self.flows:
            for t, number in zip(times, numbers):
                if boundary is None:
                    boundary = t
                elif t > boundary:
                    mode = modes[number]
                    mode_time[mode] = mode_time.get(mode, 0.0) + (t - boundary)
                    boundary = t  # (the later of the two)
        if self.end is not None and boundary is not None and self.end[0] > boundary:
            t, mode = self.end
            mode_time[mode] = mode_time.get(mode, 0.0) + (t - boundary)
        return mode_time
