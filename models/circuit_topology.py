"""Which modes of a circuit can float, found on its netlist, not by enumerating modes.

A mode of a circuit's diodes and switches leaves part of it under-determined
(:mod:`bondgraph.floating`) in two ways, each visible on the netlist:

* **floating nodes**: a set of nodes that nothing ties to ground.  The
  components that always tie the potentials of their terminals — resistors,
  capacitors, inductors, voltage sources, the windings of transformers and
  gyrators — join nodes into *tie groups* (the connected components of
  those components).  A tie group without ground floats in every mode in
  which the diodes and switches around the set it belongs to block
  (current sources fix a current, never a potential), and a circuit has a
  mode with floating nodes only if it has such a group;
* **a free loop current**: a loop of ideal diodes and switches (no
  ``r_on``) conducting together — the current circulating in it is
  undefined (each loop of a cycle basis of the graph they form; two in
  parallel are a loop).

For each such group, set of groups and loop a *witness* setting of the
diodes and switches involved is built (the group cut off; the set joined by
a spanning tree of conducting elements, so that a current source inside it
has a path and no loop shorts a source; the loop conducting), over a few
backgrounds of the other elements, and each candidate is checked with the
configuration's own analysis (:func:`bondgraph.floating.floating_part`),
which names the floating junctions and the blocking elements; the first
that floats witnesses the part.  The search costs two graph traversals and
a few checks a part: a circuit of 24 diodes needs a handful of checks, not
2²⁴.  A circuit with neither an ungrounded tie group nor a loop of ideal
elements has no floating mode at all; where it has one but a conflict in
every candidate hides it (current sources into groups that only diodes
join, sources shorted), :func:`first_floating_mode` checks every mode when
there are few.  tests/models/test_circuit_topology.py holds both against
checking every mode, on thousands of random circuits.
"""

from __future__ import annotations

import networkx as nx

from bondgraph.floating import floating_part

from .circuit_words import OFF, ON
from .netlist import REFERENCE

__all__ = ["tie_groups", "witness_modes", "group_settings", "spanning_settings", "loop_settings",
           "forest_setting", "floating_witnesses", "first_floating_mode", "OFF", "ON"]

#: the components whose terminals' potentials are tied in every mode (their letters in :class:`Part`)
TYING = ("R", "C", "L", "V", "T", "G", "K")
#: the components that conduct or block by their automaton
SWITCHING = ("D", "S")


def tie_groups(parts) -> list[frozenset]:
    """The groups of nodes joined by tying components (:data:`TYING`), ground's group first."""
    graph = nx.Graph()
    for part in parts:
        graph.add_nodes_from(part.nodes)
        if part.kind in TYING:
            for a, b in zip(part.nodes[::2], part.nodes[1::2]):
                graph.add_edge(a, b)
    groups = sorted((frozenset(c) for c in nx.connected_components(graph)), key=lambda g: REFERENCE not in g)
    return groups




def witness_modes(parts, model) -> list:
    """The modes that float a part of the circuit if any mode does (see the module documentation),
    one list of candidate modes a witness: a witness's setting (:func:`group_settings`,
    :func:`spanning_settings`, :func:`loop_settings`) over the other automata at their initial states,
    all conducting, all blocking, conducting along a spanning forest (:func:`forest_setting`), or one
    of them changed from its initial state (a conflict elsewhere — a current source into a group cut
    off, a source shorted — may hide the floating part in some)."""
    switching = [p for p in parts if p.kind in SWITCHING]
    initial = {a.name: a.initial for a in model.automata}
    groups = tie_groups(parts)
    backgrounds = [initial] + [{**initial, **{p.name: states[p.kind] for p in switching}} for states in (ON, OFF)]
    backgrounds.append({**initial, **forest_setting(groups, switching)})
    settings = group_settings(groups, switching) + spanning_settings(groups, switching) + loop_settings(switching)
    witnesses = []
    for setting in settings:
        flipped = [{**initial, p.name: ON[p.kind] if initial[p.name] == OFF[p.kind] else OFF[p.kind]}
                   for p in switching if p.name not in setting]
        candidates = []
        for background in backgrounds + flipped:
            mode = model.mode({**background, **setting})
            if mode not in candidates:
                candidates.append(mode)
        witnesses.append(candidates)
    return witnesses


def forest_setting(groups, switching) -> dict:
    """The diodes and switches of a spanning forest of the tie groups conducting, the others blocking:
    every current source has a path, no loop of them shorts a source or circulates freely."""
    group_of = {n: k for k, group in enumerate(groups) for n in group}
    joined = nx.Graph()
    for p in switching:
        a, b = (group_of[n] for n in p.nodes[:2])
        if a != b and not joined.has_edge(a, b):
            joined.add_edge(a, b, part=p.name)
    forest = {joined.edges[e]["part"] for e in nx.minimum_spanning_edges(joined, data=False)}
    return {p.name: ON[p.kind] if p.name in forest else OFF[p.kind] for p in switching}


def group_settings(groups, switching) -> list:
    """For each tie group without ground: every diode and switch touching it blocking; and those to
    ground's group blocking, the others conducting (the ungrounded groups around it joined)."""
    grounded = groups[0] if REFERENCE in groups[0] else frozenset()
    settings = []
    for group in groups:
        if REFERENCE in group:
            continue
        touching = [p for p in switching if set(p.nodes[:2]) & group]
        settings.append({p.name: OFF[p.kind] for p in touching})
        settings.append({p.name: OFF[p.kind] if set(p.nodes[:2]) & grounded else ON[p.kind] for p in touching})
    return settings


def spanning_settings(groups, switching) -> list:
    """For each set of ungrounded tie groups the diodes and switches join, the setting that floats it
    whole: a spanning tree of those elements conducting (a current source inside the set then has a
    path, and no loop of them shorts a source), every other element touching the set blocking."""
    group_of = {n: k for k, group in enumerate(groups) for n in group}
    joined = nx.Graph()
    joined.add_nodes_from(k for k, group in enumerate(groups) if REFERENCE not in group)
    for p in switching:
        a, b = (group_of[n] for n in p.nodes[:2])
        if a != b and a in joined and b in joined and not joined.has_edge(a, b):
            joined.add_edge(a, b, part=p)
    settings = []
    for component in nx.connected_components(joined):
        tree = {joined.edges[e]["part"].name for e in nx.bfs_tree(joined, next(iter(component))).edges}
        nodes = set().union(*(groups[k] for k in component))
        settings.append({p.name: ON[p.kind] if p.name in tree else OFF[p.kind] for p in switching
                         if set(p.nodes[:2]) & nodes})
    return settings


def loop_settings(switching) -> list:
    """For each loop of a cycle basis of the ideal diodes and switches (no ``r_on``; two between the
    same nodes are a loop), those conducting."""
    simple = nx.Graph()
    settings = []
    for p in switching:
        if p.values.get("r_on") is not None:
            continue
        a, b = p.nodes[:2]
        if simple.has_edge(a, b):
            other = simple.edges[a, b]["part"]
            settings.append({other.name: ON[other.kind], p.name: ON[p.kind]})
        else:
            simple.add_edge(a, b, part=p)
    for cycle in nx.cycle_basis(simple):
        loop = [simple.edges[a, b]["part"] for a, b in zip(cycle, cycle[1:] + cycle[:1])]
        settings.append({p.name: ON[p.kind] for p in loop})
    return settings


def floating_witnesses(parts, model, limit: int | None = None) -> list:
    """``[(mode, FloatingPartError), ...]``: for each witness (:func:`witness_modes`), the first of its
    candidate modes whose configuration :func:`~bondgraph.floating.floating_part` finds under-determined
    (each mode once; at most ``limit`` of them)."""
    found, seen = [], set()
    for candidates in witness_modes(parts, model):
        if limit is not None and len(found) >= limit:
            break
        for mode in candidates:
            error = floating_part(model.graph, dict(model.configuration_of(mode)))
            if error is not None:
                if mode not in seen:
                    seen.add(mode)
                    found.append((mode, error))
                break
    return found


def first_floating_mode(parts, model, every_mode, runs=lambda mode: False):
    """``(mode, FloatingPartError)`` of a mode that floats part of the circuit and that the model cannot
    run (``runs(mode)`` false: the limit of vanishing leaks, :func:`bondgraph.regularize.floating_limit`,
    has no equations for it), or ``None`` when there is none: among the witnesses
    (:func:`floating_witnesses`); else, when witnesses exist (the netlist says some mode may float) but
    a conflict hid the part in each, among ``every_mode(model)`` (a check of every mode, or ``[]`` when
    there are too many)."""
    found = floating_witnesses(parts, model)
    if found:
        return next(((mode, error) for mode, error in found if not runs(mode)), None)
    if not witness_modes(parts, model):
        return None
    return next(((mode, error) for mode, error in every_mode(model) if not runs(mode)), None)
