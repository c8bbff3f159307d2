"""How long the plot of a long run takes: a million samples, thousands of mode intervals.

    python benchmarks/plot_long_run.py

Each row simulates a shipped converter (its kernel compiled and its modes derived by a first, short run),
then times ``trajectory.plot()`` and ``savefig`` of the PNG separately.  The plot draws a panel of more
than ``MAX_POINTS`` samples as its min–max envelope, and shades more than ``MAX_SPANS`` mode intervals per
column (``switching/simulate/plotting.py``), so its cost does not grow with the run.  Issue 44's target: a
10⁶-sample run plotted in about a second.  Times depend on the machine and its load.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from models import boost_converter  # noqa: E402
from models.netlists import ideal_buck  # noqa: E402

SCENES = {
    "boost converter, 0.2 s, 10^6 samples": (boost_converter.build, 0.2, dict(samples=1_000_000)),
    "ideal buck 100 kHz, 20 ms, every step": (lambda: ideal_buck().build(), 0.02, {}),
}


def main() -> None:
    print(f"{'run':42} {'samples':>9} {'instants':>9} {'plot [s]':>9} {'save [s]':>9}")
    with tempfile.TemporaryDirectory() as folder:
        for name, (build, t_end, options) in SCENES.items():
            model = build()
            model.simulate(t_end / 100, "auto")  # (compiled, modes derived: the plot is what is timed)
            run = model.simulate(t_end, "auto", **options)
            start = time.perf_counter()
            figure = run.plot()
            drawn = time.perf_counter()
            figure.savefig(Path(folder, "plot.png"))
            saved = time.perf_counter()
            print(f"{name:42} {len(run.t):9d} {len(run.events):9d} {drawn - start:9.2f} {saved - drawn:9.2f}")


if __name__ == "__main__":
    main()
