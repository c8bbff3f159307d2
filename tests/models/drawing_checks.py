"""Checks of a netlist's drawing read off the drawing itself, not its pixels (shared by
``test_schematic.py`` and ``test_lumped_diagram.py``).

Connectivity: the wires are the straight lines drawn (schemdraw ``Line`` elements; a mass's block,
which is its node, by its outline), two wires connect where an end of one lies on the other (a
crossing joins nothing), and a component's terminals are the ends of its symbols (schemdraw's own
``start`` and ``end`` anchors).  A drawing is right when the terminals of each node of the netlist
lie on one connected set of wires and those of two nodes never do."""

from __future__ import annotations

from xml.etree import ElementTree

from schemdraw import elements as elm

TOL = 1e-6


def _on(point, segment) -> bool:
    (x0, y0), (x1, y1) = segment
    x, y = point
    cross = (x1 - x0) * (y - y0) - (y1 - y0) * (x - x0)
    if abs(cross) > TOL * max(1.0, abs(x1 - x0) + abs(y1 - y0)):
        return False
    return min(x0, x1) - TOL <= x <= max(x0, x1) + TOL and min(y0, y1) - TOL <= y <= max(y0, y1) + TOL


def segments(drawn, blocks=()) -> list:
    """Every wire drawn: the ``Line`` elements' ends, and the outlines of the ``blocks`` (elements)."""
    found = []
    for element in drawn.drawing.elements:
        if type(element) is elm.Line:
            a, b = element.absanchors["start"], element.absanchors["end"]
            found.append(((float(a[0]), float(a[1])), (float(b[0]), float(b[1]))))
    for block in blocks:
        box = block.get_bbox(transform=True)
        corners = [(box.xmin, box.ymin), (box.xmax, box.ymin), (box.xmax, box.ymax), (box.xmin, box.ymax)]
        found += list(zip(corners, corners[1:] + corners[:1]))
    return found


def nets(wires) -> list:
    """The index of each wire's connected set (an end of one on another joins them)."""
    parent = list(range(len(wires)))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, a in enumerate(wires):
        for j, b in enumerate(wires):
            if i < j and (_on(a[0], b) or _on(a[1], b) or _on(b[0], a) or _on(b[1], a)):
                parent[root(i)] = root(j)
    return [root(i) for i in range(len(wires))]


def net_of(point, wires, roots) -> set:
    return {roots[i] for i, w in enumerate(wires) if _on(point, w)}


def terminal_points(drawn, part) -> list:
    """``(node, point)`` of each terminal of ``part`` as drawn: its symbols' start and end anchors (a
    two-port's windings in turn), else the terminals the drawing says (a gyrator's box)."""
    symbols = [s for s in drawn.elements[part.name] if "start" in s.absanchors and s.absanchors["start"]
               != s.absanchors["end"]]
    if len(symbols) * 2 >= len(part.nodes) and len(part.nodes) >= 2:
        points = [s.absanchors[k] for s in symbols for k in ("start", "end")]
        return [(n, (float(p[0]), float(p[1]))) for n, p in zip(part.nodes, points)]
    return list(zip(part.nodes, drawn.terminals[part.name]))


def check_connectivity(drawn, netlist, blocks=()) -> None:
    """The drawing connects exactly the nodes of ``netlist`` (see the module documentation)."""
    wires = segments(drawn, blocks)
    roots = nets(wires)
    net_by_node: dict = {}
    for part in netlist._parts.values():
        if part.kind in ("PI", "M"):
            continue
        for node, point in terminal_points(drawn, part):
            found = net_of(point, wires, roots)
            assert len(found) == 1, f"{part.name}'s terminal at node {node!r} {point} lies on {len(found)} nets"
            net_by_node.setdefault(node, set()).update(found)
    for node, found in net_by_node.items():
        assert len(found) == 1, f"node {node!r} is drawn as {len(found)} separate nets"
    owners: dict = {}
    for node, (net,) in net_by_node.items():
        assert net not in owners, f"nodes {owners.get(net)!r} and {node!r} are drawn connected"
        owners[net] = node


def check_no_overlap(drawn) -> None:
    """No two symbols or labels overlap (their bounding boxes, a label's text inside a mass's block)."""
    blocks = {id(s) for name, group in drawn.elements.items() for s in group if type(s) is elm.Rect}
    symbols = [s for group in drawn.elements.values() for s in group]
    labels = [e for e in drawn.drawing.elements if type(e) is elm.Label]
    items = [(e, e.get_bbox(transform=True)) for e in symbols + labels]
    for i, (p, a) in enumerate(items):
        for q, b in items[i + 1:]:
            if id(p) in blocks or id(q) in blocks:
                continue  # (a block's label is inside it; blocks are checked against each other below)
            overlap_x = min(a.xmax, b.xmax) - max(a.xmin, b.xmin)
            overlap_y = min(a.ymax, b.ymax) - max(a.ymin, b.ymin)
            assert overlap_x <= 0.02 or overlap_y <= 0.02, f"{a} overlaps {b}"
    boxes = [e.get_bbox(transform=True) for e in symbols if id(e) in blocks]
    others = [box for e, box in items if id(e) not in blocks and type(e) is not elm.Label]
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:] + others:
            overlap_x = min(a.xmax, b.xmax) - max(a.xmin, b.xmin)
            overlap_y = min(a.ymax, b.ymax) - max(a.ymin, b.ymin)
            assert overlap_x <= 0.02 or overlap_y <= 0.02, f"block {a} overlaps {b}"


def svg_texts(svg: str) -> str:
    """The SVG's texts, parsed as XML, joined."""
    root = ElementTree.fromstring(svg)
    return "\n".join("".join(node.itertext()) for node in root.iter() if node.tag.endswith("text"))
