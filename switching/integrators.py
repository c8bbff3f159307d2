"""Integrators for the flow within one mode.

Each integrates the *independent* states ``y`` of the mode (the dependent ones
are recomputed from the constraints, so they never drift) and offers, after
every accepted step, an interpolant over that step for event location.

=========  =====  ==================================================================
method     order  step and interpolant
=========  =====  ==================================================================
euler      1      fixed ``dt``; linear (the Euler step itself, as in the paper's Alg. 1)
rk4        4      fixed ``dt``; cubic Hermite from the end-point slopes
RK45 …     —      scipy's RK45, DOP853, Radau, BDF, LSODA with their dense output
=========  =====  ==================================================================
"""

from __future__ import annotations

import numpy as np

__all__ = ["FIXED_STEP", "ADAPTIVE", "make_stepper", "ORDERS"]

FIXED_STEP = ("euler", "rk4")
ADAPTIVE = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
ORDERS = {"euler": 1, "rk4": 4}


class _Stepper:
    """Common interface: ``step()`` advances and returns ``(t, y)`` or raises;
    ``interpolate(tau)`` evaluates the last step's interpolant."""

    def __init__(self, fun, t0, y0, t_bound):
        self.fun = fun
        self.t = float(t0)
        self.y = np.array(y0, dtype=float)
        self.t_bound = float(t_bound)
        self.n_steps = 0
        self.message = None


class Euler(_Stepper):
    def __init__(self, fun, t0, y0, t_bound, dt):
        super().__init__(fun, t0, y0, t_bound)
        self.dt = float(dt)

    def step(self):
        h = min(self.dt, self.t_bound - self.t)
        self.t_old, self.y_old = self.t, self.y
        self.f_old = self.fun(self.t, self.y)
        self.y = self.y + h * self.f_old
        self.t = self.t + h if self.t + h < self.t_bound else self.t_bound
        self.n_steps += 1
        return self.t, self.y

    def interpolate(self, tau):
        return self.y_old + (tau - self.t_old) * self.f_old


class RK4(_Stepper):
    def __init__(self, fun, t0, y0, t_bound, dt):
        super().__init__(fun, t0, y0, t_bound)
        self.dt = float(dt)
        self.f = fun(self.t, self.y)

    def step(self):
        h = min(self.dt, self.t_bound - self.t)
        t, y, k1 = self.t, self.y, self.f
        k2 = self.fun(t + h / 2, y + h / 2 * k1)
        k3 = self.fun(t + h / 2, y + h / 2 * k2)
        k4 = self.fun(t + h, y + h * k3)
        self.t_old, self.y_old, self.f_old, self.h = t, y, k1, h
        self.y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        self.t = t + h if t + h < self.t_bound else self.t_bound
        self.f = self.fun(self.t, self.y)
        self.n_steps += 1
        return self.t, self.y

    def interpolate(self, tau):
        h = self.h
        s = (tau - self.t_old) / h
        h00 = 2 * s**3 - 3 * s**2 + 1
        h10 = s**3 - 2 * s**2 + s
        h01 = -2 * s**3 + 3 * s**2
        h11 = s**3 - s**2
        return h00 * self.y_old + h10 * h * self.f_old + h01 * self.y + h11 * h * self.f


class Adaptive(_Stepper):
    """A scipy ``OdeSolver`` driven step by step."""

    def __init__(self, fun, t0, y0, t_bound, method, rtol, atol, max_step, first_step):
        import scipy.integrate as si

        super().__init__(fun, t0, y0, t_bound)
        cls = getattr(si, method)
        options = dict(rtol=rtol, atol=atol, max_step=max_step)
        if first_step is not None:
            options["first_step"] = min(first_step, t_bound - t0)
        self.solver = cls(fun, t0, self.y, t_bound, **options)
        self._dense = None

    def step(self):
        message = self.solver.step()
        if self.solver.status == "failed":
            self.message = message or "step failed"
            raise RuntimeError(self.message)
        self.t_old = self.t
        self.t, self.y = self.solver.t, self.solver.y.copy()
        self._dense = None
        self.n_steps += 1
        return self.t, self.y

    def interpolate(self, tau):
        if self._dense is None:
            self._dense = self.solver.dense_output()
        return self._dense(tau)

    @property
    def step_size(self):
        return self.solver.step_size


def make_stepper(method, fun, t0, y0, t_bound, dt=None, rtol=1e-6, atol=1e-9, max_step=np.inf, first_step=None):
    """An integrator for ``y' = fun(t, y)`` from ``(t0, y0)`` up to ``t_bound``."""
    if method == "euler":
        return Euler(fun, t0, y0, t_bound, dt)
    if method == "rk4":
        return RK4(fun, t0, y0, t_bound, dt)
    return Adaptive(fun, t0, y0, t_bound, method, rtol, atol, max_step, first_step)
