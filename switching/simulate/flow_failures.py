"""How a flow fails: :class:`FlowFailure`, which the driver turns into an
error of the hierarchy carrying the trajectory, and the messages that say
what happened and what to do (a step-size collapse, stiffness with the
estimated ``|h·λ|``, a non-finite state, the step limit)."""

from __future__ import annotations

import functools

import numpy as np

from ..errors import StepLimitError
from .methods import METHOD_CLASSES, method_names

__all__ = ["FlowFailure", "OVERFLOW_NEAR", "nonfinite_jump_message", "nonfinite_message", "overflow_message",
           "step_limit", "stiff_advice", "stiffness_message"]

#: a state this large (about the square root of the largest double) leaves the reals by overflow within a few
#: steps of a flow that keeps growing: products of two such numbers are already infinite
OVERFLOW_NEAR = 1e150


class FlowFailure(Exception):
    """A flow stopped: the error class ``cls`` to raise with ``message`` at ``(t, x)`` after ``steps`` steps
    (in ``mode`` when the flow changed it: the compiled kernel)."""

    def __init__(self, cls, message, t, x, steps=0, mode=None):
        super().__init__(message)
        self.cls, self.message, self.t, self.x, self.steps, self.mode = cls, message, t, x, steps, mode


def stiff_advice(method: str) -> str:
    """Advice after ``method`` failed with a collapsed step: the stiff
    (implicit) methods of the table to try instead, never ``method`` itself."""
    python = METHOD_CLASSES[method].python.name
    others = [repr(name) for name in method_names() if METHOD_CLASSES[name].stiff and
              not METHOD_CLASSES[name].compiled and name != python]
    return "try method=" + ", ".join(others[:-1]) + " or " + others[-1]


def step_limit(o, t, t_end, mode, x, steps) -> "FlowFailure":
    """The failure of a flow that reached the run's ``max_steps`` before ``t_end``."""
    max_steps = o.max_steps
    return FlowFailure(
        functools.partial(StepLimitError, max_steps=max_steps),
        f"the run took max_steps = {max_steps} steps and reached only t = {t:.12g} s of t_end = {t_end:g} s "
        f"(mode {mode.describe()}): raise max_steps if a run that long is meant, or take a larger step (dt, "
        "max_step) or looser tolerances (rtol, atol)", t, x, steps, mode)


def stiffness_message(model, cm, mode, exc) -> str:
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


def nonfinite_jump_message(model, instant) -> str:
    x = instant.x_after
    bad = [f"{model.states[k].name} = {x[k]}" for k in np.flatnonzero(~np.isfinite(x))]
    return (f"the jump at t = {instant.t:.12g} from mode {instant.mode_before.describe()} into "
            f"{instant.mode_after.describe()} gives a non-finite state ({', '.join(bad)}); check the parameters "
            "of the jump (restitution coefficients, masses and other storage parameters must be finite and nonzero).")


def overflow_message(model, method, mode, t, x) -> str | None:
    """The message of a flow that failed (non-finite rates, a collapsed step) with a last accepted state near
    overflow, or ``None`` when no state is that large: the flow grew without bound, no law left its domain."""
    x = np.asarray(x, dtype=float)
    big = np.flatnonzero(~(np.abs(x) < OVERFLOW_NEAR))
    if big.size == 0:
        return None
    names = ", ".join(f"{model.states[k].name} = {x[k]:.3g}" for k in big)
    return (f"{method}: the state grew without bound and overflowed near t = {t:.12g} s in mode {mode.describe()} "
            f"({names}, beyond {OVERFLOW_NEAR:g}): the flow is unstable there (a negative resistance, a positive "
            "feedback, a parameter of the wrong sign?). Check the parameters, or end the run before it blows up")


def nonfinite_message(model, mode, t, x) -> str:
    bad = [model.states[k].name for k in np.flatnonzero(~np.isfinite(x))] or ["the state"]
    return (f"state became non-finite ({', '.join(bad)}) at t ≈ {t:.12g} in mode {mode.describe()}; "
            "check parameters for divisions by zero, or use a smaller step / tighter tolerance.")
