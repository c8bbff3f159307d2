"""The hybrid kernel of the compiled methods (``euler-jit``, ``rk4-jit``,
``RK45-jit``, ``rodas-jit``): one model-independent numba function, :func:`run`, compiled
once per installation and kept by numba's disk cache (``cache=True``).

:func:`run` integrates a whole hybrid run in compiled code, by phase:

* the flow in the current mode (:mod:`.flow`): Euler (kind 0), classical RK4
  (kind 1) with fixed ``dt``, scipy's RK45 (kind 2), or the implicit RODAS4P
  (kind 3, :mod:`.implicit`); kind 4 (``auto``) flows with RODAS4P in the
  modes the record marks implicit (``M.implicit``), with RK45 in the others;
* at every accepted step, event detection (:mod:`.events`, the translation
  of the Python path's ``switching.simulate.events.GuardScan``);
* the instant's resolution (:mod:`.instants`, the paper's selMode, DESIGN
  §6) through mythical modes and pinnacles;
* the restart in the mode reached;
* samples at requested output times (``t_eval``) on the steps' dense output.

An instant that needs more than the kernel does stops it with status
``RESOLVE`` and the a priori state, and Python resolves that instant
(deterministically, so the results are the same).  Zeno behaviour is
watched by Python at every instant the kernel returns
(``switching.simulate.driver._ZenoWatch``).  The guards' comparison with its
round-off band are the rules of :mod:`codegen.decision`, compiled here as
:func:`decide` and :data:`larger` for the per-mode functions, and called by
``codegen.runtime.decide`` on the Python path.

The rules of :mod:`switching.rules` (the semantics written once) are
compiled by the kernel from the very functions the Python path calls; the
sources of the rules and of every kernel module are part of the stamp of the
kernel's numba cache (:func:`.compiler.stamp_with_rules`), so a change of
any of them compiles the kernel again.  The model reaches the kernel as a
:class:`Model` record (:mod:`.calls`).

``run`` returns ``(status, n_saved, n_events, t, mode, steps, n_te)`` and
writes the state where it stopped into ``info[5:]``; status :data:`DONE` 0:
reached ``t_end``; :data:`FULL` 2: an output buffer is full (call again from
``t, mode, x``); :data:`COLLAPSED` 3: the step size collapsed;
:data:`NONFINITE` 4; :data:`RESOLVE` 5: an event at ``t`` needs Python
(``x`` a priori); :data:`STIFF` 6: the stiffness tests of
:mod:`switching.simulate.integrators` fired (:mod:`.flow`) — ``info`` gets
``|h·λ|``, ``h``, —, the limit and the dominant component;
:data:`WORKSPACE` 7: the workspaces are smaller than :func:`workspace_sizes`
says (nothing ran).  With ``resolve_first`` the instant at ``t0`` is
resolved before the first flow (recorded as an event if it passed more than
one mode; ``info[2] = 1`` then).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from codegen import decision

from .calls import MODE_SIGNATURE as MODE_SIGNATURE
from .calls import OPS as OPS
from .calls import Model as Model
from .calls import call as call
from .calls import finite, full, fun
from .compiler import band, dispatch, entry, finite_holds, inline, jit, pulse_decides, pulse_holds, stamp_with_rules
from .events import S_START, S_STEP, event_in_step, point
from .flow import RK_A as RK_A
from .flow import RK_B as RK_B
from .flow import RK_C as RK_C
from .flow import RK_E as RK_E
from .flow import RK_P as RK_P
from .flow import adaptive_step, dense_coefficients, fixed_step, hairer, initial_step, interp
from .implicit import implicit_workspaces, rosenbrock_step
from .instants import resolve
from .views import rows_of

__all__ = ["COLLAPSED", "DONE", "FULL", "MODE_SIGNATURE", "Model", "NONFINITE", "OPS", "RESOLVE", "RK_A", "RK_B",
           "RK_C", "RK_E", "RK_P", "STIFF", "WORKSPACE", "call", "decide", "larger", "run", "workspace_sizes"]

# the return codes of run
DONE = 0
FULL = 2
COLLAPSED = 3
NONFINITE = 4
RESOLVE = 5
STIFF = 6
WORKSPACE = 7
_EVENT = -1  # (flow_in_mode: an event, to be resolved)


@inline
def _layout(n, n_automata, width, n_sides, samples, max_instant):
    """Sizes of the float, integer and boolean workspaces of a run (see run)."""
    ne = max(n, 1)
    w = max(width, 1)
    slots = S_STEP + samples + 2 + w * (samples + 3)
    floats = 72 * n + 18 * ne + 3 * max(n_sides, 1) + slots * (1 + w) + w + 2 * ne * ne + 2 * ne + 5
    ints = n_automata + max_instant + 1 + 64 + slots + samples + 4 + 2 * w + 1 + 6 * ne
    bools = slots * (1 + w) + w
    return floats, ints, bools


@entry
def workspace_sizes(M, n, samples, max_instant):
    """(floats, integers, booleans) that ``run`` needs in ``wf, wi, wb`` for the model ``M``."""
    return _layout(n, M.radix.shape[0], M.tables[3].shape[1], M.n_sides, samples, max_instant)


@inline
def _carve(x0, M, samples, max_instant, work):
    """The workspaces ``work = (wf, wi, wb)``, carved in the order of _layout's sums into the run's arrays;
    zeroed where a slot may be read before written; the template is ``x0``.  Returns ``(X, B, PT, SC, R)``:
    ``X = (template, z, x_out, xa)`` full states, ``B = (dbuf, ybuf, fbuf, tmpbuf, ynbuf, fnbuf, errbuf, K, Q,
    s)`` the flow's buffers, and the records of :mod:`.calls` and :mod:`.implicit` (``L``)."""
    wf, wi, wb = work
    n = x0.shape[0]
    radix = M.radix
    ne = max(n, 1)
    ns = max(M.n_sides, 1)
    width = max(M.tables[3].shape[1], 1)
    slots = S_STEP + samples + 2 + width * (samples + 3)
    o = 0
    template = wf[o:o + n]
    o += n
    for i in range(n):
        template[i] = x0[i]
    z = wf[o:o + n]
    o += n
    motion = wf[o:o + n]  # each state's motion within the round-off of an instant's time (rules.jumps)
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
    pin_x = rows_of(wf[o:o + 64 * n], 64, n)
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
    Kbuf = rows_of(wf[o:o + 7 * ne], 7, ne)
    o += 7 * ne
    Qbuf = rows_of(wf[o:o + 4 * ne], ne, 4)
    o += 4 * ne
    s = wf[o:o + ns]
    o += ns
    post = wf[o:o + 2 * ns]
    o += 2 * ns
    ptau = wf[o:o + slots]
    o += slots
    pmg = rows_of(wf[o:o + slots * width], slots, width)
    o += slots * width
    fscr = wf[o:o + width]
    o += width
    wf[zeroed:o] = 0.0  # K, Q, the sides and the points' slots
    jbuf = wf[o:o + ne * ne + ne]
    o += ne * ne + ne
    lu = wf[o:o + ne * ne]
    o += ne * ne
    fx = wf[o:o + ne]
    o += ne
    ctl = wf[o:o + 5]
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
    o += 1
    piv = wi[o:o + 3 * ne]
    o += 3 * ne
    perm = wi[o:o + 3 * ne]
    ptr = rows_of(wb[:slots * width], slots, width)
    phd = wb[slots * width:slots * (width + 1)]
    q = wb[slots * (width + 1):slots * (width + 1) + width]
    wb[:slots * (width + 1) + width] = False
    X = (template, z, x_out, xa)
    B = (dbuf, ybuf, fbuf, tmpbuf, ynbuf, fnbuf, errbuf, Kbuf, Qbuf, s)
    PT = (ptau, pmg, ptr, phd)
    SC = (order, ext, iscr, fscr, q, scan)
    R = (s, post, xa, rx, rxp, rd, target, chain, pin_m, pin_x, motion)
    L = (jbuf, lu, piv, fx, ctl, perm)
    return X, B, PT, SC, R, L


@inline
def _record(ev_f, ev_i, j, t, m_before, m_after, at, steps, xb, xa):
    """Event ``j``: its time, the states before and after, the modes before and after, the samples saved
    and the steps taken (by this call) before it."""
    n = xb.shape[0]
    ev_f[j, 0] = t
    ev_i[j, 0] = m_before
    ev_i[j, 1] = m_after
    ev_i[j, 2] = at
    ev_i[j, 3] = steps
    for i in range(n):
        ev_f[j, 1 + i] = xb[i]
        ev_f[j, 1 + n + i] = xa[i]


@entry
def run(M, ints, floats, x0, te, out, work, implicit):
    """A hybrid run of the model ``M`` (:class:`Model`) from ``(t0, mode, x0)`` until ``t_end`` (see the module
    docstring).  Returns ``(status, n_saved, n_events, t, mode, steps, n_te)``.

    ints[8]: kind (0 euler, 1 rk4, 2 RK45, 3 RODAS4P, 4 auto: RODAS4P in the modes M.implicit marks, else
          RK45), mode (its number in M), samples (guard samples per step),
          max_instant (step cap per instant), save (0 events only, 1 every step, 2 the requested times te,
          sorted; those consumed are counted in the returned ``n_te``), max_steps (step cap of this call),
          resolve_first (1: resolve the instant at t0 first), stiffness_check (0: no stiffness test, the
          flow goes on whatever the step's |h·λ|);
    floats[11]: t0, t_end, dt, rtol, (unused: each state's atol is M.atol's), max_step, first_step (0:
          select) [s, -]; rtol_g, atol_g, jrtol, jatol: the guards' and the jump's tolerances;
    out = (out_t[N], out_x[N, n], out_m[N], ev_f[E, 1 + 2n], ev_i[E, 4], info[5 + n]): saved steps, or the
          samples at te (N ≥ len(te) when save is 2); each event's time, state before, after; its mode before,
          mode after, samples saved and steps taken by this call before it; stiffness |h·λ| and h, 1 if the first event is the initial
          instant, stiffness limit, dominant component of y, then the state where the call stopped;
    work = (wf, wi, wb): float, integer and boolean workspaces of at least workspace_sizes(M, n, samples,
          max_instant);
    implicit: ``None`` for the explicit kinds (0, 1, 2), ``True`` for kinds 3 and 4.  With ``None`` the
          implicit method is not compiled into this specialisation of ``run`` (numba prunes the branches on
          ``is None``): a first explicit run compiles ~5 s less (15–16 s against 21 s)."""
    return _run(M, ints, floats, x0, te, out, work, implicit)


@dispatch
def _run(M, ints, floats, x0, te, out, work, implicit):
    """The body of :func:`run`, compiled without reference counting: the views it carves from the workspaces
    (some thirty) are borrowed for the call, not counted at each."""
    kind, mode, samples, max_instant, save, max_steps, resolve_first = (ints[0], ints[1], ints[2], ints[3], ints[4],
                                                                         ints[5], ints[6])
    stiffness_check = ints[7] != 0
    t0 = floats[0]
    F = (floats[1], floats[2], floats[3], floats[4], floats[5], floats[6], floats[7], floats[8])  # t_end … atol_g
    tol_g = (floats[7], floats[8], floats[9], floats[10])
    ev_f, ev_i, info = out[3], out[4], out[5]
    wf, wi, wb = work
    n = x0.shape[0]
    floats_needed, ints_needed, bools_needed = _layout(n, M.radix.shape[0], M.tables[3].shape[1], M.n_sides, samples,
                                                       max_instant)
    if (wf.shape[0] < floats_needed or wi.shape[0] < ints_needed or wb.shape[0] < bools_needed
            or info.shape[0] < 5 + n or ev_i.shape[1] < 4):
        return WORKSPACE, 0, 0, t0, mode, 0, 0
    for i in range(5):
        info[i] = 0.0
    X, B, PT, SC, R, L = _carve(x0, M, samples, max_instant, work)
    Li = implicit_workspaces(L, implicit)
    template, z, x_out, xa = X
    dbuf, ybuf, fbuf, tmpbuf, ynbuf, fnbuf, errbuf, Kbuf, Qbuf, s = B
    m = mode
    t = t0
    # (int64 from the start: a literal 0 would have flow_in_mode compiled twice, for Literal[int](0) and int64)
    n_saved = np.int64(0)
    n_ev = np.int64(0)
    steps = np.int64(0)
    pos = np.int64(0)
    if resolve_first != 0:  # the initial instant: the initial mode may be mythical, or a pinnacle
        m_new, passes = resolve(m, x0, t, M, tol_g, max_instant, R)
        if m_new < 0:
            return _stop(info, x0, RESOLVE, n_saved, n_ev, t, m, steps, pos)
        if passes > 1:
            _record(ev_f, ev_i, 0, t, m, m_new, 0, steps, x0, xa)
            n_ev = 1
            info[2] = 1.0
        for i in range(n):
            template[i] = xa[i]
        m = m_new
    setting = (kind, samples, max_steps, save)
    while True:
        ke = max(M.lengths[0][m], 1)
        # (whole K and Q, rows of ne ≥ ke entries: one array layout for every compiled callee)
        A = (ybuf[:ke], fbuf[:ke], ynbuf[:ke], fnbuf[:ke], Qbuf)  # a step: its start, its end (and rates), the
        # dense output's coefficients
        W = (tmpbuf[:ke], errbuf[:ke], Kbuf)  # an interpolated or stage y, the error estimate, the stages
        E = (template, z, dbuf, s, W[0])
        code, t, steps, pos, n_saved = flow_in_mode(m, t, steps, pos, n_saved, F, setting, stiffness_check, te, out,
                                                    x_out, A, E, W, Li, M, PT, SC)
        if code != _EVENT:
            return _stop(info, z, code, n_saved, n_ev, t, m, steps, pos)
        # an event at t with a priori state x_out: resolve it here if no symbolic work is needed
        if n_ev >= ev_f.shape[0]:
            return _stop(info, x_out, RESOLVE, n_saved, n_ev, t, m, steps, pos)
        m_new, passes = resolve(m, x_out, t, M, tol_g, max_instant, R)
        if m_new < 0:
            return _stop(info, x_out, RESOLVE, n_saved, n_ev, t, m, steps, pos)
        _record(ev_f, ev_i, n_ev, t, m, m_new, n_saved, steps, x_out, xa)
        for i in range(n):
            template[i] = xa[i]
        n_ev += 1
        m = m_new


@inline
def _start(m, k, t, F, setting, te, pos, n_saved, out, A, E, M, PT, SC):
    """The flow's start in mode m at t: ``y`` from the template, its rates, the requested output times at t (the
    state itself, after the instant if any), the guards at the start (no previous step yet), RK45's first step
    size (``first_step``, or scipy's selection; also RODAS4P's).  Returns ``(h_abs, pos, n_saved)``."""
    t_end, dt, rtol, _, max_step, first_step, rtol_g, atol_g = F
    kind, samples, max_steps, save = setting
    y, f, y_new, f_new, Q = A
    template, z, dbuf, s, tmp = E
    out_t, out_x, out_m = out[0], out[1], out[2]
    ind = M.tables[0]
    for i in range(k):
        y[i] = template[ind[m, i]]
    if k == 0:
        y[0] = 0.0
    fun(m, t, y, k, M, f)
    while save == 2 and pos < te.shape[0] and te[pos] <= t:
        out_t[n_saved] = te[pos]
        out_m[n_saved] = m
        for i in range(template.shape[0]):
            out_x[n_saved, i] = template[i]
        n_saved += 1
        pos += 1
    SC[5][0] = 0  # scan: no previous step
    if M.lengths[4][m] > 0:
        point(np.int64(S_START), t, np.bool_(True), y, kind, m, k, t, 0.0, (y, f, y, f, Q), E, M, rtol_g, atol_g,
              PT)
    h_abs = 0.0
    if kind >= 2:
        if first_step > 0.0:
            h_abs = min(first_step, abs(t_end - t))
        else:
            h_abs = initial_step(m, k, t, y, f, t_end, rtol, max_step, M, tmp, f_new)
    return h_abs, pos, n_saved


@dispatch
def flow_in_mode(m, t, steps, pos, n_saved, F, setting, check, te, out, x_out, A, E, W, L, M, PT, SC):
    """The flow in mode m from t (the state in the template) until an event, ``t_end`` or a stop: steps of the
    method (``setting = (kind, samples, max_steps, save)``; ``F = (t_end, dt, rtol, —, max_step, first_step,
    rtol_g, atol_g)``, each state's atol in ``M.atol``), the guards on each, the outputs.  Returns ``(code, t, steps, pos, n_saved)``: ``code``
    -1 for an event at ``t`` (its a priori state in ``x_out``), else the status of a stop at ``t`` with the
    state in ``z``."""
    t_end, dt, rtol, _, max_step, first_step, rtol_g, atol_g = F
    kind, samples, max_steps, save = setting
    if kind == 4:  # auto: the method of this mode
        kind = 3 if M.implicit[m] != 0 else 2
        setting = (kind, samples, max_steps, save)
    y, f, y_new, f_new, Q = A
    template, z, dbuf, s, tmp = E
    out_t, out_x, out_m, info = out[0], out[1], out[2], out[5]
    k = M.lengths[0][m]
    if L is not None:  # (L is None: an explicit run, compiled without the implicit method)
        L[4][0] = 0.0  # RODAS4P's controller: no accepted step yet; its Jacobian's buffer and order not made
        L[4][1] = 0.0
        L[4][3] = 0.0
        L[4][4] = 0.0
    ke = y.shape[0]
    h_abs, pos, n_saved = _start(m, k, t, F, setting, te, pos, n_saved, out, A, E, M, PT, SC)
    stiff_run = 0
    calm_run = 0
    streak = 0
    history = 0
    while True:
        if steps >= max_steps:
            full(m, y, k, t, E, M)
            return FULL, t, steps, pos, n_saved
        if kind < 2:
            t_new, h, streak, history = fixed_step(kind, m, k, t, t_end, dt, streak, history, check, A, W, M, info)
            if streak < 0:
                full(m, y, k, t, E, M)
                return STIFF, t, steps, pos, n_saved
        elif kind == 3:
            if L is None:  # (never: the implicit kinds are run with their workspaces)
                full(m, y, k, t, E, M)
                return COLLAPSED, t, steps, pos, n_saved
            ok, t_new, h, h_abs = rosenbrock_step(m, k, t, t_end, h_abs, rtol, max_step, A, W, L, M)
            if not ok:
                full(m, y, k, t, E, M)
                return (NONFINITE if h_abs != h_abs else COLLAPSED), t, steps, pos, n_saved
        else:
            ok, t_new, h, h_abs = adaptive_step(m, k, t, t_end, h_abs, rtol, max_step, A, W, M)
            if not ok:
                full(m, y, k, t, E, M)
                return (NONFINITE if h_abs != h_abs else COLLAPSED), t, steps, pos, n_saved
            stiff_run, calm_run, stiff = hairer(t_end, t_new, h, stiff_run, calm_run, check, A, W, info)
            if stiff:
                full(m, y, k, t, E, M)
                return STIFF, t, steps, pos, n_saved
            if save == 2 or M.lengths[4][m] > 0:  # (the interpolant serves the guards and the requested times)
                dense_coefficients(W[2], Q)
        steps += 1
        if not finite(y_new):
            full(m, y, k, t, E, M)
            return NONFINITE, t_new, steps, pos, n_saved
        t_ev = -1.0
        if M.lengths[4][m] > 0:
            t_ev = event_in_step(kind, m, k, t, t_new, h, A, E, M, rtol_g, atol_g, samples, PT, SC)
        if t_ev >= 0.0:
            if save == 2:  # requested output times before the event's instant
                pos, n_saved = _dense(te, pos, t_ev, np.bool_(True), kind, m, k, t, h, A, E, M, out, n_saved)
            # the state the guard was seen to hold on: the step's end itself, or the interpolant
            if t_ev == t_new:
                for i in range(ke):
                    tmp[i] = y_new[i]
            else:
                interp(kind, t, h, A, t_ev, tmp)
            full(m, tmp, k, t_ev, E, M)
            for i in range(z.shape[0]):
                x_out[i] = z[i]
            return _EVENT, t_ev, steps, pos, n_saved
        if save == 2:
            pos, n_saved = _dense(te, pos, t_new, np.bool_(False), kind, m, k, t, h, A, E, M, out, n_saved)
        for i in range(ke):
            y[i] = y_new[i]
            f[i] = f_new[i]
        t = t_new
        if save == 1:
            full(m, y, k, t, E, M)
            out_t[n_saved] = t
            out_m[n_saved] = m
            for i in range(z.shape[0]):
                out_x[n_saved, i] = z[i]
            n_saved += 1
        if t >= t_end:
            full(m, y, k, t, E, M)
            return DONE, t, steps, pos, n_saved
        if save == 1 and n_saved >= out_t.shape[0]:
            full(m, y, k, t, E, M)
            return FULL, t, steps, pos, n_saved




@dispatch
def _dense(te, pos, t_hi, strict, kind, m, k, t_old, h, A, E, M, out, n_saved):
    """The requested output times ``te[pos:]`` up to ``t_hi`` (before it if ``strict``) on the step's
    interpolant, full states, into ``out_*`` (as the Python path's ``_Recorder.dense``); returns the new
    ``(pos, n_saved)``."""
    template, z, dbuf, s, tmp = E
    out_t, out_x, out_m = out[0], out[1], out[2]
    while pos < te.shape[0] and (te[pos] < t_hi if strict else te[pos] <= t_hi):
        tau = te[pos]
        interp(kind, t_old, h, A, tau, tmp)
        full(m, tmp, k, tau, E, M)
        out_t[n_saved] = tau
        out_m[n_saved] = m
        for i in range(z.shape[0]):
            out_x[n_saved, i] = z[i]
        n_saved += 1
        pos += 1
    return pos, n_saved


@jit
def _stop(info, x, status, n_saved, n_ev, t, m, steps, pos):
    """The kernel's return: the state x into info[5:], the rest as a tuple."""
    for i in range(x.shape[0]):
        info[5 + i] = x[i]
    return status, n_saved, n_ev, t, m, steps, pos




# the comparison as functions of their own (compiled once, with the kernel) for the per-mode functions: inlining
# it into each at numba's level would cost seconds of compile time per mode
@njit(cache=True, error_model="numpy")
def decide(op, li, lf, ri, rf, sc, rtol, atol):
    """The rules of :mod:`codegen.decision`: does ``left op right`` hold (``op`` numbered as its ``OPS``;
    impulse parts ``li``, ``ri``, finite parts ``lf``, ``rf``, round-off scale ``sc``)."""
    if pulse_decides(li, ri):
        return pulse_holds(op, li, ri)
    return finite_holds(op, lf, rf, band(lf, rf, sc, rtol, atol))


#: the rule :func:`codegen.decision.larger`: the larger of two round-off scales, ignoring a non-finite one
larger = njit(cache=True, error_model="numpy")(decision.larger)

stamp_with_rules(globals(), __name__)
