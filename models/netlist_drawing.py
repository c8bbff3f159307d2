"""What the drawings of netlists share: the drawing itself, its texts, the states it shows.

A :class:`NetlistDrawing` is what :meth:`Circuit.draw <models.circuits.Circuit.draw>` (a schematic,
:mod:`models.schematic`) and :meth:`Mechanism.draw <models.mechanics.Mechanism.draw>` (a lumped
diagram, :mod:`models.lumped_diagram`) return: a `schemdraw <https://schemdraw.readthedocs.io>`_
drawing placed by :mod:`models.schematic_layout`, with what it drew by name, so that tests and
tools read it without pixels — each component's symbols (``elements``), its terminal points in the
order of its nodes (``terminals``), every wire with the node it belongs to (``wires``) — and the
state each switching component is drawn in (``states``: ``S1 closed``, ``D1 blocking``, ``K
engaged``).  ``svg()`` is its SVG text (texts as SVG text, so the names are searchable), ``save(path)``
writes it (SVG, or PNG, PDF, … through matplotlib), and notebooks show it inline (``_repr_svg_``).

The states drawn are a mode's (DESIGN.md §4b: the words the run says): ``draw(mode)`` takes a mode
of a model built from the netlist (``model.mode("S1=closed, D1=blocking")``, ``model.initial_mode``),
a mapping or a text ``"S1=closed, D1=blocking"`` of the components' states; without one, each
component is drawn in the state its netlist gives it at t = 0.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field

from bondgraph.errors import UnknownNameError

__all__ = ["NetlistDrawing", "add_controller_notes", "quantity", "short", "text_extent", "states_of", "svg_text",
           "FONT_SIZE"]

#: the labels' size [pt]
FONT_SIZE = 11.0
#: the longest text a label shows of a value (an expression of t), in characters
SHORT = 22
_PREFIXES = {-15: "f", -12: "p", -9: "n", -6: "µ", -3: "m", 0: "", 3: "k", 6: "M", 9: "G"}


@dataclass
class NetlistDrawing:
    """A drawn netlist (see the module documentation): ``drawing`` (a ``schemdraw.Drawing``),
    ``elements`` (component → its symbols), ``terminals`` (component → its terminal points, in the
    order of its nodes), ``wires`` (``(node, (x0, y0), (x1, y1))`` of every wire drawn), ``states``
    (component → the state drawn), ``layout`` (:class:`models.schematic_layout.Layout`) and ``notes``
    (the lines under the drawing: controllers, which have no terminals)."""

    name: str
    drawing: object
    elements: dict = field(default_factory=dict)
    terminals: dict = field(default_factory=dict)
    wires: list = field(default_factory=list)
    states: dict = field(default_factory=dict)
    layout: object = None
    notes: tuple = ()

    def svg(self) -> str:
        """The drawing as SVG text."""
        return svg_text(self.drawing)

    def _repr_svg_(self) -> str:
        return self.svg()

    def save(self, path) -> None:
        """Write the drawing to ``path``: SVG by its own writer, other formats (PNG, PDF) through
        matplotlib, by the extension."""
        path = str(path)
        if path.lower().endswith(".svg"):
            with open(path, "w", encoding="utf-8") as f:
                f.write(self.svg())
            return
        from bondgraph.drawing import pyplot

        plt = pyplot()
        self.drawing.draw(show=False, canvas="matplotlib")
        try:
            self.drawing.save(path, transparent=False, dpi=110)
        finally:
            plt.close(self.drawing.fig.fig)
            self.drawing.fig = None

    def __repr__(self) -> str:
        drawn = ", ".join(f"{k} {v}" for k, v in self.states.items())
        return f"NetlistDrawing({self.name!r}, {len(self.elements)} components" + (f", {drawn})" if drawn else ")")


def add_controller_notes(d, drawn, parts) -> None:
    """The controllers of ``parts`` (no terminals: nothing to draw between nodes) listed below the drawing
    ``d``'s wires, one line each — what each measures and its reference — and kept in ``drawn.notes``."""
    from schemdraw import elements as elm

    notes = [f"{p.name}: controller of {short(p.values['measure'])} → {quantity(p.values['reference'])}"
             for p in parts.values() if p.kind == "PI"]
    if notes:
        bottom = min(y for _, p, q in drawn.wires for y in (p[1], q[1])) - 1.4
        d.add(elm.Label().at((0, bottom)).label("\n".join(notes), halign="left", valign="top"))
        drawn.notes = tuple(notes)


def svg_text(drawing) -> str:
    """``drawing``'s SVG, its texts as SVG text (searchable), whatever the backend's setting."""
    import schemdraw

    setting = schemdraw.svgconfig.text
    schemdraw.svgconfig.text = "text"
    try:
        drawing.fig = None
        drawing.draw(show=False, canvas="svg")
        return drawing.fig.getimage(ext="svg").decode("utf-8")
    finally:
        schemdraw.svgconfig.text = setting
        drawing.fig = None


def text_extent(text: str, size: float = FONT_SIZE) -> tuple:
    """``(width, height)`` of a label in drawing units (as schemdraw estimates text)."""
    from schemdraw.backends.svg import text_size

    lines = text.splitlines() or [""]
    width = max(text_size(line, size=size)[0] for line in lines)
    return width * 2 / 72, len(lines) * size * 1.25 * 2 / 72


def quantity(value, unit: str = "", prefixed: bool = True) -> str:
    """A component's value as a label says it: a number with its prefix and unit (``100 µF``; without a
    prefix where ``prefixed`` is false: ``0.002 kg·m²``), a parameter's name or an expression of ``t``
    (shortened), an input's name; ``""`` for none."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, numbers.Real):
        number = float(value)
        if number == 0 or not math.isfinite(number) or not unit or not prefixed:
            return f"{number:.4g} {unit}".strip()
        exponent = max(-15, min(9, 3 * math.floor(math.log10(abs(number)) / 3)))
        mantissa = number / 10.0 ** exponent
        return f"{mantissa:.4g} {_PREFIXES[exponent]}{unit}".strip()
    if isinstance(value, tuple) and len(value) == 2 and value[0] == "-":
        return "-" + quantity(value[1], unit, prefixed)
    name = getattr(value, "name", None)
    if isinstance(name, str) and not isinstance(value, str):
        return f"input {name}"
    return short(str(value))


def short(text: str, limit: int = SHORT) -> str:
    """``text`` cut to ``limit`` characters (an ellipsis says so)."""
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[:limit - 1] + "…"


def states_of(netlist, mode, words: Mapping, initial, aliases: Mapping = None) -> dict:
    """component → the state it is drawn in.  ``words``: component → its states (``("open",
    "closed")``), ``aliases``: old names of states → their names; ``initial(part)``: a part's
    state at t = 0; ``mode``: ``None`` (each part's initial state), a model's mode (its automata of
    these components), a mapping or a text ``"S1=closed, D1=blocking"`` (a component missing keeps
    its initial state; one without states, or a state it has not, is refused by name)."""
    aliases = dict(aliases or {})
    states = {name: initial(part) for name, part in netlist._parts.items() if name in words}
    if mode is None:
        return states
    if hasattr(mode, "automata") and hasattr(mode, "states"):
        given = {a: s for a, s in zip(mode.automata, mode.states) if a in states}
    elif isinstance(mode, str):
        given = {}
        for item in filter(None, (s.strip() for s in mode.split(","))):
            name, _, state = item.partition("=")
            given[name.strip()] = state.strip()
    elif isinstance(mode, Mapping):
        given = dict(mode)
    else:
        raise TypeError(f"draw(mode=...): give a model's mode, a mapping or a text 'S1=closed', got {mode!r}")
    for name, state in given.items():
        if name not in states:
            raise UnknownNameError(f"{netlist.kind_word} {netlist.name!r} has no switching component {name!r}; "
                                   f"those with states: {', '.join(states) or 'none'}", str(name))
        if aliases.get(state) in words[name]:  # a diode's on/off
            state = aliases[state]
        if state not in words[name]:
            raise UnknownNameError(f"{name!r} has no state {state!r}: its states are {', '.join(words[name])}",
                                   str(state))
        states[name] = state
    return states
