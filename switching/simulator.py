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

import math
import time as _time

import numpy as np

from .errors import NonFiniteStateError, SimulationError, StepSizeError, ZenoError
from .integrators import ADAPTIVE, FIXED_STEP, make_stepper
from .trajectory import Trajectory

__all__ = ["simulate", "METHODS"]

COMPILED = ("euler-jit", "rk4-jit", "RK45-jit")
METHODS = FIXED_STEP + ADAPTIVE + COMPILED


class _Recorder:
    def __init__(self, model, output, t_eval, keep_instants=True):
        self.model = model
        self.output = output
        self.keep_instants = keep_instants
        self.n_events = 0
        self.last_instant = None
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

    def event(self, instant):
        self.n_events += 1
        self.last_instant = instant
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

    def trajectory(self, stopped=None, stats=None):
        stats = dict(stats or {})
        stats["instants"] = self.n_events
        n = len(self.model.states)
        x = np.array(self.x).reshape(len(self.x), n) if self.x else np.zeros((0, n))
        return Trajectory(self.model, self.t, x, self.modes, self.events, self.event_index, stopped, stats)


class _ZenoWatch:
    """Detects events accumulating in geometrically shrinking time.

    Zeno is declared when the last ``window`` gaps between events shrink by a
    steady ratio (within 5 %), the latest gap is below ``min_gap`` (so a
    sequence that a resting rule would still end is not cut short), and the
    Aitken extrapolation of the event times — exact for a geometric sequence —
    falls before ``t_end``.  Three gaps at round-off level also count."""

    def __init__(self, window: int, t_end: float, min_gap: float):
        self.window = window
        self.t_end = t_end
        self.min_gap = min_gap
        self.times: list[float] = []

    def add(self, t: float):
        """Return the estimated accumulation time if Zeno behaviour is seen."""
        self.times.append(t)
        del self.times[: -(self.window + 2)]  # only the recent events matter: bounded memory
        times = self.times
        gaps = np.diff(times)
        if len(gaps) >= 3 and np.all(gaps[-3:] <= 16 * np.spacing(abs(t) + 1.0)):
            return t  # events one ulp apart: accumulated already
        if len(times) < self.window + 2 or np.any(gaps <= 0):
            return None
        ratios = gaps[1:] / gaps[:-1]
        if gaps[-1] < self.min_gap and np.all(ratios < 0.995) and np.ptp(ratios) <= 0.05 * np.mean(ratios):
            t2, t1, t0 = times[-1], times[-2], times[-3]
            denominator = t2 - 2 * t1 + t0
            accumulation = t2 - (t2 - t1) ** 2 / denominator if denominator != 0 else t2
            if accumulation <= self.t_end:
                return accumulation
        return None


def _check_options(method, dt, rtol, atol):
    if method not in METHODS:
        raise SimulationError(f"unknown method {method!r}; choose one of: {', '.join(METHODS)}")
    if method in FIXED_STEP or method in ("euler-jit", "rk4-jit"):
        if dt is None or not (dt > 0 and math.isfinite(dt)):
            raise SimulationError(f"method {method!r} is fixed-step: give a positive step dt=…")
    elif dt is not None:
        raise SimulationError(f"method {method!r} is adaptive: give rtol/atol, not dt (dt is for euler and rk4)")
    if not (rtol > 0 and atol > 0):
        raise SimulationError("rtol and atol must be positive")


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
    progress=None,
    event_samples: int = 3,
) -> Trajectory:
    """Simulate ``model`` from ``t0`` to ``t_end``; see :meth:`HybridModel.simulate`."""
    _check_options(method, dt, rtol, atol)
    if on_zeno not in ("raise", "stop"):
        raise SimulationError("on_zeno must be 'raise' or 'stop'")
    if output not in ("steps", "events"):
        raise SimulationError("output must be 'steps' or 'events' (give t_eval=… for chosen times)")
    if not t_end > t0:
        raise SimulationError(f"t_end ({t_end}) must be after t0 ({t0})")
    if t_eval is not None:
        output = "events"
    started = _time.perf_counter()
    x = model.initial_state() if x0 is None else np.array(x0, dtype=float)
    current = model.initial_mode if mode is None else model.mode(mode)
    recorder = _Recorder(model, output, t_eval, keep_instants)
    zeno = _ZenoWatch(zeno_window, t_end, 1e-4 * (t_end - t0) if zeno_min_gap is None else zeno_min_gap)
    rtol_g, atol_g = model.tolerance.rtol, model.tolerance.atol
    n_steps = 0
    t = float(t0)

    def fail(cls, message, **extra):
        recorder.sample(t, x, current, force=True)
        return cls(message, trajectory=recorder.trajectory(stats={"failed": message.splitlines()[0]}), t=t,
                   mode=current, **extra)

    # the initial instant: the initial mode may be mythical, or a pinnacle
    try:
        instant = model.resolve(x, current, t)
    except SimulationError:
        raise
    except Exception as exc:
        if hasattr(exc, "instant"):
            exc.trajectory = recorder.trajectory()
        raise
    recorder.sample(t, instant.x_before, instant.mode_before, force=True)
    if len(instant.steps) > 1:
        recorder.event(instant)
    x, current = instant.x_after, instant.mode_after
    recorder.dense(t - 1.0, t, lambda tau: x.copy(), current)

    compiled = method in COMPILED
    if compiled:
        from codegen.jit import available

        if not available():
            raise SimulationError(f"method {method!r} needs numba: pip install '.[fast]'")
        if model.input_symbols:
            raise SimulationError(f"method {method!r} does not take models with inputs; use {method[:-4]!r}")
        if t_eval is not None:
            raise SimulationError(f"method {method!r} saves every step or events only; t_eval needs {method[:-4]!r}")
    stopped = None
    while t < t_end:
        cm = model.compiled_mode(current)
        flow = _flow_compiled if compiled else _flow_python
        try:
            event, t, x, steps = flow(model, cm, current, method, x, t, t_end, dict(
                dt=dt, rtol=rtol, atol=atol, max_step=max_step, first_step=first_step, samples=event_samples,
                save=output == "steps", progress=progress, rtol_g=rtol_g, atol_g=atol_g), recorder)
        except _FlowFailure as failure:
            t, x = failure.t, failure.x
            n_steps += failure.steps
            raise fail(failure.cls, failure.message) from None
        n_steps += steps
        if event is None:
            break
        t, x = event
        try:
            instant = model.resolve(x, current, t)
        except Exception as exc:
            if hasattr(exc, "instant"):
                recorder.sample(t, x, current, force=True)
                exc.trajectory = recorder.trajectory(stats={"failed": str(exc).splitlines()[0]})
            raise
        recorder.event(instant)
        x, current = instant.x_after, instant.mode_after
        if recorder.n_events > max_events:
            raise fail(SimulationError, f"more than {max_events} events; raise max_events if this is expected")
        accumulation = zeno.add(t)
        if accumulation is not None:
            message = (
                f"Zeno behaviour: events pile up in shrinking time near t = {t:.12g} (mode {current.describe()}); "
                f"they accumulate at t ≈ {accumulation:.10g} s. Add a rule that ends the sequence (e.g. a resting "
                "threshold), or pass on_zeno='stop' to end the run there."
            )
            if on_zeno == "raise":
                raise fail(ZenoError, message, accumulation_time=accumulation)
            stopped = "zeno"
            break

    stats = {"method": method, "steps": n_steps, "wall time [s]": round(_time.perf_counter() - started, 6)}
    if stopped == "zeno":
        stats["zeno accumulation time [s]"] = accumulation
    if output == "events" and (not recorder.t or recorder.t[-1] != t):
        recorder.sample(t, x, current, force=True)
    return recorder.trajectory(stopped=stopped, stats=stats)


class _FlowFailure(Exception):
    def __init__(self, cls, message, t, x, steps=0):
        super().__init__(message)
        self.cls, self.message, self.t, self.x, self.steps = cls, message, t, x, steps


def _flow_python(model, cm, mode, method, x, t, t_end, o, recorder):
    """Flow in one mode with a Python/scipy integrator until ``t_end`` or an
    event; returns ``(event or None, t, x, steps)``, ``event = (t_ev, x_ev)``."""
    ind = cm.independent
    template = x.copy()
    work = np.empty(cm.n)

    def full(y, tau):
        z = template.copy()
        z[ind] = y
        return cm.complete(z, tau)

    if len(ind):
        def fun(tau, y):
            return cm.rates(full(y, tau), tau, work)[ind].copy()
        y0 = x[ind]
    else:  # nothing flows: step a dummy variable so time guards are still found
        def fun(tau, y):
            return np.zeros(1)
        y0 = np.zeros(1)

    def state_at(tau, y):
        return full(y, tau) if len(ind) else template.copy()

    stepper = make_stepper(method, fun, t, y0, t_end, dt=o["dt"], rtol=o["rtol"], atol=o["atol"],
                           max_step=o["max_step"], first_step=o["first_step"])
    steps = 0
    while True:
        t_prev = stepper.t
        try:
            t_new, y_new = stepper.step()
        except RuntimeError as exc:
            raise _FlowFailure(
                StepSizeError,
                f"{method} failed at t = {t:.12g} in mode {mode.describe()}: {exc}. "
                "The step size collapsed: the problem may be stiff here (try method='Radau' or 'BDF'), "
                "or a state may be running into a singularity.", t, x, steps,
            ) from None
        steps += 1
        if o["progress"] is not None:
            o["progress"](t_new)
        x_new = state_at(t_new, y_new)
        if not np.all(np.isfinite(x_new)):
            raise _FlowFailure(NonFiniteStateError, _nonfinite_message(model, mode, t_new, x_new), t, x, steps)
        bracket = _first_hold(cm, stepper, state_at, t_prev, t_new, x_new, o["rtol_g"], o["atol_g"], o["samples"])
        if bracket is not None:
            t_ev = _locate(cm, stepper, state_at, *bracket, o["rtol_g"], o["atol_g"])
            # the state the guard was seen to hold on: the step's end itself, or the interpolant
            x_ev = x_new if t_ev == t_new else state_at(t_ev, stepper.interpolate(t_ev))
            recorder.dense(t_prev, np.nextafter(t_ev, -np.inf), lambda tau: state_at(tau, stepper.interpolate(tau)),
                           mode)
            return (t_ev, x_ev), t, x, steps
        recorder.dense(t_prev, t_new, lambda tau: state_at(tau, stepper.interpolate(tau)), mode)
        t, x = t_new, x_new
        if t >= t_end:
            recorder.sample(t, x, mode, force=True)
            return None, t, x, steps
        recorder.sample(t, x, mode)


def _nonfinite_message(model, mode, t, x) -> str:
    bad = [model.states[k].name for k in np.flatnonzero(~np.isfinite(x))] or ["the state"]
    return (f"state became non-finite ({', '.join(bad)}) at t ≈ {t:.12g} in mode {mode.describe()}; "
            "check parameters for divisions by zero, or use a smaller step / tighter tolerance.")


def _flow_compiled(model, cm, mode, method, x, t, t_end, o, recorder):
    """The same flow in compiled code (numba): one call per flow, Python only at events."""
    module = model.jit_mode(mode)
    ind = cm.independent.astype(np.int64)
    dep = cm.dependent.astype(np.int64)
    p = model.parameter_array
    u = np.zeros(0)
    capacity = 4096 if o["save"] else 1
    out_t = np.empty(capacity)
    out_x = np.empty((capacity, cm.n))
    steps = 0
    while True:
        if method == "RK45-jit":
            max_step = o["max_step"] if np.isfinite(o["max_step"]) else np.inf
            status, n_saved, t_stop, x_stop, k = module.flow_rk45(
                x, t, t_end, o["rtol"], o["atol"], max_step, p, u, ind, dep, o["rtol_g"], o["atol_g"], o["samples"],
                o["save"], out_t, out_x, 10**9)
        else:
            kind = 0 if method == "euler-jit" else 1
            status, n_saved, t_stop, x_stop, k = module.flow_fixed(
                kind, x, t, t_end, o["dt"], p, u, ind, dep, o["rtol_g"], o["atol_g"], o["samples"], o["save"],
                out_t, out_x, 10**9)
        steps += k
        for j in range(n_saved):
            recorder.sample(out_t[j], out_x[j], mode, force=True)
        if o["progress"] is not None:
            o["progress"](t_stop)
        if status == 1:
            return (t_stop, x_stop.copy()), t, x, steps
        if status == 0:
            if not o["save"]:
                recorder.sample(t_stop, x_stop, mode, force=True)
            return None, t_stop, x_stop.copy(), steps
        if status == 2:
            t, x = t_stop, x_stop.copy()
            continue
        if status == 3:
            raise _FlowFailure(StepSizeError, f"{method} failed at t = {t_stop:.12g} in mode {mode.describe()}: the "
                               "step size collapsed (stiff here? try Radau or BDF)", t_stop, x_stop.copy(), steps)
        raise _FlowFailure(NonFiniteStateError, _nonfinite_message(model, mode, t_stop, x_stop), t, x, steps)


def _first_hold(cm, stepper, state_at, t_prev, t_new, x_new, rtol, atol, samples):
    """``(a, b)``: a guard does not hold at ``a`` and holds at ``b``, for the
    first such pair among ``samples`` interior points of the step and its end
    (so a guard that holds only inside the step is still found when that
    interval is longer than a fraction of the step); ``None`` if none holds."""
    if not cm.guards:
        return None
    a = t_prev
    h = t_new - t_prev
    for j in range(1, samples + 1):
        tau = t_prev + h * j / (samples + 1)
        if cm.holds(state_at(tau, stepper.interpolate(tau)), tau, rtol, atol):
            return a, tau
        a = tau
    if cm.holds(x_new, t_new, rtol, atol):
        return a, t_new
    return None


def _locate(cm, stepper, state_at, a, b, rtol, atol) -> float:
    """The first time in ``(a, b]`` at which a guard holds on the interpolant
    (bisection down to adjacent floating-point numbers)."""
    for _ in range(200):
        mid = 0.5 * (a + b)
        if mid <= a or mid >= b:
            break
        if cm.holds(state_at(mid, stepper.interpolate(mid)), mid, rtol, atol):
            b = mid
        else:
            a = mid
    return b
