"""A mechanism's lumped diagram, drawn from its netlist: :meth:`Mechanism.draw <models.mechanics.Mechanism.draw>`.

The frame is the hatched wall on the left; every other node a column to its right, in the order
the parts lead away from the wall (:mod:`models.schematic_layout`): a node with a mass (an inertia)
is its block, labelled with its name and value, a node without one a thin bar.  Every part between
two nodes is drawn across the columns in a lane, parts in series on one line: springs (a zigzag),
dampers (a dashpot), gears (two wheels in mesh), clutches (two plates: together when engaged, apart
when disengaged), stops (a plate before a bar fixed to the frame: touching in contact, apart while
free) and backlashes (a plate in a bracket); a force is an arrow from its node in the positive
direction, a prescribed velocity a source (a circle and its arrow), a motor a circle on its shaft.
Each part is labelled with its name and value; a clutch, a stop and a backlash with the state
drawn, a mode's (``draw(model.mode("K=engaged, end=free"))``) or, by default, the state at t = 0.
Controllers have no node: they are listed under the drawing.  A rotational machine is drawn the
same way: its shafts are the columns, its inertias the blocks.
"""

from __future__ import annotations

from schemdraw import Segment, SegmentCircle
from schemdraw import elements as elm
from schemdraw.elements.elements import Element2Term
from schemdraw.elements.twoterm import gap

from .netlist import REFERENCE, holds_at_start
from .netlist_drawing import FONT_SIZE, NetlistDrawing, add_controller_notes, quantity, states_of, text_extent
from .schematic_layout import Piece, geometry, place

__all__ = ["draw_mechanism", "Spring", "Damper", "Clutch", "Stop", "Backlash", "Gears", "LANE"]

#: the distance between two lanes
LANE = 2.2
#: units of each kind of value, translational and rotational
UNITS = {"translational": {"M": "kg", "K": "N/m", "B": "N·s/m", "F": "N", "S": "m/s", "x": "m", "T": "N"},
         "rotational": {"M": "kg·m²", "K": "N·m/rad", "B": "N·m·s/rad", "F": "N·m", "S": "rad/s", "x": "rad",
                        "T": "N·m"}}
#: the kinds of value a label shows with a unit
_VALUED = ("M", "K", "B", "F", "S")
_STUB = 1.7  # the length of a force's arrow, a source's or a motor's symbol
_BODY = 2.4  # the least length of a part's symbol between two nodes


class Spring(Element2Term):
    """A spring: a zigzag."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        points = [(0, 0), (0.15, 0)] + [(0.15 + 0.15 * (k + 0.5), 0.25 * (-1) ** k) for k in range(6)]
        self.segments.append(Segment(points + [(1.05, 0), (1.2, 0)]))


class Damper(Element2Term):
    """A damper: a piston in a cylinder (a dashpot)."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.segments.append(Segment([(0, 0), (0.6, 0), gap, (1.0, 0), (1.2, 0)]))
        self.segments.append(Segment([(0.6, -0.18), (0.6, 0.18)]))
        self.segments.append(Segment([(0.3, 0.28), (1.0, 0.28), (1.0, -0.28), (0.3, -0.28)]))


class Clutch(Element2Term):
    """A clutch: two plates, together when ``engaged``."""

    def __init__(self, engaged: bool = False, **kwargs):
        super().__init__(**kwargs)
        self.engaged = engaged
        half = 0.03 if engaged else 0.15
        a, b = 0.5 - half, 0.5 + half
        self.segments.append(Segment([(0, 0), (a, 0), gap, (b, 0), (1.0, 0)]))
        for x in (a, b):
            self.segments.append(Segment([(x, -0.35), (x, 0.35)], lw=3))


class Stop(Element2Term):
    """A hard stop: the node's plate (at the start) before a bar fixed to the frame (at the end),
    touching it ``in_contact``."""

    def __init__(self, in_contact: bool = False, **kwargs):
        super().__init__(**kwargs)
        self.in_contact = in_contact
        plate = 0.62 if in_contact else 0.4
        self.segments.append(Segment([(0, 0), (plate, 0), gap, (0.7, 0), (1.0, 0)]))
        self.segments.append(Segment([(plate, -0.2), (plate, 0.2)], lw=3))
        self.segments.append(Segment([(0.7, -0.35), (0.7, 0.35)], lw=3))


class Backlash(Element2Term):
    """A backlash: a plate (from the start) with play inside a bracket (from the end)."""

    def __init__(self, in_contact: bool = False, **kwargs):
        super().__init__(**kwargs)
        self.in_contact = in_contact
        plate = 0.72 if in_contact else 0.55
        self.segments.append(Segment([(0, 0), (plate, 0), gap, (0.8, 0), (1.2, 0)]))
        self.segments.append(Segment([(plate, -0.2), (plate, 0.2)], lw=3))
        self.segments.append(Segment([(0.3, 0.32), (0.8, 0.32), (0.8, -0.32), (0.3, -0.32)]))


class Gears(Element2Term):
    """A gear pair: two wheels in mesh, the input's (at the start) the smaller."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.segments.append(Segment([(0, 0), (0.05, 0), gap, (0.95, 0), (1.0, 0)]))
        self.segments.append(SegmentCircle((0.2, 0), 0.15))
        self.segments.append(SegmentCircle((0.65, 0), 0.3))


def draw_mechanism(mechanism, mode=None) -> NetlistDrawing:
    """The lumped diagram of ``mechanism`` (a :class:`~models.mechanics.Mechanism`) with its clutches,
    stops and backlashes in the states of ``mode``: a mode of a model built from it, a mapping or a text
    ``"K=engaged"``; ``None``: the states at t = 0 (see the module documentation)."""
    import schemdraw

    parts = mechanism._parts
    states = states_of(mechanism, mode, {n: _states(p) for n, p in parts.items() if p.kind in ("CL", "ST")},
                       _initial_state)
    units = UNITS[mechanism.kind]
    labels = {name: _label(part, states.get(name), units) for name, part in parts.items()}
    masses = {p.nodes[0]: p.name for p in parts.values() if p.kind == "M"}
    layout = place(_pieces(parts), REFERENCE, chains=False, reference_first=True)
    halves = _halves(layout, masses, labels)
    track_at = _columns(layout, parts, labels, halves)
    shape = geometry(layout, track_at, lambda k: (-LANE * k, 0.0, 0.0), margin=lambda t: halves.get(t, 0) + 0.2,
                     stub=_STUB, body_gap=lambda piece, lo, hi: hi - 1)
    d = schemdraw.Drawing(canvas="svg", fontsize=FONT_SIZE, lw=1.5)
    drawn = NetlistDrawing(mechanism.name, d, states=states, layout=layout)
    blocks = _blocks(layout, shape, masses, halves)
    walls = []
    for node, (p, q) in shape.buses.items():
        if node == REFERENCE:
            walls = [(node, a, b) for a, b in _wall(d, _flipped(p), _flipped(q))]
            drawn.wires += walls
        elif node in blocks:
            drawn.wires += [(node, a, b) for a, b in _edges(blocks[node])]
        elif p != q:
            drawn.wires.append((node, _flipped(p), _flipped(q)))
    for name, part in parts.items():
        if part.kind in ("M", "PI"):
            continue
        a, b = (_flipped(p) for p in shape.body[name])
        terminals = []
        for node, end, inner in zip(part.nodes, shape.ends[name], (a, b)):
            end = _flipped(end)
            if node in blocks:  # on the block's side
                (x0, _), (x1, _) = blocks[node]
                end = (x1 if inner[0] > end[0] else x0, end[1])
            terminals.append(end)
            if end != inner:
                drawn.wires.append((node, end, inner))
        symbol = d.add(_symbol(part, states.get(name)).endpoints(a, b))
        if part.kind == "S":  # a prescribed motion: against the frame
            _wall(d, (b[0], b[1] - 0.1), (b[0], b[1] + 0.1), 0.3)
        drawn.elements[name] = (symbol,)
        drawn.terminals[name] = tuple(terminals)
        middle = ((a[0] + b[0]) / 2, a[1] + (0.65 if part.kind in ("S", "DC") else 0.45))
        d.add(elm.Label().at(middle).label(labels[name], halign="center", valign="bottom"))
    outlines = {(node, a, b) for node, block in blocks.items() for a, b in _edges(block)}  # drawn as blocks
    outlines.update(walls)
    for node, p, q in drawn.wires:
        if p != q and (node, p, q) not in outlines:
            d.add(elm.Line().endpoints(p, q))
    for node, name in masses.items():
        (x0, y0), (x1, y1) = blocks[node]
        block = d.add(elm.Rect(corner1=(x0, y1), corner2=(x1, y0)).at((0, 0)))
        d.add(elm.Label().at(((x0 + x1) / 2, (y0 + y1) / 2)).label(labels[name], halign="center", valign="center"))
        drawn.elements[name] = (block,)
        drawn.terminals[name] = (((x0 + x1) / 2, (y0 + y1) / 2),)
    add_controller_notes(d, drawn, parts)
    return drawn


def _flipped(point):
    return (point[1], point[0])


def _states(part) -> tuple:
    if part.kind == "CL":
        return ("disengaged", "engaged")
    sides = [side for side in ("upper", "lower") if part.values.get(side) is not None]
    return ("free",) + tuple(f"{side}{end}" for side in sides for end in ("_impact", ""))


def _initial_state(part) -> str:
    """A clutch's state at t = 0 as its netlist gives it (``engaged``, else its condition's when time alone
    decides it); a stop's and a backlash's: free."""
    if part.kind == "ST":
        return "free"
    engaged = part.values.get("engaged")
    if engaged is None:
        engaged = holds_at_start(part.values["engaged_when"], {})
    return "engaged" if engaged else "disengaged"


def _pieces(parts) -> list:
    pieces = []
    for part in parts.values():
        if part.kind == "PI":
            continue
        side = 0 if part.kind == "M" else 1
        pieces.append(Piece(part.name, part.nodes, side=side))
    return pieces


def _label(part, state, units) -> str:
    kind, values = part.kind, part.values
    lines = [part.name if state is None else f"{part.name} {state}"]
    if kind in _VALUED:
        if values.get("law"):
            lines.append("law")
        elif values.get("value") is not None:
            lines.append(quantity(values["value"], units[kind], False))
    elif kind == "G":
        lines.append(f"ratio {quantity(values['value'])}")
    elif kind == "DC":
        lines.append(f"k {quantity(values['k'])}, {quantity(values['V'], 'V', False)}, "
                     f"{quantity(values['R'], 'Ω', False)}")
    elif kind == "CL" and values.get("T_max") is not None:
        lines.append(f"T_max {quantity(values['T_max'], units['T'], False)}")
    elif kind == "ST":
        if isinstance(values.get("lower"), tuple):
            lines.append(f"±{quantity(values['upper'], units['x'], False)}, e {quantity(values['e'])}")
        else:
            bounds = [f"{side} {quantity(values[side], units['x'], False)}" for side in ("lower", "upper")
                      if values.get(side) is not None]
            lines.append(", ".join(bounds + [f"e {quantity(values['e'])}"]))
    return "\n".join(lines)


def _symbol(part, state):
    kind = part.kind
    contact = state is not None and state != "free"
    if kind == "ST":
        return Backlash(contact) if isinstance(part.values.get("lower"), tuple) else Stop(contact)
    if kind == "CL":
        return Clutch(state == "engaged")
    if kind == "F":
        return elm.Arrow()
    if kind == "S":
        return elm.SourceI()
    if kind == "DC":
        return elm.Motor()
    return {"K": Spring, "B": Damper, "G": Gears}[kind]()


def _halves(layout, masses, labels) -> dict:
    """track → half the width of the widest block on it."""
    halves: dict = {}
    for node, name in masses.items():
        t = layout.tracks[node]
        halves[t] = max(halves.get(t, 0.0), text_extent(labels[name])[0] / 2 + 0.3)
    return halves


def _columns(layout, parts, labels, halves):
    """``track_at(t)``: each gap as wide as the blocks beside it and the labels of the symbols in it."""
    need: dict = {}
    for name, piece in layout.pieces.items():
        lo, hi = layout.interval(name)
        if len(piece.nodes) == 1:
            t = layout.tracks[piece.nodes[0]]
            g = t if piece.side > 0 else t - 1
            need[g] = max(need.get(g, 0.0), _STUB + 0.6 + (text_extent(labels[name])[0] / 2 if piece.side else 0))
        else:
            need[hi - 1] = max(need.get(hi - 1, 0.0), _BODY, text_extent(labels[name])[0] + 0.4)
    last = max(layout.tracks.values())
    positions = [0.0]
    for t in range(last):
        positions.append(positions[-1] + halves.get(t, 0) + halves.get(t + 1, 0) + need.get(t, _BODY) + 0.4)

    def track_at(t):
        return positions[t] if 0 <= t <= last else positions[-1] + (t - last) * _BODY

    return track_at


def _blocks(layout, shape, masses, halves) -> dict:
    """node → the corners of its mass's block, ``((left, bottom), (right, top))``, around its bar."""
    blocks = {}
    for node in masses:
        (u0, v), (u1, _) = shape.buses[node]
        half = halves[layout.tracks[node]]
        blocks[node] = ((v - half, u0 - 0.75), (v + half, u1 + 0.75))
    return blocks


def _edges(block) -> list:
    (x0, y0), (x1, y1) = block
    corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    return list(zip(corners, corners[1:] + corners[:1]))


def _wall(d, p, q, beyond: float = 0.6) -> list:
    """The frame: a wall along ``p``–``q``, ``beyond`` longer at each end, hatched on its left; its line."""
    (x, y0), (_, y1) = p, q
    low, high = min(y0, y1) - beyond, max(y0, y1) + beyond
    k = 0.0
    while low + k + 0.3 <= high + 1e-9:
        d.add(elm.Line().endpoints((x, low + k + 0.3), (x - 0.25, low + k + 0.05)).linewidth(1))
        k += 0.3
    d.add(elm.Line().endpoints((x, low), (x, high)))
    return [((x, low), (x, high))]
