"""The hybrid simulator (``HybridModel.simulate``).

Loop: flow in the current mode with the chosen integrator (independent
states only; dependent states follow their constraints exactly), test every
guard at each step end, locate the first time a guard holds by bisection on
the step's interpolant (to adjacent floating-point numbers, so the event time
is exact up to the interpolant's own error), resolve the instant there
(mythical modes, pinnacles; DESIGN §6), and restart the flow.

The guard test during location is the one the instant's resolution uses
(tolerance band included): the located time is the first at which the
resolution sees the guard hold, so a located event fires, and an event never
re-triggers itself — after resolution no guard holds, and flow must make one
hold again before it can fire.

Failures raise a :class:`~switching.errors.SimulationError` subclass that
carries the trajectory computed so far.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import math
import re
import time as _time
import weakref

import numpy as np

from bondgraph.errors import HybridBondGraphError
from codegen.jit import available as _jit_available

from ..errors import (NonFiniteStateError, SimulationError, SimulationInterrupted, StepLimitError, StepSizeError,
                     StiffnessError, UnknownOptionError, ZenoError)
from .events import GuardScan, locate_event
from .integrators import StepFailed, StiffnessDetected
from ..library.jit_model import KINDS, CompiledInstant
from ..library.jit_model import STATUS as _KERNEL_STATUS
from ..library.jit_model import choose_method as _choose_method
from ..library.jit_model import input_problem as _input_problem
from ..library.jit_model import remember_modes as _remember_modes
from .preflight import nonfinite_at_start
from .real_values import ComplexValueError, complex_failure
from .methods import METHOD_CLASSES, METHODS, method_names
from .option_groups import RunOptions
from .run_options import DEFAULT_MAX_STEPS, checked_options
from .trajectory import Trajectory

__all__ = ["simulate", "HybridRun", "Status", "METHODS", "check_option_names", "option_defaults"]


class _Recorder:
    def __init__(self, model, output, t_eval, keep_instants=True):
        self.model = model
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
                          mode_time=mode_time, instants_kept=self.keep_instants)


class _ZenoWatch:
    """Detects events accumulating in geometrically shrinking time.

    Zeno is declared when the last ``window`` gaps between events shrink by a
    steady ratio (within 5 %), the latest gap is below ``min_gap`` (so a
    sequence that a resting rule would still end is not cut short), and the
    Aitken extrapolation of the event times — exact for a geometric sequence —
    falls before ``t_end``.  Three gaps at round-off level also count.

    ``simulate`` takes ``min_gap`` = 1e-9 of the horizon unless told: a
    resting rule of a physical model acts on flights far longer than that,
    and a true Zeno sequence with gap ratio ``e`` is still declared after
    about ``log(1e9)/log(1/e)`` events (the bouncing ball with e = 0.95: 334),
    its accumulation time exact to round-off (the gaps stay geometric down
    to that size)."""

    def __init__(self, window: int, t_end: float, min_gap: float):
        self.window = window
        self.t_end = t_end
        self.min_gap = min_gap
        self.times: list[float] = []

    def add(self, t: float):
        """Return the estimated accumulation time if Zeno behaviour is seen
        (plain floats: this runs at every event)."""
        times = self.times
        times.append(t)
        if len(times) > self.window + 2:
            del times[0]  # only the recent events matter: bounded memory
        gaps = [b - a for a, b in zip(times, times[1:])]
        tiny = 16 * math.ulp(abs(t) + 1.0)
        if len(gaps) >= 3 and gaps[-1] <= tiny and gaps[-2] <= tiny and gaps[-3] <= tiny:
            return t  # events one ulp apart: accumulated already
        if len(times) < self.window + 2 or min(gaps) <= 0:
            return None
        ratios = [b / a for a, b in zip(gaps, gaps[1:])]
        if not ratios:
            return None
        if gaps[-1] < self.min_gap and max(ratios) < 0.995 and \
                max(ratios) - min(ratios) <= 0.05 * (sum(ratios) / len(ratios)):
            t2, t1, t0 = times[-1], times[-2], times[-3]
            denominator = t2 - 2 * t1 + t0
            accumulation = t2 - (t2 - t1) ** 2 / denominator if denominator != 0 else t2
            if accumulation <= self.t_end:
                return accumulation
        return None


#: options of HybridModel.simulate besides those of simulate() itself
_MODEL_OPTIONS = ("sensitivities", "sensitivity_rtol", "sensitivity_atol")


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


def check_option_names(options, what: str = "simulate") -> None:
    """Raise :class:`UnknownOptionError` for an option ``simulate`` does not
    take (a misspelt ``rtoll=``), naming the closest known ones — before
    anything runs, rather than Python's bare ``TypeError`` (or, in a sweep,
    one failed run per parameter set)."""
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
    atol: float = 1e-9,
    t0: float = 0.0,
    x0=None,
    mode=None,
    output: str = "steps",
    t_eval=None,
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
    keywords = dict(dt=dt, rtol=rtol, atol=atol, t0=t0, x0=x0, mode=mode, output=output, t_eval=t_eval,
                    max_step=max_step, first_step=first_step, on_zeno=on_zeno, zeno_window=zeno_window,
                    zeno_min_gap=zeno_min_gap, keep_instants=keep_instants, max_events=max_events, max_steps=max_steps,
                    progress=progress, event_samples=event_samples, stiffness_check=stiffness_check)
    return HybridRun(model, checked_options(model, t_end, method, keywords)).execute()


class Status(enum.Enum):
    """How a run ended (``Trajectory.stopped`` holds the value: ``None`` when it reached ``t_end``)."""

    FINISHED = None
    ZENO = "zeno"  # events piled up in shrinking time and on_zeno="stop" ended the run at their accumulation


class HybridRun:
    """One run of :func:`simulate`: flows in a mode (compiled or in Python),
    the instants between them, the record, the checks that stop a run.

    ``options`` are :func:`simulate`'s, checked and grouped
    (:func:`switching.simulate.run_options.checked_options`).  :meth:`execute` runs to
    ``t_end`` and returns the :class:`~switching.simulate.trajectory.Trajectory`; a
    failure raises an error of the hierarchy that carries the trajectory
    computed so far (:meth:`fail`)."""

    def __init__(self, model, options: RunOptions):
        self.model, self.t_end, self.options = model, options.t_end, options
        start, stepping, events = options.start, options.stepping, options.events
        method, t_end, t0 = options.method, options.t_end, start.t0
        self.auto = None
        if METHOD_CLASSES[method].chooses:  # auto: RK45 compiled or not (switching.library.jit_model.choose_method)
            self.auto = _choose_method(model, t0, t_end, stepping.rtol, stepping.dt)  # the stats say which and why
            method = self.auto.method
        self.method = method
        self.method_class = METHOD_CLASSES[method]
        self.output = options.output.recorded
        self.started = _time.perf_counter()
        self.x = model.initial_state() if start.x0 is None else start.x0
        self.mode = model.starting_mode(self.x, t0, start.mode)
        self.recorder = _Recorder(model, self.output, options.output.t_eval, options.output.keep_instants)
        self.recorder.start(t0)
        self.zeno = _ZenoWatch(events.zeno_window, t_end,
                               1e-9 * (t_end - t0) if events.zeno_min_gap is None else events.zeno_min_gap)
        self.rtol_g, self.atol_g = model.tolerance.rtol, model.tolerance.atol
        self.t = float(t0)
        self.n_steps = 0
        self.python_instants = 0
        self.accumulation = None
        self.compiled, self.flow_method = self._compiled_path()

    def _compiled_path(self):
        """``(the compiled model or None, the method class of a flow in Python)``."""
        method, model = self.method, self.model
        if not self.method_class.compiled:
            return None, self.method_class.python
        if not _jit_available():
            raise SimulationError(f"method {method!r} needs numba: pip install '.[fast]'")
        problem = _input_problem(model, method)  # inputs that are Python functions cannot run compiled
        if problem:
            raise SimulationError(problem)
        model.compiled_mode(self.mode)
        return model.compiled_model(), self.method_class.python  # the modes visited or remembered; one first reached: then

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
            raise self.fail(NonFiniteStateError, _nonfinite_jump_message(self.model, instant))
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
        message = (
            f"Zeno behaviour: events pile up in shrinking time near t = {self.t:.12g} (mode {self.mode.describe()}); "
            f"they accumulate at t ≈ {self.accumulation:.10g} s. Add a rule that ends the sequence (e.g. a resting "
            "threshold), or pass on_zeno='stop' to end the run there."
        )
        if self.options.events.on_zeno == "raise":
            raise self.fail(ZenoError, message, accumulation_time=self.accumulation)
        return True

    def instant_at(self, event) -> bool:
        """Resolve the instant of a located ``event`` ``(t, x)`` in Python; True when it stops the run."""
        self.t, self.x = event
        try:
            instant = self.model.resolve(self.x, self.mode, self.t)
        except Exception as exc:
            if hasattr(exc, "instant"):
                self.recorder.sample(self.t, self.x, self.mode, force=True)
                exc.trajectory = self.recorder.trajectory(stats={"failed": str(exc).splitlines()[0]})
            raise
        self.python_instants += 1
        if not np.all(np.isfinite(instant.x_after)):
            self.t, self.x, self.mode = instant.t, instant.x_after, instant.mode_after
            raise self.fail(NonFiniteStateError, _nonfinite_jump_message(self.model, instant))
        return self.after_event(instant)

    # ------------------------------------------------------------ the run

    def _flow_settings(self) -> _FlowSettings:
        o = self.options
        return _FlowSettings(o.stepping, o.events.event_samples, self.output == "steps", o.output.progress,
                             self.rtol_g, self.atol_g, o.limits.max_steps)

    def _start(self) -> bool:
        """Record the start and resolve the initial instant (in Python, unless the kernel does); returns
        whether the kernel resolves it."""
        model, compiled = self.model, self.compiled
        self.recorder.sample(self.t, self.x, self.mode, force=True)
        initial_in_kernel = compiled is not None and compiled.covers(self.mode)
        if not initial_in_kernel:
            self.initial_instant()
        elif not model.compiled_mode(self.mode).holds(self.x, self.t, self.rtol_g, self.atol_g):
            problem = nonfinite_at_start(model, model.compiled_mode(self.mode), self.x, self.t)  # the kernel flows
            if problem:
                raise self.fail(NonFiniteStateError, problem)
        if self.options.output.t_eval is not None and not initial_in_kernel:  # (the kernel samples t0 after its instant)
            x = self.x
            self.recorder.dense(self.t - 1.0, self.t, lambda tau: x.copy(), self.mode)
        return initial_in_kernel

    def _run(self) -> Status:
        """Flows and instants up to ``t_end``."""
        model, compiled = self.model, self.compiled
        initial_in_kernel = self._start()
        settings = self._flow_settings()
        while self.t < self.t_end:
            steps_left = settings.max_steps - self.n_steps  # a run stops after max_steps steps
            try:
                if compiled is not None and compiled.covers(self.mode):
                    event, self.t, self.x, self.mode, steps, stop = _run_kernel(
                        model, compiled, self.method, self.mode, self.x, self.t, self.t_end, settings, steps_left,
                        self.recorder, self.after_event, initial_in_kernel)
                    if stop == "initial":  # the kernel leaves this initial instant to Python
                        initial_in_kernel = False
                        self.initial_instant()
                        continue
                    initial_in_kernel = False
                    if stop:
                        return Status.ZENO
                else:
                    cm = model.compiled_mode(self.mode)
                    problem = nonfinite_at_start(model, cm, self.x, self.t)
                    if problem:
                        raise self.fail(NonFiniteStateError, problem)
                    event, self.t, self.x, steps = _flow_python(model, cm, self.mode, self.flow_method, self.x,
                                                                self.t, self.t_end, settings, steps_left,
                                                                self.recorder)
            except _FlowFailure as failure:
                self.t, self.x = failure.t, failure.x
                self.mode = failure.mode or self.mode
                self.n_steps += failure.steps
                raise self.fail(failure.cls, failure.message) from None
            self.n_steps += steps
            if event is None:
                break
            if self.instant_at(event):
                return Status.ZENO
        return Status.FINISHED

    def execute(self) -> Trajectory:
        """Run to ``t_end``; the trajectory, or an error carrying it (Ctrl-C: :class:`SimulationInterrupted`)."""
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
            if complex_value is not None:
                raise self.fail(ComplexValueError, complex_value.pop("message"), **complex_value) from exc
            raise self.fail(SimulationError,
                            f"the run failed at t = {self.t:.12g} s in mode {self.mode.describe()} with "
                            f"{type(exc).__name__}: {exc} (the trajectory up to there is attached; the original "
                            "error and its traceback are its cause)") from exc
        return self._finish(status)

    def _finish(self, status: Status) -> Trajectory:
        """The trajectory of a run that ended (``status``), with its statistics."""
        stats = {"method": self.method, "steps": self.n_steps,
                 "wall time [s]": round(_time.perf_counter() - self.started, 6)}
        if self.compiled is not None:
            stats["instants resolved in Python"] = self.python_instants
            if self.python_instants:  # modes met outside the kernel: a new process's kernel covers them too
                _remember_modes(self.model, self.model.visited_modes)
        if self.auto is not None:
            stats.update(self.auto.report(stats["wall time [s]"], self.t_end - self.options.start.t0))
        if status is Status.ZENO:
            stats["zeno accumulation time [s]"] = self.accumulation
        recorder = self.recorder
        if self.output == "events" and (not recorder.t or recorder.t[-1] != self.t):
            recorder.sample(self.t, self.x, self.mode, force=True)
        return recorder.trajectory(stopped=status.value, stats=stats)


@dataclasses.dataclass(frozen=True)
class _FlowSettings:
    """What every flow of a run needs: the step options, the guard samples
    per step, whether every step is saved, the progress callback, the guard
    tolerances, the run's ``max_steps``."""

    stepping: object
    samples: int
    save: bool
    progress: object
    rtol_g: float
    atol_g: float
    max_steps: int


class _FlowFailure(Exception):
    def __init__(self, cls, message, t, x, steps=0, mode=None):
        super().__init__(message)
        self.cls, self.message, self.t, self.x, self.steps, self.mode = cls, message, t, x, steps, mode


_NUMERIC_ERRORS = (ArithmeticError, TypeError)  # where Python floats raise and numpy scalars give inf/NaN
_LIST_STATES = 16  # euler and rk4 step on lists of floats up to this many states (faster than small arrays)
_READS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _reads(cm, name):
    """The state indices the generated function ``name`` of ``cm`` reads,
    from its source (``local = x[k]`` lines); ``None`` when that cannot be
    told for sure."""
    known = _READS.setdefault(cm, {})
    if name not in known:
        match = re.search(rf"^def {name}\(x, t, p, u, out\):\n(.*?)(?=^def |\Z)", cm.source, re.DOTALL | re.MULTILINE)
        body = match.group(1).split('"""') if match else []
        code = body[2] if len(body) == 3 else None
        reads = re.findall(r"^ +\w+ = x\[(\d+)\]$", code, re.MULTILINE) if code is not None else []
        known[name] = {int(k) for k in reads} if code is not None and len(re.findall(r"\bx\[", code)) == len(
            reads) else None
    return known[name]


def _inputs(model):
    """``(inputs, u0)``: the input function, or ``None`` and the constant (empty) inputs."""
    if model.input_symbols:
        return model.input_values, None
    return None, model.input_values(0.0)


def _flow_functions(model, cm, x):
    """``(fun, state_at, y0)`` of a flow from ``x`` in the mode of ``cm``:
    ``fun(tau, y)`` the rates of the independent states ``y`` and
    ``state_at(tau, y)`` the full state (a new array), with the values of
    ``cm.rates`` and ``cm.complete``.

    For speed the generated functions run on Python floats (lists): several
    times faster than on numpy scalars, with the same IEEE results; where
    Python floats raise instead of giving inf or NaN (a division by zero, an
    overflowing power) the evaluation is repeated on arrays.  The rates skip
    the dependent states when they do not read them."""
    ind, dep = cm.independent, cm.dependent
    n = cm.n
    template = x.copy()
    if not len(ind):  # nothing flows: step a dummy variable so time guards are still found
        def state_at(tau, y):  # the dependent states follow their constraints (which may hold t or inputs)
            return cm.complete(template.copy(), tau) if len(dep) else template.copy()

        return (lambda tau, y: np.zeros(1)), state_at, np.zeros(1)
    rates, phi, p = cm._rates, cm._phi, model.parameter_array  # the mode's generated functions
    floats = p.tolist()
    inputs, u0 = _inputs(model)
    ind_l, dep_l = ind.tolist(), dep.tolist()
    whole = not dep_l and ind_l == list(range(n))  # y is the whole state
    low, high = ind_l[0], ind_l[0] + len(ind_l)
    contiguous = ind_l == list(range(low, high))
    reads = _reads(cm, "rates")
    with_dependent = bool(dep_l) and (reads is None or not reads.isdisjoint(dep_l))
    base = template.tolist()
    work = np.empty(n)
    dep_out = np.empty(len(dep_l))

    def on_arrays(tau, y, u):  # numpy's math: inf or NaN where Python floats raise
        rates_np, phi_np = cm.on_numpy("rates"), cm.on_numpy("phi")
        tau = np.float64(tau)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if whole:
                return rates_np(np.asarray(y, dtype=float), tau, p, u, np.empty(n))
            z = template.copy()
            z[ind] = y
            if dep_l:
                z[dep] = phi_np(z, tau, p, u, np.empty(len(dep_l)))
            return rates_np(z, tau, p, u, work)[ind]

    def fun(tau, y):
        u = u0 if inputs is None else inputs(tau)
        try:
            if whole:
                return rates(y.tolist(), tau, floats, u, np.empty(n))
            z = base.copy()
            if contiguous:
                z[low:high] = y.tolist()
            else:
                for k, value in zip(ind_l, y.tolist()):
                    z[k] = value
            if with_dependent:
                for k, value in zip(dep_l, phi(z, tau, floats, u, dep_out).tolist()):
                    z[k] = value
            return rates(z, tau, floats, u, work)[ind]
        except _NUMERIC_ERRORS:
            return on_arrays(tau, y, u)

    def fun_list(tau, y):
        """``fun`` on a list, returning a list (for the fixed-step methods)."""
        u = u0 if inputs is None else inputs(tau)
        try:
            if whole:
                return rates(y, tau, floats, u, work).tolist()  # numpy stores: a complex value raises
            z = base.copy()
            if contiguous:
                z[low:high] = y
            else:
                for k, value in zip(ind_l, y):
                    z[k] = value
            if with_dependent:
                for k, value in zip(dep_l, phi(z, tau, floats, u, dep_out).tolist()):
                    z[k] = value
            out = rates(z, tau, floats, u, work)
            return out[low:high].tolist() if contiguous else out[ind].tolist()
        except _NUMERIC_ERRORS:
            return on_arrays(tau, np.array(y), u).tolist()

    if whole:
        def state_at(tau, y):
            return y.copy()
    else:
        def state_at(tau, y):
            s = template.copy()
            s[ind] = y
            if dep_l:
                s[dep] = phi(s, tau, p, u0 if inputs is None else inputs(tau), dep_out)
            return s

    fun.on_lists = fun_list
    return fun, state_at, x[ind]


def _sides_function(model, cm):
    """``sides(x, tau)``: the guards' comparison sides as a list of floats
    (computed on Python floats, on arrays where those raise), as ``cm.sides``."""
    generated, p, count = cm._sides, model.parameter_array, cm.n_sides
    floats = p.tolist()
    inputs, u0 = _inputs(model)

    def sides(x, tau):
        u = u0 if inputs is None else inputs(tau)
        try:
            return generated(x.tolist(), float(tau), floats, u, np.empty(count)).tolist()
        except _NUMERIC_ERRORS:
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # a side or scale may be inf
                return cm.on_numpy("sides")(np.asarray(x, dtype=float), np.float64(tau), p, u,
                                            np.empty(count)).tolist()

    return sides


def _flow_python(model, cm, mode, method, x, t, t_end, o, steps_left, recorder):
    """Flow in one mode with the integrator of ``method`` (a Python method's
    class) until ``t_end`` or an event; returns ``(event or None, t, x,
    steps)``, ``event = (t_ev, x_ev)``."""
    fun, state_at, y0 = _flow_functions(model, cm, x)
    on_lists = getattr(fun, "on_lists", None) if len(y0) <= _LIST_STATES else None
    stepper = method.stepper(fun, t, y0, t_end, autonomous=not model.input_symbols, fun_list=on_lists,
                             **o.stepping.integrator_options())
    scan = (GuardScan(cm, _sides_function(model, cm), stepper, state_at, t, x, o.rtol_g, o.atol_g, o.samples)
            if cm.guards else None)
    save = recorder.output == "steps"
    dense = recorder.t_eval is not None
    progress = o.progress
    zero = np.zeros(cm.n)
    steps = 0
    while True:
        if steps >= steps_left:
            raise _step_limit(o, t, t_end, mode, x, steps)
        t_prev = stepper.t
        try:
            t_new, y_new = stepper.step()
        except StiffnessDetected as exc:
            raise _FlowFailure(
                functools.partial(StiffnessError, h=exc.h, h_lambda=exc.h_lambda, limit=exc.limit),
                _stiffness_message(model, cm, mode, exc), t, x, steps) from None
        except StepFailed as exc:
            raise _FlowFailure(
                StepSizeError,
                f"{method.name} failed at t = {t:.12g} in mode {mode.describe()}: {exc}. "
                f"The step size collapsed: the problem may be stiff here ({_stiff_advice(method.name)}), "
                "or a state may be running into a singularity.", t, x, steps,
            ) from None
        steps += 1
        if progress is not None:
            progress(t_new)
        x_new = state_at(t_new, y_new)
        if x_new.dot(zero) != 0.0:  # 0·x is 0 for finite x, NaN otherwise
            raise _FlowFailure(NonFiniteStateError, _nonfinite_message(model, mode, t_new, x_new), t, x, steps)
        if scan is not None:
            bracket = scan.first_hold(t_prev, t_new, x_new)
            if bracket is not None:
                t_ev = locate_event(cm, stepper, state_at, *bracket, o.rtol_g, o.atol_g)
                # the state the guard was seen to hold on: the step's end itself, or the interpolant
                x_ev = x_new if t_ev == t_new else state_at(t_ev, stepper.interpolate(t_ev))
                if dense:
                    recorder.dense(t_prev, np.nextafter(t_ev, -np.inf),
                                   lambda tau: state_at(tau, stepper.interpolate(tau)), mode)
                return (t_ev, x_ev), t, x, steps
        if dense:
            recorder.dense(t_prev, t_new, lambda tau: state_at(tau, stepper.interpolate(tau)), mode)
        t, x = t_new, x_new
        if t >= t_end:
            recorder.sample(t, x, mode, force=True)
            return None, t, x, steps
        if save:
            recorder.sample(t, x, mode)


_KERNEL_MAX_STEPS = 2**62  # the kernel counts in int64


def _stiff_advice(method: str) -> str:
    """Advice after ``method`` failed with a collapsed step: the stiff
    (implicit) methods of the table to try instead, never ``method`` itself."""
    python = METHOD_CLASSES[method].python.name
    others = [repr(name) for name in method_names() if METHOD_CLASSES[name].stiff and
              not METHOD_CLASSES[name].compiled and name != python]
    return "try method=" + ", ".join(others[:-1]) + " or " + others[-1]


def _step_limit(o, t, t_end, mode, x, steps) -> "_FlowFailure":
    """The failure of a flow that reached the run's ``max_steps`` before ``t_end``."""
    max_steps = o.max_steps
    return _FlowFailure(
        functools.partial(StepLimitError, max_steps=max_steps),
        f"the run took max_steps = {max_steps} steps and reached only t = {t:.12g} s of t_end = {t_end:g} s "
        f"(mode {mode.describe()}): raise max_steps if a run that long is meant, or take a larger step (dt, "
        "max_step) or looser tolerances (rtol, atol)", t, x, steps, mode)


def _stiffness_message(model, cm, mode, exc) -> str:
    state = ""
    if exc.component is not None and exc.component < len(cm.independent):
        state = f", fastest in {model.states[cm.independent[exc.component]].name}"
    if METHOD_CLASSES[exc.method].fixed_step:
        held = ""
        advice = (f", or a step dt < {exc.limit:g}/|λ| ≈ {exc.limit * exc.h / exc.h_lambda:.3g} s (or smaller). "
                  "If instead the rates jump here (a discontinuity the model does not show: inside an input "
                  "function, say), this is no stiffness and a smaller dt will not help: write the discontinuity "
                  "into an element law (sign, Heaviside, Piecewise) or an automaton, or run with "
                  "stiffness_check=False")
    else:
        held = ", the step held there by the step-size control"
        if exc.steps_left is not None:
            held += f": ~{exc.steps_left:.2g} more steps to t = {exc.t + exc.steps_left * exc.h:.6g}"
        advice = ""
    return (f"{exc.method} is beyond its stability limit at t = {exc.t:.12g} in mode {mode.describe()}: the step "
            f"h = {exc.h:.3g} s gives |h·λ| ≈ {exc.h_lambda:.3g} (estimated; the limit is {exc.limit:g}{held}; "
            f"|λ| ≈ {exc.h_lambda / exc.h:.3g} /s{state}). The problem is stiff here for an explicit method: use "
            f"method='Radau', 'BDF' or 'LSODA'{advice}.")


def _nonfinite_jump_message(model, instant) -> str:
    x = instant.x_after
    bad = [f"{model.states[k].name} = {x[k]}" for k in np.flatnonzero(~np.isfinite(x))]
    return (f"the jump at t = {instant.t:.12g} from mode {instant.mode_before.describe()} into "
            f"{instant.mode_after.describe()} gives a non-finite state ({', '.join(bad)}); check the parameters "
            "of the jump (restitution coefficients, masses and other storage parameters must be finite and nonzero).")


def _nonfinite_message(model, mode, t, x) -> str:
    bad = [model.states[k].name for k in np.flatnonzero(~np.isfinite(x))] or ["the state"]
    return (f"state became non-finite ({', '.join(bad)}) at t ≈ {t:.12g} in mode {mode.describe()}; "
            "check parameters for divisions by zero, or use a smaller step / tighter tolerance.")


def _run_kernel(model, compiled, method, mode, x, t, t_end, o, steps_left, recorder, after_event, initial=False):
    """Calls of the compiled kernel from ``(t, mode, x)``: flows, events and
    restarts in compiled code, each instant recorded (and checked) by
    ``after_event``; with ``initial``, the instant at ``t`` is resolved first.
    Returns ``(event or None, t, x, mode, steps, stop)``: ``event = (t_ev,
    x_ev)`` is an instant the kernel left to Python; ``stop`` is ``True`` on
    Zeno behaviour with ``on_zeno='stop'``, ``"initial"`` when the initial
    instant is left to Python."""
    kind = KINDS[method]
    steps = 0
    while True:
        if steps >= steps_left:
            raise _step_limit(o, t, t_end, mode, x, steps)
        dense = None if recorder.t_eval is None else recorder.t_eval[recorder.eval_pos:]
        result = compiled.run(kind, mode, x, t, t_end, **o.stepping.integrator_options(), samples=o.samples,
                              save=o.save, resolve_first=initial, t_eval=dense,
                              max_steps=min(steps_left - steps, _KERNEL_MAX_STEPS))
        recorder.eval_pos += result.n_dense  # the requested times the kernel sampled on its dense output
        if initial and _KERNEL_STATUS[result.status] == "resolve" and result.n_events == 0 and result.t == t:
            return None, t, x, mode, 0, "initial"
        steps += result.steps
        saved = 0
        if result.n_events:
            for j, (at, t_ev, before, x_before, after, x_after) in enumerate(result.events()):
                for sample in result.samples(saved, at):
                    recorder.sample(*sample, force=True)
                saved = at
                t, x, mode = t_ev, x_after, after
                instant = CompiledInstant(model, t_ev, before, x_before, after, x_after)
                if j == 0 and initial and result.info[2]:
                    recorder.event(instant)  # the initial instant, as in the Python path: not a Zeno candidate
                elif after_event(instant):
                    return None, t, x, mode, steps, True
        initial = False
        if result.n_saved > saved:
            for sample in result.samples(saved, result.n_saved):
                recorder.sample(*sample, force=True)
        if o.progress is not None:
            o.progress(result.t)
        t, x, mode = result.t, result.x, result.mode
        status = _KERNEL_STATUS[result.status]
        if status == "done":
            if not o.save:
                recorder.sample(t, x, mode, force=True)
            return None, t, x, mode, steps, False
        if status == "full":
            continue
        if status == "resolve":
            return (t, x), t, x, mode, steps, False
        if status == "collapsed":
            raise _FlowFailure(StepSizeError, f"{method} failed at t = {t:.12g} in mode {mode.describe()}: the "
                               f"step size collapsed (stiff here? {_stiff_advice(method)})", t, x, steps, mode)
        if status == "stiff":
            h_lambda, h, _, limit, component = result.info[:5]
            cm = model.compiled_mode(mode)
            exc = StiffnessDetected(method, t, h, h_lambda, limit, int(component) if len(cm.independent) else None,
                                    None if METHOD_CLASSES[method].fixed_step else (t_end - t) / h)
            raise _FlowFailure(functools.partial(StiffnessError, h=h, h_lambda=h_lambda, limit=limit),
                               _stiffness_message(model, cm, mode, exc), t, x, steps, mode)
        raise _FlowFailure(NonFiniteStateError, _nonfinite_message(model, mode, t, x), t, x, steps, mode)
