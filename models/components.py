"""Reusable sub-models (bond graphs with named ports).

Place them in a model with :meth:`bondgraph.BondGraph.add_submodel`; every
inner name gets the instance name as prefix (``cell3/k``), except the
parameters passed in ``share`` (kept global, e.g. gravity ``g``) or ``bind``.

Example — a chain of mass–spring–damper cells built in a loop::

    >>> from bondgraph import BondGraph, Sf
    >>> from models.components import msd_cell
    >>> chain, cell = BondGraph("chain"), msd_cell()
    >>> previous = chain.add(Sf("wall", 0))
    >>> for i in range(1, 4):
    ...     inst = chain.add_submodel(cell, f"cell{i}", share=["m", "k", "c"])
    ...     _ = chain.connect(previous, inst.port("in"))
    ...     previous = inst.port("mass")
    >>> [s.name for s in chain.states][:2]
    ['q_cell1/k', 'p_cell1/m']
"""

from __future__ import annotations

import sympy as sp

from bondgraph import TF, BondGraph, C, I, One, R, Se, Zero

__all__ = ["msd_cell", "rlc_cell", "rigid_planar_body"]


def msd_cell() -> BondGraph:
    """One cell of a mass–spring–damper chain.

    ::

        in ──► 0 ──► 1_rel ──► C: k   (spring, e = k q, q its compression)
               │        └────► R: c   (damper, e = c f)
               ▼
             1_v  ──► I: m            (mass, p = m v)
             (port "mass")

    The 0-junction ``in`` carries the common force of spring and damper;
    its flows balance as ``v_in = v_rel + v``, so the spring is compressed at
    ``dq/dt = v_in − v`` where ``v_in`` is the velocity of whatever drives port
    ``in`` (a wall, or the previous cell's ``mass`` port).
    Parameters ``m`` [kg], ``k`` [N/m], ``c`` [N·s/m]; states ``p_<cell>/m``
    [N·s] and ``q_<cell>/k`` [m].
    """
    g = BondGraph("msd_cell")
    node = g.add(Zero("in"))
    rel = g.add(One("rel"))
    mass = g.add(One("v"))
    g.connect(node, rel)
    g.connect(node, mass)
    g.connect(rel, C("k", 1 / sp.Symbol("k")))
    g.connect(rel, R("c", "c"))
    g.connect(mass, I("m", "m"))
    g.port("in", node)
    g.port("mass", mass)
    return g


def rlc_cell() -> BondGraph:
    """One section of an RLC ladder: series R and L, shunt C.

    ::

        in ──► 1_series ──► 0_node ──► C: C     (port "out" = 0_node)
                 ├──► R: R
                 └──► I: L

    Parameters ``R`` [Ω], ``L`` [H], ``C`` [F]; states ``p_<cell>/L`` [V·s]
    (flux linkage) and ``q_<cell>/C`` [C] (charge).  Port ``in`` is the 1-junction
    carrying the series current; ``out`` is the node voltage's 0-junction.
    """
    g = BondGraph("rlc_cell")
    series = g.add(One("series"))
    node = g.add(Zero("node"))
    g.connect(series, R("R", "R"))
    g.connect(series, I("L", "L"))
    g.connect(series, node)
    g.connect(node, C("C", "C"))
    g.port("in", series)
    g.port("out", node)
    return g


def rigid_planar_body(gravity: bool = True) -> BondGraph:
    """A rigid body moving in a vertical plane, with a point ``A`` (the tip).

    States: momenta ``p_x``, ``p_y`` [N·s], angular momentum ``p_J`` [N·m·s]
    about the centre of mass, and the displacements ``x``, ``y`` [m] and
    ``theta`` [rad].  Parameters: mass ``m`` [kg], inertia ``J`` [kg·m²] about
    the centre, tip distance ``l`` [m] and gravity ``g`` [m/s²].

    Sign conventions: ``y`` points up, ``theta`` counter-clockwise; the tip is
    at ``r_A = r − l (cos θ, sin θ)``, so its velocity is

        v_Ax = v_x + l sin θ · ω,     v_Ay = v_y − l cos θ · ω

    (the paper's convention with ``l → −l``; its Fig. 19 has ``l = −0.1``).
    A force ``F`` at the tip reaches the rotation as the torque
    ``l sin θ F_x − l cos θ F_y``.

    Ports: ``vx``, ``vy``, ``omega`` (1-junctions of the centre's velocities)
    and ``tip_x``, ``tip_y`` (0-junctions whose outgoing bonds carry the tip
    velocity; connect contacts there, bonds pointing away from the body).
    """
    m, J, l, g_ = sp.symbols("m J l g")
    body = BondGraph("rigid_planar_body")
    vx, vy, w = body.add(One("vx")), body.add(One("vy")), body.add(One("omega"))
    body.connect(vx, I("I_x", m, state="p_x"))
    body.connect(vy, I("I_y", m, state="p_y"))
    body.connect(w, I("I_J", J, state="p_J"))
    if gravity:
        body.connect(Se("gravity", -m * g_), vy)
    body.displacement("x", of=vx)
    body.displacement("y", of=vy)
    theta = body.displacement("theta", of=w)
    tip_x, tip_y = body.add(Zero("tip_x")), body.add(Zero("tip_y"))
    body.connect(vx, tip_x)
    body.connect(vy, tip_y)
    body.connect(w, TF("lever_x", l * sp.sin(theta)))
    body.connect("lever_x", tip_x)
    body.connect(w, TF("lever_y", -l * sp.cos(theta)))
    body.connect("lever_y", tip_y)
    for port in ("vx", "vy", "omega", "tip_x", "tip_y"):
        body.port(port, port)
    return body
