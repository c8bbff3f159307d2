"""The compiled fast path: one numba module per model and set of modes
(optional extra ``fast``).

:mod:`switching.jit_model` generates, for every covered mode ``i``, the
functions ``fy_i``, ``sy_i``, ``phi_i``, ``sides_i``, ``post_i``,
``jump_i``, ``holds_i`` and ``fire_i`` and dispatchers ``_fy(m, …)``,
``_phi(m, …)``, ``_holds(m, …)``, ``_jump(m, …)``, ``_fire(m, …)`` that
select them by mode number.  This module supplies the rest of that module's source: the
comparison rules (:data:`COMPARE_SOURCE`) and the kernel
(:data:`KERNEL_SOURCE`) whose entry point ``run`` integrates a whole hybrid
run in compiled code:

* the flow in the current mode — Euler (kind 0), classical RK4 (kind 1) with
  fixed ``dt``, or scipy's RK45 (kind 2: Dormand–Prince 5(4) with scipy's
  initial step, error norm, step factors and dense output, so both take the
  same steps up to round-off);
* at every accepted step, event detection as the Python path's
  ``switching.events._GuardScan``: the guards at ``samples`` interior
  points and at the step's end; besides, a guard holding only between two
  points — a comparison part whose margin has an extremum between points
  within reach of its threshold (parabola through three points, the
  previous step's last point included, refined by Brent's method on the
  interpolant), or two or more parts of one guard changing truth between
  two points (each change bisected, the guards tested just after each);
  the first time a guard holds located by bisection on the step's
  interpolant down to adjacent floating-point numbers;
* the instant's resolution (the paper's selMode, DESIGN §6) through mythical
  modes and pinnacles: ``x⁺ = g_β(x)``, a posteriori guards on ``x⁺`` with
  the impulses ``Σ_k ∂side/∂ẋ_k · Δx_k`` of the jump, the next mode from the
  fired automata;
* the restart in the mode reached.

Whatever needs more than that — a mode outside the covered set, a numerical
(nonlinear) jump map, a pulse in a side that is not affine in ``ẋ``, a mode
repeating in a mythical chain or a pinnacle repeating its state (a divergence
of time, which Python reports in full), the cap on steps per instant — stops
the kernel with status ``RESOLVE`` and the a priori state, and Python resolves
that instant (deterministically, so the results are the same).

``run`` returns ``(status, n_saved, n_events, t, mode, steps)`` and writes the state
``x`` where it stopped into ``info[5:]``; status
``DONE`` 0: reached ``t_end``; ``FULL`` 2: an output buffer is full (call
again from ``t, mode, x``); ``COLLAPSED`` 3: the step size collapsed;
``NONFINITE`` 4; ``RESOLVE`` 5: an event at ``t`` needs Python (``x`` a
priori); ``STIFF`` 6: the stiffness tests of :mod:`switching.integrators`
fired — RK45: Hairer's, ``h·ρ > 3.25`` on 15 accepted steps without 6 calm
ones between, ``ρ ≈ ‖k₇ − k₆‖ / ‖y₇ − y₆‖``, when the rest of the flow would
take more than 1e4 steps at that step size; rk4 and Euler: ``|h·λ|`` from
differences of ``f`` beyond 2.78 or 2 on 3 steps in a row or once by 25 % —
``info`` gets ``|h·λ|``, ``h``, —, the limit and the dominant component; ``WORKSPACE`` 7: the
workspaces ``wf, wi, wb`` are smaller than ``workspace_sizes`` says (nothing ran).  With ``resolve_first`` the
instant at ``t0`` is resolved before the first flow (recorded as an event if
it passed more than one mode; ``info[2] = 1`` then).

The module is written to the cache directory (``jit/`` in it) and imported
from there, so numba's own on-disk cache applies: a second process loads
machine code instead of compiling it (:func:`load_module`).  That cache
cannot fail a run: unreadable ``.nbi``/``.nbc`` files are deleted and the
functions compiled again, and a cache directory that cannot be written sends
the module to a private temporary directory (compiled in every process),
each with a :class:`codegen.cache.CacheWarning`.  The size cap and
least-recently-used eviction of :mod:`codegen.cache` cover these files too.
"""

from __future__ import annotations

import atexit
import functools
import importlib.util
import os
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

from .cache import CacheWarning, warn_not_writable

__all__ = [
    "COMPARE_SOURCE",
    "DISPATCH",
    "INLINE",
    "JIT",
    "KERNEL_SOURCE",
    "STATUS",
    "available",
    "load_module",
    "module_header",
    "tree_expression",
]

STATUS = {0: "done", 2: "full", 3: "collapsed", 4: "nonfinite", 5: "resolve", 6: "stiff", 7: "workspace"}

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

_OP_CODES = {"<": 0, "<=": 1, ">": 2, ">=": 3, "==": 4, "!=": 5}

JIT = "@njit(cache=True, error_model='numpy', no_cpython_wrapper=True, no_cfunc_wrapper=True)"
ENTRY = "@njit(cache=True, error_model='numpy')"  # the one function Python calls
# A call between compiled functions costs ~20-80 ns (reference counting of its array
# arguments, status checks), more than the arithmetic of a small mode: small helpers and the
# per-mode functions are inlined (once each: into the mode dispatchers, which are called and
# run without reference counting); inlining the dispatchers themselves at every call site
# would multiply the compile time by ten.
INLINE = "@njit(cache=True, error_model='numpy', inline='always')"
DISPATCH = "@njit(cache=True, error_model='numpy', _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)"


@functools.cache
def available() -> bool:
    """Is numba installed (``pip install .[fast]``)?"""
    return importlib.util.find_spec("numba") is not None


def tree_expression(tree, finite: str, impulse: str | None = None, offset: int = 0, scale: str | None = None) -> str:
    """Source deciding a guard tree (see :func:`switching.compiled.decide_tree`).

    Comparison ``k`` reads its left/right finite parts and round-off scale
    from ``finite[3k], finite[3k+1], finite[3k+2]`` and, when ``impulse``
    names an array, the sides' impulse areas from ``impulse[offset + 2k],
    impulse[offset + 2k + 1]``; with ``scale`` naming another array of triples,
    the larger of the two scales counts (a priori and a posteriori)."""
    kind = tree[0]
    if kind == "const":
        return "True" if tree[1] else "False"
    if kind in ("and", "or"):
        return "(" + f" {kind} ".join(tree_expression(t, finite, impulse, offset, scale) for t in tree[1]) + ")"
    if kind == "not":
        return f"(not {tree_expression(tree[1], finite, impulse, offset, scale)})"
    _, k, op, _text = tree
    a, b, c = 3 * k, 3 * k + 1, 3 * k + 2
    if impulse is None:
        ia = ib = "0.0"
    else:
        ia, ib = f"{impulse}[{offset + 2 * k}]", f"{impulse}[{offset + 2 * k + 1}]"
    sc = f"{finite}[{c}]" if scale is None else f"_larger({finite}[{c}], {scale}[{c}])"
    return f"_dec({_OP_CODES[op]}, {ia}, {finite}[{a}], {ib}, {finite}[{b}], {sc}, rtol, atol)"


def module_header(title: str) -> str:
    """Imports and constants every generated compiled module starts with."""
    import numpy as np
    from scipy.integrate._ivp.rk import RK45

    return "\n".join([
        f'"""{title} (generated; do not edit)."""',
        "import math",
        "from math import *",
        "import numpy as np",
        "from numba import njit",
        "",
        f"RK_C = np.array({_RK45['C']!r})",
        f"RK_A = np.array({_RK45['A']!r})",
        f"RK_B = np.array({_RK45['B']!r})",
        f"RK_E = np.array({_RK45['E']!r})",
        f"RK_P = np.array({np.asarray(RK45.P).tolist()!r})",
        "",
    ]) + "\n"


# codegen.runtime.decide in compiled form; op: 0 <, 1 <=, 2 >, 3 >=, 4 ==, 5 !=; sides come in triples
# (left, right, round-off scale), switching.compiled
COMPARE_SOURCE = f'''
{INLINE}
def _larger(a, b):
    """The larger of two round-off scales, ignoring a non-finite one."""
    a = a if np.isfinite(a) else 0.0
    b = b if np.isfinite(b) else 0.0
    return a if a > b else b


{INLINE}
def _band(lf, rf, sc, rtol, atol):
    """rtol·max(|lf|, |rf|, sc) + atol, sc counted when finite; 0 when a side is not finite."""
    scale = max(abs(lf), abs(rf))
    if not np.isfinite(scale):
        return 0.0
    if np.isfinite(sc) and sc > scale:
        scale = sc
    return rtol * scale + atol


{INLINE}
def _dec(op, li, lf, ri, rf, sc, rtol, atol):
    impulse = li - ri
    if impulse != 0.0 and abs(impulse) > 1e-6 * max(abs(li), abs(ri)):
        if op <= 1:
            return impulse < 0.0
        if op <= 3:
            return impulse > 0.0
        return op == 5
    diff = lf - rf
    band = _band(lf, rf, sc, rtol, atol)
    if op == 0:
        return diff < -band
    if op == 1:
        return diff <= band
    if op == 2:
        return diff > band
    if op == 3:
        return diff >= -band
    if op == 4:
        return abs(diff) <= band
    return abs(diff) > band
'''

KERNEL_SOURCE = '''
@DISPATCH
def _full(m, y, k, t, template, ind, dep, n_dep, p, u, z, dbuf):
    """The full state of mode m into z: template, independent y, dependent phi."""
    for i in range(z.shape[0]):
        z[i] = template[i]
    for i in range(k):
        z[ind[m, i]] = y[i]
    nd = n_dep[m]
    if nd > 0:
        _phi(m, z, t, p, u, dbuf)
        for i in range(nd):
            z[dep[m, i]] = dbuf[i]


@DISPATCH
def _fun(m, t, y, k, template, ind, dep, n_dep, p, u, z, dbuf, r, out):
    """dy/dt of the independent states (a zero dummy when the mode has none)."""
    if k == 0:
        out[0] = 0.0
        return
    _fy(m, y, t, p, u, out)


@DISPATCH
def _holds_at(m, y, k, t, template, ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol):
    return _holds(m, y, t, p, u, s, rtol, atol)


@INLINE
def _finite(v):
    for i in range(v.shape[0]):
        if not np.isfinite(v[i]):
            return False
    return True


@INLINE
def _rms(v):
    acc = 0.0
    for i in range(v.shape[0]):
        acc += v[i] * v[i]
    return math.sqrt(acc / v.shape[0]) if v.shape[0] > 0 else 0.0


@INLINE
def _argmax_abs(v):
    best = 0
    for i in range(v.shape[0]):
        if abs(v[i]) > abs(v[best]):
            best = i
    return best


@INLINE
def _fixed_stiffness(power4, limit, streak, h, component, info):
    """The fixed-step rule of switching.integrators: |h·λ| = power4^¼ beyond ``limit`` on 3 steps in a row,
    or once 25 % beyond it.  Returns the new streak, or -1 (``info`` filled: stiff)."""
    if power4 <= limit**4:
        return 0
    streak += 1
    h_lambda = power4**0.25
    if streak >= 3 or h_lambda > 1.25 * limit:
        info[0] = h_lambda
        info[1] = h
        info[3] = limit
        info[4] = _argmax_abs(component)
        return -1
    return streak


@INLINE
def _interp(kind, t_old, h, y_old, f_old, y_new, f_new, Q, tau, out):
    """The step's interpolant: linear (Euler), cubic Hermite (RK4), scipy's RK45 dense output."""
    if kind == 0:
        dt = tau - t_old
        for i in range(out.shape[0]):
            out[i] = y_old[i] + dt * f_old[i]
    elif kind == 1:
        theta = (tau - t_old) / h
        h00 = 2 * theta**3 - 3 * theta**2 + 1
        h10 = theta**3 - 2 * theta**2 + theta
        h01 = -2 * theta**3 + 3 * theta**2
        h11 = theta**3 - theta**2
        for i in range(out.shape[0]):
            out[i] = h00 * y_old[i] + h10 * h * f_old[i] + h01 * y_new[i] + h11 * h * f_new[i]
    else:
        theta = (tau - t_old) / h
        for i in range(out.shape[0]):
            acc = 0.0
            pw = 1.0
            for j in range(Q.shape[1]):
                pw *= theta
                acc += Q[i, j] * pw
            out[i] = y_old[i] + h * acc


# event detection (switching.events._GuardScan): the points of a step are slots of the arrays
# ptau [slots], pmg [slots, parts] (margins), ptr [slots, parts] (truths), phd [slots] (a guard holds);
# slot 0: the flow's last point (the step's start), 1: the previous step's point before its end,
# 2: the bisection's last point not holding, 3: unused, 4: a hold found between the changes of parts,
# 5: scratch, 6…: the step's points
_S_START = 0
_S_BEFORE = 1
_S_INSIDE = 4
_S_SCRATCH = 5
_S_STEP = 6
_OVERSHOOT = 3.0  # as switching.events._OVERSHOOT


@INLINE
def _parts(slot, tau, hd, m, s, rtol, atol, prel, psign, pinc, npart, ptau, pmg, ptr, phd):
    """A point into ``slot``: the margins and truths of the parts from the sides ``s`` (the band rule of
    ``_dec``; as switching.events._GuardForm), the time and whether a guard holds (``hd``)."""
    for i in range(npart[m]):
        r = prel[m, i]
        left = s[3 * r]
        right = s[3 * r + 1]
        d = left - right
        band = _band(left, right, s[3 * r + 2], rtol, atol)
        sign = psign[m, i]
        if sign == 0:
            pmg[slot, i] = 0.0
            ptr[slot, i] = abs(d) > band
        else:
            mg = (d if sign > 0 else -d) + (band if pinc[m, i] != 0 else -band)
            pmg[slot, i] = mg
            ptr[slot, i] = mg >= 0.0 if pinc[m, i] != 0 else mg > 0.0
    ptau[slot] = tau
    phd[slot] = hd
    return hd


@DISPATCH
def _point(slot, tau, at, yv, kind, m, k, t_old, h, y_old, f_old, y_new, f_new, Q, template, ind, dep, n_dep, p, u,
           z, dbuf, s, rtol, atol, tmp, prel, psign, pinc, npart, ptau, pmg, ptr, phd):
    """The guards at ``tau`` into ``slot``: on ``yv`` if ``at`` (a step's end, a flow's start), else on the
    interpolant.  Returns whether a guard holds.  (Callers pass np.int64/np.bool_ constants: a literal
    argument would compile a specialisation of this function per value.)"""
    if at:
        hd = _holds_at(m, yv, k, tau, template, ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol)
    else:
        _interp(kind, t_old, h, y_old, f_old, y_new, f_new, Q, tau, tmp)
        hd = _holds_at(m, tmp, k, tau, template, ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol)
    return _parts(slot, tau, hd, m, s, rtol, atol, prel, psign, pinc, npart, ptau, pmg, ptr, phd)


@INLINE
def _differ(a, b, count, ptr):
    """Do the points in slots a and b differ in a part's truth?"""
    for i in range(count):
        if ptr[a, i] != ptr[b, i]:
            return True
    return False


@INLINE
def _copy_point(src, dst, ptau, pmg, ptr, phd):
    ptau[dst] = ptau[src]
    phd[dst] = phd[src]
    for i in range(pmg.shape[1]):
        pmg[dst, i] = pmg[src, i]
        ptr[dst, i] = ptr[src, i]


@INLINE
def _parabola_peak(t0, t1, t2, m0, m1, m2):
    """``(ok, time, value)`` of the maximum of the parabola through three points (not ok if not concave)."""
    if not (t0 < t1 and t1 < t2):
        return False, 0.0, 0.0
    d1 = (m1 - m0) / (t1 - t0)
    d2 = (m2 - m1) / (t2 - t1)
    curvature = (d2 - d1) / (t2 - t0)
    if not curvature < 0.0:
        return False, 0.0, 0.0
    at = 0.5 * (t0 + t1) - d1 / (2 * curvature)
    return True, at, m0 + d1 * (at - t0) + curvature * (at - t0) * (at - t1)


@DISPATCH
def _event_in_step(kind, m, k, t_old, t_new, h, y_old, f_old, y_new, f_new, Q, template, ind, dep, n_dep, p, u, z,
                   dbuf, s, rtol, atol, samples, tmp, prel, psign, pinc, pguard, npart, nguard, ptau, pmg, ptr, phd,
                   order, ext, iscr, fscr, q, scan):
    """First time in (t_old, t_new] a guard holds, or -1.0: switching.events._GuardScan.first_hold (the
    sample points, refined extrema of the parts' margins, holds between parts changing truth) and _locate.
    ``scan[0]``: the previous step's point before its end is in slot 1 (reset at every flow start)."""
    if nguard[m] == 0:
        return -1.0
    P = npart[m]
    nxt = _S_STEP
    order[0] = _S_START
    cnt = 1
    last = -1
    span = t_new - t_old
    for j in range(1, samples + 1):
        tau = t_old + span * j / (samples + 1)
        if ptau[order[cnt - 1]] < tau and tau < t_new:  # a step of a few ulps has fewer distinct points
            _interp(kind, t_old, h, y_old, f_old, y_new, f_new, Q, tau, tmp)
            hd = _parts(nxt, tau, _holds_at(m, tmp, k, tau, template, ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol),
                        m, s, rtol, atol, prel, psign, pinc, npart, ptau, pmg, ptr, phd)
            order[cnt] = nxt
            cnt += 1
            nxt += 1
            if hd:
                last = cnt - 1
                break
    if last < 0:
        hd = _parts(nxt, t_new, _holds_at(m, y_new, k, t_new, template, ind, dep, n_dep, p, u, z, dbuf, s, rtol,
                                          atol), m, s, rtol, atol, prel, psign, pinc, npart, ptau, pmg, ptr, phd)
        order[cnt] = nxt
        cnt += 1
        nxt += 1
        if hd:
            last = cnt - 1

    # extrema of the parts' margins between points (_GuardScan.extrema)
    first = 0
    count = 0
    if scan[0] != 0:
        ext[0] = _S_BEFORE
        first = 1
        count = 1
    for j in range(cnt):
        ext[count] = order[j]
        count += 1
    total = cnt
    if count >= 3:
        for i in range(P):
            if psign[m, i] == 0:
                continue
            top = pmg[ext[0], i]
            bottom = top
            for j in range(1, count):
                v = pmg[ext[j], i]
                top = max(top, v)
                bottom = min(bottom, v)
            if bottom > 0.0 or top + (1.0 + _OVERSHOOT) * (top - bottom) < 0.0:
                continue  # holds all along, or far from its threshold all along
            for j in range(first, count):
                if ptr[ext[j], i]:
                    continue
                mj = pmg[ext[j], i]
                if 0 < j < count - 1:
                    if not (mj >= pmg[ext[j - 1], i] and mj >= pmg[ext[j + 1], i]):
                        continue
                    c0 = j - 1
                    low = ptau[ext[j - 1]]
                    high = ptau[ext[j + 1]]
                    w0 = -np.inf
                    w1 = np.inf
                    windowed = False
                elif j == count - 1 and last < 0 and mj > pmg[ext[j - 1], i]:  # rising at the step's end
                    c0 = j - 2
                    low = ptau[ext[j - 1]]
                    high = ptau[ext[j]]
                    w0 = ptau[ext[j - 1]]
                    w1 = 2 * ptau[ext[j]] - ptau[ext[j - 1]]
                    windowed = True
                elif j == 0 and mj > pmg[ext[1], i]:  # falling from the flow's start
                    c0 = 0
                    low = ptau[ext[0]]
                    high = ptau[ext[1]]
                    w0 = 2 * ptau[ext[0]] - ptau[ext[1]]
                    w1 = ptau[ext[1]]
                    windowed = True
                else:
                    continue
                a0, a1, a2 = ext[c0], ext[c0 + 1], ext[c0 + 2]
                ok, at, value = _parabola_peak(ptau[a0], ptau[a1], ptau[a2], pmg[a0, i], pmg[a1, i], pmg[a2, i])
                if not ok:
                    continue
                reference = max(pmg[a0, i], max(pmg[a1, i], pmg[a2, i]))
                if windowed and not (w0 < at and at < w1):
                    continue
                if value + _OVERSHOOT * (value - reference) < 0.0:
                    continue
                low = max(low, t_old)
                high = min(high, t_new)
                if not high > low:
                    continue
                tau = _maximize(i, low, high, kind, m, k, t_old, h, y_old, f_old, y_new, f_new, Q, template, ind,
                                dep, n_dep, p, u, z, dbuf, s, rtol, atol, tmp, prel, psign, pinc, npart, ptau, pmg,
                                ptr, phd)
                new = True
                for jj in range(count):
                    if ptau[ext[jj]] == tau:
                        new = False
                for jj in range(cnt, total):
                    if ptau[order[jj]] == tau:
                        new = False
                if new:
                    _point(nxt, tau, np.bool_(False), y_new, kind, m, k, t_old, h, y_old, f_old, y_new, f_new, Q,
                           template, ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol, tmp, prel, psign, pinc, npart,
                           ptau, pmg, ptr, phd)
                    order[total] = nxt
                    total += 1
                    nxt += 1
        if total > cnt:  # the points in time order (stable)
            for j in range(1, total):
                slot = order[j]
                jj = j
                while jj > 0 and ptau[order[jj - 1]] > ptau[slot]:
                    order[jj] = order[jj - 1]
                    jj -= 1
                order[jj] = slot

    # the first hold, or one between the changes of parts (_GuardScan.first_hold)
    lo_a = -1.0
    hi_b = -1.0
    for j in range(1, total):
        a = order[j - 1]
        b = order[j]
        if phd[b]:
            lo, tau = _bisect(a, ptau[b], kind, m, k, t_old, h, y_old, f_old, y_new, f_new, Q, template, ind, dep,
                              n_dep, p, u, z, dbuf, s, rtol, atol, tmp, prel, psign, pinc, npart, ptau, pmg, ptr, phd)
            if lo != a and _differ(a, lo, P, ptr):
                inside = _pieces(a, lo, kind, m, k, t_old, h, y_old, f_old, y_new, f_new, Q, template, ind, dep,
                                 n_dep, p, u, z, dbuf, s, rtol, atol, tmp, prel, psign, pinc, pguard, npart, nguard,
                                 ptau, pmg, ptr, phd, iscr, fscr, q)
                if inside >= 0:
                    lo, tau = _bisect(a, ptau[inside], kind, m, k, t_old, h, y_old, f_old, y_new, f_new, Q, template,
                                      ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol, tmp, prel, psign, pinc, npart,
                                      ptau, pmg, ptr, phd)
            end = b
        else:
            if not _differ(a, b, P, ptr):
                continue
            inside = _pieces(a, b, kind, m, k, t_old, h, y_old, f_old, y_new, f_new, Q, template, ind, dep, n_dep, p,
                             u, z, dbuf, s, rtol, atol, tmp, prel, psign, pinc, pguard, npart, nguard, ptau, pmg, ptr,
                             phd, iscr, fscr, q)
            if inside < 0:
                continue
            lo, tau = _bisect(a, ptau[inside], kind, m, k, t_old, h, y_old, f_old, y_new, f_new, Q, template, ind,
                              dep, n_dep, p, u, z, dbuf, s, rtol, atol, tmp, prel, psign, pinc, npart, ptau, pmg, ptr,
                              phd)
            end = inside
        # verified: tau checked with the guards themselves (else the plain bracket)
        _interp(kind, t_old, h, y_old, f_old, y_new, f_new, Q, tau, tmp)
        if _holds_at(m, tmp, k, tau, template, ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol):
            lo_a = ptau[lo]
            hi_b = tau
        else:
            lo_a = ptau[a]
            hi_b = ptau[end]
        break
    if hi_b < 0.0:
        if total >= 2:
            _copy_point(order[total - 2], _S_BEFORE, ptau, pmg, ptr, phd)
            _copy_point(order[total - 1], _S_START, ptau, pmg, ptr, phd)
            scan[0] = 1
        return -1.0
    # switching.events._locate
    a = lo_a
    b = hi_b
    for _ in range(200):
        mid = 0.5 * (a + b)
        if mid <= a or mid >= b:
            break
        _interp(kind, t_old, h, y_old, f_old, y_new, f_new, Q, mid, tmp)
        if _holds_at(m, tmp, k, mid, template, ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol):
            b = mid
        else:
            a = mid
    return b


@DISPATCH
def _bisect(a, hi, kind, m, k, t_old, h, y_old, f_old, y_new, f_new, Q, template, ind, dep, n_dep, p, u, z, dbuf, s,
            rtol, atol, tmp, prel, psign, pinc, npart, ptau, pmg, ptr, phd):
    """_GuardScan.locate: bisection of (a, hi] (no guard holding at the point ``a``, one at ``hi``) down to
    adjacent floating-point numbers; ``(lo, hi)``, ``lo`` the slot of the last point seen not holding."""
    t_lo = ptau[a]
    for _ in range(200):
        mid = 0.5 * (t_lo + hi)
        if mid <= t_lo or mid >= hi:
            break
        _interp(kind, t_old, h, y_old, f_old, y_new, f_new, Q, mid, tmp)
        if _holds_at(m, tmp, k, mid, template, ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol):
            hi = mid
        else:
            t_lo = mid
    if t_lo == ptau[a]:
        return a, hi
    # the last point not holding, evaluated again (deterministic) for its parts' truths
    lo = 2
    _interp(kind, t_old, h, y_old, f_old, y_new, f_new, Q, t_lo, tmp)
    _parts(lo, t_lo, _holds_at(m, tmp, k, t_lo, template, ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol), m, s, rtol,
           atol, prel, psign, pinc, npart, ptau, pmg, ptr, phd)
    return lo, hi


@DISPATCH
def _pieces(a, b, kind, m, k, t_old, h, y_old, f_old, y_new, f_new, Q, template, ind, dep, n_dep, p, u, z, dbuf, s,
            rtol, atol, tmp, prel, psign, pinc, pguard, npart, nguard, ptau, pmg, ptr, phd, iscr, fscr, q):
    """_GuardScan.pieces: the slot of a point inside (a, b) where a guard holds although it holds at neither
    end, found from parts changing truth in between; -1 if none.  iscr [2·parts], fscr [parts], q [parts]."""
    P = npart[m]
    if not _differ(a, b, P, ptr):
        return -1
    changed = False
    for i in range(P):
        iscr[P + i] = 0
    for g in range(nguard[m]):
        ns = 0
        for i in range(P):
            if pguard[m, i] == g and ptr[a, i] != ptr[b, i]:
                iscr[ns] = i
                ns += 1
        if ns < 2:
            continue
        # possible: can guard g hold for some truth values of the switching parts, the others as at a?
        for i in range(P):
            q[i] = ptr[a, i]
        can = False
        for combination in range(1 << ns):
            for bit in range(ns):
                q[iscr[bit]] = (combination >> bit) & 1 == 1
            if _gparts(m, g, q):
                can = True
                break
        if can:
            changed = True
            for bit in range(ns):
                iscr[P + iscr[bit]] = 1
    if not changed:
        return -1
    nt = 0
    for i in range(P):
        if iscr[P + i] == 0:
            continue
        # switch: the first time after which part i has its truth value at b
        lo = ptau[a]
        hi = ptau[b]
        truth_lo = ptr[a, i]
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if mid <= lo or mid >= hi:
                break
            _point(np.int64(_S_SCRATCH), mid, np.bool_(False), y_new, kind, m, k, t_old, h, y_old, f_old, y_new,
                   f_new, Q, template, ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol, tmp, prel, psign, pinc, npart,
                   ptau, pmg, ptr, phd)
            if ptr[_S_SCRATCH, i] == truth_lo:
                lo = mid
            else:
                hi = mid
        fscr[nt] = hi
        nt += 1
    for j in range(1, nt):  # the times in order
        tau = fscr[j]
        jj = j
        while jj > 0 and fscr[jj - 1] > tau:
            fscr[jj] = fscr[jj - 1]
            jj -= 1
        fscr[jj] = tau
    for j in range(nt):
        tau = fscr[j]
        if j > 0 and tau == fscr[j - 1]:
            continue
        if tau < ptau[b]:
            if _point(np.int64(_S_INSIDE), tau, np.bool_(False), y_new, kind, m, k, t_old, h, y_old, f_old, y_new,
                      f_new, Q, template, ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol, tmp, prel, psign, pinc,
                      npart, ptau, pmg, ptr, phd):
                return _S_INSIDE
    return -1


@DISPATCH
def _maximize(i, a, b, kind, m, k, t_old, h, y_old, f_old, y_new, f_new, Q, template, ind, dep, n_dep, p, u, z, dbuf,
              s, rtol, atol, tmp, prel, psign, pinc, npart, ptau, pmg, ptr, phd):
    """switching.events._maximize on the margin of part i: a maximum on [a, b] (Brent's method: golden
    section with parabolic steps), stopping early where the margin is ≥ 0 (the part holds)."""
    golden = 0.3819660112501051
    x = a + golden * (b - a)
    w = x
    v = x
    _point(np.int64(_S_SCRATCH), x, np.bool_(False), y_new, kind, m, k, t_old, h, y_old, f_old, y_new, f_new, Q,
           template, ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol, tmp, prel, psign, pinc, npart, ptau, pmg, ptr,
           phd)
    fx = -pmg[_S_SCRATCH, i]
    fw = fx
    fv = fx
    if fx <= 0.0:
        return x
    d = 0.0
    e = 0.0
    xtol = 1e-10 * (b - a)
    for _ in range(60):
        middle = 0.5 * (a + b)
        tol1 = 4e-16 * abs(x) + xtol
        tol2 = 2.0 * tol1
        if abs(x - middle) <= tol2 - 0.5 * (b - a):
            break
        use_golden = True
        if abs(e) > tol1:
            r = (x - w) * (fx - fv)
            qq = (x - v) * (fx - fw)
            pp = (x - v) * qq - (x - w) * r
            qq = 2.0 * (qq - r)
            if qq > 0.0:
                pp = -pp
            qq = abs(qq)
            previous = e
            e = d
            if abs(pp) < abs(0.5 * qq * previous) and qq * (a - x) < pp and pp < qq * (b - x):
                d = pp / qq
                uu = x + d
                if uu - a < tol2 or b - uu < tol2:
                    d = tol1 if x < middle else -tol1
                use_golden = False
        if use_golden:
            e = (b - x) if x < middle else (a - x)
            d = golden * e
        uu = x + (d if abs(d) >= tol1 else (tol1 if d > 0 else -tol1))
        _point(np.int64(_S_SCRATCH), uu, np.bool_(False), y_new, kind, m, k, t_old, h, y_old, f_old, y_new, f_new, Q,
               template, ind, dep, n_dep, p, u, z, dbuf, s, rtol, atol, tmp, prel, psign, pinc, npart, ptau, pmg, ptr,
               phd)
        fu = -pmg[_S_SCRATCH, i]
        if fu <= 0.0:
            return uu
        if fu <= fx:
            if uu < x:
                b = x
            else:
                a = x
            v = w
            fv = fw
            w = x
            fw = fx
            x = uu
            fx = fu
        else:
            if uu < x:
                a = uu
            else:
                b = uu
            if fu <= fw or w == x:
                v = w
                fv = fw
                w = uu
                fw = fu
            elif fu <= fv or v == x or v == w:
                v = uu
                fv = fu
    return x


@INLINE
def _pulse(m, x, xp, moved, n_moved, jrtol, jatol, d):
    """x⁺ − x with round-off removed into d (switching.compiled.CompiledMode.pulse); True if all of it was."""
    for i in range(x.shape[0]):
        d[i] = xp[i] - x[i]
    nm = n_moved[m]
    if nm == 0:
        for i in range(x.shape[0]):
            d[i] = 0.0
        return True
    scale = 0.0
    for j in range(nm):
        i = moved[m, j]
        scale = max(scale, abs(x[i]), abs(xp[i]))
    band = jrtol * scale + jatol
    none = True
    for i in range(x.shape[0]):
        if abs(d[i]) <= band:
            d[i] = 0.0
        else:
            none = False
    return none


@INLINE
def _next_code(m, target, mstates, radix):
    code = 0
    for a in range(radix.shape[0]):
        state = target[a] if target[a] >= 0 else mstates[m, a]
        code += state * radix[a]
    return code


@INLINE
def _mode_of(code, codes, code_ids):
    if codes.shape[0] == 0:
        return -1
    j = np.searchsorted(codes, code)
    if j < codes.shape[0] and codes[j] == code:
        return code_ids[j]
    return -1


@JIT
def _resolve(m0, x_in, t, p, u, moved, n_moved, mstates, radix, codes, code_ids, mode_codes, rtol, atol, jrtol,
             jatol, max_instant, s, post, xa, x, xp, d, target, chain, pin_m, pin_x):
    """Resolve the instant from the a priori x_in in mode m0 (switching.resolution).
    Returns the mode reached (its state in xa) and the number of modes passed, or -1: Python must resolve it.
    x, xp, d [n], target [automata], chain [max_instant + 1], pin_m [P], pin_x [P, n]: scratch."""
    n = x_in.shape[0]
    for i in range(n):
        x[i] = x_in[i]
    n_chain = 1
    chain[0] = mode_codes[m0]
    n_pin = 0
    cur = m0
    for passes in range(1, max_instant + 1):
        if cur < 0:
            return -1, 0
        if not _jump(cur, x, t, p, u, xp):
            return -1, 0
        quiet = _pulse(cur, x, xp, moved, n_moved, jrtol, jatol, d) and passes == 1
        for a in range(target.shape[0]):
            target[a] = -1
        if not _fire(cur, x, xp, t, p, u, d, s, post, rtol, atol, target, quiet):
            return -1, 0
        fired = False
        for a in range(target.shape[0]):
            if target[a] >= 0:
                fired = True
        if fired:  # cur was mythical
            code = _next_code(cur, target, mstates, radix)
            for j in range(n_chain):
                if chain[j] == code:
                    return -1, 0  # divergence of time: Python reports the loop
            chain[n_chain] = code
            n_chain += 1
            cur = _mode_of(code, codes, code_ids)
            continue
        for i in range(n):
            x[i] = xp[i]
        if not _finite(x):
            return -1, 0
        for i in range(n):
            d[i] = 0.0
        if not _fire(cur, x, x, t, p, u, d, s, post, rtol, atol, target, True):
            return -1, 0
        fired = False
        for a in range(target.shape[0]):
            if target[a] >= 0:
                fired = True
        if not fired:  # continuous
            for i in range(n):
                xa[i] = x[i]
            return cur, passes
        # a pinnacle; one repeating its state is a divergence of time, reported by Python
        if n_pin == pin_m.shape[0]:
            return -1, 0
        for j in range(n_pin):
            if pin_m[j] == cur:
                same = True
                for i in range(n):
                    if abs(pin_x[j, i] - x[i]) > 1e-300 + 1e-12 * abs(x[i]):
                        same = False
                        break
                if same:
                    return -1, 0
        pin_m[n_pin] = cur
        for i in range(n):
            pin_x[n_pin, i] = x[i]
        n_pin += 1
        code = _next_code(cur, target, mstates, radix)
        n_chain = 1
        chain[0] = code
        cur = _mode_of(code, codes, code_ids)
    return -1, 0


@JIT
def _initial_step(m, k, t0, y, f, t_end, rtol, atol, max_step, template, ind, dep, n_dep, p, u, z, dbuf, r, tmp,
                  f1):
    """scipy.integrate._ivp.common.select_initial_step (order 4)."""
    interval = abs(t_end - t0)
    ke = y.shape[0]
    d0 = 0.0
    d1 = 0.0
    for i in range(ke):
        sc = atol + abs(y[i]) * rtol
        d0 += (y[i] / sc) ** 2
        d1 += (f[i] / sc) ** 2
    d0 = math.sqrt(d0 / ke)
    d1 = math.sqrt(d1 / ke)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, interval)
    for i in range(ke):
        tmp[i] = y[i] + h0 * f[i]
    _fun(m, t0 + h0, tmp, k, template, ind, dep, n_dep, p, u, z, dbuf, r, f1)
    d2 = 0.0
    for i in range(ke):
        sc = atol + abs(y[i]) * rtol
        d2 += ((f1[i] - f[i]) / sc) ** 2
    d2 = math.sqrt(d2 / ke) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1 / 5)
    return min(100 * h0, h1, interval, max_step)


@INLINE
def _layout(n, n_automata, width, samples, max_instant):
    """Sizes of the float, integer and boolean workspaces of a run (see run)."""
    ne = max(n, 1)
    w = max(width, 1)
    slots = _S_STEP + samples + 2 + w * (samples + 3)
    floats = 72 * n + 18 * ne + 3 * max(N_SIDES, 1) + slots * (1 + w) + w
    ints = n_automata + max_instant + 1 + 64 + slots + samples + 4 + 2 * w + 1
    bools = slots * (1 + w) + w
    return floats, ints, bools


@ENTRY
def workspace_sizes(n, samples, max_instant):
    """(floats, integers, booleans) that ``run`` needs in ``wf, wi, wb``."""
    return _layout(n, RADIX.shape[0], TABLES.shape[2], samples, max_instant)


@ENTRY
def run(kind, mode, samples, max_instant, save, max_steps, resolve_first, t0, t_end, dt, rtol, atol, max_step,
        first_step, rtol_g, atol_g, jrtol, jatol, x0, p, u, out_t, out_x, out_m, ev_f, ev_i, info, wf, wi, wb):
    """A hybrid run from ``(t0, mode, x0)`` until ``t_end`` (see the module docstring); arrays and scalars only.

    kind: 0 euler, 1 rk4, 2 RK45; mode: its number; samples: guard samples per step; max_instant: step cap per
          instant; save: save every step (0/1); max_steps: step cap of this call; resolve_first: resolve the
          instant at t0 first (0/1);
    t0, t_end, dt, rtol, atol, max_step, first_step (0: select) [s, -]; rtol_g, atol_g, jrtol, jatol: the
          guards' and the jump's tolerances;
    out_t[N], out_x[N, n], out_m[N]: saved steps; ev_f[E, 1 + 2n]: event time, state before, after;
    ev_i[E, 3]: mode before, mode after, samples saved before it; info[5 + n]: stiffness |h·λ| and h, 1 if the
          first event is the initial instant, stiffness limit, dominant component of y; then the state where
          the call stopped;
    wf, wi, wb: float, integer and boolean workspaces of at least workspace_sizes(n, samples, max_instant).
    The model's tables are this module's constants: TABLES[7, modes, w] independent, dependent and jump-moved
    state indices, the guards' parts (relation, sign, inclusive, guard); LENGTHS[5, modes] the counts of the
    three index rows, of parts and of guards; MSTATES[modes, automata] automaton state numbers; RADIX[automata];
    CODES[3, modes] sorted mode codes, their mode numbers, each mode's code."""
    n = x0.shape[0]
    floats, ints, bools = _layout(n, RADIX.shape[0], TABLES.shape[2], samples, max_instant)
    if wf.shape[0] < floats or wi.shape[0] < ints or wb.shape[0] < bools or info.shape[0] < 5 + n:
        return 7, 0, 0, t0, mode, 0
    m = mode
    save = save != 0
    resolve_first = resolve_first != 0
    ind, n_ind, dep, n_dep, moved, n_moved = TABLES[0], LENGTHS[0], TABLES[1], LENGTHS[1], TABLES[2], LENGTHS[2]
    mstates, radix, codes, code_ids, mode_codes = MSTATES, RADIX, CODES[0], CODES[1], CODES[2]
    prel, psign, pinc, pguard, npart, nguard = TABLES[3], TABLES[4], TABLES[5], TABLES[6], LENGTHS[3], LENGTHS[4]
    ev_t, ev_mb, ev_ma, ev_at = ev_f[:, 0], ev_i[:, 0], ev_i[:, 1], ev_i[:, 2]
    ev_xb, ev_xa = ev_f[:, 1:1 + n], ev_f[:, 1 + n:]
    # (the whole run is this one function: a separate callee would be optimised twice by LLVM, once on its
    # own and again when inlined here, adding seconds of compile time)
    ne = max(n, 1)
    ns = max(N_SIDES, 1)
    width = max(prel.shape[1], 1)
    slots = _S_STEP + samples + 2 + width * (samples + 3)
    for i in range(5):
        info[i] = 0.0
    # the workspaces, carved in the order of _layout's sums; zeroed where a slot may be read before written
    o = 0
    template = wf[o:o + n]
    o += n
    for i in range(n):
        template[i] = x0[i]
    z = wf[o:o + n]
    o += n
    r = wf[o:o + n]
    o += n
    x_out = wf[o:o + n]
    o += n
    xa = wf[o:o + n]
    o += n
    rx = wf[o:o + n]
    o += n
    rxp = wf[o:o + n]
    o += n
    rd = wf[o:o + n]
    o += n
    pin_x = wf[o:o + 64 * n].reshape((64, n))
    o += 64 * n
    dbuf = wf[o:o + ne]
    o += ne
    ybuf = wf[o:o + ne]
    o += ne
    fbuf = wf[o:o + ne]
    o += ne
    tmpbuf = wf[o:o + ne]
    o += ne
    ynbuf = wf[o:o + ne]
    o += ne
    fnbuf = wf[o:o + ne]
    o += ne
    errbuf = wf[o:o + ne]
    o += ne
    zeroed = o
    Kbuf = wf[o:o + 7 * ne].reshape((7, ne))
    o += 7 * ne
    Qbuf = wf[o:o + 4 * ne].reshape((ne, 4))
    o += 4 * ne
    s = wf[o:o + ns]
    o += ns
    post = wf[o:o + 2 * ns]
    o += 2 * ns
    ptau = wf[o:o + slots]
    o += slots
    pmg = wf[o:o + slots * width].reshape((slots, width))
    o += slots * width
    fscr = wf[o:o + width]
    wf[zeroed:o] = 0.0  # K, Q, the sides and the points' slots
    o = 0
    target = wi[o:o + radix.shape[0]]
    o += radix.shape[0]
    chain = wi[o:o + max_instant + 1]
    o += max_instant + 1
    pin_m = wi[o:o + 64]
    o += 64
    order = wi[o:o + slots]
    o += slots
    ext = wi[o:o + samples + 4]
    o += samples + 4
    iscr = wi[o:o + 2 * width]
    o += 2 * width
    scan = wi[o:o + 1]
    scan[0] = 0
    ptr = wb[:slots * width].reshape((slots, width))
    phd = wb[slots * width:slots * (width + 1)]
    q = wb[slots * (width + 1):slots * (width + 1) + width]
    wb[:slots * (width + 1) + width] = False
    t = t0
    n_saved = 0
    n_ev = 0
    steps = 0
    if resolve_first:  # the initial instant: the initial mode may be mythical, or a pinnacle
        m_new, passes = _resolve(m, x0, t, p, u, moved, n_moved, mstates, radix, codes, code_ids, mode_codes, rtol_g,
                                 atol_g, jrtol, jatol, max_instant, s, post, xa, rx, rxp, rd, target, chain, pin_m,
                                 pin_x)
        if m_new < 0:
            return _stop(info, x0, 5, n_saved, n_ev, t, m, steps)
        if passes > 1:
            ev_t[0] = t
            ev_mb[0] = m
            ev_ma[0] = m_new
            ev_at[0] = 0
            for i in range(n):
                ev_xb[0, i] = x0[i]
                ev_xa[0, i] = xa[i]
            n_ev = 1
            info[2] = 1.0
        for i in range(n):
            template[i] = xa[i]
        m = m_new
    while True:
        k = n_ind[m]
        ke = max(k, 1)
        y = ybuf[:ke]
        f = fbuf[:ke]
        tmp = tmpbuf[:ke]
        y_new = ynbuf[:ke]
        f_new = fnbuf[:ke]
        err = errbuf[:ke]
        K = Kbuf  # whole (rows of ne ≥ ke entries): one array layout for every compiled callee
        Q = Qbuf
        for i in range(k):
            y[i] = template[ind[m, i]]
        if k == 0:
            y[0] = 0.0
        _fun(m, t, y, k, template, ind, dep, n_dep, p, u, z, dbuf, r, f)
        # the guards at the flow's start; no previous step yet
        scan[0] = 0
        if nguard[m] > 0:
            _point(np.int64(_S_START), t, np.bool_(True), y, kind, m, k, t, 0.0, y, f, y, f, Q, template, ind, dep,
                   n_dep, p, u, z, dbuf, s, rtol_g, atol_g, tmp, prel, psign, pinc, npart, ptau, pmg, ptr, phd)
        h_abs = 0.0
        if kind == 2:
            if first_step > 0.0:
                h_abs = min(first_step, abs(t_end - t))
            else:
                h_abs = _initial_step(m, k, t, y, f, t_end, rtol, atol, max_step, template, ind, dep, n_dep, p, u,
                                      z, dbuf, r, tmp, f_new)
        stiff_run = 0
        calm_run = 0
        streak = 0
        history = 0
        code = -1
        while code < 0:
            if steps >= max_steps:
                _full(m, y, k, t, template, ind, dep, n_dep, p, u, z, dbuf)
                return _stop(info, z, 2, n_saved, n_ev, t, m, steps)
            if kind < 2:
                h = min(dt, t_end - t)
                t_new = t + h if t + h < t_end else t_end
                if kind == 0:
                    # stiffness (switching.integrators): f₂ − 2f₁ + f₀ ≈ (h·J)² f₀ over three steps
                    if history == 2:
                        num = 0.0
                        den = 0.0
                        for i in range(ke):
                            err[i] = f[i] - K[4, i] - K[4, i] + K[5, i]
                            num += err[i] * err[i]
                            den += K[5, i] * K[5, i]
                        if den > 0.0:
                            streak = _fixed_stiffness(num / den, 2.0, streak, dt, err, info)
                            if streak < 0:
                                _full(m, y, k, t, template, ind, dep, n_dep, p, u, z, dbuf)
                                return _stop(info, z, 6, n_saved, n_ev, t, m, steps)
                    for i in range(ke):
                        K[5, i] = K[4, i]
                        K[4, i] = f[i]
                    history = min(history + 1, 2)
                    for i in range(ke):
                        y_new[i] = y[i] + h * f[i]
                else:
                    for i in range(ke):
                        tmp[i] = y[i] + h / 2 * f[i]
                    _fun(m, t + h / 2, tmp, k, template, ind, dep, n_dep, p, u, z, dbuf, r, K[1])
                    for i in range(ke):
                        tmp[i] = y[i] + h / 2 * K[1, i]
                    _fun(m, t + h / 2, tmp, k, template, ind, dep, n_dep, p, u, z, dbuf, r, K[2])
                    # stiffness (switching.integrators): k3 − k2 ≈ (h/2)² J² k1
                    num = 0.0
                    den = 0.0
                    for i in range(ke):
                        err[i] = K[2, i] - K[1, i]
                        num += err[i] * err[i]
                        den += f[i] * f[i]
                    if den > 0.0:
                        streak = _fixed_stiffness(16.0 * num / den, 2.78, streak, h, err, info)
                        if streak < 0:
                            _full(m, y, k, t, template, ind, dep, n_dep, p, u, z, dbuf)
                            return _stop(info, z, 6, n_saved, n_ev, t, m, steps)
                    for i in range(ke):
                        tmp[i] = y[i] + h * K[2, i]
                    _fun(m, t + h, tmp, k, template, ind, dep, n_dep, p, u, z, dbuf, r, K[3])
                    for i in range(ke):
                        y_new[i] = y[i] + h / 6 * (f[i] + 2 * K[1, i] + 2 * K[2, i] + K[3, i])
                _fun(m, t_new, y_new, k, template, ind, dep, n_dep, p, u, z, dbuf, r, f_new)
            else:
                min_step = 10 * abs(np.nextafter(t, np.inf) - t)
                if h_abs > max_step:
                    h_abs = max_step
                elif h_abs < min_step:
                    h_abs = min_step
                accepted = False
                rejected = False
                while not accepted:
                    if h_abs < min_step:
                        _full(m, y, k, t, template, ind, dep, n_dep, p, u, z, dbuf)
                        return _stop(info, z, 3, n_saved, n_ev, t, m, steps)
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
                        _fun(m, t + RK_C[st] * h, tmp, k, template, ind, dep, n_dep, p, u, z, dbuf, r, K[st])
                    for i in range(ke):
                        acc = 0.0
                        for j in range(6):
                            acc += K[j, i] * RK_B[j]
                        y_new[i] = y[i] + h * acc
                    _fun(m, t + h, y_new, k, template, ind, dep, n_dep, p, u, z, dbuf, r, K[6])
                    for i in range(ke):
                        f_new[i] = K[6, i]
                    for i in range(ke):
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
                # Hairer's stiffness test (DOPRI5) on every accepted step: tmp holds the last stage's
                # argument y6, at t + h like y_new
                num = 0.0
                den = 0.0
                for i in range(ke):
                    err[i] = K[6, i] - K[5, i]
                    num += err[i] ** 2
                    den += (y_new[i] - tmp[i]) ** 2
                if den > 0.0 and abs(h) * math.sqrt(num / den) > 3.25:
                    calm_run = 0
                    stiff_run += 1
                    # reported when the rest of the flow would take more than 1e4 steps at this step size
                    if stiff_run >= 15 and (t_end - t_new) / abs(h) > 10000.0:
                        info[0] = abs(h) * math.sqrt(num / den)
                        info[1] = abs(h)
                        info[3] = 3.25
                        info[4] = _argmax_abs(err)
                        _full(m, y, k, t, template, ind, dep, n_dep, p, u, z, dbuf)
                        return _stop(info, z, 6, n_saved, n_ev, t, m, steps)
                else:
                    calm_run += 1
                    if calm_run >= 6:
                        stiff_run = 0
                for i in range(ke):
                    for j in range(4):
                        acc = 0.0
                        for mm in range(7):
                            acc += K[mm, i] * RK_P[mm, j]
                        Q[i, j] = acc
            steps += 1
            if not _finite(y_new):
                _full(m, y, k, t, template, ind, dep, n_dep, p, u, z, dbuf)
                return _stop(info, z, 4, n_saved, n_ev, t_new, m, steps)
            # the guards on this step
            t_ev = -1.0
            if nguard[m] > 0:
                t_ev = _event_in_step(kind, m, k, t, t_new, h, y, f, y_new, f_new, Q, template, ind, dep, n_dep, p, u,
                                      z, dbuf, s, rtol_g, atol_g, samples, tmp, prel, psign, pinc, pguard, npart,
                                      nguard, ptau, pmg, ptr, phd, order, ext, iscr, fscr, q, scan)
            if t_ev >= 0.0:
                # the state the guard was seen to hold on: the step's end itself, or the interpolant
                if t_ev == t_new:
                    for i in range(ke):
                        tmp[i] = y_new[i]
                else:
                    _interp(kind, t, h, y, f, y_new, f_new, Q, t_ev, tmp)
                _full(m, tmp, k, t_ev, template, ind, dep, n_dep, p, u, z, dbuf)
                for i in range(n):
                    x_out[i] = z[i]
                t = t_ev
                code = 1
                break
            for i in range(ke):
                y[i] = y_new[i]
                f[i] = f_new[i]
            t = t_new
            if save:
                _full(m, y, k, t, template, ind, dep, n_dep, p, u, z, dbuf)
                out_t[n_saved] = t
                out_m[n_saved] = m
                for i in range(n):
                    out_x[n_saved, i] = z[i]
                n_saved += 1
            if t >= t_end:
                _full(m, y, k, t, template, ind, dep, n_dep, p, u, z, dbuf)
                return _stop(info, z, 0, n_saved, n_ev, t, m, steps)
            if save and n_saved >= out_t.shape[0]:
                _full(m, y, k, t, template, ind, dep, n_dep, p, u, z, dbuf)
                return _stop(info, z, 2, n_saved, n_ev, t, m, steps)
        # an event at t with a priori state x_out: resolve it here if no symbolic work is needed
        if n_ev >= ev_t.shape[0]:
            return _stop(info, x_out, 5, n_saved, n_ev, t, m, steps)
        m_new, passes = _resolve(m, x_out, t, p, u, moved, n_moved, mstates, radix, codes, code_ids, mode_codes, rtol_g,
                         atol_g, jrtol, jatol, max_instant, s, post, xa, rx, rxp, rd, target, chain, pin_m, pin_x)
        if m_new < 0:
            return _stop(info, x_out, 5, n_saved, n_ev, t, m, steps)
        ev_t[n_ev] = t
        ev_mb[n_ev] = m
        ev_ma[n_ev] = m_new
        ev_at[n_ev] = n_saved
        for i in range(n):
            ev_xb[n_ev, i] = x_out[i]
            ev_xa[n_ev, i] = xa[i]
            template[i] = xa[i]
        n_ev += 1
        m = m_new


@JIT
def _stop(info, x, status, n_saved, n_ev, t, m, steps):
    """The kernel's return: the state x into info[5:], the rest as a tuple."""
    for i in range(x.shape[0]):
        info[5 + i] = x[i]
    return status, n_saved, n_ev, t, m, steps


'''.replace("@ENTRY", ENTRY).replace("@JIT", JIT).replace("@INLINE", INLINE).replace("@DISPATCH", DISPATCH)


_private: Path | None = None  # this process's own directory for kernels (no usable cache directory)
_rebuilt: set = set()  # modules whose unreadable numba cache files were deleted (warned once each)


def _private_directory() -> Path:
    """A directory of this process alone (mode 0700), removed at exit: compiled
    kernels live there when there is no usable cache directory, so nothing of
    another user's (a planted module or pickle) is ever loaded."""
    global _private
    if _private is None:
        _private = Path(tempfile.mkdtemp(prefix="hbg-jit-"))
        atexit.register(shutil.rmtree, _private, ignore_errors=True)
    return _private


def _unwritable(directory: Path) -> OSError | None:
    """Why ``directory`` or its ``__pycache__`` (numba's cache files) cannot
    be written, or ``None``."""
    try:
        for where in (directory, directory / "__pycache__"):
            where.mkdir(parents=True, exist_ok=True)
            fd, probe = tempfile.mkstemp(dir=where, prefix=".probe.", suffix=".tmp")
            os.close(fd)
            os.unlink(probe)
    except OSError as exc:
        return exc
    return None


def _cache_files(cache) -> list:
    """The index and data files of one function in numba's disk cache."""
    try:
        folder = cache._cache_path
        base = cache._cache_file._index_name[: -len(".nbi")]
    except AttributeError:  # another numba version: all files of the function's module
        folder = getattr(cache, "_cache_path", None)
        base = getattr(cache._py_func, "__module__", None) if hasattr(cache, "_py_func") else None
        if not folder or not base:
            return []
    try:
        names = os.listdir(folder)
    except OSError:
        return []
    return [os.path.join(folder, n) for n in names if n.startswith(base + ".") and n.endswith((".nbi", ".nbc"))]


def _guard_cache(module_name: str, dispatcher) -> None:
    """Make numba's disk cache of ``dispatcher`` unable to fail a run: a cache
    entry that cannot be read (corrupted or truncated ``.nbi``/``.nbc``
    files: ``UnpicklingError``, ``EOFError``, …) is deleted and the function
    compiled again; a cache entry that cannot be written is skipped.  Either
    gives one :class:`codegen.cache.CacheWarning` per module."""
    cache = getattr(dispatcher, "_cache", None)
    if cache is None or not hasattr(cache, "load_overload") or not hasattr(cache, "save_overload"):
        return
    load, save = cache.load_overload, cache.save_overload

    def load_overload(sig, target_context):
        try:
            return load(sig, target_context)
        except Exception as exc:
            files = _cache_files(cache)
            for path in files:
                try:
                    os.unlink(path)
                except OSError:
                    pass
            if module_name not in _rebuilt:
                _rebuilt.add(module_name)
                where = os.path.dirname(files[0]) if files else getattr(cache, "_cache_path", "numba's cache")
                warnings.warn(f"numba's cache files of compiled kernel {module_name} in {where} could not be read "
                              f"({type(exc).__name__}: {exc}); deleted them and compiling again",
                              CacheWarning, stacklevel=2)
            return None

    def save_overload(sig, data):
        try:
            save(sig, data)
        except Exception as exc:
            key = (module_name, "save")
            if key not in _rebuilt:
                _rebuilt.add(key)
                warnings.warn(f"numba's cache of compiled kernel {module_name} could not be written "
                              f"({type(exc).__name__}: {exc}); it is compiled again in the next process",
                              CacheWarning, stacklevel=2)

    cache.load_overload = load_overload
    cache.save_overload = save_overload


def _import(name: str, source: str, directory: Path):
    """Write ``source`` to ``directory/name.py`` (unless it is there already)
    and execute it as module ``name``, its numba caches guarded.  The code
    is compiled from ``source`` itself, so no ``.pyc`` is written or read."""
    from numba.core.dispatcher import Dispatcher

    path = directory / f"{name}.py"
    for attempt in range(3):
        try:
            current = path.read_text() if path.exists() else None
        except (OSError, UnicodeDecodeError):
            current = None
        if current != source:
            fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{name}.", suffix=".tmp")
            try:
                with os.fdopen(fd, "w") as handle:
                    handle.write(source)
                os.replace(tmp, path)
            finally:
                if os.path.exists(tmp):
                    os.unlink(tmp)
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            exec(compile(source, str(path), "exec"), module.__dict__)  # our own generated code
        except (OSError, RuntimeError):
            # the file vanished (another process evicted it) before numba saw it: write it again
            del sys.modules[name]
            if attempt == 2:
                raise
            continue
        except BaseException:
            del sys.modules[name]
            raise
        for value in list(vars(module).values()):
            if isinstance(value, Dispatcher):
                _guard_cache(name, value)
        return module


def load_module(name: str, source: str, directory: str | os.PathLike | None):
    """Write ``source`` as module ``name`` under ``directory`` and import it;
    numba's ``cache=True`` then keeps the machine code in
    ``directory/__pycache__`` (``name.*.nbi``/``.nbc``), which later processes
    load instead of compiling.  Unreadable cache files are deleted and the
    functions compiled again (see :func:`_guard_cache`).

    With ``directory`` ``None`` (``HBG_CACHE_DIR=off``), or not writable (a
    :class:`codegen.cache.CacheWarning` names it), the module goes to a
    private temporary directory of this process, removed at exit: it works,
    but is compiled again by every process — unless the read-only directory
    holds its machine code already, which is then copied and loaded."""
    if not available():
        raise ImportError("the compiled methods need numba: pip install '.[fast]' (or pip install numba)")
    if name in sys.modules:
        return sys.modules[name]
    if directory is not None:
        directory = Path(directory)
        error = _unwritable(directory)
        if error is None:
            try:
                return _import(name, source, directory)
            except OSError as exc:  # e.g. the disk is full
                error = exc
        warn_not_writable(directory, error)
        return _import(name, source, _adopt(name, source, directory, _private_directory()))
    return _import(name, source, _private_directory())


def _adopt(name: str, source: str, directory: Path, private: Path) -> Path:
    """Copy module ``name`` and numba's cache files of it from the read-only
    ``directory`` into ``private`` (times kept, so numba's source stamp still
    matches): a read-only cache still spares the compilation."""
    try:
        if (directory / f"{name}.py").read_text() != source:
            return private
        (private / "__pycache__").mkdir(exist_ok=True)
        shutil.copy2(directory / f"{name}.py", private / f"{name}.py")
        with os.scandir(directory / "__pycache__") as listing:
            for item in listing:
                if item.name.startswith(name + ".") and item.name.endswith((".nbi", ".nbc")):
                    shutil.copy2(item.path, private / "__pycache__" / item.name)
    except (OSError, UnicodeDecodeError):
        pass  # nothing (more) to adopt: compiled again
    return private
