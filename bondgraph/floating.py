"""Under-determined (floating) parts of a configuration, told from over-determined ones.

When the causality assignment (:mod:`bondgraph.causality`) or the solution of
an algebraic loop fails, the graph is either

* **over-determined**: sources impose one effort or flow twice (two voltage
  sources in parallel, a current source into a node whose other branches are
  all switched off) — the sources' values would have to agree; or
* **under-determined**: part of the graph has nothing that fixes its
  efforts (it *floats*: every bond joining it to the rest ends on a
  switched-off 1-junction or a flow source, which fix flows only — the four
  blocking diodes around a bridge rectifier's load), or nothing that fixes
  the flow around a loop (ideal closed switches in parallel).

Both make the propagation of causal strokes meet itself, so the procedure
alone cannot tell them apart.  Linear algebra on the junction structure
does.  Write every bond's effort ``e_b`` and flow ``f_b`` as unknowns and
collect the homogeneous rows

* of the *structure* ``S``: an on 0-junction ``e_1 = e_k``, ``Σ ±f_k = 0``;
  an on 1-junction ``f_1 = f_k``, ``Σ ±e_k = 0`` (+ for bonds pointing in);
  TF ``e_1 = m e_2``, ``f_2 = m f_1``; GY ``e_1 = r f_2``, ``e_2 = r f_1``
  (moduli replaced by generic numbers: the answer is structural); an off
  0-junction ``e_k = 0``, an off 1-junction ``f_k = 0``, a dead bond
  ``e = f = 0``, a source whose value is the number 0 (a zero fixes nothing
  that could disagree);
* of the *sources* ``Q``: ``e = 0`` for an Se, ``f = 0`` for an Sf (the
  other sources);
* of the *ports* ``P``: ``e = f = 0`` for every R, C, I and open port.

Then, over the reals (singular values below 10⁻⁹ of the largest count as 0):

* over-determined ⇔ a left null vector ``y`` of ``[S; Q]`` (``yᵀ[S; Q] = 0``)
  weighs on a row of ``Q``: that source's value is a combination of the
  other sources' values (the structure's rows equal 0), and may
  contradict them — the sources it weighs on are the ones named;
* under-determined ⇔ ``[S; Q; P]`` has a non-zero null vector: with every
  source and every port at zero, some bond variables can still be non-zero —
  nothing fixes them.  The null vectors' efforts name the floating
  junctions (the on 0-junctions whose effort moves; when none moves, the on
  junctions whose bonds' efforts do), their flows the junctions of a free
  loop.

The rows are few (two per bond), and the analysis runs only when a
derivation has already failed.
"""

from __future__ import annotations

import numpy as np

from .elements import GY, TF, Junction, Se, Sf, Source, Zero
from .errors import FloatingPartError

__all__ = ["floating_part", "determination"]

_TOLERANCE = 1e-9


def _rows(graph, config, dead):
    """(structure, sources, ports): lists of rows (dicts column → coefficient)."""
    bonds = list(graph.bonds)
    column = {b: 2 * k for k, b in enumerate(bonds)}  # effort at 2k, flow at 2k + 1
    rng = np.random.default_rng(20261127)
    structure, sources, ports = [], [], []

    def e(b):
        return column[b]

    def f(b):
        return column[b] + 1

    for b in dead:
        structure += [{e(b): 1.0}, {f(b): 1.0}]
    for name, el in graph.elements.items():
        mine = [b for b in graph.bonds_of(name) if b.name not in dead]
        if isinstance(el, Junction):
            on = not (el.controlled and not config.get(name, True))
            common, summed = (e, f) if isinstance(el, Zero) else (f, e)
            if not on:
                structure += [{common(b.name): 1.0} for b in mine]
                continue
            for b in mine[1:]:
                structure.append({common(mine[0].name): 1.0, common(b.name): -1.0})
            if mine:
                structure.append({summed(b.name): float(b.sign_at(name)) for b in mine})
        elif isinstance(el, (TF, GY)):
            b1, b2 = (b.name for b in graph.two_port_bonds(name))
            m = float(rng.uniform(0.5, 2.0))
            if isinstance(el, TF):
                structure += [{e(b1): 1.0, e(b2): -m}, {f(b2): 1.0, f(b1): -m}]
            else:
                structure += [{e(b1): 1.0, f(b2): -m}, {e(b2): 1.0, f(b1): -m}]
        elif isinstance(el, Source):
            (b,) = [b.name for b in graph.bonds_of(name)]
            row = {e(b): 1.0} if isinstance(el, Se) else {f(b): 1.0}
            if el.value == 0:
                structure.append(row)
            else:
                sources.append((name, row))
        else:  # R, C, I, open port: what the rest of the graph is determined from
            (b,) = [b.name for b in graph.bonds_of(name)]
            ports += [{e(b): 1.0}, {f(b): 1.0}]
    return bonds, structure, sources, ports


def _matrix(rows, width):
    A = np.zeros((len(rows), width))
    for i, row in enumerate(rows):
        for j, value in row.items():
            A[i, j] += value
    return A


def determination(graph, config, dead=frozenset()):
    """``(over, free_efforts, free_flows)`` of ``config``: ``over`` names the
    sources whose values the structure and the other sources fix (empty when
    none); ``free_efforts`` / ``free_flows`` the bonds whose effort / flow
    nothing fixes (empty when the configuration is determined).  See the
    module documentation for the mathematics."""
    bonds, structure, sources, ports = _rows(graph, config, frozenset(dead))
    width = 2 * len(bonds)
    S = _matrix(structure, width)
    Q = _matrix([row for _, row in sources], width)
    over = []
    if sources:
        # a source is over-determined when a left null vector y of [S; Q] (yᵀ[S; Q] = 0: a combination
        # of rows that vanishes) weighs on its row: then its value is a combination of the others'
        M = np.vstack([S, Q])
        u, singular, _ = np.linalg.svd(M)
        rank = int(np.sum(singular > _TOLERANCE * max(1.0, singular[0] if singular.size else 1.0)))
        left_null = u[:, rank:]  # orthonormal basis of the left null space
        if left_null.shape[1]:
            weight = np.sqrt(np.sum(left_null[len(structure):] ** 2, axis=1))
            over = [name for (name, _), w in zip(sources, weight) if w > 1e-6]
    A = np.vstack([S, Q, _matrix(ports, width)])
    if A.shape[0] == 0:
        return tuple(over), (), ()
    _, singular, vt = np.linalg.svd(A)
    scale = max(1.0, singular[0] if singular.size else 1.0)
    rank = int(np.sum(singular > _TOLERANCE * scale))
    null = vt[rank:]  # orthonormal basis of the null space
    if null.shape[0] == 0:
        return tuple(over), (), ()
    weight = np.sqrt(np.sum(null ** 2, axis=0))
    free_efforts = tuple(b for k, b in enumerate(bonds) if weight[2 * k] > 1e-6)
    free_flows = tuple(b for k, b in enumerate(bonds) if weight[2 * k + 1] > 1e-6)
    return tuple(over), free_efforts, free_flows


def _fmt_config(config) -> str:
    if not config:
        return "(no controlled junctions)"
    return "{" + ", ".join(f"{k}: {'on' if v else 'off'}" for k, v in config.items()) + "}"


def floating_part(graph, config, dead=frozenset()):
    """A :class:`~bondgraph.errors.FloatingPartError` describing the
    under-determined part of ``config`` when the configuration is
    under-determined and not over-determined, else ``None`` (a real conflict,
    or a determined configuration)."""
    over, free_efforts, free_flows = determination(graph, config, dead)
    if over or not (free_efforts or free_flows):
        return None
    elements = graph.elements

    def on(name):
        el = elements[name]
        return isinstance(el, Junction) and not (el.controlled and not config.get(name, True))

    kind = "effort" if free_efforts else "flow"
    free = free_efforts or free_flows
    touched = list(dict.fromkeys(end for b in free for end in (graph.bonds[b].tail, graph.bonds[b].head)))
    # the floating junctions: on 0-junctions whose effort moves (on 1-junctions for a free loop flow)
    junctions = [n for n in touched if on(n) and isinstance(elements[n], Zero) == (kind == "effort")]
    junctions = junctions or [n for n in touched if on(n)] or touched
    cut = [n for n in touched if isinstance(elements[n], Junction) and not on(n)]
    cut += [n for n in touched if isinstance(elements[n], Sf if kind == "effort" else Se)]
    cut = list(dict.fromkeys(cut))
    names = ", ".join(map(repr, junctions))
    nodes = [n[len("node_"):] for n in junctions if n.startswith("node_")]
    if nodes and kind == "effort":  # models.circuits names the 0-junction of node n "node_<n>"
        names += f" (circuit node{'s' if len(nodes) > 1 else ''} {', '.join(map(repr, nodes))})"
    if kind == "effort":
        isolated = (f"; around them {', '.join(map(repr, cut))} fix only flows (a switched-off 1-junction fixes "
                    "its flow at 0)" if cut else "")
        message = (
            f"the graph is under-determined, not over-determined, in configuration {_fmt_config(config)}: "
            f"nothing fixes the effort of {names} — they float{isolated}. In a circuit these are nodes no "
            "conducting element ties to a known voltage (all diodes and switches around them block), so their "
            "voltage, and the voltage across each blocking element, is undefined. To fix it, give them a path "
            "that fixes their effort: a resistance or storage element to a reference (a resistor or capacitor "
            "from the node to ground), or a leak across each switching element "
            "(models.circuits: Circuit.build(gmin=...), SPICE's gmin)."
        )
    else:
        message = (
            f"the graph is under-determined, not over-determined, in configuration {_fmt_config(config)}: "
            f"nothing fixes the flow around the loop through {names} (ideal elements, e.g. closed switches or "
            "conducting diodes, in parallel: the current circulating among them is undefined). To fix it, put "
            "a resistance in the loop (a diode's r_on) or switch only one of the parallel paths."
        )
    return FloatingPartError(message, junctions, cut, config, kind)
