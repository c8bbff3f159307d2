"""Work–precision of every method: wall time versus error against exact answers.

    python benchmarks/work_precision.py [--quick] [--plot FILE.png]

Problems
  * bouncing ball (e = 0.8, y0 = 1, g = 9.81) to t = 2.5 s: error = the largest
    of |bounce time − closed form| over the four bounces and |y(2.5) − exact|;
  * rod pivoting on its tip (m = 1, J = 1/12, l = 0.5, from θ = 0.9 at rest) to
    t = 1 s: error = |θ(1) − reference|, the reference from DOP853 at rtol 1e-13.

Each row is the median wall time of several runs (after one warm-up run that
also generates — and for ``*-jit`` methods compiles — the code).  Prints a
table and saves a log–log plot.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from models import bouncing_ball  # noqa: E402
from models.graphs import pivoting_rod  # noqa: E402
from switching import HybridModel  # noqa: E402

G, E, Y0 = 9.81, 0.8, 1.0


def ball_exact(t_end):
    t1 = math.sqrt(2 * Y0 / G)
    v = G * t1
    times, t = [t1], t1
    while True:
        gap = 2 * E ** len(times) * v / G
        if t + gap > t_end:
            break
        t += gap
        times.append(t)
    v_up = E ** len(times) * v
    s = t_end - times[-1]
    return np.array(times), v_up * s - G * s * s / 2


def ball_error(trajectory, exact_times, exact_y):
    n = min(len(exact_times), len(trajectory.event_times))
    if n < len(exact_times):
        return math.inf
    time_error = np.max(np.abs(trajectory.event_times[:n] - exact_times[:n]))
    return max(time_error, abs(trajectory.state("y")[-1] - exact_y))


def rod_model():
    model = HybridModel(pivoting_rod(), [], {"m": 1.0, "J": 1 / 12, "l": 0.5, "g": 9.81},
                        initial_state={"rod/theta": 0.9})
    # start on the constraint: x and y of the centre follow from the pinned tip at the origin
    return model


def timed(run, repeats):
    run()  # warm-up: code generation
    samples = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = run()
        samples.append(time.perf_counter() - t0)
    return statistics.median(samples), result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer settings and repeats")
    parser.add_argument("--plot", default=str(Path(__file__).with_name("work_precision.png")))
    args = parser.parse_args(argv)
    repeats = 3 if args.quick else 5
    fixed = {"euler": [1e-2, 1e-3, 1e-4], "rk4": [1e-1, 3e-2, 1e-2, 3e-3]}
    rtols = [1e-3, 1e-6, 1e-9] if args.quick else [1e-3, 1e-5, 1e-7, 1e-9, 1e-11]
    adaptive = ["RK45", "DOP853", "Radau", "BDF", "LSODA"]
    from codegen.jit import available

    if available():  # the compiled path (pip install .[fast])
        fixed["rk4-jit"] = fixed["rk4"]
        adaptive.append("RK45-jit")

    ball = bouncing_ball.build()
    exact_times, exact_y = ball_exact(2.5)
    rod = rod_model()
    reference = rod.simulate(1.0, "DOP853", rtol=1e-13, atol=1e-14).state("rod/theta")[-1]

    rows = []
    for problem, model, t_end, error_of in (
        ("bouncing ball", ball, 2.5, lambda tr: ball_error(tr, exact_times, exact_y)),
        ("pivoting rod", rod, 1.0, lambda tr: abs(tr.state("rod/theta")[-1] - reference)),
    ):
        for method, steps in fixed.items():
            for dt in steps:
                wall, tr = timed(lambda: model.simulate(t_end, method, dt=dt, output="events"), repeats)
                rows.append((problem, method, f"dt={dt:g}", wall, error_of(tr), tr.stats["steps"]))
        for method in adaptive:
            for rtol in rtols:
                atol = rtol * 1e-3
                wall, tr = timed(lambda: model.simulate(t_end, method, rtol=rtol, atol=atol, output="events"), repeats)
                rows.append((problem, method, f"rtol={rtol:g}", wall, error_of(tr), tr.stats["steps"]))

    print(f"{'problem':<14} {'method':<7} {'setting':<12} {'wall [ms]':>10} {'error':>10} {'steps':>7}")
    for problem, method, setting, wall, error, steps in rows:
        print(f"{problem:<14} {method:<7} {setting:<12} {1e3 * wall:>10.3f} {error:>10.2e} {steps:>7}")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, problem in zip(axes, ("bouncing ball", "pivoting rod")):
        for method in list(fixed) + adaptive:
            pts = [(r[4], r[3]) for r in rows if r[0] == problem and r[1] == method and r[4] > 0 and math.isfinite(r[4])]
            if pts:
                err, wall = zip(*pts)
                ax.loglog(err, np.array(wall) * 1e3, "o-", label=method)
        ax.set_title(problem)
        ax.set_xlabel("error")
        ax.set_ylabel("wall time [ms]")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.plot, dpi=120)
    print(f"plot saved to {args.plot}")


if __name__ == "__main__":
    main()
