"""Runs per second of the falling rod's friction sweep with simulate_many.

    python benchmarks/batch_sweep.py [--runs N] [--method M] [--repeat R]

Times a sweep of N friction coefficients μ ∈ [0.001, 0.01] (0.5 s each),
on one worker and on all cores, after one warm-up run that fills the caches;
the best of R sweeps is shown (other load on a shared machine only slows).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from models import falling_rod  # noqa: E402
from switching import simulate_many  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--method", default="RK45-jit")
    parser.add_argument("--repeat", type=int, default=1, help="sweeps per row; the fastest is shown")
    args = parser.parse_args(argv)
    sets = [{"mu": float(mu)} for mu in np.linspace(0.001, 0.01, args.runs)]
    options = {"rtol": 1e-9, "atol": 1e-12, "output": "events"}
    warm = [sets[0], sets[len(sets) // 2], sets[-1]]  # both behaviours: every mode compiled before timing
    simulate_many(falling_rod.build, warm, 0.5, args.method, workers=1, **options)
    print(f"{'workers':>7} {'runs':>5} {'wall [s]':>9} {'runs/s':>8}")
    for workers in sorted({1, os.cpu_count() or 1}):
        wall = float("inf")
        for _ in range(max(1, args.repeat)):
            t0 = time.perf_counter()
            results = simulate_many(falling_rod.build, sets, 0.5, args.method, workers=workers, **options)
            wall = min(wall, time.perf_counter() - t0)
        print(f"{workers:>7} {len(results):>5} {wall:>9.2f} {len(results) / wall:>8.1f}")
    sliding = sum(r.instants[0][-1][0].endswith(("slide_neg", "slide_pos")) for r in results if r.ok)
    print(f"{sliding} of {len(results)} runs slide right after impact (small μ), the rest stick; "
          f"failed runs: {sum(not r.ok for r in results)}")


if __name__ == "__main__":
    main()
