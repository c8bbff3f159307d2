"""Time to build and derive a chain of N mass–spring–damper cells.

    python benchmarks/chain_derivation.py [N ...]

Prints, per N: graph construction, causality, equations (median of several
runs, each on a freshly built graph so no cache helps), and the cost per cell.
The derivation should be far below a second at N = 50 and grow close to
linearly with N.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from models.graphs import msd_chain  # noqa: E402


def measure(n: int, repeats: int) -> dict:
    build, causality, equations = [], [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        graph = msd_chain(n)
        t1 = time.perf_counter()
        graph.causality()
        t2 = time.perf_counter()
        graph.equations()
        t3 = time.perf_counter()
        build.append(t1 - t0)
        causality.append(t2 - t1)
        equations.append(t3 - t2)
    return {
        "build": statistics.median(build),
        "causality": statistics.median(causality),
        "equations": statistics.median(equations),
    }


def main(sizes) -> None:
    print(f"{'N':>6} {'build [s]':>10} {'causality [s]':>14} {'equations [s]':>14} {'derive total [s]':>17} {'per cell [ms]':>14}")
    for n in sizes:
        repeats = 5 if n <= 200 else 3
        r = measure(n, repeats)
        total = r["causality"] + r["equations"]
        print(
            f"{n:>6} {r['build']:>10.4f} {r['causality']:>14.4f} {r['equations']:>14.4f} "
            f"{total:>17.4f} {1e3 * (r['build'] + total) / n:>14.3f}"
        )


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [5, 20, 50, 200, 500, 1000])
