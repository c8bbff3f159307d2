"""The hybrid simulator (``HybridModel.simulate``).

Loop: flow in the current mode with the chosen integrator (independent
states only; dependent states follow their constraints exactly), test every
guard at each step end, locate the first time a guard holds on the step's
interpolant (narrowed to adjacent floating-point numbers by the ITP method,
bisection's bracket in fewer evaluations, :mod:`switching.rules.bracket`; so
the event time is exact up to the interpolant's own error), resolve the instant there
(mythical modes, pinnacles; DESIGN §6), and restart the flow.

The guard test during location is the one the instant's resolution uses
(tolerance band included): the located time is the first at which the
resolution sees the guard hold, so a located event fires, and an event never
re-triggers itself — after resolution no guard holds, and flow must make one
hold again before it can fire.  The one exception is an instant that rested
at a tie (:mod:`switching.rules.instants`: a cycle of switches each enabled
only by an inclusive comparison at its edge, none taken): a guard may hold
there at its edge, and the flow from it — in Python, also for a compiled
method — counts a guard only once it holds strictly
(:class:`~switching.simulate.events.GuardScan`, ``strict``).

Failures raise a :class:`~switching.errors.SimulationError` subclass that
carries the trajectory computed so far.

This module is the driver: :func:`simulate`, the run object
:class:`HybridRun` and how a run ended (:class:`Status`).  It looks the
method up in the table of :mod:`.methods`, takes its options checked and
grouped from :mod:`.run_options` (:mod:`.option_groups`), and hands each
flow to :mod:`.python_flow` (the integrators of :mod:`.integrators` on the
functions of :mod:`.flow_rates`) or to the compiled kernel
(:mod:`.compiled_flow`); :mod:`.recorder` keeps the samples, :mod:`.zeno`
watches the instants, :mod:`.flow_failures` words what went wrong.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import math
import time as _time
from typing import NamedTuple

import numpy as np

from bondgraph.errors import HybridBondGraphError
from codegen.jit import available as _jit_available

from ..errors import (NonFiniteStateError, SimulationError, SimulationInterrupted, StiffnessError, UnknownOptionError,
                      ZenoError)
from ..library.jit_model import choose_method as _choose_method
from ..library.jit_model import input_problem as _input_problem
from ..library.jit_model import remember_modes as _remember_modes
from ..model.source_periods import step_bound
from .compiled_flow import kernel_arguments, kernel_kind, run_kernel
from .flow_failures import FlowFailure, nonfinite_jump_message
from .methods import METHOD_CLASSES, METHODS, canonical_method
from .option_groups import RunOptions
from .energy_watch import warn_if_created
from .preflight import nonfinite_at_start, nonfinite_sides_at_start
from .progress import ProgressBar
from .step_doubling import warn_if_coarse
from .python_flow import flow_python
from .real_values import ComplexValueError, complex_failure
from .recorder import Recorder
from .run_options import DEFAULT_MAX_STEPS, checked_options, options_key
from .set_up import keep_set_up, kept_set_up
from .state_tolerances import state_tolerances
from .trajectory import Trajectory
from .zeno import ZenoWatch

__all__ = ["simulate", "HybridRun", "Status", "METHODS", "check_option_names", "option_defaults"]


#: options of HybridModel.simulate besides those of simulate() itself
_MODEL_OPTIONS = ("sensitivities", "sensitivity_rtol", "sensitivity_atol")
_LIST_STATES = 16  # euler and rk4 step on lists of floats up to this many states (faster than small arrays)


@functools.cache
def _known_options() -> tuple:
    """The keyword options of :func:`simulate` and of ``HybridModel.simulate`` (read once: ~50 µs a run)."""
    import inspect

    return tuple(name for name, p in inspect.signature(simulate).parameters.items()
                 if p.kind is inspect.Parameter.KEYWORD_ONLY) + _MODEL_OPTIONS


@functools.cache
def option_defaults() -> dict:
    """The keyword options of :func:`simulate` with their defaults."""
    import inspect

    return {name: p.default for name, p in inspect.signature(simulate).parameters.items()
            if p.kind is inspect.Parameter.KEYWORD_ONLY}


@functools.cache
def _known_option_set() -> frozenset:
    """:func:`_known_options` as a set (a look-up in it costs one hash, not a scan)."""
    return frozenset(_known_options())


def check_option_names(options, what: str = "simulate") -> None:
    """Raise :class:`UnknownOptionError` for an option ``simulate`` does not
    take (a misspelt ``rtoll=``), naming the closest known ones — before
    anything runs, rather than Python's bare ``TypeError`` (or, in a sweep,
    one failed run per parameter set)."""
    if _known_option_set().issuperset(options):
        return
    known = _known_options()
    for name in options:
        if name not in known:
            import difflib

            close = difflib.get_close_matches(name, known, n=3)
            raise UnknownOptionError(
                f"{what}: unknown option {name!r}" + (f"; did you mean {' or '.join(map(repr, close))}?" if close else "")
                + f" The options are: {', '.join(known)}")


def simulate(
    model,
    t_end: float,
    method: str = "RK45",
    *,
    dt: float | None = None,
    rtol: float = 1e-6,
    atol: float | None = None,
    t0: float = 0.0,
    x0=None,
    mode=None,
    output: str = "steps",
    t_eval=None,
    samples: int | None = None,
    max_step: float = np.inf,
    first_step: float | None = None,
    on_zeno: str = "raise",
    zeno_window: int = 8,
    zeno_min_gap: float | None = None,
    keep_instants: bool = True,
    max_events: int = 1_000_000,
    max_steps: int = DEFAULT_MAX_STEPS,
    progress=None,
    event_samples: int = 3,
    stiffness_check: bool = True,
) -> Trajectory:
    """Simulate ``model`` from ``t0`` to ``t_end``; see :meth:`HybridModel.simulate`
    (the options, their units and bounds: :mod:`switching.simulate.run_options`)."""
    keywords = {"dt": dt, "rtol": rtol, "atol": atol, "t0": t0, "x0": x0, "mode": mode, "output": output,
                "t_eval": t_eval, "samples": samples, "max_step": max_step, "first_step": first_step,
                "on_zeno": on_zeno, "zeno_window": zeno_window, "zeno_min_gap": zeno_min_gap,
                "keep_instants": keep_instants, "max_events": max_events, "max_steps": max_steps,
                "progress": progress, "event_samples": event_samples, "stiffness_check": stiffness_check}
    if progress is not True:
        return prepared_run(model, t_end, method, keywords).execute()
    bar = ProgressBar(t0, t_end)
    try:
        return prepared_run(model, t_end, method, {**keywords, "progress": bar}).execute()
    finally:
        bar.close()


def prepared_run(model, t_end: float, method: str, keywords: dict, keep: bool = True) -> HybridRun:
    """The run :func:`simulate` executes, set up and not started: ``keywords`` are all of its options
    (:func:`option_defaults` gives them), checked here.  A batch of runs
    (:mod:`switching.sweep.kernel_batch`) prepares each this way, so that its runs start as ``simulate``'s.
    ``keep``: the run may take the set-up of the model's last run and keep its own (:mod:`.set_up`); a
    batch's runs, each with its own values, do neither."""
    method = canonical_method(method)  # (a method's name in any case)
    key = None if METHOD_CLASSES.get(method) is None or METHOD_CLASSES[method].chooses \
        or keywords["progress"] is not None else options_key(t_end, method, keywords)
    kept = kept_set_up(model, key) if keep else None  # the model's last run's set-up, if it had these options
    if kept is not None:
        options = kept[0].options
    elif key is not None:
        options = checked_options(model, t_end, method, keywords, key)
    else:  # (auto, a progress callback: options kept by checked_options alone)
        options = checked_options(model, t_end, method, keywords)
    dt, rtol, atol, max_step = keywords["dt"], keywords["rtol"], keywords["atol"], keywords["max_step"]
    #: the settings of the model's last run (``model.save()`` writes them as the file's ``[run]``)
    model.last_run = _last_run(t_end, method, dt, rtol, atol, max_step)
    if kept is not None:  # (its options bounded and scaled already)
        return HybridRun(model, options, kept)
    if options.stepping.dt is None and max_step == math.inf:  # a step that samples every cycle of the sources
        bound = max(step_bound(model), 4.0 * (options.t_end - options.start.t0) / options.limits.max_steps)
        if bound < np.inf:
            options = _with_stepping(options, "max_step", bound)
    return HybridRun(model, options, keep_as=key if keep else None)


def _last_run(t_end, method: str, dt, rtol, atol, max_step) -> dict:
    """The settings a run's ``[run]`` section of a model file holds: ``t_end`` [s], ``method``, ``dt`` [s] or
    ``rtol`` (and ``atol`` when given), ``max_step`` [s] when finite."""
    settings = {"t_end": float(t_end), "method": method}
    if dt is not None:
        settings["dt"] = float(dt)
    else:
        settings["rtol"] = float(rtol)
        if atol is not None:
            settings["atol"] = float(atol)
    if math.isfinite(max_step):
        settings["max_step"] = float(max_step)
    return settings


#: (options, a step option, its value) → the options with that value: the last kept
_WITH_STEPPING: dict = {}
_WITH_STEPPING_KEPT = 64


def _with_stepping(options: RunOptions, name: str, value) -> RunOptions:
    """``options`` with ``stepping.<name> = value``, the same object for the same options and value (a
    number told by its value and type, an array by its identity: the entry holds both alive), so that
    a loop of runs (a parameter study) does not rebuild them every run."""
    key = (id(options), name, id(value) if isinstance(value, np.ndarray) else (type(value), value))
    found = _WITH_STEPPING.get(key)
    if found is None:
        if len(_WITH_STEPPING) >= _WITH_STEPPING_KEPT:
            _WITH_STEPPING.clear()
        found = _WITH_STEPPING[key] = (options, value, dataclasses.replace(
            options, stepping=dataclasses.replace(options.stepping, **{name: value})))
    return found[2]


class Status(enum.Enum):
    """How a run ended (``Trajectory.stopped`` holds the value: ``None`` when it reached ``t_end``)."""

    FINISHED = None
    ZENO = "zeno"  # events piled up in shrinking time and on_zeno="stop" ended the run at their accumulation


#: a Zeno sequence accumulating within this fraction of the run after its start is a bad initial state
_AT_THE_START = 1e-12


class HybridRun:
    """One run of :func:`simulate`: flows in a mode (compiled or in Python),
    the instants between them, the record, the checks that stop a run.

    ``options`` are :func:`simulate`'s, checked and grouped
    (:func:`switching.simulate.run_options.checked_options`).  :meth:`execute` runs to
    ``t_end`` and returns the :class:`~switching.simulate.trajectory.Trajectory`; a
    failure raises an error of the hierarchy that carries the trajectory
    computed so far (:meth:`fail`).  ``kept``: ``(the set-up of an earlier run, this run's initial
    state)`` (:func:`switching.simulate.set_up.kept_set_up`), taken whole with its options; ``keep_as``:
    the options' key under which this run keeps its own set-up as it starts (``None``: it keeps none)."""

    def __init__(self, model, options: RunOptions, kept: tuple | None = None, keep_as=None):
        self.model, self.t_end, self.options = model, options.t_end, options
        start, stepping, events = options.start, options.stepping, options.events
        method, t_end, t0 = options.method, options.t_end, start.t0
        self.auto = None
        self.output = options.output.recorded
        self.started = _time.perf_counter()
        #: the set-up of an earlier run this one takes whole (options, starting mode, the start's check:
        #: switching.simulate.set_up), else None; what this run keeps its own under (None: nothing kept)
        self.kept, self.keep_as = (None, keep_as) if kept is None else (kept[0], None)
        if kept is not None:  # (its options carry the states' tolerances already)
            self.x, projected, self.mode = kept[1], self.kept.projected, self.kept.mode
        else:
            self.x = model.initial_state() if start.x0 is None else start.x0
            projected = model.initial_projection if start.x0 is None else None
            self.mode = model.starting_mode(self.x, t0, start.mode)
        if stepping.dt is None and kept is None:  # each state's absolute tolerance (.state_tolerances)
            self.options = options = _with_stepping(options, "atol", state_tolerances(model, self.x, stepping.atol))
            stepping = options.stepping
        if METHOD_CLASSES[method].chooses:  # auto: compiled or not, explicit or implicit (stats: which and why;
            # switching.library.jit_model.choose_method)
            self.auto = _choose_method(model, t0, t_end, stepping.rtol, stepping.dt, self.x, self.mode)
            method = self.auto.method
        self.method = method
        self.method_class = METHOD_CLASSES[method]
        self.recorder = Recorder(model, self.output, options.output.t_eval, options.output.keep_instants,
                                 None if projected is None else (float(t0), *projected),
                                 with_instants=options.output.samples is not None)
        self.recorder.start(t0)
        self.zeno = ZenoWatch(events.zeno_window, t_end,
                               1e-9 * (t_end - t0) if events.zeno_min_gap is None else events.zeno_min_gap)
        self.rtol_g, self.atol_g = model.tolerance.rtol, model.tolerance.atol
        self.t = float(t0)
        self.n_steps = 0
        self.python_instants = 0
        self.progress_failed_at = None  # the time a progress callback that raised was called with
        self.implicit_python: set = set()  # auto: modes whose Python flow proved stiff (they flow with Radau)
        self.accumulation = None
        self.compiled, self.flow_method, self.start_functions = self._compiled_path()

    def _compiled_path(self):
        """``(the compiled model or None, the method class of a flow in Python, the starting mode's generated
        functions (its CompiledMode) or None)``."""
        method, model = self.method, self.model
        if not self.method_class.compiled:
            return None, self.method_class.python, None
        if not _jit_available():
            raise SimulationError(f"method {method!r} needs numba: pip install '.[fast]'")
        problem = _input_problem(model, method)  # inputs that are Python functions cannot run compiled
        if problem:
            raise SimulationError(problem)
        cm = model.compiled_mode(self.mode)
        # the modes visited or remembered; one first reached: then
        return model.compiled_model(), self.method_class.python, cm

    # ------------------------------------------------------------ failures

    def fail(self, cls, message, **extra):
        """An error ``cls`` with ``message`` carrying the trajectory up to now (the current state recorded)."""
        recorder, t, x = self.recorder, self.t, self.x
        if not recorder.t or t > recorder.t[-1] or (t == recorder.t[-1] and not np.array_equal(x, recorder.x[-1])):
            recorder.sample(t, x, self.mode, force=True)  # (a flow stopped mid-way has recorded beyond t)
        return cls(message, trajectory=recorder.trajectory(stats={"failed": message.splitlines()[0]}), t=t,
                   mode=self.mode, **extra)

    # ------------------------------------------------------------ instants

    def initial_instant(self) -> None:
        """The instant at t0 in Python: the initial mode may be mythical, or a pinnacle."""
        try:
            instant = self.model.resolve(self.x, self.mode, self.t)
        except SimulationError:
            raise
        except Exception as exc:
            if hasattr(exc, "instant"):
                exc.trajectory = self.recorder.trajectory()
            raise
        if len(instant.steps) > 1:
            self.recorder.event(instant)
        if not np.all(np.isfinite(instant.x_after)):
            raise self.fail(NonFiniteStateError, nonfinite_jump_message(self.model, instant))
        self.x, self.mode = instant.x_after, instant.mode_after

    def after_event(self, instant) -> bool:
        """Record an instant; stop (True) or raise on Zeno behaviour or too many events."""
        self.recorder.event(instant)
        self.t, self.x, self.mode = instant.t, instant.x_after, instant.mode_after
        max_events = self.options.limits.max_events
        if self.recorder.n_events > max_events:
            raise self.fail(SimulationError, f"more than {max_events} events; raise max_events if this is expected")
        self.accumulation = self.zeno.add(self.t)
        if self.accumulation is None:
            return False
        t0 = self.options.start.t0
        if self.accumulation - t0 <= _AT_THE_START * (self.t_end - t0):
            # a sequence that accumulates as the run starts is a state that starts beyond what a transition
            # allows (a position below a stop: each rebound leaves it there), not a physical Zeno sequence
            state = ", ".join(f"{s.name} = {v:.6g}" for s, v in zip(self.model.states, self.x))
            message = (
                f"events pile up at the start of the run (t0 = {t0:g} s, {self.recorder.n_events} instants by t = "
                f"{self.t:.3g} s, mode {self.mode.describe()}; state {state}): the initial state is where a "
                "transition fires again after each of its own jumps — a position beyond a stop or a limit, say. "
                "Check the initial state (x0, the initial values of the model) against the model's limits"
            )
        else:
            message = (
                f"Zeno behaviour: events pile up in shrinking time near t = {self.t:.12g} (mode "
                f"{self.mode.describe()}); they accumulate at t ≈ {self.accumulation:.10g} s. Add a rule that ends "
                "the sequence (e.g. a resting threshold), or pass on_zeno='stop' to end the run there."
            )
        if self.options.events.on_zeno == "raise":
            raise self.fail(ZenoError, message, accumulation_time=self.accumulation)
        return True

    def instants_pass(self, times: list, count: int) -> bool:
        """Would ``count`` instants about to be recorded, the Zeno watch seeing those at ``times`` [s], all
        pass :meth:`after_event` without stopping the run (nor raising)?  True: the watch has taken them,
        record them at once; False: nothing changed, take them one by one (:meth:`after_event` decides)."""
        if times and self.recorder.n_events + count > self.options.limits.max_events:
            return False
        return self.zeno.quiet(times)

    def instant_at(self, event) -> bool:
        """Resolve the instant of a located ``event`` ``(t, x)`` in Python; True when it stops the run."""
        self.t, self.x = event
        try:
            instant = self.model.resolve(self.x, self.mode, self.t)
        except Exception as exc:
            # a divergence of time, or a mode first met here that cannot be derived (a floating part):
            # the state at the instant is known, keep it
            if hasattr(exc, "instant") or isinstance(exc, HybridBondGraphError):
                self.recorder.sample(self.t, self.x, self.mode, force=True)
                exc.trajectory = self.recorder.trajectory(stats={"failed": str(exc).splitlines()[0]})
            raise
        self.python_instants += 1
        if not np.all(np.isfinite(instant.x_after)):
            self.t, self.x, self.mode = instant.t, instant.x_after, instant.mode_after
            raise self.fail(NonFiniteStateError, nonfinite_jump_message(self.model, instant))
        return self.after_event(instant)

    # ------------------------------------------------------------ the run

    def _flow_settings(self) -> _FlowSettings:
        o = self.options
        progress = o.output.progress
        return _FlowSettings(o.stepping, o.events.event_samples, self.output == "steps",
                             None if progress is None else self._watched(progress), self.rtol_g, self.atol_g,
                             o.limits.max_steps)

    def _watched(self, progress):
        """``progress``, noting the time it was called with when it raises (the error then names that time)."""
        def call(t):
            try:
                progress(t)
            except Exception:
                self.progress_failed_at = t
                raise
        return call

    def _start(self) -> bool:
        """Record the start and resolve the initial instant (in Python, unless the kernel does); returns
        whether the kernel resolves it."""
        model, compiled, kept = self.model, self.compiled, self.kept
        self.recorder.sample(self.t, self.x, self.mode, force=True)
        initial_in_kernel = compiled is not None and compiled.covers(self.mode)
        cm = self.start_functions  # (of self.mode, which only an initial instant in Python changes)
        if not initial_in_kernel:
            self._keep_set_up(cm, False)
            self.initial_instant()
        elif not (kept is not None and kept.start_checked and kept.start_functions() is cm):
            # the kernel flows, and tells non-finite rates itself (compiled_flow then names them): the sides here
            problem = nonfinite_sides_at_start(model, cm, self.x, self.t, self.rtol_g, self.atol_g)
            if problem:
                raise self.fail(NonFiniteStateError, problem)
            self._keep_set_up(cm, True)
        if self.options.output.t_eval is not None and not initial_in_kernel:  # (the kernel samples t0 after its instant)
            x = self.x
            self.recorder.dense(self.t - 1.0, self.t, lambda tau: x.copy(), self.mode)
        return initial_in_kernel

    def _keep_set_up(self, start_functions, start_checked: bool) -> None:
        """Keep this run's set-up for the model's next run with the same options (:mod:`.set_up`), as it
        starts (in ``self.mode``, with ``start_functions``; ``start_checked``: the guard sides are finite)."""
        if self.keep_as is not None:  # (a model with inputs checks its sides each start: they read u(t0))
            keep_set_up(self.model, self.keep_as, self.options, self.x, self.model.initial_projection, self.mode,
                        start_functions, start_checked and not self.model.input_signals.names)

    def first_kernel_call(self) -> dict | None:
        """The keywords of this run's first kernel call (:meth:`CompiledModel.run
        <switching.library.jit_model.CompiledModel.run>`'s), the initial instant resolved in it, when the
        run starts that way: a compiled method of one kind (not ``auto``, whose choice may change between
        runs), the initial mode compiled.  Otherwise ``None``.  It records the run's start, as
        :meth:`execute` does first, so a run asked this is not executed afterwards (a batch of runs,
        :mod:`switching.sweep.kernel_batch`, makes that call for many runs at once)."""
        if self.compiled is None or self.auto is not None or not self.t < self.t_end or not self._start():
            return None
        settings = self._flow_settings()
        return kernel_arguments(self.compiled, kernel_kind(self.compiled, self.method, None), self.mode, self.x,
                                self.t, self.t_end, settings, settings.max_steps, self.recorder, True)

    def _at_tie(self) -> bool:
        """Does a guard hold as the flow starts?  Only after an instant that rested at a tie: that flow counts a
        guard only once it holds strictly."""
        cm = self.model.compiled_mode(self.mode)
        return bool(cm.guards) and cm.holds(self.x, self.t, self.rtol_g, self.atol_g)

    def _run(self) -> Status:
        """Flows and instants up to ``t_end``."""
        model, compiled = self.model, self.compiled
        initial_in_kernel = self._start()
        settings = self._flow_settings()
        while self.t < self.t_end:
            steps_left = settings.max_steps - self.n_steps  # a run stops after max_steps steps
            try:
                tie = not initial_in_kernel and self._at_tie()
                # (a run that starts in the kernel: _start has just asked compiled.covers of this mode)
                if compiled is not None and (initial_in_kernel or compiled.covers(self.mode)) and not tie:
                    event, self.t, self.x, self.mode, steps, stop = run_kernel(
                        model, compiled, self.method, self.mode, self.x, self.t, self.t_end, settings, steps_left,
                        self.recorder, self.after_event, initial_in_kernel, auto=self.auto,
                        instants_pass=self.instants_pass)
                    if stop == "initial":  # the kernel leaves this initial instant to Python
                        initial_in_kernel = False
                        self.initial_instant()
                        continue
                    initial_in_kernel = False
                    if stop:
                        self.n_steps += steps
                        return Status.ZENO
                else:
                    cm = model.compiled_mode(self.mode)
                    problem = nonfinite_at_start(model, cm, self.x, self.t)
                    if problem:
                        raise self.fail(NonFiniteStateError, problem)
                    method = METHOD_CLASSES["Radau"] if self.mode in self.implicit_python else self.flow_method
                    event, self.t, self.x, steps = flow_python(model, cm, self.mode, method, self.x, self.t,
                                                               self.t_end, settings, steps_left, self.recorder,
                                                               _LIST_STATES, tie)
            except FlowFailure as failure:
                self.t, self.x = failure.t, failure.x
                self.mode = failure.mode or self.mode
                self.n_steps += failure.steps
                if self._implicit_from_here(failure):
                    continue
                raise self.fail(failure.cls, failure.message) from None
            self.n_steps += steps
            if event is None:
                break
            if self.instant_at(event):
                return Status.ZENO
        return Status.FINISHED

    def _implicit_from_here(self, failure) -> bool:
        """``auto``: a flow in Python whose explicit method proved stiff (its stiffness test fired) goes on from
        its last step with Radau, in this mode from now on (the stats say so); other failures stop the run."""
        cls = getattr(failure.cls, "func", failure.cls)
        if self.auto is None or not (isinstance(cls, type) and issubclass(cls, StiffnessError)) \
                or self.mode in self.implicit_python:
            return False
        self.implicit_python.add(self.mode)
        self.auto.note(self.mode, f"Radau in Python from t = {self.t:.6g} s, where {self.flow_method.name}'s "
                                  "stiffness test fired")
        return True

    def execute(self, all_rows: bool = False) -> Trajectory:
        """Run to ``t_end``; the trajectory, or an error carrying it (Ctrl-C:
        :class:`SimulationInterrupted`).  Its rows are those of the run's
        sampling (:meth:`Recorder.rows`), or with ``all_rows`` every sample
        recorded (the sensitivities integrate along those, then take the rows)."""
        try:
            status = self._run()
        except KeyboardInterrupt as exc:
            if isinstance(exc, SimulationInterrupted):
                raise
            if self.recorder.t:  # the latest state recorded, possibly inside a flow
                self.t, self.x, self.mode = self.recorder.t[-1], self.recorder.x[-1], self.recorder.modes[-1]
            raise self.fail(SimulationInterrupted,
                            f"interrupted at t = {self.t:.12g} s in mode {self.mode.describe()} (of "
                            f"{self.options.start.t0:g} … {self.t_end:g} s); what was computed up to there is kept"
                            ) from None
        except HybridBondGraphError as exc:  # e.g. a mode first reached mid-run that cannot be derived
            if getattr(exc, "trajectory", None) is None:
                exc.trajectory = self.recorder.trajectory(stats={"failed": str(exc).splitlines()[0]})
            raise
        except Exception as exc:  # an input function, a callback, a library: still nothing computed is lost
            complex_value = complex_failure(self.model, self.mode, exc)  # a law that left the reals: name it
            if complex_value is not None:  # the run ends where the law failed (the error's t and x)
                self.t, self.x = complex_value.pop("t"), np.asarray(complex_value["x"], dtype=float)
                raise self.fail(ComplexValueError, complex_value.pop("message"), **complex_value) from exc
            if self.recorder.t and self.recorder.t[-1] > self.t:  # the latest state recorded, inside a flow
                self.t, self.x, self.mode = self.recorder.t[-1], self.recorder.x[-1], self.recorder.modes[-1]
            where = f"at t = {self.t:.12g} s"
            if self.progress_failed_at is not None:
                where = (f"in its progress callback, called with t = {self.progress_failed_at:.12g} s (the run is "
                         f"kept up to t = {self.t:.12g} s)")
            raise self.fail(SimulationError,
                            f"the run failed {where} in mode {self.mode.describe()} with {type(exc).__name__}: "
                            f"{exc} (the trajectory up to there is attached; the original error and its traceback "
                            "are its cause)") from exc
        return self._finish(status, all_rows)

    def _finish(self, status: Status, all_rows: bool = False) -> Trajectory:
        """The trajectory of a run that ended (``status``), with its statistics."""
        stats = {"method": self.method, "steps": self.n_steps,
                 "wall time [s]": round(_time.perf_counter() - self.started, 6)}
        if self.compiled is not None:
            stats["instants resolved in Python"] = self.python_instants
            if self.python_instants:  # modes met outside the kernel: a new process's kernel covers them too
                _remember_modes(self.model, self.model.visited_modes)
        if self.auto is not None:
            stats.update(self.auto.report(self.t_end - self.options.start.t0, self.n_steps, self.recorder.n_events))
        if status is Status.ZENO:
            stats["zeno accumulation time [s]"] = self.accumulation
        recorder = self.recorder
        recorder.finish(self.t, self.x, self.mode)  # requested times at an instant that ended the run
        if self.output == "events" and recorder.last_time != self.t:
            recorder.sample(self.t, self.x, self.mode, force=True)
        trajectory = recorder.trajectory(stopped=status.value, stats=stats, complete=status is Status.FINISHED,
                                         all_rows=all_rows)
        # a fixed-step run's energy balance and its error estimate (adaptive methods control their error), on
        # its steps: other rows would not close the balance
        if self.method_class.fixed_step and self.output == "steps" and trajectory.sampling == "steps":
            created = warn_if_created(trajectory, self.method, self.options.stepping.dt)
            if created is not None:
                trajectory.stats["energy created in flows [J]"] = created
            estimate = warn_if_coarse(self.model, trajectory, self.method_class, self.options.stepping.dt)
            if estimate is not None:
                trajectory.stats["error estimate (step doubling)"] = estimate
        return trajectory


class _FlowSettings(NamedTuple):
    """What every flow of a run needs: the step options, the guard samples
    per step, whether every step is saved, the progress callback, the guard
    tolerances, the run's ``max_steps``.  (A named tuple: made at every run,
    in a fifth of a frozen dataclass's time.)"""

    stepping: object
    samples: int
    save: bool
    progress: object
    rtol_g: float
    atol_g: float
    max_steps: int

