"""Ready-made bond graphs (no switching logic yet): the building blocks of the
paper's examples and classic textbook systems.

Each function returns a :class:`bondgraph.BondGraph`; :data:`GRAPHS` maps a
name to its builder (used by ``hbg equations NAME``).

    >>> from models.graphs import pivoting_rod
    >>> eq = pivoting_rod().equations()
    >>> [s.name for s in eq.dependent]
    ['rod/p_x', 'rod/p_y']
"""

from __future__ import annotations

import sympy as sp

from bondgraph import GY, BondGraph, C, I, One, R, Se, Sf, Zero, t

from .components import msd_cell, rigid_planar_body, rlc_cell

__all__ = ["series_rlc", "msd_chain", "rlc_ladder", "pivoting_rod", "parallel_capacitors", "switched_rl", "dc_motor", "GRAPHS"]


def series_rlc() -> BondGraph:
    """Voltage source ``V0`` driving R, L and C in series (one 1-junction).

    ``dp_L/dt = V0 − R p_L/L − q_C/C``, ``dq_C/dt = p_L/L``.
    """
    g = BondGraph("series_rlc")
    j = g.add(One("i"))
    g.connect(Se("V", "V0"), j)
    for el in (R("R", "R"), I("L", "L"), C("C", "C")):
        g.connect(j, el)
    return g


def msd_chain(n: int = 5, force: bool = True) -> BondGraph:
    """``n`` masses in a row, each tied to the previous one (the first to a
    wall) by a spring ``k`` and damper ``c``; a force ``F`` pulls the last.

    For ``i = 1..n`` with ``v_0 = 0``, ``v_i = p_i/m``, ``F_i = k q_i + c (v_{i−1} − v_i)``:
    ``dq_i/dt = v_{i−1} − v_i``, ``dp_i/dt = F_i − F_{i+1}`` with ``F_{n+1} = −F``.
    """
    chain = BondGraph(f"msd_chain_{n}")
    cell = msd_cell()
    previous = chain.add(Sf("wall", 0))
    for i in range(1, n + 1):
        inst = chain.add_submodel(cell, f"cell{i}", share=["m", "k", "c"])
        chain.connect(previous, inst.port("in"))
        previous = inst.port("mass")
    if force:
        chain.connect(Se("pull", "F"), previous)
    return chain


def rlc_ladder(n: int = 3) -> BondGraph:
    """A voltage source feeding ``n`` RLC sections in a ladder, with per-section parameters."""
    g = BondGraph(f"rlc_ladder_{n}")
    cell = rlc_cell()
    previous = g.add(Se("V", "V0"))
    for i in range(1, n + 1):
        inst = g.add_submodel(cell, f"cell{i}")
        g.connect(previous, inst.port("in"))
        previous = inst.port("out")
    return g


def pivoting_rod() -> BondGraph:
    """A thin rod whose tip is pinned (tip velocity held at zero by two
    Sf = 0): :func:`models.components.rigid_planar_body` plus the pin.

    Independent states: ``rod/p_J``, the displacements; ``rod/p_x``, ``rod/p_y``
    are dependent.  ``dω/dt = −m g l cos θ / (J + m l²)``.
    """
    g = BondGraph("pivoting_rod")
    rod = g.add_submodel(rigid_planar_body(), "rod", share=["m", "J", "l", "g"])
    g.connect(rod.port("tip_x"), Sf("pin_x", 0))
    g.connect(rod.port("tip_y"), Sf("pin_y", 0))
    return g


def parallel_capacitors() -> BondGraph:
    """Two capacitors joined through a controlled 1-junction ``switch``.

    Closed, the two share one voltage, so ``C2`` is dependent:
    ``q_C2 = C2 q_C1 / C1``; open, both charges are independent and constant."""
    g = BondGraph("parallel_capacitors")
    n1, n2 = g.add(Zero("n1")), g.add(Zero("n2"))
    sw = g.add(One("switch", controlled=True))
    g.connect(n1, C("C1", "C1"))
    g.connect(n2, C("C2", "C2"))
    g.connect(n1, sw)
    g.connect(sw, n2)
    return g


def switched_rl() -> BondGraph:
    """A source ``V0`` charging an inductor ``L`` through ``R``, with a
    controlled 1-junction ``switch`` in series and a freewheeling resistor
    ``R_fw`` across the inductor."""
    g = BondGraph("switched_rl")
    sw = g.add(One("switch", controlled=True))
    node = g.add(Zero("node"))
    loop = g.add(One("loop"))
    g.connect(Se("V", "V0"), sw)
    g.connect(sw, R("R", "R"))
    g.connect(sw, node)
    g.connect(node, loop)
    g.connect(loop, I("L", "L"))
    g.connect(node, R("R_fw", "R_fw"))
    return g


def dc_motor() -> BondGraph:
    """A DC motor: armature (R_a, L_a) driven by ``V0 sin(w t)``, gyrator
    ``K`` to the rotor inertia ``J`` with friction ``b``."""
    g = BondGraph("dc_motor")
    i = g.add(One("i"))
    w = g.add(One("w"))
    g.connect(Se("V", sp.Symbol("V0") * sp.sin(sp.Symbol("w") * t)), i)
    g.connect(i, R("R_a", "R_a"))
    g.connect(i, I("L_a", "L_a"))
    g.connect(i, GY("K", "K"))
    g.connect("K", w)
    g.connect(w, I("J", "J"))
    g.connect(w, R("b", "b"))
    return g


GRAPHS = {
    "series_rlc": series_rlc,
    "msd_chain": msd_chain,
    "rlc_ladder": rlc_ladder,
    "pivoting_rod": pivoting_rod,
    "parallel_capacitors": parallel_capacitors,
    "switched_rl": switched_rl,
    "dc_motor": dc_motor,
}
