"""How long ``Circuit.build`` takes as circuits grow: sections, diodes, switches.

    python benchmarks/circuit_build.py

Each row builds one circuit (``Circuit.build()``, the floating check
included: :mod:`models.circuit_topology`) in this process and prints the
wall time; nothing is simulated.  The circuits:

* an RC ladder of N sections (a source, then N series resistors each with
  a capacitor to ground): no switch, nothing can float;
* a diode chain of N diodes, each node with a capacitor to ground: 2^N
  modes, none floats;
* N bridge rectifiers, each with its own source and an RC load: 2^(4N)
  modes, one floating part per bridge, each derived at the build in the
  limit of vanishing leaks (DESIGN.md §6b) — a run would derive it when
  it first blocks;
* N switches in parallel between a source and an RL load: a loop of ideal
  switches, its all-closed mode derived in the limit of vanishing
  resistances (the symbolic ε loop of N resistances is what costs).

Issue 41's targets: a 400-section RC ladder in under 2 s, a circuit of 24
switches in under 5 s.
"""

from __future__ import annotations

import time

from bondgraph.errors import FloatingPartError
from models.circuits import PWM, Circuit


def ladder(n: int) -> Circuit:
    c = Circuit("ladder")
    c.V("V1", "n0", "0", 1.0)
    for k in range(n):
        c.R(f"R{k}", f"n{k}", f"n{k + 1}", 1.0)
        c.C(f"C{k}", f"n{k + 1}", "0", 1e-3)
    return c


def diode_chain(n: int) -> Circuit:
    c = Circuit("diodes")
    c.V("V1", "n0", "0", "10*sin(2*pi*50*t)")
    for k in range(n):
        c.diode(f"D{k}", f"n{k}", f"n{k + 1}")
        c.C(f"C{k}", f"n{k + 1}", "0", 1e-6)
        c.R(f"R{k}", f"n{k + 1}", "0", 1e3)
    return c


def bridges(n: int) -> Circuit:
    c = Circuit("bridges")
    for k in range(n):
        c.V(f"V{k}", f"a{k}", "0", "325*sin(2*pi*50*t)")
        c.diode(f"D{k}_1", f"a{k}", f"p{k}")
        c.diode(f"D{k}_2", "0", f"p{k}")
        c.diode(f"D{k}_3", f"n{k}", f"a{k}")
        c.diode(f"D{k}_4", f"n{k}", "0")
        c.C(f"C{k}", f"p{k}", f"n{k}", 1e-3)
        c.R(f"R{k}", f"p{k}", f"n{k}", 100.0)
    return c


def parallel_switches(n: int) -> Circuit:
    c = Circuit("switches")
    c.V("V1", "in", "0", 12.0)
    c.R("Rs", "in", "a", 0.1)
    for k in range(n):
        c.switch(f"S{k}", "a", "b", PWM(1e-4, 0.5))
    c.L("L1", "b", "c", 1e-3)
    c.R("RL", "c", "0", 10.0)
    return c


def timed(make, n: int) -> tuple[float, str]:
    circuit = make(n)
    start = time.perf_counter()
    try:
        circuit.build()
        outcome = "built"
    except FloatingPartError as error:
        outcome = f"refused ({error.kind} floats with no limit)"
    return time.perf_counter() - start, outcome


def main() -> None:
    rows = [(ladder, n) for n in (100, 200, 400)] + [(diode_chain, n) for n in (10, 24)]
    rows += [(bridges, n) for n in (1, 3, 6)] + [(parallel_switches, n) for n in (2, 24)]
    print(f"{'circuit':<20} {'N':>4} {'modes':>10} {'build [s]':>10}  outcome")
    for make, n in rows:
        seconds, outcome = timed(make, n)
        switching = sum(p.kind in ("D", "S") for p in make(n)._parts.values())
        print(f"{make.__name__:<20} {n:>4} {'2^' + str(switching):>10} {seconds:>10.3f}  {outcome}")


if __name__ == "__main__":
    main()
