"""Circuits that grow with a number, built with :class:`~models.circuits.Circuit`: the scale cases of
the floating check (:mod:`models.circuit_topology`), used by ``benchmarks/circuit_build.py`` and its
tests.  Each returns the unbuilt :class:`Circuit` (build it with the options under study)."""

from __future__ import annotations

from .circuits import PWM, Circuit

__all__ = ["ladder", "diode_chain", "bridges", "parallel_switches", "ideal_buck"]


def ladder(n: int) -> Circuit:
    """An RC ladder: a 1 V source, then ``n`` sections of a 1 Ω series resistor and a 1 mF capacitor
    to ground.  No switch: nothing can float."""
    c = Circuit("ladder")
    c.V("V1", "n0", "0", 1.0)
    for k in range(n):
        c.R(f"R{k}", f"n{k}", f"n{k + 1}", 1.0)
        c.C(f"C{k}", f"n{k + 1}", "0", 1e-3)
    return c


def diode_chain(n: int) -> Circuit:
    """``n`` ideal diodes in series from a 10 V, 50 Hz source, each node with 1 µF and 1 kΩ to ground:
    2^n modes, none floats."""
    c = Circuit("diodes")
    c.V("V1", "n0", "0", "10*sin(2*pi*50*t)")
    for k in range(n):
        c.diode(f"D{k}", f"n{k}", f"n{k + 1}")
        c.C(f"C{k}", f"n{k + 1}", "0", 1e-6)
        c.R(f"R{k}", f"n{k + 1}", "0", 1e3)
    return c


def bridges(n: int) -> Circuit:
    """``n`` full-wave bridge rectifiers, each with its own 325 V, 50 Hz source and a 1 mF ‖ 100 Ω load
    between its nodes ``p<k>`` and ``n<k>``: 2^(4n) modes; each load floats while its diodes all block."""
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
    """``n`` ideal PWM switches (10 kHz, D = 0.5) in parallel between a 12 V source with 0.1 Ω and an
    RL load (1 mH, 10 Ω): closed together, the current circulating among them is free."""
    c = Circuit("switches")
    c.V("V1", "in", "0", 12.0)
    c.R("Rs", "in", "a", 0.1)
    for k in range(n):
        c.switch(f"S{k}", "a", "b", PWM(1e-4, 0.5))
    c.L("L1", "b", "c", 1e-3)
    c.R("RL", "c", "0", 10.0)
    return c


def ideal_buck(period: float = 1e-5, duty: float = 0.5) -> Circuit:
    """A buck converter drawn with an ideal switch and an ideal freewheeling diode: 12 V, 100 µH, 100 µF,
    5 Ω (each closing shorts the source through the conducting diode: DESIGN.md §6a)."""
    c = Circuit("buck")
    c.V("V1", "in", "0", 12.0)
    c.switch("S1", "in", "sw", PWM(period, duty))
    c.diode("D1", "0", "sw")
    c.L("L1", "sw", "out", 100e-6)
    c.C("C1", "out", "0", 100e-6)
    c.R("R1", "out", "0", 5.0)
    return c
