"""A causality conflict of a circuit's mode in the circuit's words.

The bond graph names a conflict by its bonds and junctions (``bond 'V2'
(V2 → node_b): 'node_b' imposes its effort``); an engineer drew sources,
switches and diodes.  In a circuit a mode is over-determined when its
conducting ideal switches and diodes close a loop of voltage sources (two
sources in parallel through a closed switch, a source shorted by a switch
and a conducting diode): the loop's voltages would have to agree.
:func:`conflict_loop` finds such a loop on the netlist (a cycle of the graph
whose edges are the voltage sources and the conducting switches and diodes
without ``r_on``) and says it with the components, the nodes, the mode in
circuit words (``S1=closed, D1=conducting``) and the fix.  The words are the
states of the circuit's automata (:data:`ON`, :data:`OFF`): the mode of a
run says them too.
"""

from __future__ import annotations

import networkx as nx

from .netlist import REFERENCE

__all__ = ["conflict_loop", "mode_words", "ON", "OFF", "DIODE_ALIASES"]

#: the conducting state of a diode (D) and a switch (S), as their automata name it
ON = {"D": "conducting", "S": "closed"}
#: the blocking state of a diode and a switch
OFF = {"D": "blocking", "S": "open"}
#: the names a diode's states had before they were named as engineers say them, still read as input
DIODE_ALIASES = {"on": ON["D"], "off": OFF["D"]}


def _conducts(part, configuration: dict) -> bool:
    """Whether a diode or switch ``part`` conducts ideally (no on-resistance) in ``configuration``."""
    return bool(configuration.get(part.name, False)) and part.values.get("r_on") is None


def mode_words(parts, configuration: dict) -> str:
    """The configuration's diodes and switches as an engineer says them: ``S1=closed, D1=conducting``."""
    words = []
    for part in parts:
        if part.kind in ("D", "S") and part.name in configuration:
            words.append(f"{part.name}={(ON if configuration[part.name] else OFF)[part.kind]}")
    return ", ".join(words)


def conflict_loop(parts, configuration: dict) -> str:
    """A sentence naming a loop of voltage sources and conducting ideal switches and diodes of
    ``configuration`` (controlled element → on), with the fix; empty when there is none (the conflict
    is of another kind: a current source into blocking elements)."""
    graph = nx.MultiGraph()
    for part in parts:
        if part.kind == "V" or (part.kind in ("D", "S") and _conducts(part, configuration)):
            a, b = part.nodes[:2]
            graph.add_edge(a, b, key=part.name, part=part)
    for cycle in nx.cycle_basis(nx.Graph(graph)) + _parallel_pairs(graph):
        members = _members(graph, cycle)
        if any(p.kind == "V" for p in members):
            sources = [p.name for p in members if p.kind == "V"]
            conductors = [p.name for p in members if p.kind != "V"]
            nodes = " → ".join(("ground" if n == REFERENCE else repr(n)) for n in cycle + cycle[:1])
            return (f" In circuit words: in mode {mode_words(parts, configuration)}, the voltage source"
                    f"{'s' if len(sources) > 1 else ''} {', '.join(sources)} and the conducting "
                    f"{', '.join(conductors) or '(none)'} close a loop with no resistance ({nodes}): its "
                    "voltages would have to agree. Put a resistance in the loop (a line resistance, or the "
                    "switch's or diode's r_on), or make the switches' rules exclude this mode.")
    return ""


def _parallel_pairs(graph) -> list:
    """Two nodes joined by two edges (a source and a closed switch across it): each a loop of its own."""
    return [[a, b] for a, b in {tuple(sorted((a, b))) for a, b, k in graph.edges(keys=True)}
            if graph.number_of_edges(a, b) > 1]


def _members(graph, cycle) -> list:
    """The parts along ``cycle`` (one edge between each pair of consecutive nodes; both of a pair)."""
    members = []
    pairs = list(zip(cycle, cycle[1:] + cycle[:1]))
    if len(cycle) == 2:
        return [data["part"] for data in graph.get_edge_data(*cycle).values()]
    for a, b in pairs:
        along = [data["part"] for data in graph.get_edge_data(a, b).values()]
        members.append(min(along, key=lambda part: part.kind != "V"))  # a source where the pair has one
    return members
