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

METHODS = FIXED_STEP + ADAPTIVE


class _Recorder:
    def __init__(self, model, output, t_eval):
        self.model = model
        self.output = output
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
        self.t.append(instant.t)
        self.x.append(instant.x_before.copy())
        self.modes.append(instant.mode_before)
        self.t.append(instant.t)
        self.x.append(instant.x_after.copy())
        self.modes.append(instant.mode_after)
        self.events.append(instant)
        self.event_index.append(len(self.t) - 1)

    def trajectory(self, stopped=None, stats=None):
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
        times = self.times[-(self.window + 2) :]
        if len(times) < self.window + 2:
            return None
        gaps = np.diff(times)
        if np.any(gaps <= 0):
            tiny = gaps[-3:]
            if len(tiny) == 3 and np.all(tiny <= 1e-12 * (1 + abs(t))):
                return t
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
    if method in FIXED_STEP:
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
    recorder = _Recorder(model, output, t_eval)
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

    stopped = None
    while t < t_end:
        cm = model.compiled_mode(current)
        ind = cm.independent
        template = x.copy()
        work = np.empty(cm.n)

        def full(y, tau, cm=cm, ind=ind, template=template):
            z = template.copy()
            z[ind] = y
            return cm.complete(z, tau)

        if len(ind):
            def fun(tau, y, cm=cm, ind=ind):
                return cm.rates(full(y, tau), tau, work)[ind].copy()
            y0 = x[ind]
        else:  # nothing flows: step a dummy variable so time guards are still found
            def fun(tau, y):
                return np.zeros(1)
            y0 = np.zeros(1)

        def state_at(tau, y):
            return full(y, tau) if len(ind) else template.copy()

        stepper = make_stepper(method, fun, t, y0, t_end, dt=dt, rtol=rtol, atol=atol, max_step=max_step,
                               first_step=first_step)
        event = None
        while True:
            t_prev = stepper.t
            try:
                t_new, y_new = stepper.step()
            except RuntimeError as exc:
                raise fail(
                    StepSizeError,
                    f"{method} failed at t = {t:.12g} in mode {current.describe()}: {exc}. "
                    "The step size collapsed: the problem may be stiff here (try method='Radau' or 'BDF'), "
                    "or a state may be running into a singularity.",
                ) from None
            n_steps += 1
            if progress is not None:
                progress(t_new)
            x_new = state_at(t_new, y_new)
            if not np.all(np.isfinite(x_new)):
                bad = [model.states[k].name for k in np.flatnonzero(~np.isfinite(x_new))]
                raise fail(
                    NonFiniteStateError,
                    f"state became non-finite ({', '.join(bad)}) at t ≈ {t_new:.12g} in mode {current.describe()}; "
                    "check parameters for divisions by zero, or use a smaller step / tighter tolerance.",
                )
            bracket = _first_hold(cm, stepper, state_at, t_prev, t_new, x_new, rtol_g, atol_g, event_samples)
            if bracket is not None:
                t_ev = _locate(cm, stepper, state_at, *bracket, rtol_g, atol_g)
                x_ev = state_at(t_ev, stepper.interpolate(t_ev))
                recorder.dense(t_prev, np.nextafter(t_ev, -np.inf), lambda tau: state_at(tau, stepper.interpolate(tau)),
                               current)
                event = (t_ev, x_ev)
                break
            recorder.dense(t_prev, t_new, lambda tau: state_at(tau, stepper.interpolate(tau)), current)
            t, x = t_new, x_new
            if t >= t_end:
                recorder.sample(t, x, current, force=True)
                break
            recorder.sample(t, x, current)
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
        if len(recorder.events) > max_events:
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
