"""What measurements cost beside the run they measure: a 10 000-period converter run.

    python benchmarks/measurements.py [PERIODS]

The boost converter (10 kHz) runs PERIODS periods (default 10 000, 1 s) with the Python RK45 path and
with the compiled RK45-jit path, keeping its steps; then ``run.measure`` takes, over the last 10 periods
and over the whole run, the mean and RMS of ``v_C`` (one quadrature), its ripple (the extremes searched
in every piece), and the efficiency into ``R_load`` (two power flows).  Each measurement integrates the
run's flow piece by piece (``switching/simulate/measurements.py``: 4 Gauss nodes on the cubic Hermite
interpolant of every step), so its cost grows with the run's steps, not with its length.  Issue 42's
target: measurements on a 10 000-period run under 5 % of the run.  Times depend on the machine and its
load; the first column of each row is the run's own wall time.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from models import boost_converter  # noqa: E402

F_SW = 10e3
MEASURES = {"mean, rms of v_C": ("v_C", ["mean", "rms"]), "ripple of v_C": ("v_C", "ripple"),
            "efficiency into R_load": ("R_load", "efficiency")}


def timed(call):
    start = time.perf_counter()
    value = call()
    return value, time.perf_counter() - start


def main() -> None:
    periods = int(sys.argv[1]) if len(sys.argv) > 1 else 10_000
    t_end = periods / F_SW
    model = boost_converter.build()
    short = model.simulate(10 / F_SW, "RK45-jit")  # (the kernel compiled, the modes derived: runs are timed)
    _, cold = timed(lambda: [short.measure(s, w) for s, w in MEASURES.values()])
    print(f"boost converter, {periods} periods ({t_end:g} s); the first measurements of this process (each mode's "
          f"numpy functions generated, on a 10-period run): {cold:.3f} s")
    print(f"{'method':10} {'run [s]':>8} {'steps':>8}  {'measurement':24} {'window':>14} {'time [s]':>9} "
          f"{'of the run':>10}")
    for method in ("RK45", "RK45-jit"):
        run, wall = timed(lambda: model.simulate(t_end, method))
        for label, (signal, what) in MEASURES.items():
            for window_name, window in (("last 10 periods", dict(periods=10, period=1 / F_SW)),
                                        ("whole run", {})):
                _, spent = timed(lambda: run.measure(signal, what, **window))
                print(f"{method:10} {wall:8.3f} {len(run.t):8d}  {label:24} {window_name:>14} {spent:9.4f} "
                      f"{100 * spent / wall:9.1f}%")


if __name__ == "__main__":
    main()
