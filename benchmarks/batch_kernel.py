"""10 000 bouncing balls in one call: the batch on the compiled path against a hand loop.

    python benchmarks/batch_kernel.py [--grid 100] [--repeats 3] [--no-cold]

The runs: the bouncing ball (``models.bouncing_ball``) over a grid of restitution
``e ∈ [0.7, 0.9]`` and drop height ``y0 ∈ [1, 2] m`` (``--grid`` values of each:
100 × 100 = 10 000 runs), each to ``t_end = 2 s`` (2 to 4 bounces) with RK45 at
``rtol = 1e-8``.  Rows (each the least of ``--repeats`` rounds, warm: compiled and
loaded first):

  hand loop          ``benchmarks/compiled_speed.py``'s hand-written @njit RK45
                     (Dormand–Prince 5(4), scipy's step control) with the impact
                     located by bisection on the dense output and ``v⁺ = −e·v``,
                     one compiled call looping over the runs on one thread;
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
    hand loop              0.035 s       3.5 µs     1.0
    hand loop, prange      0.019 s       1.9 µs     0.5
    simulate_batch         0.602 s      60.2 µs    17.2
      its kernel calls     0.088 s       8.8 µs     2.5
    simulate loop          1.71 s      171 µs      48.6
    simulate_many          2.12 s      212 µs      60.4

    (a copy of the hand loop for the ball alone, without the problem's dispatch, took 3.2 µs a run:
    the batch is 19× that)

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
from compiled_speed import rk45_run as hand_ball  # noqa: E402  (its hand-written loop)

G = 9.81
T_END = 2.0
RTOL = 1e-8
ATOL = 1e-9


@njit(cache=True)
def hand_grid(es, y0s, t_end, rtol, atol, ends, counts):
    """The hand loop (``compiled_speed``'s, problem 0: the ball) for every run, one thread."""
    for r in range(es.shape[0]):
        y, k = hand_ball(0, np.array([y0s[r], 0.0]), 0.0, t_end, rtol, atol, es[r])
        ends[r, 0], ends[r, 1], counts[r] = y[0], y[1], k


@njit(cache=True, parallel=True)
def hand_grid_parallel(es, y0s, t_end, rtol, atol, ends, counts):
    """The hand loop for every run, over the cores."""
    for r in prange(es.shape[0]):
        y, k = hand_ball(0, np.array([y0s[r], 0.0]), 0.0, t_end, rtol, atol, es[r])
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
