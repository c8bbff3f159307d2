"""Bond graph drawings as textbooks draw them (Karnopp–Margolis–Rosenberg,
Borutzky).

* Elements and junctions are written as text: ``Se: V``, ``I: L``,
  ``C: tank1``, ``R: R_load``, ``TF: lever`` (``MSe``, ``MTF``, … when
  modulated by a state, a bond variable, an input or time), and
  junctions as ``0`` / ``1`` with their name as a subscript.
* A bond is a straight line (with right-angle bends where it closes a loop
  of the junction structure) with a **half-arrow** (one barb, on the left
  of the direction of travel, ⇀) at the end the positive power flows to.
* The **causal stroke** is a short bold bar across the bond at the end that
  *receives* the effort (:meth:`bondgraph.causality.Causality.stroke_at`):
  ``Se ⇀| 1`` — the source imposes the effort on the junction.
* **Layout** follows the junction structure: the junctions and two-ports
  form a tree (a spanning tree when the structure has loops); its longest
  path is the main chain, laid out left to right (oriented so that most
  power flows to the right; a long chain without branches is folded back
  and forth, as a long line of text is); every other subtree hangs below or
  above the node it leaves, as a chain of its own; the one-port elements sit
  around their junction (sources on the left, storage above, resistors
  below when the places are free).  Everything is placed on a grid whose
  column widths (row by row) and row heights come from the labels
  measured, so no two labels overlap; the chain bonds and connectors
  reserve their grid cells, and a bond that closes a loop of the junction
  structure is routed with right-angle bends through free cells, so bonds
  run clear of the labels (only in a graph so crowded that a one-port finds
  no free place in sight of its junction may its bond pass a label).
* **Controlled junctions** are boxed; given a configuration, each is marked
  ``on`` or ``off`` (a superscript) — or by the word its state has in a
  hybrid model's mode, given as ``words`` (``closed``/``open`` for a
  switch, ``conducting``/``blocking`` for a diode, ``engaged``/``disengaged``
  for a clutch: what the run says) — and an off junction, with its bonds, is
  drawn grey and dashed (a bond between two off junctions of one kind
  carries nothing and has no stroke).

Every artist carries a ``gid`` for tests and for the SVG output:
``element:<name>`` (the label), ``bond:<name>`` (the line), ``arrow:<name>``
(the half-arrow), ``stroke:<name>`` (the causal stroke), ``legend``.

:func:`layout_bond_graph` gives the grid alone (element → (column, row),
rows growing downwards); :func:`draw_bond_graph` draws on a matplotlib axis.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

__all__ = ["draw_bond_graph", "layout_bond_graph", "element_label", "GridLayout", "pyplot"]


def pyplot():
    """``matplotlib.pyplot``, on the headless Agg backend where no display can be opened."""
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "module://matplotlib_inline.backend_inline"):
        try:
            import matplotlib.pyplot  # noqa: F401
        except Exception:  # pragma: no cover - headless fallback
            matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt

#: the folded main chain: a chain longer than this, without branches, is folded
WRAP_AFTER = 16
#: places tried for hanging subtrees before the rest go below everything placed
MAX_TRIALS = 3000

# grid directions (column, row); rows grow downwards
_DIRS = {
    "up": (0, -1), "down": (0, 1), "left": (-1, 0), "right": (1, 0),
    "ul": (-1, -1), "ur": (1, -1), "dl": (-1, 1), "dr": (1, 1),
}
_DIAGONALS = ("ur", "ul", "dr", "dl")


@dataclass(frozen=True)
class GridLayout:
    """Grid places of a bond graph drawing.

    ``cells``: element → (column, row), rows growing downwards; no two
    elements share a cell.  ``reserved``: cells that a bond passes through
    (chain bonds, connectors, the bends of chords), each → the bond's name.
    ``chords``: the bonds that close a loop of the junction structure (or
    repeat a bond between two elements); each is drawn along ``paths[bond]``,
    the cells from its tail to its head through free cells, with right-angle
    bends (or straight, if no free way was found: then it has no path)."""

    cells: dict
    reserved: dict
    chords: tuple
    paths: dict = None


def _kind_of(el) -> str:
    from bondgraph.elements import GY, TF, Junction, R, Se, Sf, Storage

    if isinstance(el, Junction):
        return "junction"
    if isinstance(el, (TF, GY)):
        return "twoport"
    if isinstance(el, (Se, Sf)):
        return "source"
    if isinstance(el, Storage):
        return "storage"
    if isinstance(el, R):
        return "resistor"
    return "other"


def _slot_order(el, ahead) -> tuple:
    """The places tried for a one-port next to its junction, best first.
    ``ahead``: the straight directions that continue a line through the
    junction (the opposite place is taken), where a source reads best
    (``Se ⇀ 1 ⇀ …`` at the start of a chain, ``… 1 ⇀ Se`` at its end)."""
    kind = _kind_of(el)
    if kind == "source":
        straight = [d for d in ("left", "right", "down", "up") if d in ahead]
        rest = [d for d in ("left", "right", "up", "down") if d not in straight]
        return tuple(straight + rest) + ("ul", "dl", "ur", "dr")
    if kind == "resistor":
        return ("down", "up", "right", "left", "dr", "dl", "ur", "ul")
    return ("up", "down", "right", "left", "ur", "ul", "dr", "dl")


class _Grid:
    """Occupancy of grid cells (elements and bond routes) and of the
    crossing points of diagonal bonds."""

    def __init__(self):
        self.cells: dict = {}  # element → cell
        self.taken: dict = {}  # cell → element or "bond:<name>"
        self.corners: set = set()  # centres of grid squares a diagonal bond crosses
        self.along: dict = {}  # cell a bond passes straight through → "h" or "v"

    def copy(self):
        other = _Grid()
        other.cells = dict(self.cells)
        other.taken = dict(self.taken)
        other.corners = set(self.corners)
        other.along = dict(self.along)
        return other

    def restore(self, saved):
        self.cells, self.taken, self.corners, self.along = saved.cells, saved.taken, saved.corners, saved.along

    def free(self, cell) -> bool:
        return cell not in self.taken

    def put(self, name, cell):
        self.cells[name] = cell
        self.taken[cell] = name

    def route(self, bond, a, b) -> bool:
        """Reserve the cells strictly between ``a`` and ``b`` (same row or
        column, or one diagonal step); False if one is taken."""
        (c0, r0), (c1, r1) = a, b
        if c0 != c1 and r0 != r1:
            if abs(c0 - c1) == 1 and abs(r0 - r1) == 1:
                corner = ((c0 + c1) / 2, (r0 + r1) / 2)
                if corner in self.corners:
                    return False
                self.corners.add(corner)
                return True
            return False
        n = max(abs(c1 - c0), abs(r1 - r0))
        dc, dr = (c1 - c0) // n, (r1 - r0) // n
        between = [(c0 + k * dc, r0 + k * dr) for k in range(1, n)]
        if any(not self.free(c) for c in between):
            return False
        for c in between:
            self.taken[c] = f"bond:{bond}"
            self.along[c] = "h" if dc else "v"
        return True


def _longest_path_from(tree, root, exclude=None):
    """The longest path in ``tree`` from ``root`` away from ``exclude``
    (ties: the first found in breadth-first order)."""
    parent = {root: None}
    order = [root]
    queue = deque([root])
    while queue:
        node = queue.popleft()
        for nb in tree[node]:
            if nb not in parent and nb != exclude:
                parent[nb] = node
                order.append(nb)
                queue.append(nb)
    depth = {root: 0}
    for node in order[1:]:
        depth[node] = depth[parent[node]] + 1
    far = max(order, key=lambda n: (depth[n], -order.index(n)))
    path = [far]
    while parent[path[-1]] is not None:
        path.append(parent[path[-1]])
    return path[::-1]


class _Layout:
    def __init__(self, graph):
        import networkx as nx

        self.graph = graph
        self.g = nx.MultiGraph()
        self.g.add_nodes_from(graph.elements)
        for bond in graph.bonds.values():
            self.g.add_edge(bond.tail, bond.head, key=bond.name)
        self.structure = {n for n, el in graph.elements.items() if _kind_of(el) in ("junction", "twoport")}
        self.grid = _Grid()
        self.routed: set = set()  # bonds with a place on the grid
        self.paths: dict = {}  # bond → cells of a bond drawn with bends
        self.trials = 0  # places tried for hanging subtrees: bounded, so a crowded graph cannot take long

    # -- helpers
    def leaves_of(self, node):
        """The one-ports of ``node`` still to place, sources first (they take the chain's ends)."""
        leaves = [nb for nb in self.g[node] if nb not in self.structure and nb not in self.grid.cells]
        return sorted(leaves, key=lambda n: _kind_of(self.graph.elements[n]) != "source")

    def _bond_name(self, a, b):
        return next(iter(self.g[a][b]))

    def place_leaf(self, leaf, node, strict) -> bool:
        c, r = self.grid.cells[node]
        opposite = {"left": "right", "right": "left", "up": "down", "down": "up"}
        ahead = {d for d in opposite if not self.grid.free((c - _DIRS[d][0], r - _DIRS[d][1]))}
        for slot in _slot_order(self.graph.elements[leaf], ahead):
            dc, dr = _DIRS[slot]
            cell = (c + dc, r + dr)
            if not self.grid.free(cell):
                continue
            if slot in _DIAGONALS and not self.grid.route(self._bond_name(node, leaf), (c, r), cell):
                continue
            self.grid.put(leaf, cell)
            self.routed.add(self._bond_name(node, leaf))
            return True
        if strict:
            return False
        # crowded: the nearest free cell a bond can reach with right-angle bends (crossing
        # straight bonds where it must), then anywhere (the bond is then routed as a chord)
        bond = self._bond_name(node, leaf)
        way = self._find_way((c, r), None)
        if way is not None:
            self.grid.put(leaf, way[-1])
            self._reserve_way(bond, way)
            self.routed.add(bond)
            return True
        # boxed in: the nearest free cell in sight (a straight bond that meets no label),
        # else the nearest free cell (the bond is then drawn as a chord, possibly past labels)
        rings = []
        for dist in range(2, 200):
            ring = [(c + dc, r + dr) for dc in range(-dist, dist + 1) for dr in range(-dist, dist + 1)
                    if max(abs(dc), abs(dr)) == dist]
            ring.sort(key=lambda cell: (cell[0] - c) ** 2 + (cell[1] - r) ** 2)
            rings.append(ring)
            if len(rings) <= 8:
                for cell in ring:
                    if self.grid.free(cell) and self._in_sight((c, r), cell):
                        self.grid.put(leaf, cell)
                        self.routed.add(bond)
                        return True
            elif any(self.grid.free(cell) for ring in rings for cell in ring):
                break
        cell = next(cell for ring in rings for cell in ring if self.grid.free(cell))
        self.grid.put(leaf, cell)
        return True

    def _in_sight(self, a, b) -> bool:
        """Does the straight line from cell ``a`` to cell ``b`` stay clear of
        every other element's cell (it may pass where two cells meet)?"""
        (c0, r0), (c1, r1) = a, b
        n = 8 * max(abs(c1 - c0), abs(r1 - r0))
        for k in range(1, n):
            x, y = c0 + (c1 - c0) * k / n, r0 + (r1 - r0) * k / n
            cell = (math.floor(x + 0.5), math.floor(y + 0.5))
            if cell in (a, b):
                continue
            owner = self.grid.taken.get(cell)
            if owner is not None and not owner.startswith("bond:"):
                return False
        return True

    def place_chain(self, path, start, step) -> bool:
        """Put ``path`` on the grid from ``start``, two columns apart in
        direction ``step`` (±1); False if a cell is taken."""
        c, r = start
        cells = [(c + 2 * k * step, r) for k in range(len(path))]
        if any(not self.grid.free(cell) for cell in cells):
            return False
        for name, cell in zip(path, cells):
            self.grid.put(name, cell)
        for a, b in zip(path, path[1:]):
            if not self.grid.route(self._bond_name(a, b), self.grid.cells[a], self.grid.cells[b]):
                return False
            self.routed.add(self._bond_name(a, b))
        return True

    def place_subtree(self, tree, root, parent) -> bool:
        """Hang the subtree of ``root`` (away from ``parent``) below or above
        ``parent`` as a chain of its own, with its branches and leaves; tries
        nearer places first.  False (nothing placed) if none fits."""
        path = _longest_path_from(tree, root, exclude=parent)
        pc, pr = self.grid.cells[parent]
        for k in range(1, 8):
            for dv in (1, -1):
                for dh in (1, -1):
                    self.trials += 1
                    if self.trials > MAX_TRIALS:
                        return False
                    saved = self.grid.copy()
                    routed = set(self.routed)
                    start = (pc, pr + 2 * k * dv)
                    if (self.place_chain(path, start, dh)
                            and self.grid.route(self._bond_name(parent, root), (pc, pr), start)
                            and self.dress(tree, path, strict=True)):
                        self.routed.add(self._bond_name(parent, root))
                        return True
                    self.grid.restore(saved)
                    self.routed = routed
        return False

    def dress(self, tree, path, strict) -> bool:
        """Branches, then leaves, of every node of a placed chain."""
        on_path = set(path)
        for node in path:
            for child in tree[node]:
                if child in on_path or child in self.grid.cells:
                    continue
                if not self.place_subtree(tree, child, node):
                    if strict:
                        return False
                    self.place_anywhere(tree, child, node)
        for node in path:
            for leaf in self.leaves_of(node):
                if not self.place_leaf(leaf, node, strict):
                    return False
        return True

    def place_anywhere(self, tree, root, parent):
        """A subtree that found no clear place: below everything placed."""
        bottom = max(r for _, r in self.grid.taken) + 2
        path = _longest_path_from(tree, root, exclude=parent)
        self.place_chain(path, (self.grid.cells[parent][0], bottom), 1)
        self.dress(tree, path, strict=False)

    # -- one connected component
    def component(self, nodes, top):
        import networkx as nx

        structure = [n for n in self.graph.elements if n in nodes and n in self.structure]
        if not structure:  # one-ports bonded to each other only
            names = [n for n in self.graph.elements if n in nodes]
            self.place_chain(names, (0, top), 1)
            return
        # the junction structure, in the graph's order (a networkx subgraph view may
        # iterate a set: the layout would change from run to run)
        inside = set(structure)
        sub = nx.Graph()
        sub.add_nodes_from(structure)
        sub.add_edges_from((b.tail, b.head) for b in self.graph.bonds.values() if b.tail in inside and b.head in inside)
        tree = nx.Graph()
        tree.add_nodes_from(structure)
        tree.add_edges_from(nx.bfs_edges(sub, structure[0]))
        end = _longest_path_from(tree, structure[0])[-1]
        path = _longest_path_from(tree, end)
        path = self._orient(path)
        branches = any(nb not in path for node in path for nb in tree[node])
        if len(path) > WRAP_AFTER and not branches:
            self._fold(path, top)
        elif not self.place_chain(path, (0, top), 1):  # pragma: no cover - the grid is empty below top
            raise RuntimeError("layout: main chain does not fit")
        self.dress(tree, path, strict=False)

    def _orient(self, path):
        forward = backward = 0
        for a, b in zip(path, path[1:]):
            for name in self.g[a][b]:
                if self.graph.bonds[name].tail == a:
                    forward += 1
                else:
                    backward += 1
        if backward > forward:
            return path[::-1]
        if backward == forward:
            def sources(node):
                return sum(_kind_of(self.graph.elements[nb]) == "source" for nb in self.g[node])
            if sources(path[-1]) > sources(path[0]):
                return path[::-1]
        return path

    def _fold(self, path, top):
        """A long chain folded back and forth in bands three rows apart (room
        for a leaf below each node of one band and above each of the next);
        the turn is a vertical bond."""
        per_band = max(4, int(math.ceil(math.sqrt(len(path) * 2.0))))
        bands = [path[i : i + per_band] for i in range(0, len(path), per_band)]
        for b, band in enumerate(bands):
            row = top + 3 * b
            if b % 2 == 0:
                self.place_chain(band, (0, row), 1)
            else:
                self.place_chain(band, (2 * (per_band - 1), row), -1)
        for first, second in zip(bands, bands[1:]):
            a, b = first[-1], second[0]
            self.grid.route(self._bond_name(a, b), self.grid.cells[a], self.grid.cells[b])
            self.routed.add(self._bond_name(a, b))

    def run(self) -> GridLayout:
        import networkx as nx

        order = {n: k for k, n in enumerate(self.graph.elements)}
        components = sorted(nx.connected_components(self.g), key=lambda c: min(order[n] for n in c))
        top = 0
        for nodes in components:
            if self.grid.taken:
                top = max(r for _, r in self.grid.taken) + 3
                # a new component starts below everything placed, its upper leaves included
            self.component(nodes, top)
        chords = tuple(name for name in self.graph.bonds if name not in self.routed)
        for name in chords:
            bond = self.graph.bonds[name]
            path = self._find_way(self.grid.cells[bond.tail], self.grid.cells[bond.head])
            if path is not None:
                self._reserve_way(name, path)
        reserved = {cell: owner[5:] for cell, owner in self.grid.taken.items() if owner.startswith("bond:")}
        return GridLayout(cells=dict(self.grid.cells), reserved=reserved, chords=chords, paths=dict(self.paths))

    def _reserve_way(self, name, path):
        """Draw bond ``name`` along ``path``: its cells are taken (where it crosses
        another bond, the crossing cannot be crossed again)."""
        self.paths[name] = path
        for before, cell, after in zip(path, path[1:], path[2:]):
            if cell in self.grid.along and not self.grid.free(cell):  # crossing another bond
                self.grid.along[cell] = "+"
                continue
            self.grid.taken[cell] = f"bond:{name}"
            straight = before[0] == after[0] or before[1] == after[1]
            self.grid.along[cell] = ("h" if before[1] == after[1] else "v") if straight else "+"

    def _find_way(self, start, goal):
        """The shortest way from ``start`` to ``goal`` through free cells
        (right-angle steps, each bend costing two steps, each crossing of a
        bond that runs straight through a cell four), within the placed area
        widened by two cells; ``None`` if there is none.  ``goal=None``: to
        the nearest free cell."""
        import heapq

        cols = [c for c, _ in self.grid.taken]
        rows = [r for _, r in self.grid.taken]
        c_lo, c_hi, r_lo, r_hi = min(cols) - 2, max(cols) + 2, min(rows) - 2, max(rows) + 2
        steps = ((1, 0), (-1, 0), (0, 1), (0, -1))
        queue = [(0, 0, start, None)]
        best = {(start, None): 0}
        came = {}
        count = 0
        while queue:
            cost, _, cell, heading = heapq.heappop(queue)
            if cell == goal or (goal is None and cell != start and self.grid.free(cell)):
                path = [cell]
                state = (cell, heading)
                while state in came:
                    state = came[state]
                    path.append(state[0])
                return path[::-1]
            if cost > best.get((cell, heading), math.inf):
                continue
            crossing = cell != start and not self.grid.free(cell)
            for step in steps:
                if crossing and step != heading:  # straight on through a crossing
                    continue
                nxt = (cell[0] + step[0], cell[1] + step[1])
                if not (c_lo <= nxt[0] <= c_hi and r_lo <= nxt[1] <= r_hi):
                    continue
                extra = 0
                if nxt != goal and not self.grid.free(nxt):
                    across = "v" if step[0] else "h"  # what a bond must run along to be crossed here
                    if self.grid.along.get(nxt) != across:
                        continue
                    extra = 4
                new = cost + 1 + extra + (2 if heading is not None and step != heading else 0)
                if new < best.get((nxt, step), math.inf):
                    best[(nxt, step)] = new
                    came[(nxt, step)] = (cell, heading)
                    count += 1
                    heapq.heappush(queue, (new, count, nxt, step))
        return None


def layout_bond_graph(graph) -> GridLayout:
    """The grid places of every element of ``graph`` (see :class:`GridLayout`)."""
    if not graph.elements:
        return GridLayout({}, {}, (), {})
    return _Layout(graph).run()


# ------------------------------------------------------------------ drawing


def _mathrm(name: str) -> str:
    return r"\mathrm{" + name.replace("_", r"\_") + "}"


def element_label(element, state: bool | None = None, parameters=None, word: str | None = None) -> str:
    """The text written for an element: ``I: m``, ``Se: g``, junctions as
    ``0``/``1`` with the name as a subscript (and ``on``/``off`` as a
    superscript for a controlled junction in a known configuration, or
    ``word`` in their place: the state as a mode names it).  A
    source or two-port whose value or modulus depends on more than
    ``parameters`` (the graph's, :attr:`bondgraph.BondGraph.parameters`: on
    a state, a displacement, a bond variable, an input or time) is
    *modulated*: ``MSe``, ``MSf``, ``MTF``, ``MGY``.  Without
    ``parameters`` nothing is marked modulated."""
    kind = _kind_of(element)
    if kind == "junction":
        sup = "" if state is None else "^{" + _mathrm(word or ("on" if state else "off")) + "}"
        return "$\\mathbf{" + element.kind + "}_{" + _mathrm(element.name) + "}" + sup + "$"
    if kind in ("twoport", "source") and parameters is not None:
        symbols = set().union(*(expr.free_symbols for expr in element.expressions()))
        if symbols - set(parameters):
            return f"M{element.kind}: {element.name}"
    return f"{element.kind}: {element.name}"


def _extent(text, renderer, points_per_pixel):
    """(left, right, below, above) of a label's box around its anchor, in points."""
    patch = text.get_bbox_patch()
    if patch is not None:
        text.update_bbox_position_size(renderer)  # the box is sized when drawn
    box = patch.get_window_extent(renderer) if patch is not None else text.get_window_extent(renderer)
    x, y = text.get_transform().transform(text.get_position())
    return tuple(v * points_per_pixel for v in (x - box.x0, box.x1 - x, y - box.y0, box.y1 - y))


def _exit_distance(extent, direction, pad):
    """Distance from a label's anchor along ``direction`` to its box edge (plus ``pad``)."""
    left, right, below, above = (e + pad for e in extent)
    dx, dy = direction
    out = []
    if dx > 1e-12:
        out.append(right / dx)
    elif dx < -1e-12:
        out.append(left / -dx)
    if dy > 1e-12:
        out.append(above / dy)
    elif dy < -1e-12:
        out.append(below / -dy)
    return min(out) if out else 0.0


def draw_bond_graph(graph, config=None, ax=None, *, fontsize=10.0, legend=True, title=None, words=None):
    """Draw ``graph`` as a textbook bond graph in configuration ``config``
    (controlled junction → on/off; ``None``: every controlled junction on,
    then not marked on/off).  ``words`` (controlled junction → text) marks a
    junction with the word its state has in a mode instead of on/off, in the
    labels and the default title: a hybrid model's
    ``model.mode_space.junction_words(mode)``, so the drawing says what the run says.

    Half-arrows show the power direction, bold causal strokes the end of
    each bond that receives the effort, controlled junctions are boxed (off:
    grey, dashed, with their bonds).  The layout follows the junction
    structure (see the module docstring).  On a new figure the figure is
    sized to the drawing (``fontsize`` points for the labels, at most 40
    inches a side); on a given ``ax`` the drawing is scaled down to fit it if
    needed (never up: the labels keep ``fontsize``), centred, with one scale
    for x and y.  ``legend=False`` leaves out the line that explains the
    marks; ``title`` replaces the default (the graph's name and the
    configuration).  Returns the axis.

    Example::

        >>> from models import falling_rod
        >>> rod = falling_rod.build()
        >>> mode = rod.mode("contact|stuck")
        >>> ax = draw_bond_graph(rod.graph, rod.configuration_of(mode), words=rod.mode_space.junction_words(mode))
        >>> ax.figure.savefig("rod.svg")  # doctest: +SKIP
    """
    plt = pyplot()
    own = ax is None
    if own:
        ax = plt.figure(figsize=(6, 4)).add_axes([0, 0, 1, 1])
    if not graph.elements:
        ax.set_axis_off()
        ax.set_title(title or f"{graph.name}: no elements", fontsize=fontsize)
        return ax
    causality = graph.causality(config, open_ports=False)  # the graph as drawn: no open-port bonds
    shown_config = None if config is None else causality.configuration
    layout = layout_bond_graph(graph)
    renderer = ax.figure.canvas.get_renderer()
    ppp = 72.0 / ax.figure.dpi  # points per pixel

    # labels first, measured at the base size
    texts = _labels(ax, graph, causality, shown_config, fontsize, words or {})
    extents = {name: _extent(t, renderer, ppp) for name, t in texts.items()}

    # grid → points: columns packed row by row around the labels, rows as tall as their tallest
    xs, ys = _spread_for_diagonals(layout, extents, 2.0 * fontsize, 2.0 * fontsize, pad=0.12 * fontsize)
    pos = {name: np.array([xs[c], -ys[r]]) for name, (c, r) in layout.cells.items()}
    for name, t in texts.items():
        t.set_position(pos[name])
    lines = _bonds(ax, graph, causality, layout, pos, xs, ys, extents, fontsize)
    lo, hi = _drawn_extent(pos, extents, lines)
    if legend:
        lo, hi = _legend(ax, graph, texts, lo, hi, fontsize, renderer, ppp)
    _fit(ax, own, texts, lines, lo, hi, fontsize, renderer, ppp)
    if title is None:
        title = graph.name if shown_config is None else f"{graph.name}: {_describe(shown_config, words or {})}"
    ax.set_title(title, fontsize=fontsize, wrap=True)
    return ax


def _labels(ax, graph, causality, shown_config, fontsize: float, words: dict) -> dict:
    """The text artist of every element (placed later), by name: controlled junctions boxed, grey when off,
    marked by their word in ``words`` where they have one."""
    parameters = graph.parameters
    texts = {}
    for name, el in graph.elements.items():
        controlled = _kind_of(el) == "junction" and el.controlled
        on = causality.configuration.get(name, True)
        state = None if (shown_config is None or not controlled) else on
        off = controlled and not on
        box = dict(boxstyle="square,pad=0.25", fc="white", ec="none")
        if controlled:
            box.update(ec="0.55" if off else "black", ls="--" if off else "-", lw=1.0)
        size = fontsize * (1.2 if _kind_of(el) == "junction" else 1.0)
        label = element_label(el, state, parameters, words.get(name))
        texts[name] = ax.text(0, 0, label, ha="center", va="center", fontsize=size,
                              family="serif", math_fontfamily="dejavuserif",
                              color="0.5" if off else "black", gid=f"element:{name}",
                              bbox=box, zorder=4)
    return texts


def _bonds(ax, graph, causality, layout, pos, xs, ys, extents, fontsize: float) -> list:
    """Draw every bond (its line from label edge to label edge, its half-arrow at the head, its causal
    stroke); returns ``[(artist, base line width)]``."""
    grey = "0.55"
    pad = 0.12 * fontsize
    barb_back, barb_side, stroke_half = 0.75 * fontsize, 0.5 * fontsize, 0.55 * fontsize
    lines = []
    for bond in graph.bonds.values():
        way = [pos[bond.tail]] + [np.array([xs[c], -ys[r]]) for c, r in (layout.paths or {}).get(bond.name, [])[1:-1]]
        way.append(pos[bond.head])
        way = _corners(way)
        d0 = _unit(way[1] - way[0])
        d1 = _unit(way[-1] - way[-2])
        p0 = way[0] + d0 * _exit_distance(extents[bond.tail], d0, pad)
        p1 = way[-1] - d1 * _exit_distance(extents[bond.head], -d1, pad)
        if len(way) == 2 and np.dot(p1 - p0, d0) <= 0:  # labels touching: keep a stub
            length = float(np.hypot(*(way[1] - way[0])))
            p0, p1 = way[0] + d0 * length * 0.45, way[0] + d0 * length * 0.55
        points = [p0] + way[1:-1] + [p1]
        ends = [graph.elements[bond.tail], graph.elements[bond.head]]
        off = any(_kind_of(e) == "junction" and e.controlled and not causality.configuration.get(e.name, True)
                  for e in ends)
        dead = bond.name in causality.dead
        color = grey if off or dead else "black"
        style = ":" if dead else ("--" if off else "-")
        (line,) = ax.plot(*zip(*points), color=color, ls=style, lw=1.1, gid=f"bond:{bond.name}",
                          solid_capstyle="butt", solid_joinstyle="miter", zorder=2)
        lines.append((line, 1.1))
        n1 = np.array([-d1[1], d1[0]])  # left of the direction of travel
        barb = p1 - d1 * barb_back + n1 * barb_side
        (arrow,) = ax.plot(*zip(p1, barb), color=color, lw=1.1, gid=f"arrow:{bond.name}",
                           solid_capstyle="round", zorder=3)
        lines.append((arrow, 1.1))
        if dead:
            continue
        at = causality.stroke_at(graph, bond.name)
        end, d = (p1, d1) if at == bond.head else (p0, d0)
        n = np.array([-d[1], d[0]])
        (stroke,) = ax.plot(*zip(end - n * stroke_half, end + n * stroke_half), color=color, lw=2.4,
                            gid=f"stroke:{bond.name}", solid_capstyle="butt", zorder=3)
        lines.append((stroke, 2.4))
    return lines


def _drawn_extent(pos, extents, lines):
    """``(lo, hi)``: the corners [points] of what is drawn, labels and bonds."""
    lo = np.array([min(pos[n][0] - extents[n][0] for n in pos), min(pos[n][1] - extents[n][2] for n in pos)])
    hi = np.array([max(pos[n][0] + extents[n][1] for n in pos), max(pos[n][1] + extents[n][3] for n in pos)])
    for artist, _ in lines:
        xy = artist.get_xydata()
        lo, hi = np.minimum(lo, xy.min(axis=0)), np.maximum(hi, xy.max(axis=0))
    return lo, hi


def _legend(ax, graph, texts: dict, lo, hi, fontsize: float, renderer, ppp: float):
    """The line explaining the marks, below the drawing (scaled with the labels: kept in ``texts``);
    returns the extent grown to hold it."""
    note = ax.text((lo[0] + hi[0]) / 2, lo[1] - 1.2 * fontsize,
                   "half-arrow: power direction    bold stroke: the end that receives the effort"
                   + ("\nboxed: controlled junction (grey, dashed: off)" if graph.controlled_junctions else ""),
                   ha="center", va="top", fontsize=0.8 * fontsize, color="0.35", gid="legend", zorder=4,
                   bbox=dict(boxstyle="square,pad=0.1", fc="none", ec="none"))
    left, right, below, above = _extent(note, renderer, ppp)
    cx, cy = note.get_position()
    texts[None] = note
    return np.minimum(lo, [cx - left, cy - below]), np.maximum(hi, [cx + right, cy + above])


def _fit(ax, own: bool, texts: dict, lines: list, lo, hi, fontsize: float, renderer, ppp: float) -> None:
    """Size a figure of its own to the drawing (at most 40 inches a side), then show the drawing centred
    with one scale for x and y, scaled down (never up: the labels keep their size) to fit the axis."""
    margin = 0.6 * fontsize
    lo, hi = lo - margin, hi + margin
    width, height = hi - lo
    fig = ax.figure
    if own:
        max_in = 40.0
        w_in, h_in = width / 72.0, height / 72.0
        shrink = min(1.0, max_in / w_in, max_in / h_in)
        title_in = 0.45
        fig.set_size_inches(max(w_in * shrink, 3.0), max(h_in * shrink, 1.2) + title_in)
        ax.set_position([0, 0, 1, 1 - title_in / fig.get_size_inches()[1]])
    box = ax.get_window_extent(renderer)
    per_pixel = max(width / box.width, height / box.height, ppp)  # data units per pixel
    centre = (lo + hi) / 2
    ax.set_xlim(centre[0] - per_pixel * box.width / 2, centre[0] + per_pixel * box.width / 2)
    ax.set_ylim(centre[1] - per_pixel * box.height / 2, centre[1] + per_pixel * box.height / 2)
    scale = ppp / per_pixel
    if scale < 1.0:
        for t in texts.values():
            t.set_fontsize(t.get_fontsize() * scale)
        for artist, lw in lines:
            artist.set_linewidth(lw * scale)
    ax.set_axis_off()


def _unit(v):
    length = float(np.hypot(*v))
    return v / length if length > 0 else np.array([1.0, 0.0])


def _corners(points):
    """The points of a polyline without those in the middle of a straight run."""
    out = [points[0]]
    for k in range(1, len(points) - 1):
        a, b = _unit(points[k] - out[-1]), _unit(points[k + 1] - points[k])
        if abs(a[0] * b[1] - a[1] * b[0]) > 1e-9:
            out.append(points[k])
    out.append(points[-1])
    return out


def _describe(config, words: dict) -> str:
    """The configuration in a title: ``S1 on, D1 off`` (each junction by its word in ``words`` where it has one:
    ``S1 closed, D1 conducting``); a count when there are more than six."""
    if not config:
        return "no controlled junctions"
    if len(config) > 6:
        on = [name for name, value in config.items() if value]
        return (f"{len(config)} controlled junctions, {len(on)} on"
                + (f" ({', '.join(on)})" if 0 < len(on) <= 6 else ""))
    return ", ".join(f"{name} {words.get(name) or ('on' if on else 'off')}" for name, on in config.items())


def _spread_for_diagonals(layout, extents, gap_x, gap_y, pad):
    """Grid positions in which no diagonal bond (a one-port placed at a
    corner of its junction) cuts the label at either other corner of its
    grid square: where one would, the two columns move apart (a flatter
    bond clears both)."""
    extra: dict = {}
    diagonals = []
    where = {cell: name for name, cell in layout.cells.items()}
    for name, (c, r) in layout.cells.items():
        for dc, dr in ((1, 1), (1, -1)):
            other = where.get((c + dc, r + dr))
            if other is None:
                continue
            for corner in ((c + dc, r), (c, r + dr)):
                if corner in where:
                    diagonals.append((name, other, where[corner], c + 1))
    for _ in range(40):
        xs, ys = _grid_positions(layout, extents, gap_x, gap_y, extra)
        moved = False
        for a, b, obstacle, column in diagonals:
            (ca, ra), (cb, rb), (co, ro) = layout.cells[a], layout.cells[b], layout.cells[obstacle]
            p, q = np.array([xs[ca], -ys[ra]]), np.array([xs[cb], -ys[rb]])
            left, right, below, above = (e + pad for e in extents[obstacle])
            x, y = xs[co], -ys[ro]
            if _segment_meets_box(p, q, (x - left, x + right, y - below, y + above)):
                extra[column] = extra.get(column, 0.0) + 0.25 * gap_x
                moved = True
        if not moved:
            break
    return xs, ys


def _segment_meets_box(p, q, box):
    """Does the segment p–q pass through the box (x0, x1, y0, y1)?  (Liang–Barsky)"""
    x0, x1, y0, y1 = box
    d = q - p
    lo, hi = 0.0, 1.0
    for delta, start, a, b in ((d[0], p[0], x0, x1), (d[1], p[1], y0, y1)):
        if abs(delta) < 1e-12:
            if not a <= start <= b:
                return False
            continue
        t0, t1 = sorted(((a - start) / delta, (b - start) / delta))
        lo, hi = max(lo, t0), min(hi, t1)
        if lo > hi:
            return False
    return True


def _grid_positions(layout, extents, gap_x, gap_y, extra=None):
    """Column centres and row centres (points, rows downwards) for the
    labels' measured extents.

    Rows are as tall as their tallest label and ``gap_y`` apart, so labels of
    different rows never meet.  Columns are packed row by row: in each row,
    neighbouring labels are ``gap_x`` apart (a cell a bond passes through
    counts as a label of no width), so a wide label in one row does not push
    the others apart; a column keeps one centre, so what sits above or below
    a junction stays on its vertical.  ``extra``: column → more room before it."""
    items = {}  # row → {column: (left, right)}
    for name, (c, r) in layout.cells.items():
        items.setdefault(r, {})[c] = extents[name][:2]
    for (c, r) in layout.reserved:
        items.setdefault(r, {})[c] = None  # a bond passes: no width, a shorter gap
    cols = sorted({c for row in items.values() for c in row})
    rows = sorted(items)
    xs = {}
    last = {}  # row → column of the item placed last in it
    for c in range(cols[0], cols[-1] + 1):
        x = xs[c - 1] + 0.5 * gap_x if c - 1 in xs else 0.0
        for r, row in items.items():
            if c in row and r in last:
                p = last[r]
                if row[p] is None or row[c] is None:
                    x = max(x, xs[p] + (row[p] or (0.0, 0.0))[1] + 0.6 * gap_x + (row[c] or (0.0, 0.0))[0])
                else:
                    x = max(x, xs[p] + row[p][1] + gap_x + row[c][0])
        xs[c] = x + (extra or {}).get(c, 0.0)
        for r, row in items.items():
            if c in row:
                last[r] = c
    up, down = {}, {}
    for name, (c, r) in layout.cells.items():
        up[r] = max(up.get(r, 0.0), extents[name][3])
        down[r] = max(down.get(r, 0.0), extents[name][2])
    ys = {}
    y = 0.0
    for r in range(rows[0], rows[-1] + 1):
        if r > rows[0]:
            labelled = r - 1 in up and r in up  # both rows hold labels, not only bond routes
            y += down.get(r - 1, 0.0) + (gap_y if labelled else 0.6 * gap_y) + up.get(r, 0.0)
        ys[r] = y
    return xs, ys
