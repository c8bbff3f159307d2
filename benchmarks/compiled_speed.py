"""Speed of the compiled path against a hand-written numba loop and scipy.

    python benchmarks/compiled_speed.py [--repeats N] [--best] [--no-reload]

Problems (as in issue 7):
  * bouncing ball, first 2.5 s (4 bounces), RK45 at rtol 1e-6;
  * rod pivoting on its tip for 1 s, RK45 at rtol 1e-3 … 1e-9.

Rows (median wall time of N interleaved rounds after a warm-up that compiles; see timed()):
  hand numba   a hand-written @njit RK45 (Dormand–Prince 5(4), scipy's step
               control) with dense-output bisection for the event and the jump
               v⁺ = −e·v, everything in one compiled call;
  kernel       the model-independent kernel (switching.kernel.loop.run; flows,
               guards, instant resolution and restarts compiled, each mode's
               functions called through a function pointer) through
               CompiledModel.run; "s=3" tests the guards at 3 interior
               points of every step too (the default), "s=0" only at step ends
               like the hand loop;
  RK45-jit     HybridModel.simulate(method="RK45-jit", output="events"): the
               kernel plus the Python run set-up and the trajectory record;
  RK45 (scipy) HybridModel.simulate(method="RK45", output="events");
  solve_ivp    scipy.integrate.solve_ivp with an event function, restarted
               after each bounce by a Python loop (the usual hand-made way);
  rk4          HybridModel.simulate(method="rk4") at the dt giving the same
               error as solve_ivp (pivoting rod).
Also: the compile time of the kernel (once per installation) and of a
model's mode functions, and their reload time in a fresh process (numba's
disk cache), each in a new process.

Measured (issue 46, ``--repeats 5``, medians, µs; a 2-core machine shared
with two other workers' test runs, load average 2–3: a figure moves by
±10 % between runs; before and after measured one after the other):

  problem, setting       hand  kernel s=3  kernel s=0 | s=3/hand  s=0/hand
  before (6e04426)
  ball 2.5 s, rtol 1e-6   7.9     45.7        33.2    |   5.8       4.2
  rod 1 s, rtol 1e-3      2.7     15.6        14.3    |   5.8       5.3
  rod 1 s, rtol 1e-6      4.6     18.9        18.1    |   4.1       3.9
  rod 1 s, rtol 1e-9     12.5     36.5        34.0    |   2.9       2.7
  after (97b068e)
  ball 2.5 s, rtol 1e-6   7.5     36.9        26.0    |   4.9       3.5
  rod 1 s, rtol 1e-3      2.8     10.8         7.5    |   3.8       2.6
  rod 1 s, rtol 1e-6      4.7     12.7        10.5    |   2.7       2.3
  rod 1 s, rtol 1e-9     13.2     29.1        23.6    |   2.2       1.8

The kernel's own call (its compiled entry point called with the arguments
``CompiledModel.run`` makes, least of 5–9 batches), before → after: ball
s=0 22.7 → 20.4, s=3 26.3 → 24.2; rod 1e-3 4.67 → 4.29, 1e-6 8.12 → 7.23,
1e-9 22.2 → 19.2 µs (1.45–1.5× the hand loop on the rod).  Where the rest
goes:

* ``CompiledModel.run``'s Python side: ~3.7 µs a call (was ~10: an ``atol``
  given as a number was broadcast to an array, and the record replaced, at
  every call), mostly the settings' two arrays and the state's copy (1.2 µs),
  the model record and the result (0.5 µs); numba's unboxing of the ~24
  arrays of ``run``'s arguments, ~0.9 µs.  The hand loop's whole call at one
  step is 1.6 µs, the kernel's 2.6 µs plus the Python side: what keeps the
  short rows (rod at 1e-3: 7 steps) above 2×;
* the rod's model: 4 states, ``sin`` and ``cos`` at each rate (the hand loop
  integrates 2 states with ``cos``): the kernel's step 0.24 µs, the hand
  loop's 0.15 µs;
* each of the ball's 4 events, ~3 µs: ~54 evaluations of the mode's guards
  through its function (the bisection of the step's interpolant down to
  adjacent floating-point numbers, 51 halvings, each the whole guard: 15
  sides, 5 comparisons with their round-off bands), where the hand loop
  tests ``y ≤ 0`` on one component.  Since e1a316f the bracket is narrowed
  by ITP on the margin of the part that changes truth (the same bracket,
  12–13 evaluations an event instead of 48–51): the kernel's own ball run,
  timed alone and alternating with the commit before (``--repeats`` of 30
  batches, least), s=0 24.7 → 22.5 µs, s=3 28.0 → 26.2 µs; this table
  after it (``--repeats 7``): ball 7.7 / 33.7 / 22.4 µs (s=3 4.4×, s=0
  2.9× the hand loop), rod at 1e-9 12.9 / 28.4 / 23.2 µs (2.2×, 1.8×).
  The Python path's event location gains more (each evaluation there is a
  generated Python function): a warm RK45 run of the ball 9.5 → 7.1 ms, of
  the falling rod 3.7 → 2.9 ms;
* the rod has no guards, so "s=3" is the same work as "s=0" (8.2 µs each
  timed alone at 1e-3); the table's s=3 column, timed right after the hand
  loop, reads higher on this loaded machine.

Where the kernel's own call goes (a profile of the ball's run, s=0, numba's
functions named for the profiler): a step of the ball costs the kernel
~0.35 µs against the hand loop's ~0.1, and nearly all of the difference is
the guard scan at the step's points (GuardScan's semantics: the guards'
parts, their margins' extrema, the first bracket), not the RK45 step; the
rod's steps cost what the hand loop's do (0.21 µs at 1e-9).  The scan's
phases that run at every step were calls of their own, each passing the
model record and the scan's records; inlined into ``event_in_step`` (issue
46, session 25), the kernel's own call, run beside the commit before, one
process per core (least of 15 rounds of 3000 calls, µs):

                        ball s=0  ball s=3  rod 1e-3  rod 1e-6  rod 1e-9
  before (7c37dd7)        18.1      22.0      5.0       7.3      12.9
  after                   16.5      20.5      5.0       7.3      12.9
  hand loop (same load)    7.6       7.6      2.8       4.7      12.7

The kernel's own call is then within 2× the hand loop on the rod's rows
(1.8×, 1.55×, 1.0×), the ball's at 2.2× (s=0) and 2.7× (s=3); what keeps the
table's "kernel" columns higher is ``CompiledModel.run``'s Python set-up,
~3 µs a call (three small arrays made, the record checked), and the kernel's
fixed entry, ~2.8 µs against the hand loop's 1.0: numba unboxes its 24 array
arguments (a reference-counted wrapper allocated and freed for each, ~30 %
of that entry) and carves the workspaces.  Inlined further, into
``flow_in_mode``, the ball's call took 15.1 µs, but the kernel's first
compile 3 s longer (24.7 → 28.0 s) and the implicit one's 9 s longer (35.4 →
44.4 s): not taken.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from numba import njit  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

from models import bouncing_ball  # noqa: E402
from models.graphs import pivoting_rod  # noqa: E402
from switching import HybridModel  # noqa: E402
from switching.kernel.loop import RK_A as A  # noqa: E402
from switching.kernel.loop import RK_B as B  # noqa: E402
from switching.kernel.loop import RK_C as C  # noqa: E402
from switching.kernel.loop import RK_E as EE  # noqa: E402
from switching.kernel.loop import RK_P as P  # noqa: E402

G, E = 9.81, 0.8


@njit(cache=True)
def _ball_f(t, y, out):
    out[0] = y[1]
    out[1] = -9.81


@njit(cache=True)
def _rod_f(t, y, out):
    m, J, l, g = 1.0, 1.0 / 12.0, 0.5, 9.81
    out[0] = y[1]
    out[1] = -m * g * l * math.cos(y[0]) / (J + m * l * l)


@njit(cache=True)
def rk45_run(problem, y0, t0, t_end, rtol, atol, e=E):
    """Hand-written RK45 run: problem 0 = ball (events + the jump v⁺ = −e·v), 1 = rod.  Returns the state at
    ``t_end`` and the number of impacts."""
    n = y0.shape[0]
    y = y0.copy()
    K = np.zeros((7, n))
    f = np.empty(n)
    tmp = np.empty(n)
    y_new = np.empty(n)
    fn = np.empty(n)
    Q = np.empty((n, 4))
    t = t0
    events = 0
    restart = True
    h_abs = 0.0
    while t < t_end:
        if restart:
            if problem == 0:
                _ball_f(t, y, f)
            else:
                _rod_f(t, y, f)
            d0 = 0.0
            d1 = 0.0
            for i in range(n):
                sc = atol + abs(y[i]) * rtol
                d0 += (y[i] / sc) ** 2
                d1 += (f[i] / sc) ** 2
            d0 = math.sqrt(d0 / n)
            d1 = math.sqrt(d1 / n)
            h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
            h0 = min(h0, t_end - t)
            for i in range(n):
                tmp[i] = y[i] + h0 * f[i]
            if problem == 0:
                _ball_f(t + h0, tmp, fn)
            else:
                _rod_f(t + h0, tmp, fn)
            d2 = 0.0
            for i in range(n):
                sc = atol + abs(y[i]) * rtol
                d2 += ((fn[i] - f[i]) / sc) ** 2
            d2 = math.sqrt(d2 / n) / h0
            h1 = max(1e-6, h0 * 1e-3) if (d1 <= 1e-15 and d2 <= 1e-15) else (0.01 / max(d1, d2)) ** 0.2
            h_abs = min(100 * h0, h1, t_end - t)
            restart = False
        rejected = False
        while True:
            h = min(h_abs, t_end - t)
            for i in range(n):
                K[0, i] = f[i]
            for s in range(1, 6):
                for i in range(n):
                    acc = 0.0
                    for j in range(s):
                        acc += K[j, i] * A[s, j]
                    tmp[i] = y[i] + acc * h
                if problem == 0:
                    _ball_f(t + C[s] * h, tmp, fn)
                else:
                    _rod_f(t + C[s] * h, tmp, fn)
                for i in range(n):
                    K[s, i] = fn[i]
            for i in range(n):
                acc = 0.0
                for j in range(6):
                    acc += K[j, i] * B[j]
                y_new[i] = y[i] + h * acc
            if problem == 0:
                _ball_f(t + h, y_new, fn)
            else:
                _rod_f(t + h, y_new, fn)
            for i in range(n):
                K[6, i] = fn[i]
            err = 0.0
            for i in range(n):
                acc = 0.0
                for j in range(7):
                    acc += K[j, i] * EE[j]
                sc = atol + max(abs(y[i]), abs(y_new[i])) * rtol
                err += (acc * h / sc) ** 2
            err = math.sqrt(err / n)
            if err < 1:
                factor = 10.0 if err == 0 else min(10.0, 0.9 * err ** -0.2)
                if rejected:
                    factor = min(1.0, factor)
                h_abs = h * factor
                break
            h_abs = h * max(0.2, 0.9 * err ** -0.2)
            rejected = True
        if problem == 0 and y_new[0] <= 0.0 and y_new[1] < 0.0:
            for i in range(n):
                for j in range(4):
                    acc = 0.0
                    for m in range(7):
                        acc += K[m, i] * P[m, j]
                    Q[i, j] = acc
            a, b = t, t + h
            for _ in range(200):
                mid = 0.5 * (a + b)
                if mid <= a or mid >= b:
                    break
                theta = (mid - t) / h
                yy = y[0] + h * (Q[0, 0] * theta + Q[0, 1] * theta**2 + Q[0, 2] * theta**3 + Q[0, 3] * theta**4)
                if yy <= 0.0:
                    b = mid
                else:
                    a = mid
            theta = (b - t) / h
            for i in range(n):
                y[i] = y[i] + h * (Q[i, 0] * theta + Q[i, 1] * theta**2 + Q[i, 2] * theta**3 + Q[i, 3] * theta**4)
            y[1] = -e * y[1]
            t = b
            events += 1
            restart = True
            continue
        for i in range(n):
            y[i] = y_new[i]
            f[i] = fn[i]
        t = t + h
    return y, events


STATISTIC = statistics.median  # --best: min (on a machine other jobs load, the least disturbed round)


def timed(fns, repeats):
    """Median (or, with ``--best``, least) wall time of one call of each of ``fns`` (a list).

    The calls are interleaved — round after round, every function once per
    round — so a change of the machine's load during the measurement moves
    all of them alike and leaves their ratios fair.  A sample of a fast
    function is the mean of a batch of calls lasting about 2 ms."""
    for fn in fns:
        fn()  # warm-up (compiles)
    batches = []
    for fn in fns:
        t0 = time.perf_counter()
        fn()
        batches.append(max(1, int(2e-3 / max(time.perf_counter() - t0, 1e-7))))
    samples = [[] for _ in fns]
    for _ in range(repeats):
        for k, (fn, batch) in enumerate(zip(fns, batches)):
            t0 = time.perf_counter()
            for _ in range(batch):
                fn()
            samples[k].append((time.perf_counter() - t0) / batch)
    return [STATISTIC(column) for column in samples]


def ball_solve_ivp(rtol):
    t, y, events = 0.0, np.array([1.0, 0.0]), 0

    def hit(t, y):
        return y[0]

    hit.terminal, hit.direction = True, -1
    while t < 2.5:
        sol = solve_ivp(lambda t, y: [y[1], -G], (t, 2.5), y, method="RK45", rtol=rtol, atol=1e-9, events=hit)
        if sol.status == 1:
            t, y = sol.t_events[0][0], sol.y_events[0][0].copy()
            y[1] = -E * y[1]
            events += 1
        else:
            break
    return events


def rod_model():
    return HybridModel(pivoting_rod(), [], {"m": 1.0, "J": 1 / 12, "l": 0.5, "g": 9.81},
                       initial_state={"rod/theta": 0.9})


def reload_time() -> str:
    """Compile in new processes, reload in a later one (numba disk caches).

    Each process times: importing numba; numba's own first-use set-up (the
    first call of any compiled function pays it — here a one-line cached
    function); building the model and a Python run (derivations from the
    toolkit's cache); then its first RK45-jit run: (1) with numba's cache of
    the kernel empty (NUMBA_CACHE_DIR, a fresh installation) and an empty
    toolkit cache: the kernel and the two modes' functions compiled; (2) the
    kernel cached (this installation's), the toolkit cache empty: the modes'
    functions compiled; (3) both cached: loaded."""
    script = (
        "import time, sys; sys.path.insert(0, %r); sys.path.insert(0, sys.argv[1])\n"
        "t0 = time.perf_counter(); import numba; t1 = time.perf_counter()\n"
        "import warm; warm.one(1.0); t2 = time.perf_counter()\n"
        "from models import bouncing_ball; m = bouncing_ball.build()\n"
        "m.simulate(2.5, 'RK45', rtol=1e-6, output='events'); t3 = time.perf_counter()\n"
        "m.simulate(2.5, 'RK45-jit', rtol=1e-6, output='events'); t4 = time.perf_counter()\n"
        "print(f'{t1 - t0:.3f} {t2 - t1:.3f} {t3 - t2:.3f} {t4 - t3:.3f}')\n" % str(ROOT)
    )
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as numba_cache, \
            tempfile.TemporaryDirectory() as cache2:
        Path(cache, "warm.py").write_text("from numba import njit\n\n\n@njit(cache=True)\ndef one(x):\n"
                                          "    return x + 1.0\n")
        Path(cache2, "warm.py").write_text(Path(cache, "warm.py").read_text())

        def process(directory, **extra):
            env = {**os.environ, "HBG_CACHE_DIR": directory, **extra}
            out = subprocess.run([sys.executable, "-c", script, directory], env=env, capture_output=True, text=True,
                                 check=True).stdout.split()
            return [float(v) for v in out]

        fresh = process(cache, NUMBA_CACHE_DIR=numba_cache)
        modes = process(cache2)
        warm = process(cache2)
    lines = ["bouncing ball (both modes), each a new process: numba import, numba set-up, model + Python run, "
             "first RK45-jit run"]
    for what, (i, w, m, c) in (("kernel and mode functions compiled", fresh),
                               ("kernel cached, mode functions compiled", modes),
                               ("kernel and mode functions cached", warm)):
        lines.append(f"  {what:<40} {i:.2f} s, {w:.2f} s, {m:.2f} s, {c:.3f} s")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--best", action="store_true", help="the least time of the rounds instead of the median")
    parser.add_argument("--no-reload", action="store_true", help="skip the compile and reload times")
    args = parser.parse_args(argv)
    global STATISTIC
    STATISTIC = min if args.best else statistics.median
    r = args.repeats
    rows = []

    def kernel(model, t_end, rtol, atol, samples):
        """The compiled entry point alone, from the initial state and mode."""
        x0, mode = model.initial_state(), model.initial_mode
        compiled = model.compiled_model()
        return lambda: compiled.run(2, mode, x0, 0.0, t_end, dt=None, rtol=rtol, atol=atol, max_step=np.inf,
                                    first_step=None, samples=samples, save=False)

    ball = bouncing_ball.build()
    ball.simulate(2.5, "RK45", rtol=1e-6, atol=1e-9, output="events")  # visit both modes: the kernel covers them
    hand, k3, k0, jit, py, ivp = timed([
        lambda: rk45_run(0, np.array([1.0, 0.0]), 0.0, 2.5, 1e-6, 1e-9),
        kernel(ball, 2.5, 1e-6, 1e-9, 3),
        kernel(ball, 2.5, 1e-6, 1e-9, 0),
        lambda: ball.simulate(2.5, "RK45-jit", rtol=1e-6, atol=1e-9, output="events"),
        lambda: ball.simulate(2.5, "RK45", rtol=1e-6, atol=1e-9, output="events"),
        lambda: ball_solve_ivp(1e-6),
    ], r)
    rows.append(("ball 2.5 s", "rtol=1e-06", hand, k3, k0, jit, py, ivp))

    rod = rod_model()
    for rtol in (1e-3, 1e-6, 1e-9):
        y0 = np.array([0.9, 0.0])
        def rhs(t, y):
            return [y[1], -9.81 * 0.5 * math.cos(y[0]) / (1 / 12 + 0.25)]

        hand, k3, k0, jit, py, ivp = timed([
            lambda: rk45_run(1, y0, 0.0, 1.0, rtol, rtol * 1e-3),
            kernel(rod, 1.0, rtol, rtol * 1e-3, 3),
            kernel(rod, 1.0, rtol, rtol * 1e-3, 0),
            lambda: rod.simulate(1.0, "RK45-jit", rtol=rtol, atol=rtol * 1e-3, output="events"),
            lambda: rod.simulate(1.0, "RK45", rtol=rtol, atol=rtol * 1e-3, output="events"),
            lambda: solve_ivp(rhs, (0, 1), [0.9, 0.0], method="RK45", rtol=rtol, atol=rtol * 1e-3),
        ], r)
        rows.append(("rod 1 s", f"rtol={rtol:g}", hand, k3, k0, jit, py, ivp))

    print(f"{'problem':<11} {'setting':<11} {'hand':>8} {'kernel s=3':>11} {'kernel s=0':>11} {'RK45-jit':>9} "
          f"{'RK45 scipy':>11} {'solve_ivp':>10} | {'s=3/hand':>8} {'s=0/hand':>8} {'scipy/jit':>9} "
          f"{'scipy/kern':>10}")
    for name, setting, hand, k3, k0, jit, py, ivp in rows:
        print(f"{name:<11} {setting:<11} {1e6 * hand:>6.1f}µs {1e6 * k3:>9.1f}µs {1e6 * k0:>9.1f}µs "
              f"{1e6 * jit:>7.1f}µs {1e6 * py:>9.1f}µs {1e6 * ivp:>8.1f}µs | {k3 / hand:>8.1f} {k0 / hand:>8.1f} "
              f"{py / jit:>9.1f} {py / k3:>10.1f}")

    # pure-Python fixed step at the accuracy of solve_ivp (rod, rtol 1e-6)
    reference = rod.simulate(1.0, "DOP853", rtol=1e-13, atol=1e-14, output="events").state("rod/theta")[-1]
    sol = solve_ivp(lambda t, y: [y[1], -9.81 * 0.5 * math.cos(y[0]) / (1 / 12 + 0.25)], (0, 1), [0.9, 0.0],
                    method="RK45", rtol=1e-6, atol=1e-9)
    target = abs(sol.y[0, -1] - reference)
    dt = 0.1
    while abs(rod.simulate(1.0, "rk4", dt=dt, output="events").state("rod/theta")[-1] - reference) > target:
        dt /= 1.25
    rk4, ivp = timed([
        lambda: rod.simulate(1.0, "rk4", dt=dt, output="events"),
        lambda: solve_ivp(lambda t, y: [y[1], -9.81 * 0.5 * math.cos(y[0]) / (1 / 12 + 0.25)], (0, 1), [0.9, 0.0],
                          method="RK45", rtol=1e-6, atol=1e-9),
    ], r)
    print(f"\npure-Python rk4 (dt={dt:.3g}) at solve_ivp's error {target:.1e}: {1e6 * rk4:.1f} µs vs solve_ivp "
          f"{1e6 * ivp:.1f} µs (ratio {rk4 / ivp:.2f})")
    if not args.no_reload:
        print("\n" + reload_time())


if __name__ == "__main__":
    main()
