"""The toolkit against ngspice, side by side.

    python benchmarks/spice.py

Needs ngspice on the path (Debian: ``apt-get install ngspice``).  Two tables:

* **the same device laws** (``models/spice_reference.py``): rectifiers whose
  diodes are SPICE's exponential diode (IS = 1e-12, N = 1, GMIN across it,
  27 °C) in both — half-wave, with line resistance, with line resistance and
  inductance, and a full bridge with line resistance.  Each is run in ngspice
  (reltol 1e-7, steps of at most 1 µs) and in the toolkit with the default
  method and options, then with tight ones; the largest difference of the
  output over ngspice's own time points, and the wall times (ngspice's
  process, the toolkit's ``simulate`` call in a warm process);
* **ideal switches**: a filtered bridge with line resistance (325 V, 50 Hz,
  0.5 Ω, 1 mF ‖ 100 Ω) and a 100 kHz buck (12 V, D = 0.5, 100 µH, 100 µF,
  5 Ω), ideal in the toolkit and SPICE's device models in ngspice (its
  diode with N = 1; a switch with RON = 1 µΩ, ROFF = 1 TΩ): the
  output's mean over the last period and the wall time per simulated period.
  ngspice gives up on the bridge ("Timestep too small" at 5.66 ms, the first
  instant at which all four diodes block and the load floats — also with
  N = 0.01 or 0.1, a 1 GΩ resistor to ground or ``rshunt``); the table says so.

Times depend on the machine and its load; ratios hold better.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from models import spice_reference as S  # noqa: E402
from models.circuits import Circuit  # noqa: E402
from models.netlists import ideal_buck  # noqa: E402

#: the tight options
TIGHT = dict(rtol=1e-9, atol=1e-12)


def same_laws() -> None:
    print("same device laws: max |Δv| over ngspice's time points [V], wall times [s]")
    print(f"{'circuit':26} {'ngspice':>8} {'default':>8} {'max |Δv|':>10} {'tight':>8} {'max |Δv|':>10}")
    for name, (parts, nodes, t_end, step) in S.CIRCUITS.items():
        start = time.perf_counter()
        times, voltages = S.run_ngspice(name, parts, t_end, step, nodes)
        spice_seconds = time.perf_counter() - start
        model = S.circuit(name, parts).build()
        model.simulate(t_end, "auto", **TIGHT)  # (warm: modes derived, kernels compiled)
        reference = voltages[nodes[0]] - (voltages[nodes[1]] if len(nodes) > 1 else 0.0)
        row = [f"{name:26}", f"{spice_seconds:8.2f}"]
        for options in ({}, TIGHT):
            start = time.perf_counter()
            run = model.simulate(t_end, "auto", t_eval=times, **options)
            seconds = time.perf_counter() - start
            ours = run.signal(f"v_{nodes[0]}") - (run.signal(f"v_{nodes[1]}") if len(nodes) > 1 else 0.0)
            row += [f"{seconds:8.2f}", f"{np.max(np.abs(ours - reference)):10.2e}"]
        print(" ".join(row))


def spice_run(text: str, node_expression: str):
    """``(seconds, times, values, failure)`` of ngspice on ``text`` (a netlist without its control
    block); ``failure`` the line where ngspice gave up (``None`` when it ran to the end)."""
    with tempfile.TemporaryDirectory(prefix="hbg-spice-") as folder:
        Path(folder, "c.cir").write_text(text + f".control\nrun\nwrdata out.txt {node_expression}\nquit\n.endc\n.end\n")
        start = time.perf_counter()
        done = subprocess.run(["ngspice", "-b", "c.cir"], cwd=folder, capture_output=True, text=True, timeout=600)
        seconds = time.perf_counter() - start
        failure = next((line.strip() for line in done.stdout.splitlines() + done.stderr.splitlines()
                        if "Timestep too small" in line), None)
        out = Path(folder, "out.txt")
        table = np.loadtxt(out, ndmin=2) if out.exists() else np.zeros((1, 2))
    return seconds, table[:, 0], table[:, 1], failure


def last_period_mean(t, v, period):
    keep = t >= t[-1] - period
    return float(np.trapezoid(v[keep], t[keep]) / (t[keep][-1] - t[keep][0]))


def ideal_switches() -> None:
    print("\nideal switches (toolkit) against device models (ngspice's diode, N = 1; a switch of RON = 1 µΩ,"
          " ROFF = 1 TΩ): mean output over the last period [V]")
    print(f"{'circuit':26} {'periods':>7} {'ngspice s/period':>16} {'toolkit s/period':>16} {'ngspice mean':>12} "
          f"{'toolkit mean':>12}")
    # the filtered bridge with line resistance, 10 periods of 50 Hz
    bridge = Circuit("bridge")
    bridge.V("Vs", "s", "0", "325*sin(2*pi*50*t)")
    bridge.R("Rs", "s", "x", 0.5)
    for name, a, b in (("D1", "x", "p"), ("D2", "0", "p"), ("D3", "n", "x"), ("D4", "n", "0")):
        bridge.diode(name, a, b)
    bridge.C("C1", "p", "n", 1e-3)
    bridge.R("RL", "p", "n", 100.0)
    netlist = ("* bridge\nVs s 0 SIN(0 325 50)\nRs s x 0.5\nD1 x p dn\nD2 0 p dn\nD3 n x dn\nD4 n 0 dn\n"
               "C1 p n 1m\nRL p n 100\n.model dn D(IS=1e-12 N=1)\n.options reltol=1e-6\n.tran 1u 0.2 0 10u\n")
    _row("bridge, ideal diodes", bridge.build(), "v_RL", netlist, "v(p,n)", 0.2, 0.02)
    # the buck, 1000 periods of 100 kHz
    buck = ideal_buck()
    netlist = ("* buck\nV1 in 0 DC 12\nVg g 0 PULSE(0 1 0 1n 1n 4.999u 10u)\nS1 in sw g 0 sw\nD1 0 sw dn\n"
               "L1 sw out 100u\nC1 out 0 100u\nR1 out 0 5\n.model sw SW(VT=0.5 VH=0 RON=1e-6 ROFF=1e12)\n"
               ".model dn D(IS=1e-12 N=1)\n.options reltol=1e-6\n.tran 10n 10m 0 100n\n")
    _row("buck, ideal switch+diode", buck.build(), "v_out", netlist, "v(out)", 1e-2, 1e-5)


def _row(name, model, signal, netlist, node_expression, t_end, period):
    spice_seconds, t_s, v_s, failure = spice_run(netlist, node_expression)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.simulate(t_end, "auto")  # warm
        start = time.perf_counter()
        model.simulate(t_end, "auto")
        seconds = time.perf_counter() - start
        dense = model.simulate(t_end, "auto", t_eval=np.linspace(t_end - period, t_end, 2001))
    periods = t_end / period
    ours = last_period_mean(dense.t, dense.signal(signal), period)
    if failure:
        spice = f"ngspice aborted at t = {t_s[-1]:.4g} s ({failure.split(':')[-1].strip()})"
        print(f"{name:26} {periods:7.0f} {'—':>16} {seconds / periods:16.2e} {'—':>12} {ours:12.6f}   {spice}")
        return
    print(f"{name:26} {periods:7.0f} {spice_seconds / periods:16.2e} {seconds / periods:16.2e} "
          f"{last_period_mean(t_s, v_s, period):12.6f} {ours:12.6f}")


def main() -> None:
    if shutil.which("ngspice") is None:
        print("ngspice is not installed (Debian: apt-get install ngspice)")
        return
    same_laws()
    ideal_switches()


if __name__ == "__main__":
    main()
