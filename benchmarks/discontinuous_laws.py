"""Discontinuous element laws (issue 13): steps, error and time per method.

    python benchmarks/discontinuous_laws.py

Two problems whose right-hand side jumps, written straight into element laws:

* a block (m = 1 kg, p0 = 2 kg·m/s) stopped by Coulomb friction
  ``e = μN·sign(f)`` (μN = 4.905 N), simulated to t = 1 s: it stops at
  t* = p0/(μN) and then rests — a sliding mode of the law switch;
* the bang-bang loop ``ẋ = 2·H(1 − x) − x`` from x = 0 to t = 3 s: it reaches
  x = 1 at t = ln 2 and slides along it.

Before law switches, rk4 stopped with a StiffnessError at t*, RK45 chattered
through about 10⁶ steps (210 s), LSODA took 63 s.  Printed per method: the
samples kept (every step), the error of the event time, the largest |p| (or
|x − 1|) after it, and the wall time of a second run (the modes derived).
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
import sympy as sp

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bondgraph import C, BondGraph, I, One, R, Se  # noqa: E402
from switching import HybridModel  # noqa: E402

METHODS = [("euler", {"dt": 1e-3}), ("rk4", {"dt": 1e-3}), ("RK45", {"rtol": 1e-6}), ("DOP853", {"rtol": 1e-6}),
           ("Radau", {"rtol": 1e-6}), ("BDF", {"rtol": 1e-6}), ("LSODA", {"rtol": 1e-6})]


def friction_block():
    g = BondGraph("block")
    v = g.add(One("v"))
    g.connect(v, I("m", "m"))
    g.connect(v, R("fr", effort_law=lambda f: sp.Symbol("mu") * sp.Symbol("N") * sp.sign(f)))
    return HybridModel(g, [], {"m": 1.0, "mu": 0.5, "N": 9.81}, initial_state={"p_m": 2.0})


def bang_bang():
    g = BondGraph("bang")
    j = g.add(One("j"))
    g.connect(Se("u", 2 * sp.Heaviside(1 - sp.Symbol("q_C"))), j)
    g.connect(j, C("C", 1))
    g.connect(j, R("R", 1))
    return HybridModel(g, [], {}, initial_state={"q_C": 0.0})


def row(name, model, t_end, t_event, state, target):
    for method, options in METHODS:
        model.simulate(t_end, method, **options)  # derive the modes first
        start = time.perf_counter()
        tr = model.simulate(t_end, method, **options)
        wall = time.perf_counter() - start
        error = abs(tr.events[0].t - t_event) if tr.events else math.nan
        after = tr.t > (tr.events[0].t if tr.events else t_end)
        drift = np.max(np.abs(tr.state(state)[after] - target)) if after.any() else math.nan
        print(f"{name:<16} {method:<7} {len(tr.t):>8} {error:>12.2e} {drift:>12.2e} {wall:>9.4f}")


def main():
    print(f"{'problem':<16} {'method':<7} {'samples':>8} {'event err':>12} {'after':>12} {'wall [s]':>9}")
    row("friction block", friction_block(), 1.0, 2.0 / (0.5 * 9.81), "p_m", 0.0)
    row("bang-bang", bang_bang(), 3.0, math.log(2.0), "q_C", 1.0)


if __name__ == "__main__":
    main()
