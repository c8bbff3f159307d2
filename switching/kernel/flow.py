"""The flow within one mode: the steps of the fixed-step methods (Euler,
classical RK4) and of scipy's RK45 (Dormand–Prince 5(4) with scipy's initial
step, error norm, step factors and dense output, so both take the same steps
up to round-off), the steps' interpolants, and the stiffness tests of
:mod:`switching.simulate.integrators`:

* RK45: Hairer's, ``h·ρ > 3.25`` on 15 accepted steps without 6 calm ones
  between, ``ρ ≈ ‖k₇ − k₆‖ / ‖y₇ − y₆‖``, reported when the rest of the flow
  would take more than 1e4 steps at that step size;
* rk4 and Euler: the rule :mod:`switching.rules.stiffness` on ``|h·λ|`` from
  differences of ``f`` (limits 2.78 and 2).

Times in the model's time unit; ``y`` the mode's independent states, ``f``
their rates.
"""

from __future__ import annotations

import math

import numpy as np

from .calls import argmax_abs, finite, fun
from .compiler import (dispatch, euler_step, fixed_size, fixed_stiffness, hermite_cubic, inline, jit, nearer_end,
                       rk4_combine, rodas_dense, stamp_with_rules)

__all__ = ["RK_A", "RK_B", "RK_C", "RK_E", "RK_P", "adaptive_step", "dense_coefficients", "fixed_step", "hairer",
           "initial_step", "interp", "rk45_dense"]

RK_C = np.array([0.0, 0.2, 0.3, 0.8, 8 / 9, 1.0])
RK_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [1 / 5, 0.0, 0.0, 0.0, 0.0],
    [3 / 40, 9 / 40, 0.0, 0.0, 0.0],
    [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
])
RK_B = np.array([35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
RK_E = np.array([-71 / 57600, 0.0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
# scipy's RK45.P (dense output: y(t + θh) = y + h·K·(P·[θ, θ², θ³, θ⁴])), written out so a compiled run does not
# import scipy.integrate (~0.2 s); tests/switching/simulate/test_kernel.py checks it is scipy's
RK_P = np.array([
    [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0, 0, 0, 0],
    [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
    [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
], dtype=float)


@inline
def _rms(v):
    """The root mean square of v (0 for no entries)."""
    acc = 0.0
    for i in range(v.shape[0]):
        acc += v[i] * v[i]
    return math.sqrt(acc / v.shape[0]) if v.shape[0] > 0 else 0.0


@inline
def _stiff_verdict(power4, limit, at_once, streak, h, component, info):
    """The rule :func:`switching.rules.stiffness.fixed_stiffness` on the estimate ``power4`` of ``(h·ρ)⁴``;
    returns the new streak, or -1 with ``info`` filled (``|h·λ|``, ``h``, the limit, the dominant component)."""
    streak, h_lambda = fixed_stiffness(power4, limit, at_once, streak)
    if streak < 0:
        info[0] = h_lambda
        info[1] = h
        info[3] = limit
        info[4] = argmax_abs(component)
    return streak



@dispatch
def interp(kind, t_old, h, A, tau, out):
    """The step's interpolant: linear (Euler, kind 0), cubic Hermite (RK4, kind 1), scipy's RK45 dense output
    (kind 2), RODAS4P's continuous extension (kind 3: ``Q[:, 0]``, ``Q[:, 1]`` its coefficients ``q₁``, ``q₂``);
    a value beyond the step's end values by no more than the round-off of its terms (Hermite's weighed at
    ``θ``; the adaptive methods' coefficients at their size) is the nearer end's
    (:func:`switching.rules.steppers.nearer_end`)."""
    y_old, f_old, y_new, f_new, Q = A
    if kind == 0:
        dt = tau - t_old
        for i in range(out.shape[0]):
            out[i] = euler_step(y_old[i], f_old[i], dt)
    elif kind == 1:
        theta = (tau - t_old) / h
        for i in range(out.shape[0]):
            terms = hermite_cubic(abs(y_old[i]), abs(f_old[i]), abs(y_new[i]), -abs(f_new[i]), abs(h), theta)
            out[i] = nearer_end(hermite_cubic(y_old[i], f_old[i], y_new[i], f_new[i], h, theta), y_old[i],
                                y_new[i], terms)
    elif kind == 3:
        theta = (tau - t_old) / h
        for i in range(out.shape[0]):
            # (its coefficients q₁, q₂ carry the round-off of the stages, which are of the ends' size)
            terms = abs(y_old[i]) + abs(y_new[i]) + abs(Q[i, 0]) + abs(Q[i, 1])
            out[i] = nearer_end(rodas_dense(y_old[i], y_new[i], Q[i, 0], Q[i, 1], theta), y_old[i], y_new[i], terms)
    else:
        rk45_dense(y_old, y_new, Q, h, (tau - t_old) / h, out)


@inline
def rk45_dense(y_old, y_new, Q, h, theta, out):
    """RK45's dense output at ``θ`` (scipy's: ``y + h·Σ_j Q[:, j]·θ^(j+1)``, ``Q`` of four columns), each value
    beyond the step's end values by no more than the round-off of its terms the nearer end's."""
    for i in range(out.shape[0]):
        acc = 0.0
        terms = 0.0
        pw = 1.0
        for j in range(4):
            pw *= theta
            acc += Q[i, j] * pw
            terms += abs(Q[i, j])
        out[i] = nearer_end(y_old[i] + h * acc, y_old[i], y_new[i], abs(y_old[i]) + abs(h) * terms)


@inline
def state_atol(M, m, i):
    """The absolute tolerance of component ``i`` of mode ``m``'s flow: its ``i``-th independent state's
    (``M.atol``, :mod:`switching.simulate.state_tolerances`); 1 for the dummy of a flow with none."""
    if i < M.lengths[0][m]:
        return M.atol[M.tables[0][m, i]]
    return 1.0


@jit
def initial_step(m, k, t0, y, f, t_end, rtol, max_step, M, tmp, f1):
    """scipy.integrate._ivp.common.select_initial_step (order 4), each state's ``atol`` its own."""
    interval = abs(t_end - t0)
    ke = y.shape[0]
    d0 = 0.0
    d1 = 0.0
    for i in range(ke):
        sc = state_atol(M, m, i) + abs(y[i]) * rtol
        d0 += (y[i] / sc) * (y[i] / sc)
        d1 += (f[i] / sc) * (f[i] / sc)
    d0 = math.sqrt(d0 / ke)
    d1 = math.sqrt(d1 / ke)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, interval)
    for i in range(ke):
        tmp[i] = y[i] + h0 * f[i]
    fun(m, t0 + h0, tmp, k, M, f1)
    d2 = 0.0
    for i in range(ke):
        sc = state_atol(M, m, i) + abs(y[i]) * rtol
        d2 += ((f1[i] - f[i]) / sc) * ((f1[i] - f[i]) / sc)
    d2 = math.sqrt(d2 / ke) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1 / 5)
    return min(100 * h0, h1, interval, max_step)




@inline
def fixed_step(kind, m, k, t, t_end, dt, streak, history, check, A, W, M, info):
    """One step of Euler (kind 0) or the classical RK4 (kind 1) from ``(t, y)`` of size ``h = min(dt, t_end − t)``
    into ``y_new`` with its rates ``f_new``, after the stiffness test (``check``): Euler's over three steps,
    ``f₂ − 2f₁ + f₀ ≈ (h·J)²f₀`` (``K[4], K[5]``: the previous rates; ``history`` how many), RK4's within the
    step, ``k₃ − k₂ ≈ (h/2)²J²k₁``.  Returns ``(t_new, h, streak, history)``, ``streak`` -1 when stiff (``info``
    filled, the step not taken)."""
    y, f, y_new, f_new, Q = A
    tmp, err, K = W
    ke = y.shape[0]
    h = fixed_size(dt, t, t_end)
    t_new = t + h if t + h < t_end and h == dt else t_end
    if kind == 0:
        if history == 2 and check:
            num = 0.0
            den = 0.0
            for i in range(ke):
                err[i] = f[i] - K[4, i] - K[4, i] + K[5, i]
                num += err[i] * err[i]
                den += K[5, i] * K[5, i]
            if den > 0.0:
                streak = _stiff_verdict(num / den, 2.0, M.at_once, streak, dt, err, info)
                if streak < 0:
                    return t_new, h, streak, history
        for i in range(ke):
            K[5, i] = K[4, i]
            K[4, i] = f[i]
        history = min(history + 1, 2)
        for i in range(ke):
            y_new[i] = euler_step(y[i], f[i], h)
    else:
        for i in range(ke):
            tmp[i] = euler_step(y[i], f[i], h / 2)
        fun(m, t + h / 2, tmp, k, M, K[1])
        for i in range(ke):
            tmp[i] = euler_step(y[i], K[1, i], h / 2)
        fun(m, t + h / 2, tmp, k, M, K[2])
        num = 0.0
        den = 0.0
        for i in range(ke):
            err[i] = K[2, i] - K[1, i]
            num += err[i] * err[i]
            den += f[i] * f[i]
        if den > 0.0 and check:
            streak = _stiff_verdict(16.0 * num / den, 2.78, M.at_once, streak, h, err, info)
            if streak < 0:
                return t_new, h, streak, history
        for i in range(ke):
            tmp[i] = euler_step(y[i], K[2, i], h)
        fun(m, t + h, tmp, k, M, K[3])
        for i in range(ke):
            y_new[i] = rk4_combine(y[i], f[i], K[1, i], K[2, i], K[3, i], h)
    fun(m, t_new, y_new, k, M, f_new)
    return t_new, h, streak, history


@inline
def adaptive_step(m, k, t, t_end, h_abs, rtol, max_step, A, W, M):
    """One accepted step of RK45 from ``(t, y)``, trying ``h_abs`` first (bounded by ``max_step`` and ten
    spacings of floating-point numbers at ``t``), with scipy's error norm and step factors (0.2 to 10, safety
    0.9; no growth right after a rejection; a trial whose stages leave the reals is rejected with 0.2): the
    stages in ``K``, the end in ``y_new``, ``f_new``, the last stage's argument in ``tmp``.  Returns ``(ok,
    t_new, h, h_abs)``: not ok when the step size collapsed, or (``h_abs`` NaN) when the rates are not numbers
    where the step starts or the trials left the reals down to the smallest step; ``h_abs`` the size to try
    next."""
    y, f, y_new, f_new, Q = A
    tmp, err, K = W
    ke = y.shape[0]
    min_step = 10 * abs(np.nextafter(t, np.inf) - t)
    if h_abs > max_step:
        h_abs = max_step
    elif h_abs < min_step:
        h_abs = min_step
    accepted = False
    rejected = False
    left_reals = False  # the last trial left the reals: a collapse then reports NaN (a law left its domain)
    h = 0.0
    t_new = t
    while not accepted:
        if h_abs < min_step:
            return False, t, h, np.nan if left_reals else h_abs
        h = h_abs
        t_new = t + h
        if t_new - t_end > 0:
            t_new = t_end
        h = t_new - t
        h_abs = abs(h)
        for i in range(ke):
            K[0, i] = f[i]
        for st in range(1, 6):
            for i in range(ke):
                acc = 0.0
                for j in range(st):
                    acc += K[j, i] * RK_A[st, j]
                tmp[i] = y[i] + acc * h
            fun(m, t + RK_C[st] * h, tmp, k, M, K[st])
        for i in range(ke):
            acc = 0.0
            for j in range(6):
                acc += K[j, i] * RK_B[j]
            y_new[i] = y[i] + h * acc
        fun(m, t + h, y_new, k, M, K[6])
        for i in range(ke):
            f_new[i] = K[6, i]
        for i in range(ke):
            acc = 0.0
            for j in range(7):
                acc += K[j, i] * RK_E[j]
            sc = state_atol(M, m, i) + max(abs(y[i]), abs(y_new[i])) * rtol
            err[i] = acc * h / sc
        error_norm = _rms(err)
        if error_norm != error_norm:
            if not finite(f):  # NaN rates where the step starts: no step size helps; never loop on
                return False, t, h, np.nan
            # a trial stage left the reals (an exponential law overflowing on a step too long for a stiff
            # flow): rejected, as scipy's RK45 rejects a NaN error norm (factor 0.2)
            h_abs *= 0.2
            rejected = True
            left_reals = True
            continue
        left_reals = False
        if error_norm < 1:
            if error_norm == 0:
                factor = 10.0
            else:
                factor = min(10.0, 0.9 * error_norm ** (-1 / 5))
            if rejected:
                factor = min(1.0, factor)
            h_abs *= factor
            accepted = True
        else:
            h_abs *= max(0.2, 0.9 * error_norm ** (-1 / 5))
            rejected = True
    return True, t_new, h, h_abs


@inline
def hairer(t_end, t_new, h, stiff_run, calm_run, check, A, W, info):
    """Hairer's stiffness test (DOPRI5) on the RK45 step just accepted (``tmp``: the last stage's argument
    ``y₆``, at ``t + h`` like ``y_new``): ``|h|·‖k₇ − k₆‖/‖y₇ − y₆‖ > 3.25`` counts a stiff step, 6 calm ones
    in a row reset the count.  Returns ``(stiff_run, calm_run, stiff)``; stiff (``info`` filled) after 15 stiff
    steps when the rest of the flow would take more than 1e4 steps at this step size."""
    y, f, y_new, f_new, Q = A
    tmp, err, K = W
    num = 0.0
    den = 0.0
    for i in range(y.shape[0]):
        err[i] = K[6, i] - K[5, i]
        num += err[i] * err[i]
        den += (y_new[i] - tmp[i]) * (y_new[i] - tmp[i])
    if check and den > 0.0 and abs(h) * math.sqrt(num / den) > 3.25:
        calm_run = 0
        stiff_run += 1
        if stiff_run >= 15 and (t_end - t_new) / abs(h) > 10000.0:
            info[0] = abs(h) * math.sqrt(num / den)
            info[1] = abs(h)
            info[3] = 3.25
            info[4] = argmax_abs(err)
            return stiff_run, calm_run, True
    else:
        calm_run += 1
        if calm_run >= 6:
            stiff_run = 0
    return stiff_run, calm_run, False


@inline
def dense_coefficients(K, Q):
    """``Q = K·P``: the RK45 step's dense output coefficients (scipy's), for each row of ``Q``."""
    for i in range(Q.shape[0]):
        for j in range(4):
            acc = 0.0
            for mm in range(7):
                acc += K[mm, i] * RK_P[mm, j]
            Q[i, j] = acc


stamp_with_rules(globals(), __name__)
