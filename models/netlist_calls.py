"""Each component of a netlist as the builder call that adds it: the table a netlist's model file
(:mod:`models.netlist_files`) is written with and replayed from.

A :class:`~models.netlist.Part` holds a component as its builder keeps it: a kind letter (``"D"``),
its name, nodes and values.  Its :class:`Call` says which method of the
:class:`~models.circuits.Circuit` or :class:`~models.mechanics.Mechanism` adds a part of that kind
(``diode``), how many nodes it takes, and for each value the method's keyword (the name a user
writes in Python, and in the file), the shape of value it takes (:data:`SHAPES`) and its unit.
A component several calls make (a MOSFET: a switch and its body diode; a half-bridge: two of each; a
DC machine: a gyrator) is replayed as the parts it made; a hysteresis schedule as the two conditions
it became.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Argument", "Call", "SHAPES", "call_of", "calls", "netlist_word"]

#: what a value of each shape may be in a file
SHAPES = {
    "value": "a number, a text (a parameter name, or an expression of t where the method takes one), "
             "{ expression = \"...\" } or { input = \"u\" }",
    "number": "a number",
    "flag": "true or false",
    "text": "an expression of the signals as text",
    "condition": "a condition as text",
    "schedule": "a condition as text, or a PWM { period = ..., duty = ..., delay = ... }",
    "law": "a law { of = \"v\", law = \"...\" } (an expression of its variable 'of')",
    "limits": "{ lo = ..., hi = ... } (numbers or parameter names; either may be left out)",
}


@dataclass(frozen=True)
class Argument:
    """One value of a part: ``key`` in :attr:`Part.values`, the method's ``keyword`` for it, its
    :data:`SHAPES` word and its ``unit`` (shown beside the component's line); a law's variable is
    written ``of`` (``"v"``: a resistor's flow law of its voltage)."""

    key: str
    keyword: str
    shape: str = "value"
    unit: str = ""
    of: str = ""


@dataclass(frozen=True)
class Call:
    """The builder method that adds a part of one kind: its name, its ``nodes`` (the arguments'
    names, in order) and its :class:`Argument` values."""

    method: str
    nodes: tuple
    arguments: tuple


def _A(key, keyword=None, shape="value", unit="", of=""):
    return Argument(key, keyword or key, shape, unit, of)


def _controller() -> Call:
    return Call("pid", (), (_A("measure", shape="text"), _A("reference"), _A("kp"), _A("ki"), _A("kd"),
                            _A("limits", shape="limits"), _A("tracking", unit="s"),
                            _A("derivative_filter", unit="s"), _A("initial", shape="number"),
                            _A("sample_period", unit="s"), _A("sample_delay", unit="s")))


#: Part kind → the call of a circuit's part
CIRCUIT = {
    "R": Call("R", ("n1", "n2"), (_A("value", unit="Ω"), _A("law", "effort_law", "law", of="i"),
                                  _A("law", "flow_law", "law", of="v"))),
    "C": Call("C", ("n1", "n2"), (_A("value", unit="F"), _A("initial", "v0", "number", "V"),
                                  _A("law", "effort_law", "law", of="q"))),
    "L": Call("L", ("n1", "n2"), (_A("value", unit="H"), _A("initial", "i0", "number", "A"),
                                  _A("law", "flow_law", "law", of="p"))),
    "V": Call("V", ("n_plus", "n_minus"), (_A("value", unit="V"),)),
    "I": Call("I", ("n_from", "n_to"), (_A("value", unit="A"),)),
    "D": Call("diode", ("anode", "cathode"), (_A("r_on", unit="Ω"), _A("v_f", unit="V"), _A("on", shape="flag"))),
    "S": Call("switch", ("n1", "n2"), (_A("closed_when", shape="schedule"), _A("open_when", shape="condition"),
                                       _A("closed", shape="flag"), _A("r_on", unit="Ω"))),
    "T": Call("transformer", ("p1", "p2", "s1", "s2"), (_A("value", "ratio"),)),
    "G": Call("gyrator", ("p1", "p2", "s1", "s2"), (_A("value", "r", unit="Ω"),)),
    "K": Call("coupled_inductors", ("p1", "p2", "s1", "s2"), (_A("L1", unit="H"), _A("L2", unit="H"), _A("k"))),
    "PI": _controller(),
}


def _mechanism(rotational: bool) -> dict:
    """Part kind → the call of a mechanism's part (``"ST"``: a stop, ``"BL"`` a backlash: a part of kind
    ``"ST"`` whose ``lower`` is ``("-", delta)``)."""
    x, v, F = ("rad", "rad/s", "N·m") if rotational else ("m", "m/s", "N")
    node = ("shaft",) if rotational else ("node",)
    return {
        "M": Call("inertia", node, (_A("value", "J", unit="kg·m²"), _A("v0", "omega0", "number", v))) if rotational
        else Call("mass", node, (_A("value", "m", unit="kg"), _A("v0", shape="number", unit=v))),
        "K": Call("spring", ("n1", "n2"), (_A("value", "k", unit=f"{F}/{x}"), _A("q0", shape="number", unit=x),
                                           _A("law", "effort_law", "law", of="q"))),
        "B": Call("damper", ("n1", "n2"), (_A("value", "b", unit=f"{F}·s/{x}"),
                                           _A("law", "effort_law", "law", of="v"))),
        "F": Call("torque" if rotational else "force", node, (_A("value", unit=F),)),
        "S": Call("velocity", ("node",), (_A("value", unit=v),)),
        "G": Call("gear", ("n_in", "n_out"), (_A("value", "ratio"),)),
        "DC": Call("motor", node, (_A("k", unit="V·s/rad"), _A("V", unit="V"), _A("R", unit="Ω"), _A("L", unit="H"),
                                   _A("i0", shape="number", unit="A"))),
        "CL": Call("clutch", ("n1", "n2"), (_A("engaged_when", shape="condition"),
                                            _A("disengaged_when", shape="condition"), _A("engaged", shape="flag"),
                                            _A("T_max", unit=F))),
        "ST": Call("stop", node, (_A("upper", unit=x), _A("lower", unit=x), _A("e"), _A("v_th", unit=v))),
        "BL": Call("backlash", ("n1", "n2"), (_A("upper", "delta", unit=x), _A("e"), _A("v_th", unit=v))),
        "PI": _controller(),
    }


def netlist_word(netlist) -> str:
    """``"circuit"`` or ``"mechanism"``: the table of ``netlist``'s components in its file."""
    return "mechanism" if hasattr(netlist, "kind") else "circuit"


def calls(netlist) -> dict:
    """Method name → :class:`Call` of every component type ``netlist`` takes (both words where a
    mechanism has two: ``mass`` and ``inertia``, ``force`` and ``torque``)."""
    if netlist_word(netlist) == "circuit":
        return {call.method: call for call in CIRCUIT.values()}
    own = _mechanism(netlist.kind == "rotational")
    return {**{call.method: call for call in _mechanism(netlist.kind != "rotational").values()},
            **{call.method: call for call in own.values()}}


def call_of(netlist, part) -> Call:
    """The :class:`Call` that adds ``part`` to ``netlist`` (in the words of a rotational mechanism's
    kind where it has its own)."""
    if netlist_word(netlist) == "circuit":
        return CIRCUIT[part.kind]
    backlash = part.kind == "ST" and isinstance(part.values.get("lower"), tuple)
    return _mechanism(netlist.kind == "rotational")["BL" if backlash else part.kind]
