"""Is the flow in a mode stiff?  ``method="auto"``'s estimate from the
spectrum of the flow's Jacobian (:mod:`.jacobian`), which decides per mode
between the compiled explicit method (``RK45``) and the compiled implicit
one (RODAS4P, ``rodas-jit``).

With ``λ`` the eigenvalues of ``J = ∂ẏ/∂y`` (1/s) at a state of the mode
and ``T`` the run's time span (s), the flow is *stiff* when

    max |Re λ| · T > :data:`STIFF_SPAN`  (no unit),

that is when an explicit method, whose stable steps along the negative real
axis are at most ``3.3/max|Re λ|`` (RK45), would need more than about
``STIFF_SPAN/3.3`` steps for stability alone, whatever the accuracy asked.
Only the real parts count: an undamped fast oscillation (``λ`` imaginary)
is left to the explicit method, which follows it without the numerical
damping of an L-stable implicit method.  For a nonlinear flow the estimate
holds at the state it was taken at (the state where the run meets the mode);
the explicit method's own stiffness test stays on, and when it fires in a
mode judged not stiff, ``auto`` switches that mode to the implicit method.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .jacobian import flow_jacobian

__all__ = ["STIFF_SPAN", "ModeStiffness", "mode_stiffness"]

STIFF_SPAN = 1e4


class ModeStiffness(NamedTuple):
    """The verdict on one mode: ``stiff``, the estimate ``max|Re λ|·T``
    (NaN when there is none) and the reason in words."""

    stiff: bool
    value: float
    reason: str


def mode_stiffness(model, mode, x, t: float, span: float) -> ModeStiffness:
    """The verdict on the flow in ``mode`` at the state ``x`` (full state
    vector; its dependent entries are not read) and time ``t`` [s], for a
    run of ``span`` seconds (see the module docstring)."""
    cm = model.compiled_mode(mode)
    if not len(cm.independent):
        return ModeStiffness(False, float("nan"), "no independent state")
    x = np.asarray(x, dtype=float)
    jacobian = flow_jacobian(model, cm, x)
    if jacobian is None:
        return ModeStiffness(False, float("nan"), "its Jacobian was not derived within the symbolic budget")
    matrix = jacobian.dense(float(t), x[cm.independent])
    if not np.all(np.isfinite(matrix)):
        return ModeStiffness(False, float("nan"), f"its Jacobian is not finite at t = {float(t):.6g} s")
    rate = float(np.max(np.abs(np.linalg.eigvals(matrix).real)))
    value = rate * float(span)
    stiff = value > STIFF_SPAN
    return ModeStiffness(stiff, value, f"max |Re λ|·T = {rate:.3g} 1/s × {float(span):.3g} s = {value:.3g} "
                         f"{'>' if stiff else '≤'} {STIFF_SPAN:g}")
