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

An accepted step's Jacobian is checked at its end, where the next step needs
it anyway: the stages damp the step's motion ``Δ = y₁ − y`` by ``(I −
γh·J)``, and where ``‖(I − γh·J(y))·Δ‖`` exceeds both 1 (in the tolerance's
units) and ``DAMPING_RATIO`` times ``‖(I − γh·J(y₁))·Δ‖``, the step left the
region its linearization describes (a stiff state leaving its slow manifold:
an exponential diode turning on, in series with an inductor, where ``J``
falls by orders of magnitude within one step) and the error estimate, made
with the same ``J``, cannot see it: the step is taken again, shorter.

The records (see :mod:`.calls`): ``A = (y, f, y_new, f_new, Q)`` with the
continuous extension's ``q₁, q₂`` in ``Q[:, 0:2]``; ``W = (tmp, err, K)``
with the stages ``k₁…k₆`` in ``K[0:6]`` and a stage's rates in ``K[6]``;
``L = (jac, lu, piv, fx, ctl, order)``: ``J`` (``k·k`` row-major, then room
for ``k`` more: ``f_t`` from the compiled function) and the LU factors of
``E``'s block ``E_SS`` (below), the pivots, ``f_t``, the controller's memory
``ctl = (h_acc, err_acc)`` (the last accepted step and its error; 0 at a
flow's start) with ``|S|`` and a flag after it (0 at a flow's start: ``J``'s
buffer not zeroed, the order not made; 1: the order made from ``J``'s values;
2: from the compiled function's pattern), and the states' order ``S`` then
``Z`` (then the extents of ``Z``'s rows in ``J_ZS``: 3·k entries).

The states no rate reads at ``(t, y)`` (``Z``: the columns of ``J`` that are
zero, such as positions that only integrate velocities) are solved for
without factoring: with the others ``S`` first, ``E = [[E_SS, 0], [−J_ZS,
I/(γh)]]``, so ``E·x = b`` is ``E_SS·x_S = b_S`` (LU of ``|S| × |S|``) and
``x_Z = γh·(b_Z + J_ZS·x_S)``, exactly.  The order of ``S`` is made at the
flow's first step (:func:`_narrow`: nearly banded for a sparse ``J``): from
the compiled Jacobian's pattern (its structural nonzeros, so kept for the
whole flow, with each row of ``J_ZS`` summed over its nonzeros' extent), or
from the values of a differenced ``J``, kept while the columns of ``Z`` stay
zero (any order of ``S`` is exact; a column of ``Z`` that is no longer zero
makes the order again).
"""

from __future__ import annotations

import math

import numpy as np
from numba.core import types
from numba.extending import overload

from ..rules.rosenbrock import A as RA
from ..rules.rosenbrock import C as RC
from ..rules.rosenbrock import D as RD
from ..rules.rosenbrock import GAMMA, H as RH
from ..rules.rosenbrock import GAMMA_C as RG
from .calls import finite, fun, jac
from .flow import state_atol
from .compiler import dispatch, inline, rodas_control, stamp_with_rules

__all__ = ["implicit_workspaces", "jacobian", "lu_factor", "lu_solve", "rosenbrock_step"]

_SQRT_EPS = math.sqrt(np.finfo(np.float64).eps)
#: the shortest step RODAS4P factors: ``1/(γ·h)`` stays finite (a first step of 10 ulps of t = 0, 5e-323 s, made
#: it infinite: the relay with atol = 1e-300 started there, its matrix and stages NaN)
_MIN_IMPLICIT_STEP = 1e-290
#: a step is taken again, shorter, when the stages damped its motion more than this many times what the
#: Jacobian at its end would (see rosenbrock_step)
DAMPING_RATIO = 4.0


def implicit_workspaces(L, implicit):
    """The implicit method's records ``L`` in a run that may take implicit
    steps (``implicit`` is ``True``), else ``None`` (``implicit`` is
    ``None``): chosen by the argument's type when the kernel is compiled, so
    an explicit specialisation of the run has ``L`` typed ``None`` and
    compiles without :func:`rosenbrock_step` (its branches on ``L is None``
    are pruned)."""
    return L if implicit is not None else None


@overload(implicit_workspaces, jit_options={"cache": True})
def _implicit_workspaces(L, implicit):
    if isinstance(implicit, types.NoneType):
        return lambda L, implicit: None
    return lambda L, implicit: L


@inline
def lu_factor(a, piv, n):
    """LU factors of the ``n × n`` row-major matrix ``a`` in place, partial pivoting (row ``c`` swapped with
    ``piv[c]`` at column ``c``); ``piv[n + r]`` the first column of row ``r``'s nonzeros in ``L``,
    ``piv[2n + r]`` the last in ``U`` (``piv``: 3n entries), so that a sparse matrix eliminates and solves
    over its nonzeros' extent only.  Returns False for an exactly singular matrix."""
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
        last = c
        for j in range(n - 1, c, -1):  # the pivot row's extent
            if a[c * n + j] != 0.0:
                last = j
                break
        inv = 1.0 / a[c * n + c]
        for r in range(c + 1, n):
            ratio = a[r * n + c] * inv
            a[r * n + c] = ratio
            if ratio != 0.0:
                for j in range(c + 1, last + 1):
                    a[r * n + j] -= ratio * a[c * n + j]
    for r in range(n):
        first = r
        for j in range(r):
            if a[r * n + j] != 0.0:
                first = j
                break
        piv[n + r] = first
        last = r
        for j in range(n - 1, r, -1):
            if a[r * n + j] != 0.0:
                last = j
                break
        piv[2 * n + r] = last
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
        for j in range(piv[n + r], r):
            acc -= a[r * n + j] * b[j]
        b[r] = acc
    for r in range(n - 1, -1, -1):
        acc = b[r]
        for j in range(r + 1, piv[2 * n + r] + 1):
            acc -= a[r * n + j] * b[j]
        b[r] = acc / a[r * n + r]


@inline
def _linked(jbuf, ke, i, j):
    """Is state ``i`` coupled with ``j`` in ``J`` (either way)?"""
    return jbuf[i * ke + j] != 0.0 or jbuf[j * ke + i] != 0.0


@inline
def _narrow(jbuf, ke, order, s, scratch):
    """Reorder ``S = order[:s]`` by reverse Cuthill–McKee on the pattern of ``J_SS + J_SSᵀ`` (breadth first from
    a state of least degree, neighbours by increasing degree; then reversed), so that a sparse ``E_SS`` is
    nearly banded and its LU works within the band (``scratch``: 3·ke integers)."""
    deg, new, seen = scratch[0:ke], scratch[ke:2 * ke], scratch[2 * ke:3 * ke]
    for a in range(s):
        d = 0
        for b in range(s):
            if b != a and _linked(jbuf, ke, order[a], order[b]):
                d += 1
        deg[a] = d
        seen[a] = 0
    count = 0
    while count < s:
        start = -1
        for a in range(s):
            if seen[a] == 0 and (start < 0 or deg[a] < deg[start]):
                start = a
        seen[start] = 1
        new[count] = start
        count += 1
        head = count - 1
        while head < count:
            a = new[head]
            head += 1
            first = count
            for b in range(s):
                if seen[b] == 0 and _linked(jbuf, ke, order[a], order[b]):
                    seen[b] = 1
                    new[count] = b
                    count += 1
                    c = count - 1
                    while c > first and deg[new[c - 1]] > deg[new[c]]:
                        new[c - 1], new[c] = new[c], new[c - 1]
                        c -= 1
    for a in range(s):
        deg[a] = order[new[s - 1 - a]]
    for a in range(s):
        order[a] = deg[a]


@inline
def _partition(jbuf, ke, order, ctl, scratch, structural):
    """The states' order: those whose column of ``J`` is not zero (``S``, narrowed: :func:`_narrow`), then the
    others (``Z``); ``|S|`` into ``ctl[2]``; for each row ``order[i]`` of ``Z`` the extent of its nonzeros in
    ``J_ZS`` (positions in ``S``), ``order[ke + i]`` to ``order[2ke + i]`` — from ``jbuf`` when it holds the
    pattern (``structural``), else all of ``S`` (a value may leave 0 later)."""
    s = 0
    z = ke
    for j in range(ke):
        read = False
        for i in range(ke):
            if jbuf[i * ke + j] != 0.0:
                read = True
                break
        if read:
            order[s] = j
            s += 1
        else:
            z -= 1
            order[z] = j
    ctl[2] = s
    _narrow(jbuf, ke, order, s, scratch)
    for i in range(s, ke):
        lo = 0
        hi = s - 1
        if structural:
            lo = s
            hi = -1
            row = order[i] * ke
            for j in range(s):
                if jbuf[row + order[j]] != 0.0:
                    lo = min(lo, j)
                    hi = j
        order[ke + i] = lo
        order[2 * ke + i] = hi


@inline
def _still_zero(jbuf, ke, order, s):
    """Are the columns of ``Z`` (``order[s:]``) still zero in this ``J``?"""
    for i in range(s, ke):
        j = order[i]
        for r in range(ke):
            if jbuf[r * ke + j] != 0.0:
                return False
    return True


@inline
def _factor(jbuf, lu, piv, order, s, ke, factor):
    """The LU factors of ``E_SS = I·factor − J_SS`` (``factor = 1/(γh)``); False when it is singular."""
    for i in range(s):
        row = order[i] * ke
        for j in range(s):
            lu[i * s + j] = -jbuf[row + order[j]]
        lu[i * s + i] += factor
    return lu_factor(lu, piv, s)


@inline
def _solve(jbuf, lu, piv, order, s, ke, gh, v, g):
    """``v ← E⁻¹·v`` by blocks (see the module docstring; ``gh = γh``, ``g`` scratch of ``|S|``)."""
    for i in range(s):
        g[i] = v[order[i]]
    lu_solve(lu, piv, s, g)
    for i in range(s):
        v[order[i]] = g[i]
    for i in range(s, ke):
        z = order[i]
        acc = v[z]
        row = z * ke
        for j in range(order[ke + i], order[2 * ke + i] + 1):
            acc += jbuf[row + order[j]] * g[j]
        v[z] = gh * acc


@dispatch
def jacobian(m, k, t, y, f, M, L, tmp, f1):
    """``J`` at ``(t, y)`` (rates ``f``) into ``L[0]``, and ``f_t`` into ``L[3]`` (0 unless the flow is driven
    by inputs); at the flow's first step the order of the states (from the compiled function's pattern: kept
    for the whole flow; else from ``J``'s values: checked at each step); ``tmp``, ``f1`` scratch."""
    jbuf, fx, order, ctl = L[0], L[3], L[5], L[4]
    ke = y.shape[0]
    if k > 0 and M.jfns[m] != 0:
        if ctl[3] == 0.0:
            jac(m, y, t, M, jbuf, 2)  # the pattern
            _partition(jbuf, ke, order, ctl, L[2], True)
            ctl[3] = 2.0
            jac(m, y, t, M, jbuf, 0)
        else:
            jac(m, y, t, M, jbuf, 1)  # (the other entries hold zeros from the first call)
    else:
        if k == 0:
            jbuf[0] = 0.0
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
        if ctl[3] == 0.0 or not _still_zero(jbuf, ke, order, int(ctl[2])):
            _partition(jbuf, ke, order, ctl, L[2], False)
            ctl[3] = 1.0
    for i in range(ke * ke):
        if not (jbuf[i] - jbuf[i] == 0.0):  # J not finite (√q at q = 0): the explicit step the method can take
            for j in range(ke * ke):
                jbuf[j] = 0.0
            break
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
    for i in range(ke):
        if not (fx[i] - fx[i] == 0.0):  # ∂f/∂t not finite (an input √t at t = 0): the explicit step, as for J
            for j in range(ke):
                fx[j] = 0.0
            break


@inline
def _stages(m, k, t, h, rtol, A, W, L, M):
    """The six stages of a step of size ``h`` (``E_SS``'s LU factors in ``L[1]``) into ``K[0:6]``, ``y₁``
    into ``y_new``; returns the error norm."""
    y, f, y_new, f_new, Q = A
    tmp, err, K = W
    jbuf, lu, piv, fx, ctl, order = L
    ke = y.shape[0]
    s = int(ctl[2])
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
        _solve(jbuf, lu, piv, order, s, ke, GAMMA * h, K[st], err)
    total = 0.0
    for c in range(ke):
        y_new[c] = tmp[c] + K[5, c]
        sc = state_atol(M, m, c) + max(abs(y[c]), abs(y_new[c])) * rtol
        total += (K[5, c] / sc) * (K[5, c] / sc)
    return math.sqrt(total / ke)


@inline
def _damped_motion(jbuf, ke, gh, y, y_new, rtol, M, m):
    """``‖(I − γh·J)·Δ‖`` (root mean square, each state over ``atol + rtol·max(|y|, |y₁|)``) of the step's
    motion ``Δ = y₁ − y`` with the Jacobian ``J`` in ``jbuf``: how much the implicit stages damp that motion."""
    total = 0.0
    for i in range(ke):
        acc = y_new[i] - y[i]
        for j in range(ke):
            acc -= gh * jbuf[i * ke + j] * (y_new[j] - y[j])
        sc = state_atol(M, m, i) + max(abs(y[i]), abs(y_new[i])) * rtol
        total += (acc / sc) * (acc / sc)
    return math.sqrt(total / max(ke, 1))


@dispatch
def rosenbrock_step(m, k, t, t_end, h_abs, rtol, max_step, A, W, L, M):
    """One accepted RODAS4P step from ``(t, y)``, trying ``h_abs`` first (see the module docstring): ``y₁``
    in ``y_new`` with its rates ``f_new``, the continuous extension's coefficients in ``Q``.  Returns ``(ok,
    t_new, h, h_abs)``: not ok when the step size collapsed, or (``h_abs`` NaN) when the error is not a number;
    ``h_abs`` the size to try next."""
    y, f, y_new, f_new, Q = A
    tmp, err, K = W
    jbuf, lu, piv, fx, ctl, order = L
    ke = y.shape[0]
    min_step = max(10 * abs(np.nextafter(t, np.inf) - t), _MIN_IMPLICIT_STEP)
    h_abs = min(h_abs, max_step)
    h_abs = max(h_abs, min_step)
    if not t < t_end:  # a flow asked to go nowhere (t_end on an instant, a PWM edge): a step of length 0
        for c in range(ke):
            y_new[c] = y[c]
            f_new[c] = f[c]
            Q[c, 0] = 0.0
            Q[c, 1] = 0.0
        return True, t_end, 0.0, h_abs
    if ctl[4] == 0.0:
        jacobian(m, k, t, y, f, M, L, tmp, f_new)
    ctl[4] = 0.0
    rejected = False
    left_reals = False  # the last trial left the reals: a collapse then reports NaN (a law left its domain)
    h = 0.0
    while True:
        if h_abs < min_step:
            return False, t, h, np.nan if left_reals else h_abs
        t_new = t + h_abs
        if t_new - t_end > 0:
            t_new = t_end
        h = t_new - t
        h_abs = abs(h)
        factored = _factor(jbuf, lu, piv, order, int(ctl[2]), ke, 1.0 / (GAMMA * h))
        error = _stages(m, k, t, h, rtol, A, W, L, M) if factored else np.inf
        if error != error:
            if not finite(f):  # NaN rates where the step starts: never loop on
                return False, t, h, np.nan
            rejected = True  # a stage left the reals (an exponential law overflowing): a shorter step
            left_reals = True
            h_abs *= 0.2
            continue
        left_reals = False
        h_next, h_acc, err_acc = rodas_control(error, h_abs, ctl[0], ctl[1], rejected)
        if error <= 1.0:
            fun(m, t_new, y_new, k, M, f_new)
            start = _damped_motion(jbuf, ke, GAMMA * h, y, y_new, rtol, M, m)
            jacobian(m, k, t_new, y_new, f_new, M, L, tmp, err)
            end = _damped_motion(jbuf, ke, GAMMA * h, y, y_new, rtol, M, m)
            if start > 1.0 and start > DAMPING_RATIO * end:  # (NaN compares False: the step stands)
                jacobian(m, k, t, y, f, M, L, tmp, f_new)
                rejected = True
                h_abs *= max(0.1, min(0.5, DAMPING_RATIO * end / start))
                continue
            ctl[4] = 1.0  # J and f_t at (t_new, y_new): the next step's
            ctl[0] = h_acc
            ctl[1] = err_acc
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
