"""Many runs of one model family at once, on all cores.

:func:`simulate_many` builds and simulates one model per parameter set in a
pool of worker processes.  Workers share the generated code through the
disk cache (and numba's cache for compiled methods), so only the first run of
each mode pays for symbolic derivation and compilation; models are rebuilt per
run from the (picklable) ``build`` function, e.g. ``models.falling_rod.build``.

Each run returns a :class:`RunResult` — plain arrays, picklable, without the
model — or the error that stopped it.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field

import numpy as np

__all__ = ["RunResult", "simulate_many"]


@dataclass
class RunResult:
    """One run of :func:`simulate_many`.

    ``t``, ``x`` (samples × states), ``state_names``, ``modes`` (labels per
    sample), ``event_times``, ``instants`` (for each instant, the list of
    ``(mode label, kind)`` passed), ``stopped``; ``error`` holds the message
    when the run failed (the arrays then hold what was computed)."""

    parameters: dict
    t: np.ndarray = field(repr=False)
    x: np.ndarray = field(repr=False)
    state_names: list = field(repr=False)
    modes: list = field(repr=False)
    event_times: np.ndarray = field(repr=False)
    instants: list = field(repr=False)
    stopped: str | None = None
    error: str | None = None
    wall_time: float = 0.0

    @property
    def ok(self) -> bool:
        return self.error is None


def _result(parameters, trajectory, error=None, wall=0.0) -> RunResult:
    return RunResult(
        parameters=dict(parameters),
        t=trajectory.t.copy(),
        x=trajectory.x.copy(),
        state_names=list(trajectory.state_names),
        modes=trajectory.mode_labels,
        event_times=trajectory.event_times,
        instants=[[(s.mode.label, s.kind) for s in e.steps] for e in trajectory.events],
        stopped=trajectory.stopped,
        error=error,
        wall_time=wall,
    )


def _run_one(job):
    build, parameters, t_end, method, options = job
    from bondgraph.errors import HybridBondGraphError

    start = time.perf_counter()
    model = build(**parameters)
    try:
        trajectory = model.simulate(t_end, method, **options)
    except HybridBondGraphError as exc:
        partial = getattr(exc, "trajectory", None)
        if partial is None:
            return RunResult(dict(parameters), np.zeros(0), np.zeros((0, 0)), [], [], np.zeros(0), [],
                             error=str(exc), wall_time=time.perf_counter() - start)
        return _result(parameters, partial, error=str(exc), wall=time.perf_counter() - start)
    return _result(parameters, trajectory, wall=time.perf_counter() - start)


def simulate_many(build, parameter_sets, t_end: float, method: str = "RK45", workers: int | None = None,
                  **options) -> list[RunResult]:
    """Simulate ``build(**p)`` for every ``p`` in ``parameter_sets``, in
    parallel (``workers`` processes, default: all cores).  Results come back
    in the order of ``parameter_sets``; a failing run does not stop the others.

    Example — the falling rod's friction sweep::

        results = simulate_many(falling_rod.build, [{"mu": mu} for mu in mus], 0.5, "RK45-jit", rtol=1e-9)
    """
    jobs = [(build, dict(p), t_end, method, dict(options)) for p in parameter_sets]
    workers = workers or os.cpu_count() or 1
    if workers == 1 or len(jobs) == 1:
        return [_run_one(job) for job in jobs]
    # warm the shared caches once, so workers load generated code instead of deriving it in parallel
    first = _run_one(jobs[0])
    with ProcessPoolExecutor(max_workers=workers) as pool:
        rest = list(pool.map(_run_one, jobs[1:], chunksize=max(1, len(jobs) // (4 * workers))))
    return [first, *rest]
