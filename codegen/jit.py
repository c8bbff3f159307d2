"""The compiled fast path: numba-compiled flow kernels (optional extra ``fast``).

For one mode, :func:`jit_module` takes the generated Python source of its
``phi`` (dependent states), ``rates`` and ``sides`` (guard comparison sides),
plus the guards as trees of comparisons, and writes one module in which they
are ``@njit(cache=True)`` functions next to three flow kernels:

``flow_euler``, ``flow_rk4``, ``flow_rk45``
    integrate the independent states from ``t0`` until ``t_end`` or until a
    guard holds, entirely in compiled code: stepping, testing the guards at
    interior points of every step and at its end, and locating the first
    time a guard holds by bisection on the step's interpolant down to
    adjacent floating-point numbers.  Arguments are arrays and floats only.
    ``flow_rk45`` is scipy's RK45 (Dormand–Prince 5(4), same initial step
    selection, error norm, step-size factors and dense output), so both give
    the same steps up to round-off.

Each returns ``(status, n_saved, t, x, steps)``; status 0: reached ``t_end``,
1: a guard holds at ``t`` (``x`` is the state there), 2: the output buffer
is full (call again from ``t``), 3: the step size collapsed, 4: non-finite
state.  Accepted steps are written to ``out_t``/``out_x`` when ``save`` is true.

The module is written to the cache directory and imported from there, so
numba's own on-disk cache applies: a second process loads the machine code
instead of compiling it.
"""

from __future__ import annotations

import importlib.util
import os
import sys
import tempfile
from pathlib import Path

__all__ = ["available", "jit_module", "tree_expression"]

_RK45 = {
    "C": [0.0, 0.2, 0.3, 0.8, 8 / 9, 1.0],
    "A": [
        [0.0, 0.0, 0.0, 0.0, 0.0],
        [1 / 5, 0.0, 0.0, 0.0, 0.0],
        [3 / 40, 9 / 40, 0.0, 0.0, 0.0],
        [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0],
        [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0],
        [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
    ],
    "B": [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84],
    "E": [-71 / 57600, 0.0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40],
}


def available() -> bool:
    """Is numba installed (``pip install .[fast]``)?"""
    return importlib.util.find_spec("numba") is not None


def tree_expression(tree) -> str:
    """Python/numba source deciding a guard tree on the sides array ``s``."""
    kind = tree[0]
    if kind == "const":
        return "True" if tree[1] else "False"
    if kind in ("and", "or"):
        return "(" + f" {kind} ".join(tree_expression(t) for t in tree[1]) + ")"
    if kind == "not":
        return f"(not {tree_expression(tree[1])})"
    _, k, op, _text = tree
    name = {"<": "_lt", "<=": "_le", ">": "_gt", ">=": "_ge", "==": "_eq", "!=": "_ne"}[op]
    return f"{name}(s[{2 * k}], s[{2 * k + 1}], rtol, atol)"


_HEADER = '''"""Compiled flow kernels of one mode (generated; do not edit)."""
import math
from math import *
import numpy as np
from numba import njit

'''

_COMPARE = '''
@njit(cache=True)
def _band(a, b, rtol, atol):
    return rtol * max(abs(a), abs(b)) + atol


@njit(cache=True)
def _le(a, b, rtol, atol):
    return a - b <= _band(a, b, rtol, atol)


@njit(cache=True)
def _lt(a, b, rtol, atol):
    return a - b < -_band(a, b, rtol, atol)


@njit(cache=True)
def _ge(a, b, rtol, atol):
    return a - b >= -_band(a, b, rtol, atol)


@njit(cache=True)
def _gt(a, b, rtol, atol):
    return a - b > _band(a, b, rtol, atol)


@njit(cache=True)
def _eq(a, b, rtol, atol):
    return abs(a - b) <= _band(a, b, rtol, atol)


@njit(cache=True)
def _ne(a, b, rtol, atol):
    return abs(a - b) > _band(a, b, rtol, atol)
'''

_KERNELS = '''
@njit(cache=True)
def _full(y, t, template, ind, dep, p, u, z, dbuf):
    for i in range(z.shape[0]):
        z[i] = template[i]
    for i in range(ind.shape[0]):
        z[ind[i]] = y[i]
    if dep.shape[0] > 0:
        phi(z, t, p, u, dbuf)
        for i in range(dep.shape[0]):
            z[dep[i]] = dbuf[i]


@njit(cache=True)
def _fun(t, y, template, ind, dep, p, u, z, dbuf, r, out):
    _full(y, t, template, ind, dep, p, u, z, dbuf)
    rates(z, t, p, u, r)
    for i in range(ind.shape[0]):
        out[i] = r[ind[i]]


@njit(cache=True)
def _holds_at(y, t, template, ind, dep, p, u, z, dbuf, s, rtol, atol):
    _full(y, t, template, ind, dep, p, u, z, dbuf)
    return holds(z, t, p, u, s, rtol, atol)


@njit(cache=True)
def _pack(y, t, template, ind, dep, p, u, z, dbuf, x_out):
    """The full state (dependent entries completed) into ``x_out``."""
    _full(y, t, template, ind, dep, p, u, z, dbuf)
    for i in range(z.shape[0]):
        x_out[i] = z[i]


@njit(cache=True)
def _finite(v):
    for i in range(v.shape[0]):
        if not np.isfinite(v[i]):
            return False
    return True


@njit(cache=True)
def _rms(v):
    acc = 0.0
    for i in range(v.shape[0]):
        acc += v[i] * v[i]
    return math.sqrt(acc / v.shape[0]) if v.shape[0] > 0 else 0.0


@njit(cache=True)
def _save(out_t, out_x, n_saved, t, y, template, ind, dep, p, u, z, dbuf):
    _full(y, t, template, ind, dep, p, u, z, dbuf)
    out_t[n_saved] = t
    for i in range(z.shape[0]):
        out_x[n_saved, i] = z[i]


@njit(cache=True)
def _hermite(y0, f0, y1, f1, h, theta, out):
    h00 = 2 * theta**3 - 3 * theta**2 + 1
    h10 = theta**3 - 2 * theta**2 + theta
    h01 = -2 * theta**3 + 3 * theta**2
    h11 = theta**3 - theta**2
    for i in range(out.shape[0]):
        out[i] = h00 * y0[i] + h10 * h * f0[i] + h01 * y1[i] + h11 * h * f1[i]


@njit(cache=True)
def _linear(y0, f0, dt, out):
    for i in range(out.shape[0]):
        out[i] = y0[i] + dt * f0[i]


@njit(cache=True)
def _rk45_dense(y_old, Q, h, theta, out):
    # scipy's RkDenseOutput: y_old + h * Q @ [theta, theta^2, theta^3, theta^4]
    for i in range(out.shape[0]):
        acc = 0.0
        pw = 1.0
        for j in range(Q.shape[1]):
            pw *= theta
            acc += Q[i, j] * pw
        out[i] = y_old[i] + h * acc


@njit(cache=True)
def _interp(kind, t_old, h, y_old, f_old, y_new, f_new, Q, tau, out):
    if kind == 0:
        _linear(y_old, f_old, tau - t_old, out)
    elif kind == 1:
        _hermite(y_old, f_old, y_new, f_new, h, (tau - t_old) / h, out)
    else:
        _rk45_dense(y_old, Q, h, (tau - t_old) / h, out)


@njit(cache=True)
def _event_in_step(kind, t_old, t_new, h, y_old, f_old, y_new, f_new, Q, template, ind, dep, p, u, z, dbuf, s,
                   rtol, atol, samples, tmp):
    """First time in (t_old, t_new] a guard holds, or -1.0 (same rule as the Python driver)."""
    a = t_old
    b = -1.0
    for j in range(1, samples + 1):
        tau = t_old + (t_new - t_old) * j / (samples + 1)
        _interp(kind, t_old, h, y_old, f_old, y_new, f_new, Q, tau, tmp)
        if _holds_at(tmp, tau, template, ind, dep, p, u, z, dbuf, s, rtol, atol):
            b = tau
            break
        a = tau
    if b < 0.0:
        if _holds_at(y_new, t_new, template, ind, dep, p, u, z, dbuf, s, rtol, atol):
            b = t_new
        else:
            return -1.0
    for _ in range(200):
        mid = 0.5 * (a + b)
        if mid <= a or mid >= b:
            break
        _interp(kind, t_old, h, y_old, f_old, y_new, f_new, Q, mid, tmp)
        if _holds_at(tmp, mid, template, ind, dep, p, u, z, dbuf, s, rtol, atol):
            b = mid
        else:
            a = mid
    return b


@njit(cache=True)
def _finish_event(kind, t_old, t_new, h, y_old, f_old, y_new, f_new, Q, t_ev, template, ind, dep, p, u, z, dbuf, tmp,
                  x_out):
    # the state the guard was seen to hold on: the step's end itself, or the interpolant
    if t_ev == t_new:
        for i in range(tmp.shape[0]):
            tmp[i] = y_new[i]
    else:
        _interp(kind, t_old, h, y_old, f_old, y_new, f_new, Q, t_ev, tmp)
    _full(tmp, t_ev, template, ind, dep, p, u, z, dbuf)
    for i in range(z.shape[0]):
        x_out[i] = z[i]


@njit(cache=True)
def _end_of_step(kind, t, t_new, t_end, h, y, f, y_new, f_new, Q, template, ind, dep, p, u, z, dbuf, s, rtol_g,
                 atol_g, samples, tmp, x_out, save, out_t, out_x, n_saved):
    """After an accepted step: stop at an event (code 1, ``x_out`` its state),
    else take the step (``y``, ``f`` updated, saved if asked) and stop at
    ``t_end`` (0) or a full buffer (2); code −1: go on.  Returns
    ``(code, n_saved, t)``."""
    if N_SIDES > 0:
        t_ev = _event_in_step(kind, t, t_new, h, y, f, y_new, f_new, Q, template, ind, dep, p, u, z, dbuf, s,
                              rtol_g, atol_g, samples, tmp)
        if t_ev >= 0.0:
            _finish_event(kind, t, t_new, h, y, f, y_new, f_new, Q, t_ev, template, ind, dep, p, u, z, dbuf, tmp, x_out)
            return 1, n_saved, t_ev
    for i in range(y.shape[0]):
        y[i] = y_new[i]
        f[i] = f_new[i]
    if save:
        _save(out_t, out_x, n_saved, t_new, y, template, ind, dep, p, u, z, dbuf)
        n_saved += 1
    if t_new >= t_end:
        _pack(y, t_new, template, ind, dep, p, u, z, dbuf, x_out)
        return 0, n_saved, t_new
    if save and n_saved >= out_t.shape[0]:
        _pack(y, t_new, template, ind, dep, p, u, z, dbuf, x_out)
        return 2, n_saved, t_new
    return -1, n_saved, t_new


@njit(cache=True)
def flow_fixed(kind, x0, t0, t_end, dt, p, u, ind, dep, rtol_g, atol_g, samples, save, out_t, out_x, max_steps):
    """Euler (kind 0) or classical RK4 (kind 1) with step dt until t_end or an event."""
    n = x0.shape[0]
    k = ind.shape[0]
    template = x0.copy()
    z = np.empty(n)
    dbuf = np.empty(max(dep.shape[0], 1))
    r = np.empty(n)
    s = np.empty(N_SIDES)
    y = np.empty(k)
    for i in range(k):
        y[i] = x0[ind[i]]
    f = np.empty(k)
    _fun(t0, y, template, ind, dep, p, u, z, dbuf, r, f)
    k2 = np.empty(k)
    k3 = np.empty(k)
    k4 = np.empty(k)
    tmp = np.empty(k)
    y_new = np.empty(k)
    f_new = np.empty(k)
    Q = np.empty((k, 4))
    x_out = np.empty(n)
    t = t0
    n_saved = 0
    steps = 0
    while steps < max_steps:
        h = min(dt, t_end - t)
        t_new = t + h if t + h < t_end else t_end
        if kind == 0:
            for i in range(k):
                y_new[i] = y[i] + h * f[i]
        else:
            for i in range(k):
                tmp[i] = y[i] + h / 2 * f[i]
            _fun(t + h / 2, tmp, template, ind, dep, p, u, z, dbuf, r, k2)
            for i in range(k):
                tmp[i] = y[i] + h / 2 * k2[i]
            _fun(t + h / 2, tmp, template, ind, dep, p, u, z, dbuf, r, k3)
            for i in range(k):
                tmp[i] = y[i] + h * k3[i]
            _fun(t + h, tmp, template, ind, dep, p, u, z, dbuf, r, k4)
            for i in range(k):
                y_new[i] = y[i] + h / 6 * (f[i] + 2 * k2[i] + 2 * k3[i] + k4[i])
        steps += 1
        _fun(t_new, y_new, template, ind, dep, p, u, z, dbuf, r, f_new)
        if not _finite(y_new):
            _pack(y, t, template, ind, dep, p, u, z, dbuf, x_out)
            return 4, n_saved, t_new, x_out, steps
        code, n_saved, t = _end_of_step(kind, t, t_new, t_end, h, y, f, y_new, f_new, Q, template, ind, dep, p, u, z,
                                        dbuf, s, rtol_g, atol_g, samples, tmp, x_out, save, out_t, out_x, n_saved)
        if code >= 0:
            return code, n_saved, t, x_out, steps
    _pack(y, t, template, ind, dep, p, u, z, dbuf, x_out)
    return 2, n_saved, t, x_out, steps


@njit(cache=True)
def flow_rk45(x0, t0, t_end, rtol, atol, max_step, p, u, ind, dep, rtol_g, atol_g, samples, save, out_t, out_x,
              max_steps):
    """scipy's RK45 (Dormand–Prince 5(4)) until t_end or an event."""
    n = x0.shape[0]
    k = ind.shape[0]
    template = x0.copy()
    z = np.empty(n)
    dbuf = np.empty(max(dep.shape[0], 1))
    r = np.empty(n)
    s = np.empty(N_SIDES)
    y = np.empty(k)
    for i in range(k):
        y[i] = x0[ind[i]]
    K = np.zeros((7, k))
    f = np.empty(k)
    _fun(t0, y, template, ind, dep, p, u, z, dbuf, r, f)
    tmp = np.empty(k)
    y_new = np.empty(k)
    f_new = np.empty(k)
    Q = np.empty((k, 4))
    x_out = np.empty(n)
    # scipy.integrate._ivp.common.select_initial_step (order 4)
    interval = abs(t_end - t0)
    if k == 0:
        h_abs = interval
    else:
        d0 = 0.0
        d1 = 0.0
        for i in range(k):
            sc = atol + abs(y[i]) * rtol
            d0 += (y[i] / sc) ** 2
            d1 += (f[i] / sc) ** 2
        d0 = math.sqrt(d0 / k)
        d1 = math.sqrt(d1 / k)
        if d0 < 1e-5 or d1 < 1e-5:
            h0 = 1e-6
        else:
            h0 = 0.01 * d0 / d1
        h0 = min(h0, interval)
        for i in range(k):
            tmp[i] = y[i] + h0 * f[i]
        _fun(t0 + h0, tmp, template, ind, dep, p, u, z, dbuf, r, f_new)
        d2 = 0.0
        for i in range(k):
            sc = atol + abs(y[i]) * rtol
            d2 += ((f_new[i] - f[i]) / sc) ** 2
        d2 = math.sqrt(d2 / k) / h0
        if d1 <= 1e-15 and d2 <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / max(d1, d2)) ** (1 / 5)
        h_abs = min(100 * h0, h1, interval, max_step)
    t = t0
    n_saved = 0
    steps = 0
    err = np.empty(k)
    while steps < max_steps:
        min_step = 10 * abs(np.nextafter(t, np.inf) - t)
        if h_abs > max_step:
            h_abs = max_step
        elif h_abs < min_step:
            h_abs = min_step
        accepted = False
        rejected = False
        while not accepted:
            if h_abs < min_step:
                _pack(y, t, template, ind, dep, p, u, z, dbuf, x_out)
                return 3, n_saved, t, x_out, steps
            h = h_abs
            t_new = t + h
            if t_new - t_end > 0:
                t_new = t_end
            h = t_new - t
            h_abs = abs(h)
            for i in range(k):
                K[0, i] = f[i]
            for st in range(1, 6):
                for i in range(k):
                    acc = 0.0
                    for j in range(st):
                        acc += K[j, i] * RK_A[st, j]
                    tmp[i] = y[i] + acc * h
                _fun(t + RK_C[st] * h, tmp, template, ind, dep, p, u, z, dbuf, r, f_new)
                for i in range(k):
                    K[st, i] = f_new[i]
            for i in range(k):
                acc = 0.0
                for j in range(6):
                    acc += K[j, i] * RK_B[j]
                y_new[i] = y[i] + h * acc
            _fun(t + h, y_new, template, ind, dep, p, u, z, dbuf, r, f_new)
            for i in range(k):
                K[6, i] = f_new[i]
            for i in range(k):
                acc = 0.0
                for j in range(7):
                    acc += K[j, i] * RK_E[j]
                sc = atol + max(abs(y[i]), abs(y_new[i])) * rtol
                err[i] = acc * h / sc
            error_norm = _rms(err)
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
        steps += 1
        if not _finite(y_new):
            _pack(y, t, template, ind, dep, p, u, z, dbuf, x_out)
            return 4, n_saved, t_new, x_out, steps
        for i in range(k):
            for j in range(4):
                acc = 0.0
                for m in range(7):
                    acc += K[m, i] * RK_P[m, j]
                Q[i, j] = acc
        code, n_saved, t = _end_of_step(2, t, t_new, t_end, h, y, f, y_new, f_new, Q, template, ind, dep, p, u, z,
                                        dbuf, s, rtol_g, atol_g, samples, tmp, x_out, save, out_t, out_x, n_saved)
        if code >= 0:
            return code, n_saved, t, x_out, steps
    _pack(y, t, template, ind, dep, p, u, z, dbuf, x_out)
    return 2, n_saved, t, x_out, steps
'''


def _decorated(source: str) -> str:
    """Put ``@njit(cache=True)`` on every top-level function of generated source."""
    lines = []
    for line in source.splitlines():
        if line.startswith("def "):
            lines.append("@njit(cache=True)")
        lines.append(line)
    return "\n".join(lines) + "\n"


def jit_source(functions_source: str, guard_trees, n_sides: int) -> str:
    """The whole compiled module's source for one mode."""
    import numpy as np
    from scipy.integrate._ivp.rk import RK45

    holds = ["@njit(cache=True)", "def holds(x, t, p, u, s, rtol, atol):"]
    if n_sides:
        holds.append("    sides(x, t, p, u, s)")
    holds.append("    return " + (" or ".join(tree_expression(t) for t in guard_trees) or "False"))
    constants = [
        f"N_SIDES = {n_sides}",
        f"RK_C = np.array({_RK45['C']!r})",
        f"RK_A = np.array({_RK45['A']!r})",
        f"RK_B = np.array({_RK45['B']!r})",
        f"RK_E = np.array({_RK45['E']!r})",
        f"RK_P = np.array({np.asarray(RK45.P).tolist()!r})",
    ]
    return (
        _HEADER
        + "\n".join(constants)
        + "\n\n"
        + _COMPARE
        + "\n\n"
        + _decorated(functions_source)
        + "\n\n"
        + "\n".join(holds)
        + "\n\n"
        + _KERNELS
    )


def jit_module(key: str, functions_source: str, guard_trees, n_sides: int, directory: str | os.PathLike | None):
    """Write the compiled module for one mode under ``directory`` (a private
    temporary directory if ``None``) and import it."""
    if not available():
        raise ImportError("the compiled methods need numba: pip install '.[fast]' (or pip install numba)")
    source = jit_source(functions_source, guard_trees, n_sides)
    directory = Path(directory) if directory else Path(tempfile.gettempdir()) / "hbg-jit"
    directory.mkdir(parents=True, exist_ok=True)
    name = f"hbg_jit_{key}"
    path = directory / f"{name}.py"
    if not path.exists() or path.read_text() != source:
        fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{name}.", suffix=".tmp")
        with os.fdopen(fd, "w") as handle:
            handle.write(source)
        os.replace(tmp, path)
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
