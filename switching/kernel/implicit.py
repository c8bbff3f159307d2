"""The flow's implicit method: RODAS4P (kind 3, ``"rodas-jit"``), a
Rosenbrock method of order 4(3) with the rules of
:mod:`switching.rules.rosenbrock` (tableau, continuous extension, Hairer's
step-size control with Gustafsson's prediction), and the dense linear algebra
it needs.

Per attempted step from ``(t, y)`` (``k`` independent states; times in the
model's time unit): the Jacobian ``J = ∂f/∂y`` at ``(t, y)`` — the mode's
compiled symbolic Jacobian (:func:`.calls.jac`, op 6), or forward differences
of ``f`` where the mode has none (``δ_j = √ε·max(|y_j|, 1e-5)``) — once per
point (kept through rejections), ``f_t = ∂f/∂t`` for a flow driven by inputs
(else 0): the compiled function's, else a forward difference (``δ =
√ε·max(|t|, 1)``), the LU factors of ``E = I/(γ·h) − J`` with
partial pivoting, then six stages each one evaluation of ``f`` and one pair
of triangular solves.  The error norm is scipy's (root mean square of
``k₆/(atol + rtol·max(|y|, |y₁|))``); the step is accepted when it is at most
1.  A step cannot be shorter than ten spacings of floating-point numbers at
``t`` (else the step size collapsed), nor longer than ``max_step``.

The records (see :mod:`.calls`): ``A = (y, f, y_new, f_new, Q)`` with the
continuous extension's ``q₁, q₂`` in ``Q[:, 0:2]``; ``W = (tmp, err, K)``
with the stages ``k₁…k₆`` in ``K[0:6]`` and a stage's rates in ``K[6]``;
``L = (jac, lu, piv, fx, ctl)``: ``J`` (``k·k`` row-major, then room for
``k`` more: ``f_t`` from the compiled function) and the LU factors of ``E``,
the pivots, ``f_t``, and the controller's memory ``ctl = (h_acc,
err_acc)`` (the last accepted step and its error; 0 at a flow's start).
"""

from __future__ import annotations

import math

import numpy as np

from ..rules.rosenbrock import A as RA
from ..rules.rosenbrock import C as RC
from ..rules.rosenbrock import D as RD
from ..rules.rosenbrock import GAMMA, H as RH
from ..rules.rosenbrock import GAMMA_C as RG
from .calls import fun, jac
from .compiler import dispatch, inline, rodas_control, stamp_with_rules

__all__ = ["jacobian", "lu_factor", "lu_solve", "rosenbrock_step"]

_SQRT_EPS = math.sqrt(np.finfo(np.float64).eps)


@inline
def lu_factor(a, piv, n):
    """LU factors of the ``n × n`` row-major matrix ``a`` in place, partial pivoting (row ``c`` swapped with
    ``piv[c]`` at column ``c``).  Returns False for an exactly singular matrix."""
    for c in range(n):
        p = c
        big = abs(a[c * n + c])
        for r in range(c + 1, n):
            if abs(a[r * n + c]) > big:
                big = abs(a[r * n + c])
                p = r
        piv[c] = p
        if not big > 0.0:
            return False
        if p != c:
            for j in range(n):
                a[c * n + j], a[p * n + j] = a[p * n + j], a[c * n + j]
        inv = 1.0 / a[c * n + c]
        for r in range(c + 1, n):
            ratio = a[r * n + c] * inv
            a[r * n + c] = ratio
            if ratio != 0.0:
                for j in range(c + 1, n):
                    a[r * n + j] -= ratio * a[c * n + j]
    return True


@inline
def lu_solve(a, piv, n, b):
    """``b ← M⁻¹·b`` with ``a``, ``piv`` the LU factors of ``M`` (:func:`lu_factor`)."""
    for c in range(n):
        p = piv[c]
        if p != c:
            b[c], b[p] = b[p], b[c]
    for r in range(n):
        acc = b[r]
        for j in range(r):
            acc -= a[r * n + j] * b[j]
        b[r] = acc
    for r in range(n - 1, -1, -1):
        acc = b[r]
        for j in range(r + 1, n):
            acc -= a[r * n + j] * b[j]
        b[r] = acc / a[r * n + r]


@dispatch
def jacobian(m, k, t, y, f, M, L, tmp, f1):
    """``J`` at ``(t, y)`` (rates ``f``) into ``L[0]``, and ``f_t`` into ``L[3]`` (0 unless the flow is driven
    by inputs); ``tmp``, ``f1`` scratch."""
    jbuf, fx = L[0], L[3]
    ke = y.shape[0]
    if k == 0:
        jbuf[0] = 0.0
    elif M.jfns[m] != 0:
        jac(m, y, t, M, jbuf)
    else:
        for i in range(ke):
            tmp[i] = y[i]
        for j in range(ke):
            delta = _SQRT_EPS * max(abs(y[j]), 1e-5)
            tmp[j] = y[j] + delta
            delta = tmp[j] - y[j]
            fun(m, t, tmp, k, M, f1)
            for i in range(ke):
                jbuf[i * ke + j] = (f1[i] - f[i]) / delta
            tmp[j] = y[j]
    for i in range(ke):
        fx[i] = 0.0
    if M.driven != 0 and k > 0 and M.jfns[m] != 0:  # the compiled Jacobian's ∂f/∂t, after J
        for i in range(ke):
            fx[i] = jbuf[ke * ke + i]
    elif M.driven != 0 and k > 0:
        dt = _SQRT_EPS * max(abs(t), 1.0)
        fun(m, t + dt, y, k, M, f1)
        for i in range(ke):
            fx[i] = (f1[i] - f[i]) / dt


@inline
def _stages(m, k, t, h, rtol, atol, A, W, L, M):
    """The six stages of a step of size ``h`` (``E``'s LU factors in ``L[1]``) into ``K[0:6]``, ``y₁`` into
    ``y_new``; returns the error norm."""
    y, f, y_new, f_new, Q = A
    tmp, err, K = W
    lu, piv, fx = L[1], L[2], L[3]
    ke = y.shape[0]
    for st in range(6):
        if st > 0:
            for c in range(ke):
                acc = y[c]
                for j in range(st):
                    acc += RA[st, j] * K[j, c]
                tmp[c] = acc
            fun(m, t + RC[st] * h, tmp, k, M, K[6])
        for c in range(ke):
            acc = f[c] if st == 0 else K[6, c]
            for j in range(st):
                acc += (RG[st, j] / h) * K[j, c]
            K[st, c] = acc + h * RD[st] * fx[c]
        lu_solve(lu, piv, ke, K[st])
    total = 0.0
    for c in range(ke):
        y_new[c] = tmp[c] + K[5, c]
        sc = atol + max(abs(y[c]), abs(y_new[c])) * rtol
        total += (K[5, c] / sc) ** 2
    return math.sqrt(total / ke)


@dispatch
def rosenbrock_step(m, k, t, t_end, h_abs, rtol, atol, max_step, A, W, L, M):
    """One accepted RODAS4P step from ``(t, y)``, trying ``h_abs`` first (see the module docstring): ``y₁``
    in ``y_new`` with its rates ``f_new``, the continuous extension's coefficients in ``Q``.  Returns ``(ok,
    t_new, h, h_abs)``: not ok when the step size collapsed; ``h_abs`` the size to try next."""
    y, f, y_new, f_new, Q = A
    tmp, err, K = W
    jbuf, lu, piv, fx, ctl = L
    ke = y.shape[0]
    min_step = 10 * abs(np.nextafter(t, np.inf) - t)
    h_abs = min(h_abs, max_step)
    h_abs = max(h_abs, min_step)
    jacobian(m, k, t, y, f, M, L, tmp, f_new)
    rejected = False
    h = 0.0
    while True:
        if h_abs < min_step:
            return False, t, h, h_abs
        t_new = t + h_abs
        if t_new - t_end > 0:
            t_new = t_end
        h = t_new - t
        h_abs = abs(h)
        factor = 1.0 / (GAMMA * h)
        for i in range(ke * ke):
            lu[i] = -jbuf[i]
        for i in range(ke):
            lu[i * ke + i] += factor
        error = _stages(m, k, t, h, rtol, atol, A, W, L, M) if lu_factor(lu, piv, ke) else np.inf
        h_next, h_acc, err_acc = rodas_control(error, h_abs, ctl[0], ctl[1], rejected)
        if error <= 1.0:
            ctl[0] = h_acc
            ctl[1] = err_acc
            fun(m, t_new, y_new, k, M, f_new)
            for c in range(ke):
                q1 = 0.0
                q2 = 0.0
                for j in range(5):
                    q1 += RH[0, j] * K[j, c]
                    q2 += RH[1, j] * K[j, c]
                Q[c, 0] = q1
                Q[c, 1] = q2
            return True, t_new, h, h_next
        rejected = True
        h_abs = h_next


stamp_with_rules(globals(), __name__)
