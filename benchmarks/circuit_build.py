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
  resistances (the symbolic ε loop of N resistances is what costs: beyond
  the symbolic budget, 5 s by default, the circuit is refused as before).

Issue 41's targets: a 400-section RC ladder in under 2 s, a circuit of 24
switches in under 5 s.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bondgraph.errors import FloatingPartError  # noqa: E402
from models.netlists import bridges, diode_chain, ladder, parallel_switches  # noqa: E402


def timed(make, n: int) -> tuple[float, str]:
    circuit = make(n)
    start = time.perf_counter()
    try:
        circuit.build()
        outcome = "built"
    except FloatingPartError as error:
        outcome = f"refused ({error.kind} floats; no limit found within the symbolic budget)"
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
