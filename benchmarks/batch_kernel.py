"""10 000 bouncing balls in one call: the batch on the compiled path against a hand loop.

    python benchmarks/batch_kernel.py [--grid 100] [--repeats 3] [--no-cold]

The runs: the bouncing ball (``models.bouncing_ball``) over a grid of restitution
``e ∈ [0.7, 0.9]`` and drop height ``y0 ∈ [1, 2] m`` (``--grid`` values of each:
100 × 100 = 10 000 runs), each to ``t_end = 2 s`` (2 to 4 bounces) with RK45 at
``rtol = 1e-8``.  Rows (each the least of ``--repeats`` rounds, warm: compiled and
loaded first):

  hand loop          a hand-written @njit RK45 (Dormand–Prince 5(4), scipy's step
                     control) with the impact located by bisection on the dense
                     output and ``v⁺ = −e·v``, one compiled call looping over the
                     runs on one thread;
  hand loop, prange  the same over the cores numba is given;
  simulate_batch     ``switching.simulate_batch(model, sets, 2.0, "RK45-jit")``:
                     each run set up as ``simulate`` sets it up (options, initial
                     state, tolerances), then all runs' kernel calls at once
                     (``switching.kernel.batch.run_many``, prange), recording the
                     runs' ends and instants;
  its kernel calls   the batch's ``run_many`` calls alone (inside the row above: the
                     first set's, then the others');
  simulate loop      ``model.set_parameter_values`` and a warm ``model.simulate(...,
                     output="events")`` per set, in a Python loop (what a sweep
                     did before);
  simulate_many      ``simulate_many(model, sets, ..., trajectories=False)`` (a model,
                     not a build): the batch, then each run's trajectory recorded as
                     ``simulate`` records it, a ``RunResult`` per set (with
                     ``trajectories=True`` each result also lists every instant's
                     passes, which a compiled run's record resolves again in Python:
                     about 1 ms a run here).

``ratio`` is the row's time over the hand loop's (one thread): issue 46's target is
the batch within 20× of it.  The first batch in a new process (numba's disk cache
holding the kernel and the batch entry) is timed apart, as is its first compile.
Every run's end and instants are checked to be the same, to the bit, in the batch and
in the simulate loop.

Figures (2 cores, the machine otherwise idle: load 0.6–0.9; ``python benchmarks/batch_kernel.py
--repeats 7``)::

    row                 10 000 runs    per run    ratio
    hand loop              0.032 s       3.2 µs     1.0
    hand loop, prange      0.017 s       1.7 µs     0.5
    simulate_batch         0.615 s      61.5 µs    19.0
      its kernel calls     0.090 s       9.0 µs     2.8
    simulate loop          1.62 s      162 µs      50.0
    simulate_many          2.10 s      210 µs      64.9

    first batch of 100 in a new process (the kernel and the batch entry in numba's cache): 0.92 s;
    the batch entry's first compile (the kernel cached): 14.1 s for that process, once per installation

Where a batched run's 52 µs outside the kernel go (the ball; timers around each part, µs): its values
set on the model (``set_parameter_values``, the initial state given) 14, the run's set-up as
``simulate`` makes it (options, the projected initial state, the starting mode, the states'
tolerances, the step bound, the record) 17, its start (the guard sides checked finite, the kernel
call's arguments) 11, the kernel's inputs 5, the rest (the slab's arrays, the checks of the ends) 5.  On a loaded machine (another
process on a core) the kernel calls get one thread and the batch takes 0.74 s (23×).
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from numba import njit, prange

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from models import bouncing_ball  # noqa: E402
from switching import simulate_batch, simulate_many  # noqa: E402
from switching.kernel.loop import RK_A as A  # noqa: E402
from switching.kernel.loop import RK_B as B  # noqa: E402
from switching.kernel.loop import RK_C as C  # noqa: E402
from switching.kernel.loop import RK_E as EE  # noqa: E402
from switching.kernel.loop import RK_P as P  # noqa: E402

G = 9.81
T_END = 2.0
RTOL = 1e-8
ATOL = 1e-9


@njit(cache=True)
def _fall(y, out):
    out[0] = y[1]
    out[1] = -G


@njit(cache=True)
def _first_step(t, t_end, y, f, rtol, atol, tmp, fn):
    """scipy's initial step selection."""
    n = y.shape[0]
    d0 = d1 = 0.0
    for i in range(n):
        sc = atol + abs(y[i]) * rtol
        d0 += (y[i] / sc) ** 2
        d1 += (f[i] / sc) ** 2
    d0, d1 = math.sqrt(d0 / n), math.sqrt(d1 / n)
    h0 = min(1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1, t_end - t)
    for i in range(n):
        tmp[i] = y[i] + h0 * f[i]
    _fall(tmp, fn)
    d2 = 0.0
    for i in range(n):
        d2 += ((fn[i] - f[i]) / (atol + abs(y[i]) * rtol)) ** 2
    d2 = math.sqrt(d2 / n) / h0
    h1 = max(1e-6, h0 * 1e-3) if (d1 <= 1e-15 and d2 <= 1e-15) else (0.01 / max(d1, d2)) ** 0.2
    return min(100 * h0, h1, t_end - t)


@njit(cache=True)
def hand_ball(e, y0, t_end, rtol, atol):
    """One ball from rest at height ``y0``: RK45 steps, each impact located by bisection on the step's
    quartic interpolant, then ``v⁺ = −e·v``.  Returns the state ``(y, v)`` at ``t_end`` and the impacts."""
    n = 2
    y = np.array([y0, 0.0])
    K = np.zeros((7, n))
    f, tmp, y_new, fn = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    Q = np.empty((n, 4))
    t, events, restart, h_abs = 0.0, 0, True, 0.0
    while t < t_end:
        if restart:
            _fall(y, f)
            h_abs = _first_step(t, t_end, y, f, rtol, atol, tmp, fn)
            restart = False
        rejected = False
        while True:
            h = min(h_abs, t_end - t)
            K[0, :] = f
            for s in range(1, 6):
                for i in range(n):
                    acc = 0.0
                    for j in range(s):
                        acc += K[j, i] * A[s, j]
                    tmp[i] = y[i] + acc * h
                _fall(tmp, fn)
                K[s, :] = fn
            for i in range(n):
                acc = 0.0
                for j in range(6):
                    acc += K[j, i] * B[j]
                y_new[i] = y[i] + h * acc
            _fall(y_new, fn)
            K[6, :] = fn
            err = 0.0
            for i in range(n):
                acc = 0.0
                for j in range(7):
                    acc += K[j, i] * EE[j]
                err += (acc * h / (atol + max(abs(y[i]), abs(y_new[i])) * rtol)) ** 2
            err = math.sqrt(err / n)
            if err < 1:
                factor = 10.0 if err == 0 else min(10.0, 0.9 * err ** -0.2)
                h_abs = h * (min(1.0, factor) if rejected else factor)
                break
            h_abs = h * max(0.2, 0.9 * err ** -0.2)
            rejected = True
        if y_new[0] <= 0.0 and y_new[1] < 0.0:
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
                if y[0] + h * (Q[0, 0] * theta + Q[0, 1] * theta**2 + Q[0, 2] * theta**3 + Q[0, 3] * theta**4) <= 0:
                    b = mid
                else:
                    a = mid
            theta = (b - t) / h
            for i in range(n):
                y[i] = y[i] + h * (Q[i, 0] * theta + Q[i, 1] * theta**2 + Q[i, 2] * theta**3 + Q[i, 3] * theta**4)
            y[1] = -e * y[1]
            t, events, restart = b, events + 1, True
            continue
        y[:] = y_new
        f[:] = fn
        t = t + h
    return y, events


@njit(cache=True)
def hand_grid(es, y0s, t_end, rtol, atol, ends, counts):
    """:func:`hand_ball` for every run, one thread."""
    for r in range(es.shape[0]):
        y, k = hand_ball(es[r], y0s[r], t_end, rtol, atol)
        ends[r, 0], ends[r, 1], counts[r] = y[0], y[1], k


@njit(cache=True, parallel=True)
def hand_grid_parallel(es, y0s, t_end, rtol, atol, ends, counts):
    """:func:`hand_ball` for every run, over the cores."""
    for r in prange(es.shape[0]):
        y, k = hand_ball(es[r], y0s[r], t_end, rtol, atol)
        ends[r, 0], ends[r, 1], counts[r] = y[0], y[1], k


def least(fn, repeats):
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def cold_batch() -> str:
    """The first batch of 100 runs in a new process (warm disk caches), and its time."""
    code = ("import time; t0 = time.perf_counter(); from models import bouncing_ball; from switching import "
            "simulate_batch; m = bouncing_ball.build(); simulate_batch(m, [{'e': 0.8, 'y0': 1.0 + k / 100} for k in "
            f"range(100)], {T_END}, 'RK45-jit', rtol={RTOL}); print(f'{{time.perf_counter() - t0:.2f}}')")
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    return done.stdout.strip()


def main(argv=None):
    parser = argparse.ArgumentParser()
    parser.add_argument("--grid", type=int, default=100, help="values of e and of y0 (runs: grid²)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--no-cold", action="store_true")
    args = parser.parse_args(argv)
    es, y0s = (a.ravel() for a in np.meshgrid(np.linspace(0.7, 0.9, args.grid), np.linspace(1.0, 2.0, args.grid),
                                               indexing="ij"))
    sets = [{"e": float(e), "y0": float(h)} for e, h in zip(es, y0s)]
    R = len(sets)
    model = bouncing_ball.build()
    ends, counts = np.empty((R, 2)), np.empty(R, dtype=np.int64)
    hand_grid(es[:2], y0s[:2], T_END, RTOL, ATOL, ends, counts)
    hand_grid_parallel(es[:2], y0s[:2], T_END, RTOL, ATOL, ends, counts)
    simulate_batch(model, sets[:10], T_END, "RK45-jit", rtol=RTOL)

    from switching.kernel import batch as kernel_batch

    inside = []
    original = kernel_batch.run_many

    def timed_kernel(*arguments):
        t0 = time.perf_counter()
        original(*arguments)
        inside.append(time.perf_counter() - t0)

    hand = least(lambda: hand_grid(es, y0s, T_END, RTOL, ATOL, ends, counts), args.repeats)
    hand_events = counts.copy()
    parallel = least(lambda: hand_grid_parallel(es, y0s, T_END, RTOL, ATOL, ends, counts), args.repeats)
    kernel_batch.run_many = timed_kernel
    rounds = []

    def batch_round():
        inside.clear()
        simulate_batch(model, sets, T_END, "RK45-jit", rtol=RTOL)
        rounds.append(sum(inside))  # (the batch's kernel calls: the first set's, then the others')

    try:
        batched = least(batch_round, args.repeats)
    finally:
        kernel_batch.run_many = original
    batch = simulate_batch(model, sets, T_END, "RK45-jit", rtol=RTOL)

    def simulate_loop():
        runs = []
        for p in sets:
            model.set_parameter_values({"m": 1.0, "g": G, "e": p["e"], "v_rest": 0.0}, {"y0": p["y0"], "v0": 0.0})
            runs.append(model.simulate(T_END, "RK45-jit", rtol=RTOL, output="events"))
        return runs

    t0 = time.perf_counter()
    runs = simulate_loop()
    looped = time.perf_counter() - t0
    same = all(np.array_equal(r.x[-1], batch.x[k]) and np.array_equal(r.event_times, batch.event_times[k, :len(
        r.event_times)]) for k, r in enumerate(runs))
    t0 = time.perf_counter()
    simulate_many(model, sets, T_END, "RK45-jit", rtol=RTOL, output="events", trajectories=False)
    many = time.perf_counter() - t0

    print(f"{R} bouncing balls, e in [0.7, 0.9] x y0 in [1, 2] m, t_end {T_END} s, RK45 rtol {RTOL}: "
          f"{batch.event_counts.min()}-{batch.event_counts.max()} impacts (hand loop: {hand_events.min()}-"
          f"{hand_events.max()}); all {int(batch.in_kernel.sum())} in the batch's kernel call; the same ends and "
          f"instants as the simulate loop: {same}")
    print(f"{'row':20s}{'runs':>8s}{'time [s]':>11s}{'per run':>11s}{'ratio':>8s}")
    for name, seconds in [("hand loop", hand), ("hand loop, prange", parallel), ("simulate_batch", batched),
                          ("  its kernel calls", min(rounds)), ("simulate loop", looped), ("simulate_many", many)]:
        print(f"{name:20s}{R:8d}{seconds:11.3f}{seconds / R * 1e6:9.1f} µs{seconds / hand:8.1f}")
    if not args.no_cold:
        print(f"first batch of 100 in a new process (numba's disk cache warm): {cold_batch()} s")


if __name__ == "__main__":
    main()
