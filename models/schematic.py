"""A circuit's schematic, drawn from its netlist: :meth:`Circuit.draw <models.circuits.Circuit.draw>`.

Ground is the rail at the bottom (its symbol at its left end); every other node a horizontal wire on
a row: the source's node on the top row, with the parts in series that follow it (a buck
converter's switch and inductor, drawn along the row between the input, the switch node and the
output), the other nodes on rows below, each as near the top as the parts between rows allow
(:mod:`models.schematic_layout`).  Every other part stands between its nodes' rows in a column of
its own, its symbol below its upper node: resistors, capacitors, inductors, voltage sources (``+`` at
``n_plus``), current sources (the arrow from ``n_from`` to ``n_to``), diodes (anode to cathode),
switches; a transformer or coupled inductors as two windings side by side on a core (a dot at
each winding's first terminal: ``p1``, ``s1``), a gyrator (a DC machine) as a box between its two
ports.  A dot marks where three or more wires meet; a wire that crosses another without one does
not connect to it.  Each part is labelled with its name and value; a diode or switch with the
state it is drawn in — a switch drawn closed or open, a blocking diode grey — which is a mode's
(``draw(model.mode("S1=closed, D1=blocking"))``) or, by default, the state each has at t = 0.  A
SPICE diode with its exponential law is drawn as a diode without a state.  Controllers have no
terminals: they are listed under the drawing.
"""

from __future__ import annotations

from schemdraw import Segment, SegmentCircle
from schemdraw import elements as elm
from schemdraw.elements.elements import Element2Term

from .netlist import REFERENCE, holds_at_start
from .netlist_drawing import FONT_SIZE, NetlistDrawing, add_controller_notes, quantity, short, states_of, text_extent
from .schematic_layout import Piece, geometry, place

__all__ = ["draw_circuit", "ClosedSwitch", "ROW", "UNITS"]

#: the distance between two rows
ROW = 3.0
#: the unit of each kind of part's value
UNITS = {"R": "Ω", "C": "F", "L": "H", "V": "V", "I": "A"}
#: the states of the circuit's switching parts, and the words they had
STATES = {"D": ("blocking", "conducting"), "S": ("open", "closed")}
ALIASES = {"on": "conducting", "off": "blocking"}
_ACROSS = 0.7  # from a column's left edge to its parts
_WINDINGS = 1.3  # between a transformer's windings
_GREY = "#8c8c8c"


class ClosedSwitch(Element2Term):
    """A switch drawn closed: its blade resting on the far contact."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        r = 0.12
        self.segments.append(Segment([(0, 0), (r, 0)]))
        self.segments.append(Segment([(r, 0), (1 - r, r)]))
        self.segments.append(Segment([(1 - r, 0), (1, 0)]))
        for x in (r, 1 - r):
            self.segments.append(SegmentCircle((x, 0), r, fill="bg", zorder=3))


def draw_circuit(circuit, mode=None) -> NetlistDrawing:
    """The schematic of ``circuit`` (a :class:`~models.circuits.Circuit`) with its diodes and switches in
    the states of ``mode``: a mode of a model built from it, a mapping or a text ``"S1=closed,
    D1=blocking"``; ``None``: the states at t = 0 (see the module documentation)."""
    import schemdraw

    parts = circuit._parts
    states = states_of(circuit, mode, {n: STATES[p.kind] for n, p in parts.items() if p.kind in STATES},
                       _initial_state, ALIASES)
    pieces = _pieces(parts)
    sources = [p for p in parts.values() if p.kind in ("V", "I")] or list(parts.values())
    start = next((n for p in sources for n in p.nodes if n != REFERENCE), None)
    layout = place(pieces, REFERENCE, start=start, chains=True)
    labels = {name: _label(part, states.get(name)) for name, part in parts.items()}
    slot_at = _columns(layout, parts, labels)
    shape = geometry(layout, lambda t: -ROW * t, slot_at, body_gap=_winding_gap(layout))
    d = schemdraw.Drawing(canvas="svg", fontsize=FONT_SIZE, lw=1.5)
    drawn = NetlistDrawing(circuit.name, d, states=states, layout=layout)
    for node, p, q in shape.leads:
        drawn.wires.append((node, p, q))
    for node, (p, q) in shape.buses.items():
        if p != q:
            drawn.wires.append((node, p, q))
    for _, p, q in drawn.wires:
        d.add(elm.Line().endpoints(p, q))
    for point in shape.dots:
        d.add(elm.Dot(radius=0.09).at(point))
    if REFERENCE in shape.buses:
        d.add(elm.Ground().at(shape.buses[REFERENCE][0]))
    for name, part in parts.items():
        if part.kind == "PI":
            continue
        if part.kind in ("T", "K", "G"):
            _two_port(d, drawn, part, shape, labels[name])
            continue
        a, b = shape.body[name]
        symbol = d.add(_symbol(part, states.get(name)).endpoints(a, b))
        if part.kind == "D" and states.get(name) == "blocking":
            symbol.color(_GREY)
        drawn.elements[name] = (symbol,)
        drawn.terminals[name] = shape.ends[name]
        _place_label(d, labels[name], a, b, 0.75 if part.kind in ("V", "I") else 0.5)
    add_controller_notes(d, drawn, parts)
    return drawn


def _initial_state(part) -> str:
    """A diode's or switch's state at t = 0 as its netlist gives it: a diode's ``on``; a switch's ``closed``,
    else a PWM's (closed from the start unless delayed), else its condition's at t = 0 when time alone
    decides it (else open: the first instant decides)."""
    if part.kind == "D":
        return STATES["D"][bool(part.values.get("on"))]
    closed, rule = part.values.get("closed"), part.values.get("closed_when")
    if closed is None:
        if hasattr(rule, "period"):
            closed = rule.delay <= 0
        else:
            closed = isinstance(rule, str) and holds_at_start(rule, {})
    return STATES["S"][bool(closed)]


def _pieces(parts) -> list:
    pieces = []
    for part in parts.values():
        if part.kind == "PI":
            continue
        if part.kind in ("T", "K", "G"):
            p1, p2, s1, s2 = part.nodes
            pieces += [Piece(f"{part.name}:p", (p1, p2), group=part.name),
                       Piece(f"{part.name}:s", (s1, s2), group=part.name)]
        else:
            pieces.append(Piece(part.name, part.nodes, series=REFERENCE not in part.nodes))
    return pieces


def _label(part, state) -> str:
    """A part's label: its name, its state (a diode's, a switch's), its value(s)."""
    kind, values = part.kind, part.values
    lines = [part.name if state is None else f"{part.name} {state}"]
    if kind in UNITS:
        law = values.get("law")
        if law:
            lines.append("exponential diode" if _is_diode_law(law) else f"{law[0].replace('_', ' ')}")
        elif values.get("value") is not None:
            lines.append(quantity(values["value"], UNITS[kind]))
    elif kind == "D":
        drop = [quantity(values[k], u) for k, u in (("v_f", "V"), ("r_on", "Ω")) if values.get(k) is not None]
        if drop:
            lines.append(", ".join(drop))
    elif kind == "S":
        rule = values.get("closed_when")
        if hasattr(rule, "period"):
            lines.append(f"PWM {quantity(rule.period, 's')}, duty {quantity(rule.duty)}")
        else:
            lines.append(f"closed when {short(rule, 16)}")
    elif kind == "T":
        lines.append(f"ratio {quantity(values['value'])}")
    elif kind == "G":
        lines.append(f"r {quantity(values['value'], 'Ω')}")
    elif kind == "K":
        lines.append(f"L1 {quantity(values['L1'], 'H')}, L2 {quantity(values['L2'], 'H')}")
        lines.append(f"k {quantity(values['k'])}")
    return "\n".join(lines)


def _is_diode_law(law) -> bool:
    return "diode" in type(law[1]).__name__.lower()


def _symbol(part, state):
    """The schemdraw element of a two-terminal part, to be drawn from its first terminal to its second."""
    kind = part.kind
    if kind == "R":
        return elm.Diode() if part.values.get("law") and _is_diode_law(part.values["law"]) else elm.Resistor()
    if kind == "V":
        return elm.SourceV().reverse()  # its + towards the end: n_plus is its first node
    if kind == "S":
        return ClosedSwitch() if state == "closed" else elm.Switch()
    return {"C": elm.Capacitor, "L": elm.Inductor2, "I": elm.SourceI, "D": elm.Diode}[kind]()


def _place_label(d, text: str, a, b, away: float = 0.5) -> None:
    """A label beside a symbol: ``away`` to the right of one across the rows, above one along a row."""
    middle = ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)
    if a[0] == b[0]:
        d.add(elm.Label().at((middle[0] + away, middle[1])).label(text, halign="left", valign="center"))
    else:
        d.add(elm.Label().at((middle[0], middle[1] + 0.45)).label(text, halign="center", valign="bottom"))


def _columns(layout, parts, labels):
    """``slot_at(k)``: each column as wide as its labels."""
    starts, spans = [], []
    x = 0.0
    for slot in layout.slots:
        along = [name for name in slot if name in layout.along]
        names = [name.split(":")[0] for name in slot]
        if along:
            width = max(3.0, text_extent(labels[along[0]])[0] + 0.8)
        elif any(name.endswith(":p") for name in slot):
            width = _WINDINGS
        else:
            width = _ACROSS + 0.75 + max(text_extent(labels[n])[0] for n in names) + 0.5
        starts.append(x)
        spans.append(width)
        x += width

    def slot_at(k):
        return starts[k] + _ACROSS, starts[k], starts[k] + spans[k]

    return slot_at


def _winding_gap(layout):
    """``body_gap``: a two-port's windings side by side in the first gap both span (else each in its own)."""

    def body_gap(piece, lo, hi):
        if not piece.group:
            return lo
        low, high = zip(*(layout.interval(f"{piece.group}:{side}") for side in "ps"))
        common = (max(low), min(high))
        return common[0] if common[1] - common[0] >= 1 else lo

    return body_gap


def _two_port(d, drawn, part, shape, label: str) -> None:
    """A transformer's or coupled inductors' windings on their core (dots at ``p1`` and ``s1``), a gyrator's
    box: one symbol when both sides share a gap, one a side otherwise."""
    name = part.name
    (pa, pb), (sa, sb) = shape.body[f"{name}:p"], shape.body[f"{name}:s"]
    drawn.terminals[name] = shape.ends[f"{name}:p"] + shape.ends[f"{name}:s"]
    together = sorted((pa[1], pb[1])) == sorted((sa[1], sb[1]))
    if part.kind == "G":
        boxes = [(pa, sb)] if together else [(pa, pb), (sa, sb)]
        drawn.elements[name] = tuple(_box(d, a, b) for a, b in boxes)
        _place_label(d, label, (max(sa[0], sb[0]), sa[1]), (max(sa[0], sb[0]), sb[1]))
        return
    symbols = []
    for (a, b), outwards in (((pa, pb), -1), ((sa, sb), 1)):
        winding = elm.Inductor2(loops=3).endpoints(a, b)
        if (b[1] < a[1]) == (outwards < 0):  # the loops towards the core
            winding.flip()
        symbols.append(d.add(winding))
        sign = 1 if b[1] > a[1] else -1
        d.add(elm.Dot(radius=0.08).at((a[0] + 0.35 * outwards, a[1] + 0.3 * sign)))
    if together:
        middle = (pa[0] + sa[0]) / 2
        top, bottom = max(pa[1], pb[1]), min(pa[1], pb[1])
        for dx in (-0.07, 0.07):
            d.add(elm.Line().endpoints((middle + dx, top - 0.2), (middle + dx, bottom + 0.2)))
    drawn.elements[name] = tuple(symbols)
    _place_label(d, label, sa, sb)


def _box(d, a, b):
    """A gyrator's box, marked GY, between the body points ``a`` and ``b`` (their columns and rows)."""
    xs, ys = sorted((a[0], b[0])), sorted((a[1], b[1]))
    box = d.add(elm.Rect(corner1=(xs[0] - 0.35, ys[1]), corner2=(xs[1] + 0.35, ys[0])).at((0, 0)))
    d.add(elm.Label().at(((xs[0] + xs[1]) / 2, (ys[0] + ys[1]) / 2)).label("GY", halign="center", valign="center"))
    return box
