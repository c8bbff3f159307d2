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

Euler's step, the RK4 combination and its Hermite interpolant are the rules of
:mod:`switching.rules.steppers`, the ones the compiled kernel runs (on lists of
floats component by component, on arrays whole: the same IEEE results).

Stiffness detection (explicit methods only).  An explicit method run beyond
its stability limit either blows up (fixed step) or crawls at the step size
that limit allows (adaptive); both raise :class:`StiffnessDetected` instead,
with the estimated ``|h·λ|`` of the fastest mode:

* ``RK45``, ``DOP853``: Hairer's test (*Solving ODEs II*, IV.2; DOPRI5 and
  DOP853): ``h·ρ`` with ``ρ = ‖k_last − k_s‖ / ‖y_new − y_s‖``, ``s`` the
  stage evaluated at ``t + h`` — stiff when above 3.25 (DOP853: 6.1) on 15
  accepted steps, a run of 6 steps below resetting the count.  ``RK23`` has
  no stage at ``t + h``: ``(4/3)·k3 − (1/3)·k1`` is ``f`` at ``y + h·k2``
  for an affine ``f``, compared with ``f(y_new)``; limit 2.4 (its stability
  interval ends at −2.51).  Reported only when the rest of the flow would
  take more than 10 000 steps at that step size: a step held at the limit
  near a steady state is often cheap (the two tanks: 126 steps of 24 s).
* ``euler``, ``rk4``: ``|h·λ|`` from second differences of ``f``, which
  approximate ``h²·J²·f`` — unlike a ratio of first differences this gives
  ``ω·h`` for an oscillation whatever the units of the states, and 0 for a
  nilpotent flow (free fall): for rk4 within the step, ``h·ρ = 2·(‖k3 −
  k2‖/‖k1‖)^½``; for Euler over three steps, ``h·ρ = (‖f₂ − 2f₁ +
  f₀‖/‖f₀‖)^½`` (from the third step of a flow on; the compiled kernels
  apply the same rules).  The verdict is the rule
  :mod:`switching.rules.stiffness`: stiff when above the stability limit (euler 2, rk4 2.78)
  on 3 consecutive steps, or once when 25 % above it for an autonomous flow
  (a fixed step that far beyond the limit diverges within a few steps; a
  flow driven by inputs may show one such estimate at a jump of an input).
"""

from __future__ import annotations

import math

import numpy as np

from ..rules.steppers import euler_step, fixed_size, hermite_cubic, nearer_end, rk4_combine
from ..rules.stiffness import AT_ONCE, fixed_stiffness

__all__ = ["Euler", "RK4", "Adaptive", "ORDERS", "STABILITY_LIMITS", "StepFailed", "StiffnessDetected"]

ORDERS = {"euler": 1, "rk4": 4}
#: |h·λ| above which an explicit method is taken to be beyond its stability limit
STABILITY_LIMITS = {"euler": 2.0, "rk4": 2.78, "RK45": 3.25, "RK23": 2.4, "DOP853": 6.1}
_HAIRER_STIFF, _HAIRER_RESET = 15, 6  # Hairer's counts for the adaptive methods
_CRAWL_STEPS = 10_000  # … reported when the rest of the flow would take more steps than this at that step size


class StepFailed(RuntimeError):
    """Raised by a stepper whose solver reports a failed step (the step size
    collapsed); other exceptions from the right-hand side pass through."""


class StiffnessDetected(RuntimeError):
    """Raised by a stepper beyond its stability limit: ``h`` the step,
    ``h_lambda`` the estimated ``|h·λ|``, ``limit`` the method's limit,
    ``component`` the index (in ``y``) dominating the estimate."""

    def __init__(self, method, t, h, h_lambda, limit, component=None, steps_left=None):
        super().__init__(f"{method}: |h·λ| ≈ {h_lambda:.3g} > {limit:g} at t = {t:.12g} (h = {h:.3g})")
        self.method, self.t, self.h, self.h_lambda, self.limit, self.component = (
            method, t, h, h_lambda, limit, component)
        self.steps_left = steps_left


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


class _FixedStiffness:
    """The rule :func:`switching.rules.stiffness.fixed_stiffness` over the steps of a flow."""

    def __init__(self, method, limit, autonomous, enabled=True):
        self.method = method
        self.limit = limit if enabled else math.inf
        self.at_once = AT_ONCE if autonomous and enabled else math.inf
        self.streak = 0

    def check(self, t, h, power4, component):
        """``power4``: the estimate of ``(h·ρ)⁴``; ``component``: array whose
        largest entry names the dominant state."""
        self.streak, h_lambda = fixed_stiffness(power4, self.limit, self.at_once, self.streak)
        if self.streak < 0:
            raise StiffnessDetected(self.method, t, h, h_lambda, self.limit, int(np.argmax(np.abs(component))))


class Euler(_Stepper):
    """Euler's method.  With ``fun_list`` (the rates on lists of floats) the
    step runs on Python floats — faster for a few states, with the same IEEE
    results as on arrays; ``y`` is an array after every step either way."""

    def __init__(self, fun, t0, y0, t_bound, dt, autonomous=True, fun_list=None, stiffness_check=True):
        super().__init__(fun, t0, y0, t_bound)
        self.dt = float(dt)
        self._stiff = _FixedStiffness("euler", STABILITY_LIMITS["euler"], autonomous, stiffness_check)
        self._fun_list = fun_list
        self._y_list = self.y.tolist()
        self._history = []  # f at the starts of the last two steps (all of length dt)

    def _check(self, t, f0, f1, f2):
        """The estimate ``(h·ρ)² = ‖f₂ − 2f₁ + f₀‖ / ‖f₀‖`` (see the module)."""
        if self._fun_list is not None:
            d = [c - b - b + a for a, b, c in zip(f0, f1, f2)]
            den = math.fsum([a * a for a in f0])
            if den > 0.0:
                self._stiff.check(t, self.dt, math.fsum([a * a for a in d]) / den, np.array(d))
        else:
            d = f2 - f1
            d -= f1
            d += f0
            den = f0 @ f0
            if den > 0.0:
                self._stiff.check(t, self.dt, (d @ d) / den, d)

    def step(self):
        t = self.t
        h = fixed_size(self.dt, t, self.t_bound)
        history = self._history
        if self._fun_list is not None:
            y = self._y_list
            f = self._fun_list(t, y)
            if len(history) == 2:
                self._check(t, history[0], history[1], f)
                del history[0]
            history.append(f)
            self.t_old, self._old_lists, self._old_arrays = t, (y, f), None
            y_new = self._y_list = [euler_step(a, b, h) for a, b in zip(y, f)]
            self.y = np.array(y_new)
        else:
            y = self.y
            f = self.fun(t, y)
            if len(history) == 2:
                self._check(t, history[0], history[1], f)
                del history[0]
            history.append(f)
            self.t_old, self._old_lists, self._old_arrays = t, None, (y, f)
            self.y = euler_step(y, f, h)
        self.t = t + h if t + h < self.t_bound and h == self.dt else self.t_bound
        self.n_steps += 1
        return self.t, self.y

    def interpolate(self, tau):
        if self._old_lists is not None:
            y_old, f_old = self._old_lists
            dt = tau - self.t_old
            return np.array([euler_step(a, b, dt) for a, b in zip(y_old, f_old)])
        y_old, f_old = self._old_arrays
        return euler_step(y_old, f_old, tau - self.t_old)


class RK4(_Stepper):
    """The classical Runge–Kutta method; ``fun_list`` as for :class:`Euler`."""

    def __init__(self, fun, t0, y0, t_bound, dt, autonomous=True, fun_list=None, stiffness_check=True):
        super().__init__(fun, t0, y0, t_bound)
        self.dt = float(dt)
        self._stiff = _FixedStiffness("rk4", STABILITY_LIMITS["rk4"], autonomous, stiffness_check)
        self._fun_list = fun_list
        if fun_list is not None:
            self._y_list = self.y.tolist()
            self._f_list = fun_list(self.t, self._y_list)
        else:
            self.f = fun(self.t, self.y)

    def step(self):
        t = self.t
        h = fixed_size(self.dt, t, self.t_bound)
        half = h / 2
        th = t + half
        fun = self._fun_list
        if fun is not None:
            y, k1 = self._y_list, self._f_list
            k2 = fun(th, [euler_step(a, b, half) for a, b in zip(y, k1)])
            k3 = fun(th, [euler_step(a, b, half) for a, b in zip(y, k2)])
            w = [c - b for b, c in zip(k2, k3)]  # ≈ (h/2)² J² k1
            den = math.fsum([a * a for a in k1])
            if den > 0.0:
                self._stiff.check(t, h, 16.0 * math.fsum([a * a for a in w]) / den, np.array(w))
            k4 = fun(t + h, [euler_step(a, b, h) for a, b in zip(y, k3)])
            y_new = [rk4_combine(a, b1, b2, b3, b4, h) for a, b1, b2, b3, b4 in zip(y, k1, k2, k3, k4)]
            self.t_old, self.h, self._old_lists = t, h, (y, k1)
            self._y_list = y_new
            self.t = t + h if t + h < self.t_bound and h == self.dt else self.t_bound
            self._f_list = fun(self.t, y_new)
            self.y = np.array(y_new)
            self.n_steps += 1
            return self.t, self.y
        y, k1 = self.y, self.f
        fun = self.fun
        k2 = fun(th, euler_step(y, k1, half))
        k3 = fun(th, euler_step(y, k2, half))
        w = k3 - k2  # ≈ (h/2)² J² k1
        den = k1 @ k1
        if den > 0.0:
            self._stiff.check(t, h, 16.0 * (w @ w) / den, w)
        k4 = fun(t + h, euler_step(y, k3, h))
        self.t_old, self.h, self._old_lists = t, h, None
        self._arrays = (y, k1)
        s = self.y = rk4_combine(y, k1, k2, k3, k4, h)
        self.t = t + h if t + h < self.t_bound and h == self.dt else self.t_bound
        self.f = fun(self.t, s)
        self.n_steps += 1
        return self.t, s

    def interpolate(self, tau):
        h = self.h
        theta = (tau - self.t_old) / h
        if self._old_lists is not None:
            y_old, f_old = self._old_lists
            return np.array([nearer_end(hermite_cubic(a, b, c, d, h, theta), a, c,
                                        hermite_cubic(abs(a), abs(b), abs(c), -abs(d), abs(h), theta))
                             for a, b, c, d in zip(y_old, f_old, self._y_list, self._f_list)])
        y_old, f_old = self._arrays
        terms = hermite_cubic(np.abs(y_old), np.abs(f_old), np.abs(self.y), -np.abs(self.f), abs(h), theta)
        return nearer_end(hermite_cubic(y_old, f_old, self.y, self.f, h, theta), y_old, self.y, terms)


# the stage evaluated at t + h for Hairer's test (RK23 has none: see Adaptive._hairer)
_HAIRER_STAGE = {"RK45": 5, "DOP853": 11, "RK23": None}


def _dense_terms(dense, y_old, y) -> np.ndarray:
    """``Σ|terms|`` of scipy's dense output ``dense`` of a step from ``y_old`` to ``y``, for
    :func:`~switching.rules.steppers.nearer_end`: ``|y_old| + |h|·Σ_j |Q_ij|`` where it is ``y_old +
    h·Q·p(θ)`` (RK45, RK23; the kernel's RK45 alike), ``|y_old| + Σ_j |Q_ij|`` where it is ``y_old + Q·p``
    (Radau), else ``|y_old| + |y|`` (a step's ends).  Unweighted by ``θ``: the coefficients ``Q`` carry the
    round-off of the stages they were formed from."""
    Q = getattr(dense, "Q", None)
    kind = type(dense).__name__
    if kind not in ("RkDenseOutput", "RadauDenseOutput") or not isinstance(Q, np.ndarray) or Q.ndim != 2:
        return np.abs(y_old) + np.abs(y)
    scale = abs(dense.h) if kind == "RkDenseOutput" else 1.0
    return np.abs(y_old) + scale * np.abs(Q).sum(axis=1)


class Adaptive(_Stepper):
    """A scipy ``OdeSolver`` driven step by step (``jac``: the implicit
    methods' Jacobian ``J(t, y)``, an array or a sparse matrix)."""

    def __init__(self, fun, t0, y0, t_bound, method, rtol, atol, max_step, first_step, stiffness_check=True,
                 jac=None):
        import scipy.integrate as si

        super().__init__(fun, t0, y0, t_bound)
        cls = getattr(si, method)
        options = dict(rtol=rtol, atol=atol, max_step=max_step)
        if jac is not None:  # (Radau, BDF, LSODA: ∂fun/∂y, else estimated by finite differences)
            options["jac"] = getattr(jac, "dense", jac) if method == "LSODA" else jac  # (LSODA: dense only)
        if first_step is not None:
            options["first_step"] = min(first_step, t_bound - t0)
        self.solver = cls(fun, t0, self.y, t_bound, **options)
        self.method = method
        self._dense = None
        self._stiffness_test = stiffness_check and method in _HAIRER_STAGE
        self._stage = _HAIRER_STAGE.get(method)
        self._stiff_steps = self._calm_steps = 0

    def step(self):
        message = self.solver.step()
        if self.solver.status == "failed":
            self.message = message or "step failed"
            raise StepFailed(self.message)
        self.t_old, self.y_old = self.t, self.y
        self.t, self.y = self.solver.t, self.solver.y.copy()
        self._dense = None
        self.n_steps += 1
        if self._stiffness_test:
            self._hairer()
        return self.t, self.y

    def _hairer(self):
        """Hairer's stiffness test on the step just accepted."""
        solver, s = self.solver, self._stage
        h = solver.h_previous
        K = solver.K
        if s is None:  # RK23: its stages are at t, t + h/2, t + 3h/4; (4/3)·stage 3 − (1/3)·stage 1 is at t + h
            num = K[3] - (4 / 3) * K[2] + (1 / 3) * K[0]  # f at y + h·k2 for an affine f
            den = solver.y - (solver.y_old + h * K[1])
        else:
            num = K[-1] - K[s]
            den = solver.y - (solver.y_old + np.dot(K[:s].T, solver.A[s, :s]) * h)  # the stage's argument
        dd = den @ den
        limit = STABILITY_LIMITS[self.method]
        h_lambda = abs(h) * math.sqrt((num @ num) / dd) if dd > 0.0 else 0.0
        if h_lambda > limit:
            self._calm_steps = 0
            self._stiff_steps += 1
            steps_left = (self.t_bound - self.t) / abs(h)
            if self._stiff_steps >= _HAIRER_STIFF and steps_left > _CRAWL_STEPS:
                raise StiffnessDetected(self.method, self.t, abs(h), h_lambda, limit, int(np.argmax(np.abs(num))),
                                        steps_left)
        else:
            self._calm_steps += 1
            if self._calm_steps >= _HAIRER_RESET:
                self._stiff_steps = 0

    def interpolate(self, tau):
        if self._dense is None:
            self._dense = self.solver.dense_output()
            self._terms = _dense_terms(self._dense, self.y_old, self.y)
            self._hull = (np.minimum(self.y_old, self.y), np.maximum(self.y_old, self.y))
        value = self._dense(tau)
        lower, upper = self._hull
        if ((value < lower) | (value > upper)).any():  # (between the ends the rule keeps the value: not called)
            return nearer_end(value, self.y_old, self.y, self._terms)
        return value

    @property
    def step_size(self):
        return self.solver.step_size
