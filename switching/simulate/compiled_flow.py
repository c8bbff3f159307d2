"""Flows in the compiled kernel: its calls from a state, the samples and
instants it returns recorded, its status read into the run's failures."""

from __future__ import annotations

import functools

import numpy as np

from ..errors import NonFiniteStateError, StepSizeError, StiffnessError
from ..library.jit_jacobian import jacobian_function
from ..library.jit_model import AUTO_KIND, KINDS
from ..library.jit_model import STATUS as KERNEL_STATUS
from .flow_failures import FlowFailure, nonfinite_message, overflow_message, step_limit, stiff_advice, stiffness_message
from .integrators import StiffnessDetected
from .methods import METHOD_CLASSES
from .preflight import nonfinite_at_start
from .recorder import REQUESTED, STATE
from .resolution import CompiledInstant, KernelInstants

__all__ = ["kernel_arguments", "kernel_kind", "run_kernel"]

_KERNEL_MAX_STEPS = 2**62  # the kernel counts in int64


def kernel_kind(compiled, method: str, auto) -> int:
    """The kernel's method number for ``method`` (``auto``: its per-mode choice, when it makes one); the
    modes' Jacobians compiled when the method is implicit."""
    kind = AUTO_KIND if auto is not None and auto.per_mode else KINDS[method]
    if kind >= KINDS["rodas-jit"]:
        compiled.need_jacobians(jacobian_function)  # the implicit method's J, derived and compiled per mode
    return kind


def kernel_arguments(compiled, kind, mode, x, t, t_end, o, steps_left, recorder, initial) -> dict:
    """The keywords of :meth:`CompiledModel.run <switching.library.jit_model.CompiledModel.run>` for a
    kernel call from ``(t, mode, x)`` of a run with flow settings ``o``, ``steps_left`` steps to go and the
    requested times its ``recorder`` has not sampled yet; ``initial``: the instant at ``t`` is resolved first."""
    return {"kind": kind, "mode": mode, "x": x, "t": t, "t_end": t_end, **o.stepping.integrator_options(),
            "samples": o.samples, "save": o.save, "resolve_first": initial,
            "t_eval": None if recorder.t_eval is None else recorder.t_eval[recorder.eval_pos:],
            "max_steps": min(steps_left, _KERNEL_MAX_STEPS)}


def run_kernel(model, compiled, method, mode, x, t, t_end, o, steps_left, recorder, after_event, initial=False,
               auto=None, instants_pass=None):
    """Calls of the compiled kernel from ``(t, mode, x)``: flows, events and
    restarts in compiled code, each instant recorded (and checked) by
    ``after_event``; with ``initial``, the instant at ``t`` is resolved first.
    ``instants_pass(times, count)``: would the ``count`` instants of a call,
    the run's checks seeing those at ``times``, all pass ``after_event``?
    When it says so (having taken them) the call's samples and instants are
    recorded at once (:meth:`~switching.simulate.recorder.Recorder.block`).
    ``auto`` (a :class:`~switching.library.jit_model.AutoChoice` on the
    compiled path): the kernel flows with RK45 or RODAS4P per mode, each mode
    judged before the call that may enter it; a mode where RK45's stiffness
    test fires flows with RODAS4P from there on.
    Returns ``(event or None, t, x, mode, steps, stop)``: ``event = (t_ev,
    x_ev)`` is an instant the kernel left to Python; ``stop`` is ``True`` on
    Zeno behaviour with ``on_zeno='stop'`` (``steps`` then those taken up to
    the instant that stopped it), ``"initial"`` when the initial
    instant is left to Python."""
    kind = kernel_kind(compiled, method, auto)
    steps = 0
    while True:
        if steps >= steps_left:
            raise step_limit(o, t, t_end, mode, x, steps)
        start = (t, x, mode)  # (a flow that cannot start there is named with its rates, below)
        if kind == AUTO_KIND:
            auto.classify(compiled, x, t)
        arguments = kernel_arguments(compiled, kind, mode, x, t, t_end, o, steps_left - steps, recorder, initial)
        dense = arguments["t_eval"]
        result = compiled.run(**arguments)
        recorder.eval_pos += result.n_dense  # the requested times the kernel sampled on its dense output
        if initial and KERNEL_STATUS[result.status] == "resolve" and result.n_events == 0 and result.t == t:
            return None, t, x, mode, 0, "initial"
        steps += result.steps
        saved, at_once = 0, False
        if (result.n_events or result.n_saved) and instants_pass is not None \
                and _recorded_at_once(model, compiled, result, recorder, dense is not None, initial, instants_pass):
            saved, at_once = result.n_saved, True
        keep = None if at_once else _keeper(recorder, dense is not None)
        if result.n_events and not at_once:
            for at, t_ev, before, after, states, j in result.events():
                for sample in result.samples(saved, at):
                    keep(*sample)
                saved = at
                instant = CompiledInstant(model, t_ev, before, after, states, j)
                t, x, mode = t_ev, instant.x_after, after
                if j == 0 and initial and result.info[2]:
                    recorder.event(instant)  # the initial instant, as in the Python path: not a Zeno candidate
                elif after_event(instant):  # (the steps up to this instant: the kernel went on past it)
                    return None, t, x, mode, steps - result.steps + result.steps_before(j), True
        initial = False
        if result.n_saved > saved:
            for sample in result.samples(saved, result.n_saved):
                keep(*sample)
        if o.progress is not None:
            o.progress(result.t)
        t, x, mode = result.t, result.x, result.mode
        status = KERNEL_STATUS[result.status]
        if status == "done":
            if not o.save:
                recorder.sample(t, x, mode, force=True)
            return None, t, x, mode, steps, False
        if status == "full":
            continue
        if status == "resolve":
            return (t, x), t, x, mode, steps, False
        # a flow that cannot start where this call began (a zero inductance: NaN rates, which the RK45 step
        # control sees as a collapsing step): the run ends there, its rates and the parameters they read named
        # (the driver checks only the guard sides before the kernel runs)
        problem = nonfinite_at_start(model, model.compiled_mode(start[2]), start[1], start[0])
        if problem:
            raise FlowFailure(NonFiniteStateError, problem, start[0], start[1], steps, start[2])
        if status in ("nonfinite", "collapsed") and kind == AUTO_KIND and not auto.is_implicit(mode) \
                and np.all(np.isfinite(x)):
            # an explicit step whose trial stages left the reals (an exponential law overflowing on a stiff
            # flow: a conducting diode's dynamic resistance times a capacitance is nanoseconds) or whose size
            # collapsed: the implicit method takes the mode from the last accepted state
            auto.switch(compiled, mode, f"RK45's step {'left the reals' if status == 'nonfinite' else 'collapsed'} "
                        f"at t = {t:.6g} s (a stiff flow)")
            continue
        what = "left the reals" if status == "nonfinite" else "collapsed"
        if status in ("nonfinite", "collapsed") and kind == AUTO_KIND and auto.is_implicit(mode) and t == start[0] \
                and np.all(np.isfinite(x)) and \
                auto.fall_back(compiled, mode, f"RODAS4P's step {what} where its flow started, t = {t:.6g} s"):
            continue  # the implicit method cannot start here: the explicit one takes the mode
        if kind == AUTO_KIND:  # the method that failed, not the one auto is named by
            method = "rodas-jit" if auto.is_implicit(mode) else "RK45-jit"
        overflow = overflow_message(model, method, mode, t, x) if status in ("nonfinite", "collapsed") else None
        if overflow:
            raise FlowFailure(NonFiniteStateError, overflow, t, x, steps, mode)
        if status == "collapsed":
            raise FlowFailure(StepSizeError, f"{method} failed at t = {t:.12g} in mode {mode.describe()}: the "
                               f"step size collapsed (stiff here? {stiff_advice(method)})", t, x, steps, mode)
        if status == "stiff" and kind == AUTO_KIND:
            h_lambda, h = result.info[:2]
            auto.switch(compiled, mode, f"RK45's stiffness test fired at t = {t:.6g} s: |h·λ| = {h_lambda:.3g} at "
                        f"h = {h:.3g} s")
            continue
        if status == "stiff":
            h_lambda, h, _, limit, component = result.info[:5]
            cm = model.compiled_mode(mode)
            exc = StiffnessDetected(method, t, h, h_lambda, limit, int(component) if len(cm.independent) else None,
                                    None if METHOD_CLASSES[method].fixed_step else (t_end - t) / h)
            raise FlowFailure(functools.partial(StiffnessError, h=h, h_lambda=h_lambda, limit=limit),
                               stiffness_message(model, cm, mode, exc), t, x, steps, mode)
        if np.all(np.isfinite(x)):  # a trial stage left the reals between accepted states
            message = (f"{method}: the rates became non-finite in a step near t = {t:.12g} s in mode "
                       f"{mode.describe()} (the last accepted state is finite): a law left its domain between it "
                       "and the next (sqrt or log of a negative value, a division by zero). The Python methods "
                       "name the law: run method='RK45' or 'Radau' to see which")
        else:
            message = nonfinite_message(model, mode, t, x)
        raise FlowFailure(NonFiniteStateError, message, t, x, steps, mode)


def _keeper(recorder, requested: bool):
    """What records a kernel call's sample ``(t, x, mode)`` one at a time: a requested time's, or a state's."""
    return recorder.requested if requested else functools.partial(recorder.sample, force=True)


def _recorded_at_once(model, compiled, result, recorder, requested: bool, initial: bool, instants_pass) -> bool:
    """Record a kernel call's samples (of requested times with ``requested``) and instants at once
    (:meth:`~switching.simulate.recorder.Recorder.block`) if ``instants_pass`` says its instants pass the
    run's checks (the initial instant, resolved first with ``initial``, not watched); whether it did."""
    times, before, after, states = result.event_columns()
    if not instants_pass(times[1:] if initial and result.info[2] else times, len(times)):
        return False
    instants = KernelInstants(model, compiled.modes, times, before, after, states)
    recorder.block(result.rows, compiled.mode_objects(), REQUESTED if requested else STATE, instants, times, before)
    return True
