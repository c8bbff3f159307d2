"""The fixed-step steppers' arithmetic: Euler's step and the classical
Runge–Kutta combination.

For ``y' = f(t, y)`` and a step ``h`` from ``(t, y)``:

* Euler: ``y₁ = y + h·f(t, y)`` (order 1; the paper's Alg. 1);
* classical RK4 (order 4): the stages ``k₁ = f(t, y)``, ``k₂ = f(t + h/2,
  y + (h/2)·k₁)``, ``k₃ = f(t + h/2, y + (h/2)·k₂)``, ``k₄ = f(t + h, y +
  h·k₃)`` — their arguments are Euler steps (:func:`euler_step` with ``h/2``,
  ``h/2``, ``h``) — and ``y₁ = y + (h/6)·(k₁ + 2·k₂ + 2·k₃ + k₄)``
  (:func:`rk4_combine`).

The caller evaluates ``f`` (the Python path with Python objects, the kernel
through its function pointers) and calls these rules between evaluations.
Each is written component-wise, so it applies as it is to floats (the kernel
calls it for each component; numba inlines it) and to numpy arrays (the Python
path's arrays, whole): the same operations in the same order, so the same
IEEE results either way.
"""

from __future__ import annotations

__all__ = ["RULES", "euler_step", "rk4_combine"]

RULES = ("euler_step", "rk4_combine")


def euler_step(y, f, h):
    """``y + h·f``: Euler's step of size ``h`` (and RK4's stage arguments)."""
    return y + h * f


def rk4_combine(y, k1, k2, k3, k4, h):
    """``y + (h/6)·(k₁ + 2·k₂ + 2·k₃ + k₄)``: the classical RK4 step from its
    four stages."""
    return y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
