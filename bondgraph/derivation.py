"""What is derived from a bond graph, kept until the graph changes: per
configuration (its causality, equations and jump maps) and island by island
(:mod:`bondgraph.islands`: a configuration that splits into independent
pieces is assembled from its islands', each derived once for every
configuration holding it)."""

from __future__ import annotations

from itertools import compress, repeat
from operator import is_, itemgetter, not_

from .causality import assign_causality
from .equations import derive_equations
from .errors import HybridBondGraphError
from .island_merge import merge_causality, merge_equations
from .islands import IslandCells, element_couplings, has_modulated_two_port


_NOT_KEPT = (None, None)


class Derivations:
    """The derivations of one graph: ``entries`` (key → result), emptied by
    :meth:`clear` whenever the graph changes.  ``graph`` in the methods is the
    graph derived (the graph itself, or its open view for the port setting
    ``ports``, :meth:`bondgraph.BondGraph.open_view`)."""

    def __init__(self):
        self.entries: dict = {}

    def clear(self) -> None:
        self.entries.clear()

    def per_configuration(self, kind: str, config: dict, compute):
        """``compute(config)`` kept under ``kind`` for the normalised configuration ``config``
        (:meth:`bondgraph.BondGraph.configuration`: every controlled junction, in the graph's order)."""
        key = (kind, tuple(config.items()))
        if key not in self.entries:
            self.entries[key] = compute(config)
        return self.entries[key]

    def memo(self, key, compute):
        """``compute()`` kept in the graph's cache under ``key`` (dropped when the graph changes)."""
        if key not in self.entries:
            self.entries[key] = compute()
        return self.entries[key]

    def islands(self, graph, config: dict, ports: str):
        """The islands of ``config`` (:mod:`bondgraph.islands`) in ``graph``
        (this graph, or its open view ``ports``), or ``None`` when the
        configuration is all one piece (or has no junction off: no island
        of it could serve another configuration)."""
        if all(config.values()):
            return None
        key = (ports, tuple(config.items()))
        last = self.entries.get("islands")  # (kept for one configuration: its causality, then its equations)
        if last is None or last[0] != key:
            cells = self.memo(("island cells", ports), lambda: IslandCells(graph, element_couplings(graph)))
            parts = cells.islands(config)
            last = self.entries["islands"] = (key, parts if len(parts) > 1 else None)
        return last[1]

    def island_graph(self, graph, island, ports: str):
        """The island as a graph of its own (:meth:`bondgraph.BondGraph.island_graph`), kept."""
        return self.memo(("island graph", ports, island.key), lambda: graph.island_graph(island))

    def island_causality(self, graph, island, ports: str):
        """The causality of one island, kept for every configuration holding it."""

        def derive():
            rank = self.memo(("modulated two-port", ports), lambda: has_modulated_two_port(graph))
            return assign_causality(self.island_graph(graph, island, ports), dict(island.key[1]), validate=False,
                                    rank_storage=rank)

        return self.memo(("island causality", ports, island.key), derive)

    def island_equations(self, graph, island, ports: str):
        """The equations of one island, kept for every configuration holding it."""
        return self.memo(("island equations", ports, island.key),
                         lambda: derive_equations(self.island_graph(graph, island, ports), dict(island.key[1]),
                                                  self.island_causality(graph, island, ports)))

    def _kept(self, kind: str, derive, graph, parts: list, ports: str) -> list:
        """``derive(graph, island, ports)`` of each island in ``parts``, read straight from the entries
        where kept (a configuration of a large scene holds hundreds of islands, nearly all kept): by the
        island object first (an island met before is the same object, :class:`IslandCells`; its key, a
        tuple of its bonds, is not hashed again), else by its key."""
        entries = self.entries
        by_object = entries.setdefault(("pieces by island", kind, ports), {})
        # (a scene's thousand islands looked up without a Python loop; those not kept in one over them)
        found = list(map(by_object.get, map(id, parts), repeat(_NOT_KEPT)))
        kept = list(map(is_, map(itemgetter(0), found), parts))
        pieces = list(map(itemgetter(1), found))
        for k in compress(range(len(parts)), map(not_, kept)):
            island = parts[k]
            piece = entries.get((kind, ports, island.key))
            if piece is None:
                piece = derive(graph, island, ports)
            by_object[id(island)] = (island, piece)  # (the island held: its id stays its own)
            pieces[k] = piece
        return pieces

    def checked(self, graph, ports: str) -> None:
        """Validate ``graph`` once per version of this graph (it raises every time while invalid)."""
        if ("validated", ports) not in self.entries:
            graph.validate()
            self.entries[("validated", ports)] = True

    def causality(self, graph, config: dict, ports: str):
        """The causality of ``config``: assembled from its islands' (each
        derived once for all configurations holding it) when it has several;
        a conflict in an island is reported by the whole graph's derivation."""
        self.checked(graph, ports)
        parts = self.islands(graph, config, ports)
        if parts is None:
            return assign_causality(graph, config, validate=False)
        try:
            pieces = self._kept("island causality", self.island_causality, graph, parts, ports)
        except HybridBondGraphError:
            return assign_causality(graph, config, validate=False)
        return self._merged(merge_causality, ("last merged causality", ports), graph, config, pieces)

    def equations(self, graph, config: dict, causality, ports: str):
        """The equations of ``config``, assembled from its islands' like
        :meth:`causality`."""
        parts = self.islands(graph, config, ports)
        if parts is None:
            return derive_equations(graph, config, causality)
        try:
            pieces = self._kept("island equations", self.island_equations, graph, parts, ports)
        except HybridBondGraphError:
            return derive_equations(graph, config, causality)
        return self._merged(merge_equations, ("last merged equations", ports), graph, config, causality, pieces)

    def _merged(self, merge, last: tuple, *arguments):
        """``merge(*arguments, previous)`` (:mod:`bondgraph.island_merge`), ``previous`` the merge kept under
        ``last``: that of the configuration derived before, whose islands it swaps for its own."""
        merged = self.entries[last] = merge(*arguments, previous=self.entries.get(last))
        return merged
