"""A flow in one mode in Python: the integrator of the run's method steps
it, every guard tested on each step (and located on the step's
interpolant), the record kept as it goes."""

from __future__ import annotations

import functools

import numpy as np

from ..errors import NonFiniteStateError, StepSizeError, StiffnessError
from ..library.jacobian import flow_jacobian
from .events import GuardScan, locate_event
from .flow_failures import FlowFailure, nonfinite_message, overflow_message, step_limit, stiff_advice, stiffness_message
from .flow_rates import flow_functions, sides_function
from .integrators import StepFailed, StiffnessDetected

__all__ = ["flow_python"]


def flow_python(model, cm, mode, method, x, t, t_end, o, steps_left, recorder, list_states, strict=False):
    """Flow in one mode with the integrator of ``method`` (a Python method's
    class) from ``(t, x)`` until ``t_end`` [s] or an event, at most
    ``steps_left`` steps (``o``: the run's flow settings); a flow of at most
    ``list_states`` independent states gives the integrator the rates on
    lists of floats (the fixed-step methods step on them: faster than small
    arrays); ``strict``: a guard counts only once it holds strictly (the
    flow from an instant that rested at a tie, :class:`GuardScan`).
    Returns ``(event or None, t, x, steps)``, ``event = (t_ev, x_ev)``."""
    fun, state_at, y0 = flow_functions(model, cm, x)
    on_lists = getattr(fun, "on_lists", None) if len(y0) <= list_states else None
    jac = flow_jacobian(model, cm, x) if method.stiff else None  # the implicit methods' J, derived
    options = o.stepping.integrator_options()
    if np.ndim(options["atol"]):  # each state's own (switching.simulate.state_tolerances), the flow's states'
        options["atol"] = np.asarray(options["atol"])[cm.independent] if len(cm.independent) else 1.0
    stepper = method.stepper(fun, t, y0, t_end, autonomous=not model.input_symbols, fun_list=on_lists,
                             jac=jac, **options)
    scan = (GuardScan(cm, sides_function(model, cm), stepper, state_at, t, x, o.rtol_g, o.atol_g, o.samples,
                      strict) if cm.guards else None)
    save = recorder.output == "steps"
    dense = recorder.t_eval is not None
    progress = o.progress
    zero = np.zeros(cm.n)
    steps = 0
    while True:
        if steps >= steps_left:
            raise step_limit(o, t, t_end, mode, x, steps)
        t_prev = stepper.t
        try:
            t_new, y_new = stepper.step()
        except StiffnessDetected as exc:
            raise FlowFailure(
                functools.partial(StiffnessError, h=exc.h, h_lambda=exc.h_lambda, limit=exc.limit),
                stiffness_message(model, cm, mode, exc), t, x, steps) from None
        except (StepFailed, ValueError) as exc:  # (scipy's Radau factors a matrix of an overflowed state: ValueError)
            overflow = overflow_message(model, method.name, mode, t, x)
            if overflow:
                raise FlowFailure(NonFiniteStateError, overflow, t, x, steps) from None
            if not isinstance(exc, StepFailed):
                raise
            raise FlowFailure(
                StepSizeError,
                f"{method.name} failed at t = {t:.12g} in mode {mode.describe()}: {exc}. "
                f"The step size collapsed: the problem may be stiff here ({stiff_advice(method.name)}), "
                "or a state may be running into a singularity.", t, x, steps,
            ) from None
        steps += 1
        if progress is not None:
            progress(t_new)
        x_new = state_at(t_new, y_new)
        if x_new.dot(zero) != 0.0:  # 0·x is 0 for finite x, NaN otherwise
            raise FlowFailure(NonFiniteStateError, nonfinite_message(model, mode, t_new, x_new), t, x, steps)
        if scan is not None:
            bracket = scan.first_hold(t_prev, t_new, x_new)
            if bracket is not None:
                t_ev = locate_event(scan.holds, stepper, state_at, *bracket)
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
