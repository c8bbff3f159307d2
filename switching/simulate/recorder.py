"""The record of a run: the samples kept (every step, the instants, or the
requested times ``t_eval`` [s] read from the steps' interpolants), the
instants, and the time [s] spent in each mode; it makes the
:class:`~switching.simulate.trajectory.Trajectory`."""

from __future__ import annotations

import numpy as np

from .trajectory import Trajectory

__all__ = ["Recorder"]


class Recorder:
    """The samples of a run as it goes: ``output="steps"`` keeps every step,
    ``"events"`` only what is forced (the start, the instants, the end);
    ``t_eval`` [s] adds the states at those times (:meth:`dense`);
    ``keep_instants=False`` keeps only the instants' count; ``projection``
    ``(t0, given, projected)``: the start was the given state projected onto the
    initial mode's constraints (the energy ledger records it)."""

    def __init__(self, model, output, t_eval, keep_instants=True, projection=None):
        self.model = model
        self.projection = projection
        self.output = output
        self.keep_instants = keep_instants
        self.n_events = 0
        self.last_instant = None
        self.mode_time: dict = {}  # flow time per mode [s], whatever samples are kept
        self.boundary = None  # the time of the last instant (or the start)
        self.t_eval = None if t_eval is None else np.asarray(sorted(t_eval), dtype=float)
        self.eval_pos = 0
        self.t: list = []
        self.x: list = []
        self.modes: list = []
        self.events: list = []
        self.event_index: list = []

    def sample(self, t, x, mode, force=False):
        if force or self.output == "steps":
            self.t.append(float(t))
            self.x.append(np.array(x, dtype=float))
            self.modes.append(mode)

    def dense(self, t0, t1, evaluate, mode):
        """Samples at requested times in ``(t0, t1]`` from the step interpolant."""
        if self.t_eval is None:
            return
        te = self.t_eval
        while self.eval_pos < len(te) and te[self.eval_pos] <= t1:
            tau = te[self.eval_pos]
            if tau >= t0:
                self.t.append(float(tau))
                self.x.append(evaluate(tau))
                self.modes.append(mode)
            self.eval_pos += 1

    def start(self, t):
        self.boundary = float(t)

    def event(self, instant):
        self.n_events += 1
        self.last_instant = instant
        self._flowed(instant.t, instant.mode_before)
        if not self.keep_instants:
            return
        self.t.append(instant.t)
        self.x.append(instant.x_before.copy())
        self.modes.append(instant.mode_before)
        self.t.append(instant.t)
        self.x.append(instant.x_after.copy())
        self.modes.append(instant.mode_after)
        self.events.append(instant)
        self.event_index.append(len(self.t) - 1)

    def _flowed(self, t, mode):
        if self.boundary is not None and t > self.boundary:
            self.mode_time[mode] = self.mode_time.get(mode, 0.0) + (t - self.boundary)
        self.boundary = max(self.boundary if self.boundary is not None else t, t)

    def trajectory(self, stopped=None, stats=None):
        stats = dict(stats or {})
        stats["instants"] = self.n_events
        n = len(self.model.states)
        x = np.array(self.x).reshape(len(self.x), n) if self.x else np.zeros((0, n))
        mode_time = dict(self.mode_time)
        if self.t and self.boundary is not None and self.t[-1] > self.boundary:
            mode_time[self.modes[-1]] = mode_time.get(self.modes[-1], 0.0) + (self.t[-1] - self.boundary)
        return Trajectory(self.model, self.t, x, self.modes, self.events, self.event_index, stopped, stats,
                          mode_time=mode_time, instants_kept=self.keep_instants, initial_projection=self.projection)
