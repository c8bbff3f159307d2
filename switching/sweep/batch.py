"""Many runs of one model family: sweeps and ensembles, on Dask.

:func:`simulate_many` builds and simulates one model per parameter set on a
``dask.distributed`` cluster: a :class:`~distributed.LocalCluster` on this
machine's cores that it starts and closes (``client=None``), or any cluster
you connect to (a ``Client`` or a scheduler address: SSH, Kubernetes, Slurm
through dask-jobqueue, …).  Runs travel several to a task (:func:`run_batch`)
so the per-run overhead stays small; a task whose worker is lost is rerun
by Dask (``retries``); results come back in input order.  ``client="serial"``
runs every set in this process, with no Dask needed.

Within one worker process, runs share one model per distinct structure.
Each run still calls the (picklable) ``build`` function, e.g.
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
and loading their code.  Workers on one machine share the generated code
through the disk cache (and numba's cache for the compiled methods).

Each run returns a :class:`RunResult` — plain arrays, picklable, without the
model — or the error that stopped it, with the part of the run computed.
"""

from __future__ import annotations

import math
import os
import threading
import time
import uuid
from collections import OrderedDict
from collections.abc import Mapping
from contextlib import contextmanager
from functools import partial

import numpy as np

from bondgraph.errors import HybridBondGraphError, MissingDependencyError, ParameterValueError

from ..errors import SweepInterrupted
from ..simulate.driver import check_option_names
from .kernel_batch import batch_results
from .results import RunResult, failed_run, result_of_run

__all__ = ["BuildError", "MissingDependencyError", "RunResult", "local_cluster", "run_batch", "shared_model",
           "simulate_many"]

#: the extra that installs what sweeps on Dask need
DASK_EXTRA = "pip install '.[dask]'"


# ------------------------------------------------------------ one model per structure and process

#: models kept per process for sharing, least recently used dropped first
SHARED_MODELS = 8
_models: OrderedDict = OrderedDict()  # (model type, fingerprint) → model
_busy: set = set()  # keys of the models a run is using now (one run per model at a time)
_lock = threading.Lock()


def _after_fork_in_child() -> None:
    # a forked process inherits the parent's models (with derived modes and code), never its runs
    global _lock
    _lock = threading.Lock()
    _busy.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


class BuildError(ParameterValueError):
    """The ``build`` function of a sweep raised for a parameter set, or gave
    something that is not a model; ``name`` is the build's name, ``value`` the set."""


def _build_name(build) -> str:
    return getattr(build, "__qualname__", None) or getattr(getattr(build, "func", None), "__qualname__", None) \
        or type(build).__name__


def _built(build, parameters):
    """``build(**parameters)``, a :class:`~switching.model.hybrid_model.HybridModel`; any
    failure is a :class:`BuildError` naming the build and the set (the
    build's own error is its cause), so that the sweep goes on without it."""
    from ..model.hybrid_model import HybridModel

    name = _build_name(build)
    try:
        model = build(**parameters)
    except HybridBondGraphError:
        raise
    except Exception as exc:  # noqa: BLE001 - the user's build fails this set, not the sweep
        raise BuildError(f"{name}(**{parameters!r}) raised {type(exc).__name__}: {exc}", name, parameters) from exc
    if not isinstance(model, HybridModel):
        raise BuildError(f"{name}(**{parameters!r}) returned {type(model).__name__}, not a HybridModel; a sweep's "
                         "build function must return the model it built", name, parameters)
    return model


@contextmanager
def shared_model(build, parameters):
    """Context giving ``build(**parameters)``, or an equivalent model that
    shares derived modes and generated code with earlier runs.

    If a model of the same type and fingerprint was built earlier in this
    process (or in the parent of a forked process), that model is given: it
    takes the new one's definition (parameter values, initial state, inputs,
    tolerances, …; the projected initial state is recomputed) and keeps its
    mode library — derived modes, generated code, every memo of the code
    generator (:meth:`~switching.model.hybrid_model.HybridModel.take_definition`,
    :mod:`switching.library.mode_library`).  A model is used by one run at a time: a run in another
    thread meanwhile gets its own new model.  At most :data:`SHARED_MODELS`
    are kept."""
    fresh = _built(build, parameters)
    key = (type(fresh), fresh.fingerprint)
    with _lock:
        model = _models.get(key)
        if key in _busy:
            model, key = fresh, None
        elif model is None:
            model = _models[key] = fresh
        else:
            model.take_definition(fresh)
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


# ------------------------------------------------------------ what one task does (in a worker)


def _run_one(build, parameters, t_end, method, options, metrics=None, trajectories=True) -> RunResult:
    """Build and simulate one parameter set; an error of the toolkit (a bad
    parameter set included) gives a failed :class:`RunResult`, not a failed
    sweep.  ``metrics(trajectory)`` is evaluated while the shared model still
    holds this run's values (signals read them)."""
    start = time.perf_counter()
    try:
        with shared_model(build, parameters) as model:
            return result_of_run(parameters, partial(model.simulate, t_end, method, **options), metrics, trajectories,
                                 start)
    except KeyboardInterrupt:  # SimulationInterrupted too: Ctrl-C stops the sweep, not one run
        raise
    except HybridBondGraphError as exc:  # the set could not be built
        return failed_run(parameters, str(exc), type(exc).__name__, time.perf_counter() - start)


def run_batch(parameter_sets, build, t_end, method, options, metrics=None, trajectories=True) -> list[RunResult]:
    """Run several parameter sets one after the other in this process (one
    Dask task of :func:`simulate_many`); one :class:`RunResult` per set, in order."""
    return [_run_one(build, p, t_end, method, options, metrics, trajectories) for p in parameter_sets]


# ------------------------------------------------------------ the sweep

#: tasks per worker thread the runs are cut into (load balance at the end of a sweep)
TASKS_PER_THREAD = 8
#: at most this many runs per task (a lost worker loses at most this many runs' work)
MAX_BATCH = 50


def batch_size_for(runs: int, threads: int) -> int:
    """Runs per task: about :data:`TASKS_PER_THREAD` tasks per worker thread,
    1 to :data:`MAX_BATCH` runs each."""
    return max(1, min(MAX_BATCH, math.ceil(runs / (TASKS_PER_THREAD * max(1, threads)))))


def _distributed():
    try:
        import distributed
    except ImportError as exc:
        raise MissingDependencyError(
            "simulate_many runs on Dask, which is not installed here: " + DASK_EXTRA
            + " (dask[distributed] and pandas); or pass client='serial' to run every set in this process"
        ) from exc
    return distributed


def _positive_int(name: str, value, minimum: int = 1) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ParameterValueError(f"simulate_many: {name} must be an integer >= {minimum}, got {value!r}", name, value)


#: Dask settings of :func:`local_cluster`'s workers: their housekeeping takes the GIL from the
#: runs (a statistical profiler sampling every 10 ms for a dashboard, event-loop health ticks every
#: 20 ms, memory checks every 100 ms); less of it made runs in a worker ~4% faster, as fast as in a
#: plain process (2 cores, falling rod, RK45-jit)
QUIET_WORKERS = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "500ms",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "1s",
}


def local_cluster(workers: int | None = None, retries: int = 3):
    """The ``distributed.LocalCluster`` that :func:`simulate_many` starts when
    ``client=None``: ``workers`` processes (default: all cores) of one thread
    each, whose scheduler reruns a task after its worker died up to
    ``retries`` times, with less housekeeping (:data:`QUIET_WORKERS`) and the
    dashboard (if bokeh is installed) on a free port.  Keep one over several
    sweeps with ``with local_cluster(2) as cluster, Client(cluster) as client: ...``."""
    distributed = _distributed()
    import dask

    with dask.config.set({"distributed.scheduler.allowed-failures": retries, **QUIET_WORKERS}):
        return distributed.LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                                        processes=True, dashboard_address=":0")


@contextmanager
def _connected(client, workers: int | None, runs: int, retries: int):
    """A ``distributed.Client``: the one given, one connected to a scheduler
    address (closed after), or one on a :func:`local_cluster` of ``workers``
    processes, at most one per run (closed after, with the cluster)."""
    distributed = _distributed()
    if isinstance(client, distributed.Client):
        if client.status in ("closing", "closed"):
            raise ParameterValueError(
                f"simulate_many: the Dask client given is {client.status} (it was closed, or its cluster "
                "stopped); connect a new one, or pass client=None to start a local cluster", "client", client)
        yield client
        return
    if isinstance(client, str):
        try:
            connection = distributed.Client(client, timeout="10s")
        except (OSError, TimeoutError, ValueError) as exc:  # (ValueError: no address, e.g. no port)
            raise ParameterValueError(
                f"simulate_many: cannot reach a Dask scheduler at {client!r} ({exc}); start one "
                "(`dask scheduler`, then `dask worker ADDRESS` on each machine) or check the address",
                "client", client) from exc
        try:
            yield connection
        finally:
            connection.close()
        return
    if client is not None:
        raise ParameterValueError(f"simulate_many: client must be None, 'serial', a scheduler address or a "
                                  f"distributed.Client, got a {type(client).__name__}", "client", client)
    with local_cluster(min(workers or os.cpu_count() or 1, runs), retries) as cluster:
        with distributed.Client(cluster) as connection:
            yield connection


def _on_dask(client, jobs, task, batch_size, retries, progress_bar) -> list[RunResult]:
    distributed = _distributed()
    threads = sum(client.nthreads().values())
    size = batch_size or batch_size_for(len(jobs), threads)
    chunks = [jobs[k:k + size] for k in range(0, len(jobs), size)]
    token = uuid.uuid4().hex
    futures = client.map(task, chunks, key=[f"simulate_many-{token}-{k}" for k in range(len(chunks))],
                         retries=retries, pure=False)
    try:
        with client.as_current():  # the client given, whether or not it is the default one
            if progress_bar:
                distributed.progress(futures, notebook=False)
            distributed.wait(futures)
        finished = [f for f in futures if f.status == "finished"]
        done = dict(zip((f.key for f in finished), client.gather(finished)))
    except KeyboardInterrupt:  # Ctrl-C: keep what finished, leave nothing running on the cluster
        unfinished = [f for f in futures if f.status != "finished"]
        client.cancel(unfinished)
        kept = {}
        for k, (chunk, future) in enumerate(zip(chunks, futures)):
            if future.status == "finished":
                kept.update({k * size + j: r for j, r in enumerate(future.result())})
        raise _interrupted(jobs, kept) from None
    except BaseException:
        client.cancel(futures)
        raise
    results = []
    for chunk, future in zip(chunks, futures):
        if future.key in done:
            results.extend(done[future.key])
            continue
        try:
            exc = future.exception()
            why = f"{type(exc).__name__}: {exc}"
        except Exception as cancelled:  # noqa: BLE001 - a cancelled task has no exception to give
            exc, why = cancelled, f"the task was cancelled ({type(cancelled).__name__})"
        message = (f"the Dask task holding this parameter set (and {len(chunk) - 1} others) was given up after "
                   "its reruns (retries=, or the scheduler's allowed-failures when its workers died): " + why)
        results.extend(failed_run(p, message, type(exc).__name__) for p in chunk)
    return results


def _interrupted(jobs, done: dict) -> SweepInterrupted:
    """The :class:`SweepInterrupted` of a sweep stopped by Ctrl-C: ``done``
    maps the positions of finished runs to their results."""
    message = (f"simulate_many was interrupted: {len(done)} of {len(jobs)} runs had finished; they are in "
               "error.results (the others as failed results marked interrupted)")
    results = [done[k] if k in done else failed_run(p, "the sweep was interrupted (Ctrl-C) before this run finished",
                                                   "SweepInterrupted")
               for k, p in enumerate(jobs)]
    return SweepInterrupted(message, results)


def simulate_many(build, parameter_sets, t_end: float, method: str = "RK45", *, client=None,
                  workers: int | None = None, batch_size: int | None = None, retries: int = 3,
                  metrics=None, trajectories: bool = True, progress_bar: bool = False,
                  **options) -> list[RunResult]:
    """Simulate ``build(**p)`` to ``t_end`` [s] with ``method`` for every
    ``p`` in ``parameter_sets`` on Dask; one :class:`RunResult` per set, in
    the order of ``parameter_sets``.  ``options`` go to
    :meth:`~switching.model.hybrid_model.HybridModel.simulate` (``rtol``, ``output``, …).

    ``client``: ``None`` starts a :func:`local_cluster` of ``workers``
    processes (default: all cores; one thread each) and closes it after;
    a ``distributed.Client`` or a scheduler address (``"tcp://host:8786"``)
    is used as it is (``workers`` is then an error: size that cluster
    yourself); ``"serial"`` runs every set in this process, without Dask.
    Without Dask installed, every other choice raises
    :class:`MissingDependencyError` naming ``pip install '.[dask]'``.

    A run that fails (any error of the toolkit, a bad parameter set
    included) records its error and the part computed; the others go on.
    Runs travel ``batch_size`` to a task (default :func:`batch_size_for`:
    about 8 tasks per worker thread, at most 50 runs each).  A task whose
    worker dies is rerun elsewhere, up to ``retries`` times (as is a task
    that raised an error outside the toolkit); past that its runs come back
    failed, naming the cause.  On a cluster you started, the scheduler's own
    ``distributed.scheduler.allowed-failures`` (3 by default) bounds the
    reruns after lost workers.

    ``metrics(trajectory) -> dict`` is evaluated in the worker on every run
    that completes (signals can be evaluated there: the model is attached);
    its values land in ``RunResult.metrics`` and in :func:`switching.to_frame`.
    ``trajectories=False`` sends back only the last sample and the event
    times of each run, not its whole trajectory.  ``progress_bar=True`` shows
    Dask's progress bar (on stdout) while the tasks run (not when serial).
    The runs hold the GIL: give workers of your own one thread each
    (``dask worker ADDRESS --nworkers N --nthreads 1``).

    Every argument travels to the workers pickled: ``build`` and ``metrics``
    by reference when they are module-level functions (the workers must be
    able to import them), by value when they are lambdas or closures.  A
    script that starts a LocalCluster must guard its top level with
    ``if __name__ == "__main__":`` (the workers are spawned processes that
    import the script's module).

    ``build`` may be a model instead (a :class:`~switching.model.hybrid_model.HybridModel` built once):
    each set then gives values of its parameters (and of those only its initial state uses), the
    runs are made in this process, and with a compiled method of one kind (``RK45-jit``, ``rodas-jit``,
    …) their kernel calls in batches over the cores (:func:`switching.simulate_batch`), each run's
    result the same as ``model.simulate`` with its values (``client``, ``workers``, ``batch_size``
    and ``progress_bar`` are then errors).

    Example — the falling rod's friction sweep::

        results = simulate_many(falling_rod.build, [{"mu": mu} for mu in mus], 0.5, "RK45-jit", rtol=1e-9)
    """
    from ..model.hybrid_model import HybridModel

    if isinstance(build, HybridModel):
        for name, value, default in (("client", client, None), ("workers", workers, None),
                                     ("batch_size", batch_size, None), ("progress_bar", progress_bar, False)):
            if value is not default and not (name == "client" and value == "serial"):
                raise ParameterValueError(
                    f"simulate_many: {name}= is for sweeps of a build function on Dask; a model's sets run in this "
                    "process, a compiled method's in one kernel batch over the cores (pass the build function, e.g. "
                    "models.bouncing_ball.build, to spread the runs over a Dask cluster)", name, value)
        return batch_results(build, parameter_sets, t_end, method, metrics=metrics, trajectories=trajectories,
                             **options)
    jobs = list(parameter_sets)
    for k, p in enumerate(jobs):
        if not isinstance(p, Mapping):
            raise ParameterValueError(f"simulate_many: parameter set {k} is a {type(p).__name__}, not a dict of "
                                      "build arguments", "parameter_sets", p)
    jobs = [dict(p) for p in jobs]
    if workers is not None:
        _positive_int("workers", workers)
    if batch_size is not None:
        _positive_int("batch_size", batch_size)
    _positive_int("retries", retries, minimum=0)
    if workers is not None and client is not None:
        raise ParameterValueError("simulate_many: workers= sizes the LocalCluster started when client=None; "
                                  f"with client={client!r} it would have no effect: drop it (a cluster you give "
                                  "is sized by whoever started it)", "workers", workers)
    check_option_names(options, "simulate_many")
    if "progress" in options:
        raise ParameterValueError("simulate_many: a per-step progress callable cannot follow runs on other "
                                  "processes; pass progress_bar=True for a bar over the runs", "progress",
                                  options["progress"])
    task = partial(run_batch, build=build, t_end=t_end, method=method, options=dict(options), metrics=metrics,
                   trajectories=trajectories)
    if isinstance(client, str) and client == "serial":
        done: list = []
        try:
            for p in jobs:
                done += task([p])
        except KeyboardInterrupt:
            raise _interrupted(jobs, dict(enumerate(done))) from None
        return done
    _distributed()  # a missing Dask is said before anything else
    if not jobs:
        return []
    with _connected(client, workers, len(jobs), retries) as connection:
        return _on_dask(connection, jobs, task, batch_size, retries, progress_bar)
