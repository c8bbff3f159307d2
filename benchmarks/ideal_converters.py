"""Converters drawn with ideal switches and diodes, against their closed forms.

    python benchmarks/ideal_converters.py

* a 100 kHz buck (12 V, D = 0.5, 100 µH, 100 µF, 5 Ω) with an ideal switch
  and an ideal freewheeling diode — each closing passes the shorted source as
  a mythical mode (DESIGN.md §6a) — run for 10 ms: the output's mean over the
  last five periods against D·V, the inductor current's ripple against
  V(1 − D)D·T/L (which holds for a constant output voltage; the filter's own
  ripple moves it by a few 1e-4), and the wall time per method;
* the capacitor-filtered ideal bridge (10 V, 50 Hz, 100 µF ‖ 100 Ω) with no
  gmin — its blocking diodes' voltages the limit of vanishing leaks
  (DESIGN.md §6b) — run for 50 ms: its instants against the exact piecewise
  solution.

Times are of a warm process (the modes derived once before), which is what
a study that runs a circuit many times meets.
"""

from __future__ import annotations

import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from models.circuits import Circuit  # noqa: E402
from models.netlists import ideal_buck  # noqa: E402


def buck():
    return ideal_buck().build()


def bridge():
    c = Circuit("bridge")
    c.V("Vs", "a", "0", "10*sin(2*pi*50*t)")
    c.diode("D1", "a", "p")
    c.diode("D2", "0", "p")
    c.diode("D3", "n", "a")
    c.diode("D4", "n", "0")
    c.C("C1", "p", "n", 100e-6)
    c.R("Rload", "p", "n", 100.0)
    return c.build()


def bridge_instants(t_end: float) -> list[float]:
    """The exact instants of the filtered bridge: the charging current reaches 0 at t_off, |v_s| meets
    the decaying v_C at t_on, every half period."""
    V, w, R, C = 10.0, 2 * math.pi * 50, 100.0, 100e-6
    half = math.pi / w
    t_off = (math.pi - math.atan(w * R * C)) / w
    decay = lambda t: V * math.sin(w * t_off) * math.exp(-(t - t_off) / (R * C))  # noqa: E731
    t_on = brentq(lambda t: -V * math.sin(w * t) - decay(t), half, 1.5 * half, xtol=1e-15)
    exact = []
    for k in range(10):
        exact += [t_off + k * half, t_on + k * half]
    return [t for t in exact if t < t_end]


def main() -> None:
    warnings.simplefilter("ignore")
    V, D, T, L = 12.0, 0.5, 1e-5, 100e-6
    print(f"{'circuit':<28} {'method':<6} {'wall [s]':>9}  result")
    for method in ("RK45", "auto"):
        model = buck()
        model.simulate(2e-4, method, max_step=T / 5, rtol=1e-9)  # derive and compile once
        start = time.perf_counter()
        run = model.simulate(0.01, method, max_step=T / 5, rtol=1e-9)
        seconds = time.perf_counter() - start
        last = run.t > 0.01 - 5 * T
        mean = float(np.mean(run.signal("v_out")[last]))
        i_L = run.signal("i_L1")[last]
        print(f"{'ideal buck, 100 kHz, 10 ms':<28} {method:<6} {seconds:>9.2f}  mean v_out {mean:.6f} V (D·V = "
              f"{D * V:g}), ripple {float(i_L.max() - i_L.min()):.6f} A (V(1-D)DT/L = {V * (1 - D) * D * T / L:g})")
    model = bridge()
    start = time.perf_counter()
    run = model.simulate(0.05, "RK45", rtol=1e-10, atol=1e-14)
    seconds = time.perf_counter() - start
    times = [e.t for k, e in enumerate(run.events)
             if k + 1 == len(run.events) or run.events[k + 1].t - e.t > 1e-12 * max(e.t, 1e-300)][1:]
    exact = bridge_instants(0.05)
    worst = max(abs(a - b) / b for a, b in zip(times, exact)) if len(times) == len(exact) else float("nan")
    print(f"{'ideal bridge, no gmin, 50 ms':<28} {'RK45':<6} {seconds:>9.2f}  {len(times)} instants "
          f"({len(exact)} exact), largest relative error {worst:.2e}")


if __name__ == "__main__":
    main()
