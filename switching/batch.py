"""Many runs of one model family at once, on all cores.

:func:`simulate_many` builds and simulates one model per parameter set in a
pool of worker processes.  Workers share the generated code through the
disk cache (and numba's cache for compiled methods), so only the first run of
each mode pays for symbolic derivation and compilation.

Within one process, runs share one model per distinct structure.  Each run
still calls the (picklable) ``build`` function, e.g.
``models.falling_rod.build``, which gives its parameter values, initial state,
inputs and tolerances; when the result has the symbolic fingerprint of a model
already used in this process (same graph, laws, automata, guards, signals and
parameter order — the key of the disk cache), the run's values are moved onto
that model, which keeps its derived modes, generated functions and numba
kernels.  This is exact: derived equations and generated code hold the
parameters as symbols and read the values (``parameter_array``,
``parameter_values``) at every call, and the initial state is projected anew
with the run's values.  A run therefore costs the build and the fingerprint
instead of the build, the fingerprint, the derivation of the modes it visits
and loading their code.

Each run returns a :class:`RunResult` — plain arrays, picklable, without the
model — or the error that stopped it.
"""

from __future__ import annotations

import gc
import os
import threading
import time
from collections import OrderedDict
from contextlib import contextmanager
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


#: models kept per process for sharing, least recently used dropped first
SHARED_MODELS = 8
#: attributes of a HybridModel that are derived from its structure alone and kept
#: when a run's values are moved onto a shared model; all others are the run's
_DERIVED = ("_mode_cache", "_compiled", "_jit", "_fingerprint", "derivation_count")
_models: OrderedDict = OrderedDict()  # (model type, fingerprint) → model
_busy: set = set()  # keys of the models a run is using now (one run per model at a time)
_lock = threading.Lock()


def _after_fork_in_child() -> None:
    # a forked worker inherits the parent's models (with derived modes and code), never its runs
    global _lock
    _lock = threading.Lock()
    _busy.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


@contextmanager
def shared_model(build, parameters):
    """Context giving ``build(**parameters)``, or an equivalent model that
    shares derived modes and generated code with earlier runs.

    If a model of the same type and fingerprint was built earlier in this
    process (or in the parent of a forked worker), that model is given, with
    every attribute of the new one except those in ``_DERIVED`` (parameter
    values, initial state, inputs, tolerances, …; the projected initial state
    is recomputed).  A model is used by one run at a time: a run in another
    thread meanwhile gets its own new model.  At most :data:`SHARED_MODELS`
    are kept."""
    fresh = build(**parameters)
    key = (type(fresh), fresh.fingerprint)
    with _lock:
        model = _models.get(key)
        if key in _busy:
            model, key = fresh, None
        elif model is None:
            model = _models[key] = fresh
        else:
            derived = {name: vars(model)[name] for name in _DERIVED if name in vars(model)}
            vars(model).clear()
            vars(model).update(vars(fresh))
            vars(model).update(derived)
        if key is not None:
            _busy.add(key)
            _models.move_to_end(key)
            for old in [k for k in _models if k not in _busy][: max(0, len(_models) - SHARED_MODELS)]:
                del _models[old]
    try:
        yield model
    finally:
        if key is not None:
            with _lock:
                _busy.discard(key)


def _run_one(job):
    build, parameters, t_end, method, options = job
    from bondgraph.errors import HybridBondGraphError

    start = time.perf_counter()
    try:
        with shared_model(build, parameters) as model:
            trajectory = model.simulate(t_end, method, **options)
    except HybridBondGraphError as exc:  # a bad parameter set included: one failed run, not a failed sweep
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
    # (and forked workers inherit the model it built, with its derived modes and code)
    first = _run_one(jobs[0])
    # forked workers would otherwise copy every inherited page their first full garbage
    # collection visits (≈ 0.1 s each): keep the parent's objects out of the collector meanwhile
    gc.freeze()
    try:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            rest = list(pool.map(_run_one, jobs[1:], chunksize=max(1, len(jobs) // (4 * workers))))
    finally:
        gc.unfreeze()
    return [first, *rest]
