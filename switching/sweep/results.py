"""What one run of a sweep gives: :class:`RunResult`, made from a run's trajectory or its error.

Sweeps of build functions (:mod:`.batch`) and batches of one model (:mod:`.kernel_batch`) both give
these: plain arrays, picklable, without the model.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from bondgraph.errors import HybridBondGraphError

__all__ = ["RunResult", "failed_run", "result_of_run", "run_result"]


@dataclass
class RunResult:
    """One run of :func:`simulate_many`.

    ``parameters`` (the build arguments), ``t`` [s] (samples), ``x``
    (samples × states), ``state_names``, ``modes`` (labels per sample),
    ``event_times`` [s], ``instants`` (for each instant, the list of
    ``(mode label, kind)`` passed), ``instant_count`` (also when
    ``keep_instants=False`` kept no record of them), ``stopped`` (why the run ended early on
    purpose, e.g. ``"zeno"`` with ``on_zeno="stop"``), ``metrics`` (what the
    sweep's ``metrics`` callable returned for this run, computed in the
    worker), ``wall_time`` [s] of the run in its worker.  A failed run has
    ``error`` (the message) and ``error_type`` (the exception's class name);
    its arrays hold what was computed.  With ``trajectories=False`` the
    arrays hold only the last sample and ``instants`` is empty (the event
    times are kept)."""

    parameters: dict
    t: np.ndarray = field(repr=False)
    x: np.ndarray = field(repr=False)
    state_names: list = field(repr=False)
    modes: list = field(repr=False)
    event_times: np.ndarray = field(repr=False)
    instants: list = field(repr=False)
    instant_count: int = 0
    stopped: str | None = None
    error: str | None = None
    error_type: str | None = None
    metrics: dict = field(default_factory=dict)
    wall_time: float = 0.0

    @property
    def ok(self) -> bool:
        """The run reached its end (or stopped early on purpose)."""
        return self.error is None

    @property
    def status(self) -> str:
        """``"ok"``, ``"stopped"`` (ended early on purpose) or ``"failed"``."""
        return "failed" if self.error is not None else "stopped" if self.stopped else "ok"


def run_result(parameters, trajectory, wall, keep=True, metrics=None, error=None, error_type=None) -> RunResult:
    """The :class:`RunResult` of a run of ``parameters`` that gave ``trajectory`` (its whole or, ``keep``
    false, its last sample) in ``wall`` seconds."""
    last = slice(None) if keep else slice(-1, None)
    return RunResult(
        parameters=dict(parameters),
        t=trajectory.t[last].copy(),
        x=trajectory.x[last].copy(),
        state_names=list(trajectory.state_names),
        modes=trajectory.mode_labels[last],
        event_times=trajectory.event_times,
        instants=[[(s.mode.describe(), s.kind) for s in e.steps] for e in trajectory.events] if keep else [],
        instant_count=trajectory.instant_count,
        stopped=trajectory.stopped,
        error=error,
        error_type=error_type,
        metrics=dict(metrics or {}),
        wall_time=wall,
    )


def failed_run(parameters, error, error_type, wall=0.0) -> RunResult:
    """A failed run that computed nothing (its model could not be built, or its task was lost)."""
    return RunResult(dict(parameters), np.zeros(0), np.zeros((0, 0)), [], [], np.zeros(0), [],
                     error=error, error_type=error_type, wall_time=wall)


def result_of_run(parameters, simulate, metrics, trajectories, start: float) -> RunResult:
    """The :class:`RunResult` of the run ``simulate()`` (which returns its trajectory) of ``parameters``,
    begun at ``start`` (``time.perf_counter()``): an error of the toolkit gives a failed result with the
    part computed; ``metrics(trajectory)`` is evaluated on a run that completes (its failure fails this
    result, keeping the trajectory)."""
    measured, metric_error = {}, None
    try:
        trajectory = simulate()
        if metrics is not None:
            try:
                measured = dict(metrics(trajectory))
            except Exception as exc:  # noqa: BLE001 - the user's metric fails this run, not the sweep
                metric_error = exc
    except KeyboardInterrupt:  # SimulationInterrupted too: Ctrl-C stops the sweep, not one run
        raise
    except HybridBondGraphError as exc:
        wall = time.perf_counter() - start
        partial_run = getattr(exc, "trajectory", None)
        if partial_run is None:
            return failed_run(parameters, str(exc), type(exc).__name__, wall)
        return run_result(parameters, partial_run, wall, trajectories, error=str(exc), error_type=type(exc).__name__)
    wall = time.perf_counter() - start
    if metric_error is not None:
        message = (f"the metrics callable {getattr(metrics, '__name__', type(metrics).__name__)} failed on this "
                   f"run: {type(metric_error).__name__}: {metric_error} (it must return a dict name → value; "
                   "the run itself completed and its trajectory is kept)")
        return run_result(parameters, trajectory, wall, trajectories, error=message,
                          error_type=type(metric_error).__name__)
    return run_result(parameters, trajectory, wall, trajectories, metrics=measured)
