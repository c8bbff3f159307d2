"""Runs per second of the falling rod's friction sweep with simulate_many on Dask.

    python benchmarks/batch_sweep.py [--runs N] [--method M] [--repeat R] [--workers 1,2]

A sweep of N friction coefficients μ ∈ [0.001, 0.01] (0.5 s each, events
output), timed

* in this process (``client="serial"``): the reference without Dask;
* on a LocalCluster of 1, 2, … worker processes of one thread each
  (``switching.local_cluster``, the one ``simulate_many`` starts by itself),
  after one sweep that warms the fresh workers (imports, models, kernels
  loaded from the disk cache; its time is shown apart, as are the cluster's
  start and the first compile of the kernels in this process).

Each row is the best of R sweeps (other load on a shared machine only
slows): the Dask rows' sweeps interleaved (a load that drifts hits them
alike), the reference's before the clusters start and after they close (a
scheduler and client in this process would take the GIL from its runs).
``speedup`` is against one Dask worker; ``overhead`` is the extra wall time
per run against the same runs in this process; ``in runs`` is the runs' own
time (build + simulate) summed over the workers: when it grows with the
workers, they did not get a core each (other load).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from models import falling_rod  # noqa: E402
from switching import local_cluster, simulate_many  # noqa: E402
from switching.sweep.batch import batch_size_for  # noqa: E402


def main(argv=None):
    from contextlib import ExitStack

    from dask.distributed import Client

    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--method", default="RK45-jit")
    parser.add_argument("--repeat", type=int, default=5, help="sweeps per row; the fastest is shown")
    parser.add_argument("--workers", default="1,2", help="LocalCluster sizes, comma-separated")
    args = parser.parse_args(argv)
    sets = [{"mu": float(mu)} for mu in np.linspace(0.001, 0.01, args.runs)]
    options = {"rtol": 1e-9, "atol": 1e-12, "output": "events"}
    warm = [sets[0], sets[len(sets) // 2], sets[-1]]  # both behaviours: every mode visited and compiled

    t0 = time.perf_counter()
    simulate_many(falling_rod.build, warm, 0.5, args.method, client="serial", **options)
    print(f"first use in this process (derive or load the modes, compile or load the kernels): "
          f"{time.perf_counter() - t0:.2f} s")
    serial_name = "1 process (serial)"
    where = {serial_name: (None, "serial")}
    best = {serial_name: (float("inf"), None)}

    def sweep(name, client):
        t0 = time.perf_counter()
        results = simulate_many(falling_rod.build, sets, 0.5, args.method, client=client, **options)
        wall = time.perf_counter() - t0
        if wall < best[name][0]:
            best[name] = (wall, results)
        return wall

    # the reference runs while no Dask scheduler or client shares this process (their event loops
    # would take the GIL from it): before the clusters start and after they close
    for _ in range(max(1, args.repeat)):
        sweep(serial_name, "serial")
    notes = [f"1 process: best {best[serial_name][0]:.2f} s before the clusters"]
    with ExitStack() as stack:
        for workers in [int(w) for w in args.workers.split(",")]:
            t0 = time.perf_counter()
            cluster = stack.enter_context(local_cluster(workers))  # the one simulate_many starts by itself
            client = stack.enter_context(Client(cluster, set_as_default=False))
            started = time.perf_counter() - t0
            t0 = time.perf_counter()
            simulate_many(falling_rod.build, sets, 0.5, args.method, client=client, **options)
            notes.append(f"{workers} worker(s): cluster start {started:.2f} s, first sweep on fresh workers "
                         f"{time.perf_counter() - t0:.2f} s, {batch_size_for(len(sets), workers)} runs per task")
            name = f"Dask, {workers} worker{'s' if workers > 1 else ''}"
            where[name], best[name] = (workers, client), (float("inf"), None)
        for _ in range(max(1, args.repeat)):  # interleaved: a load that drifts hits every row alike
            for name, (workers, client) in where.items():
                if workers:
                    sweep(name, client)
    after = min(sweep(serial_name, "serial") for _ in range(max(1, args.repeat)))
    notes[0] += f", {after:.2f} s after they closed (the best of both is shown)"

    serial = best[serial_name][0]
    one = next((best[name][0] for name, (w, _) in where.items() if w == 1), None)
    print(f"\n{len(sets)} falling-rod runs, {args.method}, 0.5 s each, best of {args.repeat}")
    print(f"{'where':<20} {'wall [s]':>9} {'runs/s':>8} {'speedup':>8} {'in runs [s]':>12} {'overhead/run':>13}")
    for name, (workers, _) in where.items():
        wall, results = best[name]
        in_runs = sum(r.wall_time for r in results)
        speedup = f"{one / wall:>8.2f}" if one and workers else f"{'':>8}"
        overhead = (f"{1e3 * (wall - serial) / len(sets):>+9.2f} ms ({100 * (wall - serial) / serial:+.0f}%)"
                    if workers == 1 else "")
        print(f"{name:<20} {wall:>9.2f} {len(sets) / wall:>8.1f} {speedup} {in_runs:>12.2f} {overhead}")
    print("in runs: the runs' own time (build + simulate), summed over workers; speedup: against 1 worker; "
          "overhead: against 1 process")
    print("\n".join(notes))
    sliding = sum(r.instants[0][-1][0].endswith(("slide_neg", "slide_pos")) for r in results if r.ok)
    print(f"{sliding} of {len(results)} runs slide right after impact (small μ), the rest stick; "
          f"failed runs: {sum(not r.ok for r in results)}")


if __name__ == "__main__":
    main()
