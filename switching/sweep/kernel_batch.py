"""Many runs of one model in one call of the compiled kernel.

:func:`simulate_batch` runs one model (a :class:`HybridModel` built once)
for many sets of values — of its parameters, of the parameters of its
initial state (a drop height, an initial angle), of its states' initial
values — with a compiled method (``euler-jit``, ``rk4-jit``, ``RK45-jit``,
``rodas-jit``).  Each run is set up exactly as
:func:`switching.simulate` sets it up (its options checked, its initial
state projected, its starting mode, each state's tolerance, the step bound:
:func:`switching.simulate.driver.prepared_run`), and the first kernel call
of every run — which on a warm model is the whole run — is made for all of
them at once by :func:`switching.kernel.batch.run_many`, in parallel over
the cores numba is given.  Only what is asked is recorded, into arrays
allocated once per slab of runs: each run's end (time, state, mode), its
instants' times, and the states at the requested times ``t_eval``.

Results are identical to one ``simulate`` per set, to the bit: a run is
taken from the batch only where its kernel call ended it, its instants
passing the checks a run makes (the Zeno watch, ``max_events``); any other
run — a mode met that is not compiled yet, an instant left to Python, more
instants than a run's record holds (``event_capacity``), Zeno behaviour, an
error — is finished by ``simulate``'s own recording from that call on
(:class:`FirstCallAnswered`), which compiles what it meets for the runs
after.  The first set runs alone, so that the modes it meets are compiled
for the others' batch calls.  The model's own values are restored afterwards
(DESIGN §7c).

:func:`switching.simulate_many` given a model (not a build function) runs
its sets this way too and gives each run's :class:`RunResult`: each run's
trajectory is then made by ``simulate``'s own recording, its first kernel
call answered by the batch's (:class:`FirstCallAnswered`).
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from bondgraph.errors import HybridBondGraphError, ParameterValueError, UnknownNameError, UnknownParameterError

from ..library.jit_model import KINDS, STATUS, KernelResult, kernel
from ..model.definition import initial_only_names
from ..simulate.driver import check_option_names, option_defaults, prepared_run
from ..simulate.methods import METHOD_CLASSES, canonical_method
from ..simulate.zeno import ZenoWatch
from .results import RunResult, result_of_run

__all__ = ["BatchResult", "FirstCallAnswered", "batch_results", "settable_names", "simulate_batch"]

#: the kernel's status of a run that reached ``t_end``
DONE = next(code for code, name in STATUS.items() if name == "done")
#: the outputs of a slab of runs are allocated for at most this many bytes (runs are cut into slabs)
SLAB_BYTES = 256 * 2**20
#: the instants a run's record holds in the batch by default (a run with more is run again by simulate)
EVENT_CAPACITY = 256
#: samples a run's record holds when every step is kept (as a single run's first kernel call: the same steps)
STEP_CAPACITY = 4096


@dataclass
class BatchResult:
    """The runs of :func:`simulate_batch`, as arrays over the runs (``R``
    runs, ``n`` states, ``T`` requested times):

    * ``parameters``: the sets, in order; ``state_names`` (n,);
    * ``t`` (R,) [s]: where each run ended (``t_end``, or an earlier stop);
      ``x`` (R, n): its state there; ``modes``: its mode's label;
    * ``status``: ``"ok"``, ``"stopped"`` (ended early on purpose, e.g.
      ``on_zeno="stop"``) or ``"failed"`` per run; ``errors``: each failed
      run's message (``None`` elsewhere); ``steps`` (R,);
    * ``event_counts`` (R,) and ``event_times`` (R, max count) [s]: each
      run's instants (NaN past its count), the initial instant included when
      it passed more than one mode, as ``Trajectory.event_times``;
    * ``t_eval`` (T,) [s] and ``samples`` (R, T, n): the states at the
      requested times (``None`` without ``t_eval``; NaN where a run that
      failed or stopped early has none);
    * ``in_kernel`` (R,): the run came from the batch's kernel call (``False``:
      ``simulate`` ran it again, see the module docstring).
    """

    parameters: list
    state_names: tuple
    t: np.ndarray = field(repr=False)
    x: np.ndarray = field(repr=False)
    modes: list = field(repr=False)
    status: list = field(repr=False)
    errors: list = field(repr=False)
    steps: np.ndarray = field(repr=False)
    event_counts: np.ndarray = field(repr=False)
    event_times: np.ndarray = field(repr=False)
    t_eval: np.ndarray | None = field(repr=False)
    samples: np.ndarray | None = field(repr=False)
    in_kernel: np.ndarray = field(repr=False)

    def __len__(self) -> int:
        return len(self.parameters)

    def final(self, name: str) -> np.ndarray:
        """State ``name``'s value at each run's end (R,)."""
        return self.x[:, self._column(name)]

    def at_times(self, name: str) -> np.ndarray:
        """State ``name`` at the requested times (R, T)."""
        if self.samples is None:
            raise ParameterValueError("this batch recorded no requested times: pass t_eval= to simulate_batch",
                                      "t_eval", None)
        return self.samples[:, :, self._column(name)]

    def _column(self, name: str) -> int:
        if name not in self.state_names:
            raise UnknownNameError(f"the batch's model has no state {name!r}; its states: "
                                   f"{', '.join(self.state_names)}", name)
        return self.state_names.index(name)


class FirstCallAnswered:
    """A compiled model (:class:`~switching.library.jit_model.CompiledModel`) whose first kernel call
    returns ``result``, already computed for the same arguments by a batch (``arguments``: the call's
    keywords, checked); every other call and attribute is the compiled model's."""

    def __init__(self, compiled, result: KernelResult, arguments: dict):
        self.compiled, self.result, self.arguments = compiled, result, arguments

    def __getattr__(self, name):
        return getattr(self.compiled, name)

    def run(self, **arguments) -> KernelResult:
        """The batch's result for the first call, the kernel's for the others."""
        if self.result is None:
            return self.compiled.run(**arguments)
        result, self.result = self.result, None
        expected = self.arguments
        if any(arguments[k] != expected[k] for k in ("kind", "mode", "t", "t_end", "save", "max_steps")) \
                or not np.array_equal(arguments["x"], expected["x"]):
            raise RuntimeError("a batch's run started other than its batch call (a bug): the run is not replayed")
        return result


# ------------------------------------------------------------ parameter sets onto the model


def settable_names(model) -> set:
    """The names a set of a batch may give values of: ``model``'s parameters, the parameters only its
    initial state uses, its states."""
    return ({s.name for s in model.parameter_symbols} | initial_only_names(model.initial_expressions,
                                                                             model.parameter_symbols)
            | set(model.state_names))


class _Values:
    """The model's values of now (restored by :meth:`restore`), and each set's applied on top of them."""

    def __init__(self, model):
        self.model = model
        self.values = {s.name: v for s, v in model.parameter_values.items()}
        self.initial = {s.name: v for s, v in model.initial_parameters.items()}
        self.initial_names = initial_only_names(model.initial_expressions, model.parameter_symbols)
        self.state_index = {name: k for k, name in enumerate(model.state_names)}

    def apply(self, changes: Mapping) -> dict:
        """The model's values with ``changes`` (name → number: a parameter, a parameter only the initial
        state uses, or a state), set on the model (its initial state projected anew when asked).  Returns
        the run's own options of ``simulate``: ``{"x0": …}`` when ``changes`` name states — the model's
        initial state (projected) with those states' values — else ``{}``."""
        values, initial, states = dict(self.values), dict(self.initial), {}
        unknown = []
        for name, value in changes.items():
            name = str(name)
            if name in values:
                values[name] = value
            elif name in self.initial_names:
                initial[name] = value
            elif name in self.state_index:
                states[name] = value
            else:
                unknown.append(name)
        if unknown:
            raise UnknownParameterError(unknown, sorted([*values, *self.initial_names, *self.model.state_names]))
        self.model.set_parameter_values(values, initial)
        if not states:
            return {}
        x0 = self.model.initial_state().astype(object)  # (a state's value checked as simulate's x0 checks it)
        for name, value in states.items():
            x0[self.state_index[name]] = value
        return {"x0": list(x0)}

    def restore(self) -> None:
        self.model.set_parameter_values(self.values, self.initial)


# ------------------------------------------------------------ a slab of runs in one kernel call


@dataclass
class _Slab:
    """The runs ``first … first + len(calls) − 1`` and their first kernel calls' arguments (``None``: the
    run does not start in the kernel), then their outputs after :meth:`run`."""

    first: int
    calls: list
    inputs: list = field(default_factory=list)  # each run's kernel inputs with its values (call_arrays), or None
    outs: tuple = ()
    ends: np.ndarray | None = None
    t_stop: np.ndarray | None = None
    index: dict = field(default_factory=dict)  # run → its row in the kernel's arrays
    modes: list = field(default_factory=list)  # the compiled modes, numbered as the kernel numbers them

    def run(self, compiled, event_capacity: int) -> None:
        """The first kernel call of every run that has one, in one call of
        :func:`switching.kernel.batch.run_many`."""
        rows = [(r, a) for r, a in enumerate(self.calls) if a is not None]
        if not rows:
            return
        inputs = [self.inputs[r] for r, _ in rows]
        record = compiled.record  # (the modes the set-up of the slab's runs compiled included)
        te = inputs[0][4]
        kinds = {int(i[1][0]) for i in inputs}
        if len(kinds) != 1 or any(i[4] is not te and not np.array_equal(i[4], te) for i in inputs):
            raise RuntimeError("the runs of a batch differ in their method or requested times (a bug)")
        R, n = len(rows), compiled.n
        save = int(inputs[0][1][4])
        samples_a_run = max(len(te), 1) if save == 2 else (STEP_CAPACITY if save == 1 else 1)
        self.outs = (np.empty((R, samples_a_run)), np.empty((R, samples_a_run, n)),
                     np.empty((R, samples_a_run), dtype=np.int64), np.empty((R, event_capacity, 1 + 2 * n)),
                     np.empty((R, event_capacity, 4), dtype=np.int64), np.zeros((R, 5 + n)))
        samples, max_instant = int(inputs[0][1][2]), int(inputs[0][1][3])
        from ..kernel import batch

        threads = _threads()
        entry = batch.run_many if threads > 1 and _parallel_here() else batch.run_many_serial
        chunks = min(R, threads) if entry is batch.run_many else 1
        floats, ints_, bools = kernel().workspace_sizes(record, n, samples, max_instant)
        works = (np.empty((chunks, floats)), np.empty((chunks, ints_), dtype=np.int64),
                 np.empty((chunks, bools), dtype=np.bool_))
        self.ends = np.zeros((R, 6), dtype=np.int64)
        self.t_stop = np.zeros(R)
        entry(record, np.array([i[0].p for i in inputs]).reshape(R, -1),
                 np.array([i[0].u for i in inputs]).reshape(R, -1), np.array([i[0].atol for i in inputs]),
                 np.array([i[1] for i in inputs]), np.array([i[2] for i in inputs]), np.array([i[3] for i in inputs]),
                 te, self.outs, works, self.ends, self.t_stop,
                 True if next(iter(kinds)) >= KINDS["rodas-jit"] else None)
        self.index = {self.first + r: k for k, (r, _) in enumerate(rows)}
        self.modes = list(compiled.modes)

    def completed(self, options: dict) -> np.ndarray:
        """For each run of the slab: did its batch call end it as ``simulate`` would have it end, nothing
        left for Python — at ``t_end``, every requested time sampled, its instants under ``max_events``
        and through the Zeno watch's test (:meth:`ZenoWatch.quiet_rows`; the initial instant not watched)?"""
        done = np.zeros(len(self.calls), dtype=bool)
        if not self.index:
            return done
        rows = np.fromiter(self.index.keys(), dtype=np.int64, count=len(self.index)) - self.first
        ends, te = self.ends, self.inputs[rows[0]][4]
        ok = (ends[:, 0] == DONE) & (ends[:, 2] <= options["max_events"])
        if self.inputs[rows[0]][1][4] == 2:
            ok &= ends[:, 5] == len(te)
        t0, t_end = options["t0"], float(self.inputs[rows[0]][2][1])
        gap = options["zeno_min_gap"]
        watch = ZenoWatch(options["zeno_window"], t_end, 1e-9 * (t_end - t0) if gap is None else gap)
        most = max(int(ends[:, 2].max()), 1)
        ok &= watch.quiet_rows(self.outs[3][:, :most, 0], ends[:, 2], self.outs[5][:, 2] != 0)
        done[rows] = ok
        return done

    def result(self, compiled, run: int) -> KernelResult | None:
        """The kernel's result of ``run`` (views of the slab's arrays), ``None`` if it had no batch call."""
        k = self.index.get(run)
        if k is None:
            return None
        status, n_saved, n_events, mode, steps, n_te = (int(v) for v in self.ends[k])
        return KernelResult(compiled, status, float(self.t_stop[k]), mode, steps, n_saved, n_events,
                            tuple(a[k] for a in self.outs), n_te)


def _threads() -> int:
    import numba

    return max(1, int(numba.get_num_threads()))


_PARALLEL_IN = []  # the process that first ran the batch in parallel


def _parallel_here() -> bool:
    """Can this process run the batch on numba's threads?  Not in a process forked from one whose GNU
    OpenMP pool ran (numba's ``omp`` layer): that pool does not survive ``fork`` (the child would be
    terminated), so such a child runs its batches on one thread."""
    import numba

    pid = os.getpid()
    if not _PARALLEL_IN:
        _PARALLEL_IN.append(pid)
    if _PARALLEL_IN[0] == pid:
        return True
    try:
        return numba.threading_layer() != "omp"
    except ValueError:  # (no parallel region ran in this process's line yet)
        return True


# ------------------------------------------------------------ the batch


def _checked(model, parameter_sets, t_end, method, options, what: str, one_kind: bool = True) -> tuple[list, str, dict]:
    from ..model.hybrid_model import HybridModel

    if not isinstance(model, HybridModel):
        raise ParameterValueError(f"{what}: model must be a HybridModel (built once; the sets give its values), "
                                  f"got {type(model).__name__}", "model", model)
    sets = list(parameter_sets)
    for k, p in enumerate(sets):
        if not isinstance(p, Mapping):
            raise ParameterValueError(f"{what}: parameter set {k} is a {type(p).__name__}, not a dict of parameter "
                                      "values", "parameter_sets", p)
    method = canonical_method(method)
    if one_kind and (not METHOD_CLASSES[method].compiled or METHOD_CLASSES[method].chooses):
        raise ParameterValueError(f"{what}: a batch runs in the compiled kernel with one method: give 'euler-jit', "
                                  f"'rk4-jit', 'RK45-jit' or 'rodas-jit', not {method!r} (simulate_many runs any "
                                  "method one run at a time)", "method", method)
    check_option_names(options, what)
    for name in ("progress", "x0", "mode"):
        if options.get(name) is not None:
            raise ParameterValueError(f"{what}: option {name}= is not taken by a batch (runs start from the model's "
                                      "initial state and mode, which each set's values give; a set may give "
                                      "states' initial values by their names)", name, options[name])
    return [dict(p) for p in sets], method, {**option_defaults(), **options}


def _slabs(count: int, n: int, options: dict, event_capacity: int) -> int:
    """Runs a slab holds: its outputs within :data:`SLAB_BYTES`."""
    te = options.get("t_eval")
    per_sample = 8 * (n + 2)
    samples = len(te) if te is not None else (STEP_CAPACITY if options["output"] == "steps" else 1)
    per_run = samples * per_sample + event_capacity * 8 * (5 + 2 * n) + 8 * (5 + n)
    return max(1, min(count, SLAB_BYTES // max(per_run, 1)))


def _batched(model, sets, t_end, method, keywords, event_capacity, each) -> None:
    """Run every set of ``sets`` on ``model``, a slab of runs at a time, and call ``each(slab, complete,
    replay)`` for each slab in order: the slab (its runs' kernel results, :meth:`_Slab.result`), which of
    its runs the batch call completed (:meth:`_Slab.completed`), and ``replay(run)``, which sets the run's
    values on the model and gives the run's trajectory as ``simulate`` records it (from its batch call
    on, or ``simulate``'s own run) or raises its error.  The model's values are restored at the end."""
    values = _Values(model)
    compiled = None
    size = _slabs(len(sets), len(model.states), keywords, event_capacity)
    # the first run alone: the modes it meets that are not compiled yet are compiled as simulate meets them,
    # for the batch calls of the others (which would each leave such a mode to simulate)
    starts = [0, *range(1, len(sets), size)] if sets else []
    try:
        for first, end in zip(starts, [*starts[1:], len(sets)]):
            slab = _Slab(first, [])
            for run in range(first, end):
                arguments = None
                try:
                    own = values.apply(sets[run])
                    hybrid = prepared_run(model, t_end, method, {**keywords, **own} if own else keywords, keep=False)
                    arguments = hybrid.first_kernel_call()
                    compiled = hybrid.compiled
                except HybridBondGraphError:
                    arguments = None  # simulate meets the same error, and records it
                slab.calls.append(arguments)
                slab.inputs.append(None if arguments is None else compiled.call_arrays(**arguments))
            if compiled is not None:
                slab.run(compiled, event_capacity)

            def replay(run, slab=slab):
                own = values.apply(sets[run])  # (a value the model refuses raises here: the run's error)
                hybrid = prepared_run(model, t_end, method, {**keywords, **own} if own else keywords, keep=False)
                result = slab.result(compiled, run)
                if result is not None:
                    hybrid.compiled = FirstCallAnswered(hybrid.compiled, result, slab.calls[run - slab.first])
                return hybrid.execute()

            each(slab, slab.completed(keywords), replay)
    finally:
        values.restore()


def simulate_batch(model, parameter_sets, t_end: float, method: str = "RK45-jit", *,
                   event_capacity: int = EVENT_CAPACITY, **options) -> BatchResult:
    """Simulate ``model`` to ``t_end`` [s] with the compiled ``method`` for
    every set of values in ``parameter_sets`` (each a dict name → number of
    the model's parameters and of the parameters only its initial state
    uses, the others keeping the model's values; and of states, whose values
    replace those of the model's initial state: the run's ``x0``); one batch of kernel calls in
    parallel, results identical to ``model.simulate`` with each set's values
    (see the module docstring).  ``options`` are ``simulate``'s (``rtol``,
    ``atol``, ``max_step``, ``t_eval``, ``on_zeno``, …; not ``x0``, ``mode``,
    ``samples``, ``output`` or ``progress``); ``event_capacity``: the instants a
    run's record holds in the batch (a run with more is finished by
    ``simulate``'s own recording).  What is recorded: :class:`BatchResult`
    (each run's end, its instants' times, the states at ``t_eval``).

    Example — 10 000 bouncing balls over a grid of restitution and drop height::

        sets = [{"e": e, "y0": h} for e in np.linspace(0.5, 0.9, 100) for h in np.linspace(0.5, 2.0, 100)]
        batch = simulate_batch(bouncing_ball.build(), sets, 4.0, "RK45-jit", rtol=1e-8)
        batch.final("y"), batch.event_counts
    """
    for name in ("samples", "output"):
        if options.get(name) is not None:
            raise ParameterValueError(f"simulate_batch: option {name}= is not taken: a batch records each run's end, "
                                      "its instants and the states at t_eval (simulate_many(model, …) gives whole "
                                      "trajectories)", name, options[name])
    sets, method, keywords = _checked(model, parameter_sets, t_end, method, options, "simulate_batch")
    if not isinstance(event_capacity, int) or isinstance(event_capacity, bool) or event_capacity < 1:
        raise ParameterValueError(f"simulate_batch: event_capacity must be an integer >= 1, got {event_capacity!r}",
                                  "event_capacity", event_capacity)
    if keywords["t_eval"] is None:
        keywords["output"] = "events"  # what a batch records needs no steps
    te = None if keywords["t_eval"] is None else np.asarray(sorted(keywords["t_eval"]), dtype=float)
    out = _Arrays(len(sets), len(model.states), te)

    def each(slab, complete, replay):
        out.from_kernel(slab, complete)
        for k in np.flatnonzero(~complete):
            run = slab.first + int(k)
            try:
                out.from_trajectory(run, replay(run))
            except HybridBondGraphError as exc:
                out.errors[run] = str(exc)
                if getattr(exc, "trajectory", None) is not None:
                    out.from_trajectory(run, exc.trajectory, failed=True)

    _batched(model, sets, t_end, method, keywords, event_capacity, each)
    most = int(out.counts.max()) if len(sets) else 0
    events = out.events[:, :most]
    return BatchResult(sets, tuple(model.state_names), out.t, out.x, out.modes, out.status, out.errors, out.steps,
                       out.counts, events, te, out.samples, out.in_kernel)


class _Arrays:
    """What :func:`simulate_batch` records of ``R`` runs of ``n`` states (see :class:`BatchResult`), filled
    from the kernel's arrays a slab at a time, or from a trajectory a run at a time."""

    def __init__(self, R: int, n: int, te):
        self.t, self.x = np.full(R, np.nan), np.full((R, n), np.nan)
        self.modes, self.status, self.errors = [None] * R, ["failed"] * R, [None] * R
        self.steps, self.counts = np.zeros(R, dtype=np.int64), np.zeros(R, dtype=np.int64)
        self.events = np.full((R, 0), np.nan)
        self.te = te
        self.samples = None if te is None else np.full((R, len(te), n), np.nan)
        self.in_kernel = np.zeros(R, dtype=bool)
        self.labels: dict = {}  # a mode → its label

    def from_kernel(self, slab, complete) -> None:
        """The slab's runs its batch call completed."""
        runs = np.flatnonzero(complete)
        if not len(runs):
            return
        rows = np.array([slab.index[slab.first + int(k)] for k in runs], dtype=np.int64)
        runs = runs + slab.first
        ends, (_, out_x, _, ev_f, _, info) = slab.ends[rows], slab.outs
        self.t[runs] = slab.t_stop[rows]
        self.x[runs] = info[rows, 5:]
        self.steps[runs] = ends[:, 4]
        self.counts[runs] = ends[:, 2]
        times = ev_f[rows, :max(int(ends[:, 2].max()), 1), 0]
        self._widen(times.shape[1])
        self.events[runs, :times.shape[1]] = np.where(np.arange(times.shape[1])[None, :] < ends[:, 2:3], times, np.nan)
        self.in_kernel[runs] = True
        if self.samples is not None:
            self.samples[runs] = out_x[rows]
        modes = slab.modes
        for run, number in zip(runs.tolist(), ends[:, 3].tolist()):
            self.modes[run] = self._label(modes[number])
            self.status[run] = "ok"

    def _widen(self, width: int) -> None:
        """Room for ``width`` instants' times in every run's row."""
        if width > self.events.shape[1]:
            self.events = np.pad(self.events, ((0, 0), (0, width - self.events.shape[1])), constant_values=np.nan)

    def _label(self, mode) -> str:
        label = self.labels.get(mode)
        if label is None:
            label = self.labels[mode] = mode.describe()
        return label

    def from_trajectory(self, run: int, trajectory, failed: bool = False) -> None:
        """A run that ``simulate``'s recording finished (or that failed, with what it computed)."""
        if len(trajectory.t):
            self.t[run] = trajectory.t[-1]
            self.x[run] = trajectory.x[-1]
            self.modes[run] = self._label(trajectory.modes[-1])
        self.status[run] = "failed" if failed else "stopped" if trajectory.stopped else "ok"
        self.steps[run] = trajectory.stats.get("steps", 0)
        self.counts[run] = trajectory.instant_count
        times = np.asarray(trajectory.event_times, dtype=float)
        self._widen(len(times))
        self.events[run, :len(times)] = times
        if self.te is not None:
            keep = np.isin(trajectory.t, self.te)
            self.samples[run, np.searchsorted(self.te, trajectory.t[keep])] = trajectory.x[keep]


def batch_results(model, parameter_sets, t_end: float, method: str, *, metrics=None, trajectories: bool = True,
                  **options) -> list[RunResult]:
    """:func:`switching.simulate_many` of a model (not a build function): each set's :class:`RunResult`
    (the same as ``model.simulate`` with the set's values).  With a compiled method of one kind the runs'
    first kernel calls are made in batches (:func:`simulate_batch`'s) and each run's trajectory recorded
    by ``simulate`` itself from its batch call; with another method the runs are made one after the
    other.  ``metrics`` and ``trajectories`` as for ``simulate_many``."""
    sets, method, keywords = _checked(model, parameter_sets, t_end, method, options, "simulate_many", one_kind=False)
    results: list = [None] * len(sets)
    if not METHOD_CLASSES[method].compiled or METHOD_CLASSES[method].chooses:  # one run after the other
        values = _Values(model)

        def simulate(run):
            own = values.apply(sets[run])
            return prepared_run(model, t_end, method, {**keywords, **own} if own else keywords, keep=False).execute()

        try:
            return [result_of_run(p, partial(simulate, run), metrics, trajectories, time.perf_counter())
                    for run, p in enumerate(sets)]
        finally:
            values.restore()

    def each(slab, complete, replay):
        for run in range(slab.first, slab.first + len(slab.calls)):
            results[run] = result_of_run(sets[run], partial(replay, run), metrics, trajectories, time.perf_counter())

    _batched(model, sets, t_end, method, keywords, EVENT_CAPACITY, each)
    return results
