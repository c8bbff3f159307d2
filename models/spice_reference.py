"""Circuits run in the toolkit and in ngspice with the same device laws: the SPICE comparison's reference.

Each circuit is described once, as a list of parts, and built both ways:
:func:`circuit` gives the toolkit's :class:`~models.circuits.Circuit`,
:func:`netlist` the SPICE netlist, :func:`run_ngspice` runs ngspice on it
and reads its waveforms back.  The parts are

* ``("R" | "C" | "L", name, node, node, value)`` [Ω, F, H];
* ``("V", name, plus, minus, Sine(amplitude, frequency))`` or a number [V];
* ``("D", name, anode, cathode)``: an exponential diode — SPICE's ``D`` with
  ``IS`` = :data:`SATURATION_CURRENT`, ``N = 1``, no series resistance and no
  charge storage, beside which ngspice puts its ``GMIN`` conductance.  The
  toolkit builds it as a resistor with SPICE's law,
  ``i = IS·(exp(v/VT) − 1) + GMIN·v`` with ``VT = k·T/q`` at SPICE's nominal
  27 °C (300.15 K), so that both solve the same equations: what differs is
  the methods' error, not the models.

Node ``"0"`` is ground in both.  ngspice is a Debian package (``ngspice``);
:func:`ngspice_available` says whether it is on the path.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import sympy as sp

from .circuits import Circuit

__all__ = ["Sine", "CIRCUITS", "THERMAL_VOLTAGE", "SATURATION_CURRENT", "GMIN", "circuit", "netlist",
           "run_ngspice", "ngspice_available", "diode_law"]

BOLTZMANN = 1.380649e-23  # J/K
CHARGE = 1.602176634e-19  # C
#: SPICE's nominal temperature TNOM = 27 °C [K]
NOMINAL_TEMPERATURE = 300.15
#: k·T/q at TNOM [V]
THERMAL_VOLTAGE = BOLTZMANN * NOMINAL_TEMPERATURE / CHARGE
#: the diodes' saturation current IS [A]
SATURATION_CURRENT = 1e-12
#: ngspice's default GMIN [S], across every junction
GMIN = 1e-12


@dataclass(frozen=True)
class Sine:
    """``amplitude·sin(2π·frequency·t)`` [V], SPICE's ``SIN(0 amplitude frequency)``."""

    amplitude: float
    frequency: float


def diode_law(v):
    """SPICE's diode current [A] at the voltage ``v`` [V] across it (anode to cathode), with GMIN."""
    return SATURATION_CURRENT * (sp.exp(v / THERMAL_VOLTAGE) - 1) + GMIN * v


def circuit(name: str, parts) -> Circuit:
    """The toolkit's circuit of ``parts`` (see the module docstring); ``name`` in any words (made an
    identifier: ``"half-wave, line R"`` → ``half_wave_line_R``)."""
    c = Circuit(re.sub(r"\W+", "_", name).strip("_"))
    for part in parts:
        kind, label, a, b = part[:4]
        if kind == "D":
            c.R(label, a, b, flow_law=diode_law)
        elif kind == "V":
            value = part[4]
            c.V(label, a, b, f"{value.amplitude!r}*sin(2*pi*{value.frequency!r}*t)" if isinstance(value, Sine)
                else float(value))
        else:
            getattr(c, kind)(label, a, b, float(part[4]))
    return c


def netlist(name: str, parts, t_end: float, step: float, nodes) -> str:
    """The SPICE netlist of ``parts``: a transient analysis to ``t_end`` [s] with steps of at most
    ``step`` [s], writing the voltages of ``nodes`` to ``out.txt`` (ngspice's ``wrdata``)."""
    lines = [f"* {name}"]
    for part in parts:
        kind, label, a, b = part[:4]
        if kind == "D":
            lines.append(f"D{label} {a} {b} dhbg")
        elif kind == "V":
            value = part[4]
            source = f"SIN(0 {value.amplitude!r} {value.frequency!r})" if isinstance(value, Sine) else f"DC {value!r}"
            lines.append(f"V{label} {a} {b} {source}")
        else:
            lines.append(f"{kind}{label} {a} {b} {float(part[4])!r}")
    lines += [f".model dhbg D(IS={SATURATION_CURRENT!r} N=1)",
              f".options reltol=1e-7 abstol=1e-14 vntol=1e-10 gmin={GMIN!r} temp=27 tnom=27",
              f".tran {step!r} {t_end!r} 0 {step!r}",
              ".control", "run", "wrdata out.txt " + " ".join(f"v({n})" for n in nodes), "quit", ".endc", ".end"]
    return "\n".join(lines) + "\n"


def ngspice_available() -> bool:
    """Is ``ngspice`` on the path?"""
    return shutil.which("ngspice") is not None


def run_ngspice(name: str, parts, t_end: float, step: float, nodes, timeout: float = 600.0):
    """``(times, {node: voltages})`` of ngspice's transient run of ``parts`` (arrays [s], [V]).  Raises
    ``FileNotFoundError`` without ngspice, ``RuntimeError`` (with its output) when it fails."""
    executable = shutil.which("ngspice")
    if executable is None:
        raise FileNotFoundError("ngspice is not installed (Debian: apt-get install ngspice)")
    with tempfile.TemporaryDirectory(prefix="hbg-spice-") as folder:
        Path(folder, "circuit.cir").write_text(netlist(name, parts, t_end, step, nodes))
        done = subprocess.run([executable, "-b", "circuit.cir"], cwd=folder, capture_output=True, text=True,
                              timeout=timeout)
        out = Path(folder, "out.txt")
        if done.returncode != 0 or not out.exists():
            raise RuntimeError(f"ngspice failed on {name!r} (exit {done.returncode}):\n{done.stdout[-2000:]}"
                               f"\n{done.stderr[-2000:]}")
        table = np.loadtxt(out, ndmin=2)
    times = table[:, 0]
    return times, {node: table[:, 2 * k + 1] for k, node in enumerate(nodes)}


LINE = Sine(10.0, 50.0)

#: the comparison's circuits: name → (parts, nodes compared, t_end [s], ngspice's largest step [s])
CIRCUITS = {
    "half-wave": ([("V", "Vs", "s", "0", LINE), ("D", "D1", "s", "p"), ("C", "C1", "p", "0", 100e-6),
                   ("R", "RL", "p", "0", 1e3)], ("p",), 0.1, 1e-6),
    "half-wave, line R": ([("V", "Vs", "s", "0", LINE), ("R", "Rs", "s", "x", 1.0), ("D", "D1", "x", "p"),
                           ("C", "C1", "p", "0", 100e-6), ("R", "RL", "p", "0", 1e3)], ("p",), 0.1, 1e-6),
    "half-wave, line R and L": ([("V", "Vs", "s", "0", LINE), ("R", "Rs", "s", "x", 1.0),
                                 ("L", "Ls", "x", "y", 1e-3), ("D", "D1", "y", "p"),
                                 ("C", "C1", "p", "0", 100e-6), ("R", "RL", "p", "0", 1e3)], ("p",), 0.1, 1e-6),
    "bridge, line R": ([("V", "Vs", "s", "0", LINE), ("R", "Rs", "s", "x", 1.0), ("D", "D1", "x", "p"),
                        ("D", "D2", "0", "p"), ("D", "D3", "n", "x"), ("D", "D4", "n", "0"),
                        ("C", "C1", "p", "n", 100e-6), ("R", "RL", "p", "n", 1e3),
                        # node capacitances (in both): each node's potential a state, no nonlinear loop
                        ("C", "Cx", "x", "0", 100e-9), ("C", "Cp", "p", "0", 100e-9)], ("p", "n"), 0.1, 1e-6),
}

