"""Islands: the independent parts of a configuration, derived one by one and
reused by every configuration that contains them.

A controlled junction that is *off* imposes zero on all of its bonds (an off
0-junction their efforts, an off 1-junction their flows); causality does not
propagate through it, and no equation passes a bond variable through it.  So
the graph splits at its off junctions into **islands**: classes of bonds
joined by the elements that are on (every bond of an on element is in that
element's island), and by the symbols an element's expressions read (a
modulus ``l sin θ`` joins the bonds of the rod's ``TF`` to the bond whose
flow integrates ``θ``; a source modulated by ``e_b`` joins bond ``b``).

Within one configuration the islands share no unknown: the causal assignment
of the whole graph, restricted to an island, is the assignment of the island
derived on its own (its off junctions still imposing their zeros on the bonds
it holds), and so are its bond relations, its constraints ``x_d = φ(x_i)`` and
its rates ``f``.  An island is determined by its bonds and the states of the
controlled junctions among its elements, so two configurations that differ
only in junctions far away share it: a pinnacle of an N-ball chain switches
one contact, and only the one or two islands next to it are derived again.

The procedures run on an island exactly as on the whole graph, in the
graph's own order of elements and bonds; the results are merged back into
one :class:`~bondgraph.causality.Causality` and one
:class:`~bondgraph.equations.ConfigurationEquations` with the very
expressions a derivation of the whole graph gives (``tests/bondgraph/test_islands.py``
compares them over many configurations of the shipped models): see
:mod:`bondgraph.island_merge`.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import compress, repeat
from operator import is_not

from .elements import Junction, TwoPort

__all__ = ["Island", "IslandCells", "element_couplings", "has_modulated_two_port", "islands"]


@dataclass(frozen=True)
class Island:
    """One island of a configuration: its ``bonds`` and ``elements`` (in the
    graph's order; an off junction belongs to every island it has a bond in)
    and ``key``, which identifies it in every configuration holding it (the
    bonds and the on/off state of the controlled junctions among its
    elements)."""

    bonds: tuple
    elements: tuple
    key: tuple


def element_couplings(graph) -> dict:
    """Element → the bonds its expressions read (through a state, a
    displacement or a bond variable); computed once per graph version."""
    bond_of_symbol = {}
    for name, bond in graph.bonds.items():
        bond_of_symbol[bond.effort] = name
        bond_of_symbol[bond.flow] = name
    for el in graph.storage:
        bond_of_symbol[el.state] = graph._bonds_of[el.name][0]
    for sym, disp in graph.displacements.items():
        bond_of_symbol[sym] = disp.bond
    couplings = {}
    for name, el in graph.elements.items():
        read = set()
        for expr in el.expressions():
            read.update(bond_of_symbol[s] for s in expr.free_symbols if s in bond_of_symbol)
        if read:
            couplings[name] = sorted(read)
    return couplings


def islands(graph, config: dict, couplings: dict | None = None) -> list[Island]:
    """The islands of ``graph`` in configuration ``config`` (every controlled
    junction named), in the order of their first bond.  ``couplings`` is
    :func:`element_couplings` of the graph (computed when not given)."""
    return IslandCells(graph, couplings).islands(config)


def _find(parent: list, k: int) -> int:
    while parent[k] != k:
        parent[k] = parent[parent[k]]
        k = parent[k]
    return k


class IslandCells:
    """The graph cut at *every* controlled junction into **cells** (classes of
    bonds joined by the other elements and by the couplings), computed once;
    the islands of a configuration are then the cells joined across its on
    junctions.  A configuration so costs a look at each controlled junction
    and the work of its on ones, instead of a walk of every element and bond
    (a scene of many contacts asks for one configuration a mode, a few of its
    contacts on), and an island met before is the same :class:`Island` object.  Cells are numbered in the order of their
    first bond, so groups of cells come out in the order of their first bond."""

    def __init__(self, graph, couplings: dict | None = None):
        if couplings is None:
            couplings = element_couplings(graph)
        controlled = _controlled(graph)
        parent = {b: b for b in graph.bonds}

        def find(b):
            while parent[b] != b:
                parent[b] = parent[parent[b]]
                b = parent[b]
            return b

        def union(bonds):
            root = find(bonds[0])
            for b in bonds[1:]:
                other = find(b)
                if other != root:
                    parent[other] = root

        bonds_of = graph._bonds_of
        for name, el in graph.elements.items():
            bonds = bonds_of[name]
            if not bonds:
                continue
            if not (isinstance(el, Junction) and name in controlled):
                union(bonds)
            read = couplings.get(name)
            if read:
                union([bonds[0], *read])
        self.bond_index = {b: k for k, b in enumerate(graph.bonds)}
        cell_of_root: dict = {}
        cell_bonds: list = []
        self.cell_of: dict = {}
        for b in graph.bonds:
            root = find(b)
            if root not in cell_of_root:
                cell_of_root[root] = len(cell_bonds)
                cell_bonds.append([])
            cell = cell_of_root[root]
            cell_bonds[cell].append(b)
            self.cell_of[b] = cell
        self.cell_bonds = [tuple(bonds) for bonds in cell_bonds]
        self.cell_elements: list = [[] for _ in cell_bonds]  # (element index, name) of its uncontrolled elements
        junctions = []  # (element index, name, its cells in the order of its bonds)
        for k, (name, el) in enumerate(graph.elements.items()):
            cells = tuple(dict.fromkeys(self.cell_of[b] for b in bonds_of[name]))
            if not cells:
                continue
            if isinstance(el, Junction) and name in controlled:
                junctions.append((k, name, cells))
            else:
                (cell,) = cells
                self.cell_elements[cell].append((k, name))
        self.junctions = tuple(junctions)
        self.junction_names = tuple(name for _, name, _ in junctions)
        self.cell_junctions: list = [[] for _ in cell_bonds]  # (element index, name) of the junctions at a cell
        for k, name, cells in junctions:
            for c in cells:
                self.cell_junctions[c].append((k, name))
        self.known: dict = {}  # (cells, switched) → the Island
        # every junction off: each cell an island of its own
        self.apart = [self._known([c], self.cell_junctions[c], {}) for c in range(len(cell_bonds))]

    def _known(self, cells: list, held: list, config: dict) -> Island:
        """The island of ``cells`` with the controlled junctions ``held`` (in the graph's order) set as
        in ``config`` (off where it does not name them), built when first met."""
        found = (tuple(cells), tuple(config.get(name, False) for _, name in held))
        island = self.known.get(found)
        if island is None:
            island = self.known[found] = self._island(cells, held, config)
        return island

    def islands(self, config: dict) -> list[Island]:
        """The islands of ``config`` (as :func:`islands`): the cells apart, but those an on junction
        touches, joined across the on junctions (a configuration costs its on junctions)."""
        parent: dict = {}

        def find(c):
            while parent[c] != c:
                parent[c] = parent[parent[c]]
                c = parent[c]
            return c

        # (the on junctions sieved without a Python loop over a scene's thousand)
        for _, _, cells in compress(self.junctions, map(config.__getitem__, self.junction_names)):
            for c in cells:
                parent.setdefault(c, c)
            root = find(cells[0])
            for c in cells[1:]:
                other = find(c)
                if other != root:
                    parent[other] = root
        if not parent:
            return list(self.apart)
        groups: dict = {}
        for c in sorted(parent):
            groups.setdefault(find(c), []).append(c)
        out = list(self.apart)
        for cells in groups.values():  # (each in the place of its first cell: the order of first bonds)
            held = sorted({j for c in cells for j in self.cell_junctions[c]})
            out[cells[0]] = self._known(cells, held, config)
            for c in cells[1:]:
                out[c] = None
        return list(compress(out, map(is_not, out, repeat(None))))

    def _island(self, cells: list, held: list, config: dict) -> Island:
        if len(cells) == 1:
            bonds = self.cell_bonds[cells[0]]
        else:
            index = self.bond_index
            bonds = tuple(sorted((b for c in cells for b in self.cell_bonds[c]), key=index.__getitem__))
        members = sorted([*(e for c in cells for e in self.cell_elements[c]), *held])
        names = tuple(name for _, name in members)
        switched = tuple((name, config.get(name, False)) for _, name in sorted(held))
        return Island(bonds, names, (bonds, switched))


def _controlled(graph) -> frozenset:
    """The names of the graph's controlled junctions."""
    return graph.derived.memo("controlled junction set", lambda: frozenset(graph.controlled_junctions))


def has_modulated_two_port(graph) -> bool:
    """Does the graph hold a TF or GY whose modulus is not constant?  (Then
    its storage is ranked before causality is assigned, in every island:
    :meth:`bondgraph.causality._SCAP._storage_order`.)"""
    return any(isinstance(el, TwoPort) and el.modulated for el in graph.elements.values())
