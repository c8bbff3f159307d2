"""What the netlist builders share (:mod:`models.circuits`,
:mod:`models.mechanics`): components between named nodes, their names and
values checked as they are added.

A component's name is an identifier (it names signals, parameters and
modes: ``v_D1``, ``D1=on``); a node's name is letters, digits and ``_``
(``"0"``, the reference: ground or the fixed frame).  A value is a number
(it becomes the parameter of the component's name), a parameter name, an
expression of ``t`` as text (parsed, never evaluated), or a declared input.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field

import sympy as sp

from bondgraph import BondGraph
from bondgraph.errors import InvalidGraphError
from bondgraph.symbols import t as TIME
from switching.errors import GuardSyntaxError
from switching.language.parsing import parse_condition, parse_expression

__all__ = ["NAME", "NODE", "REFERENCE", "Netlist", "NetlistBuilder", "Part", "checked_name", "checked_node", "holds_at_start", "parameter_name",
           "source_value", "units_by_prefix"]

#: a component's (and a parameter's) name
NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
#: a node's name
NODE = re.compile(r"[A-Za-z0-9_]+")
#: the reference node: ground, the fixed frame
REFERENCE = "0"


@dataclass
class Part:
    """One component: its kind (the builder's letter), name, nodes and values."""

    kind: str
    name: str
    nodes: tuple
    values: dict = field(default_factory=dict)


def checked_name(name, what: str, example: str):
    """``name`` if it is an identifier, else an error naming ``what`` with an ``example``."""
    if not isinstance(name, str) or not NAME.fullmatch(name):
        raise InvalidGraphError(f"invalid {what} {name!r}: use letters, digits and '_', not starting with "
                                f"a digit (e.g. {example})")
    return name


def checked_node(node, owner, reference: str):
    """The node's name as text (a whole number ≥ 0 is taken as its digits), else
    an error naming the component ``owner``; ``reference`` says what ``"0"`` is."""
    if isinstance(node, int) and not isinstance(node, bool) and node >= 0:
        node = str(node)
    if not isinstance(node, str) or not NODE.fullmatch(node):
        raise InvalidGraphError(f"component {owner!r}: invalid node name {node!r}: use letters, digits and "
                                f"'_' ({reference} is '0')", [str(owner)])
    return node


def parameter_name(text, what: str) -> str:
    """``text`` if it can name a parameter, else an error naming ``what``."""
    if not isinstance(text, str) or not NAME.fullmatch(text):
        raise InvalidGraphError(f"{what}: {text!r} is not a parameter name (letters, digits and '_', "
                                "not starting with a digit)")
    return text


def source_value(value, name, inputs: tuple = ()):
    """A source's value as given, if it is a number, a text (a parameter name or an expression of ``t``),
    a sympy expression or one of the ``inputs`` classes; else an error naming the source ``name``."""
    if isinstance(value, (bool, type(None))) or not isinstance(value, (int, float, str, sp.Expr, *inputs)):
        raise InvalidGraphError(f"{name!r}: its value must be a number, a parameter name, an expression of t "
                                f"as text, or an Input, got {value!r}", [str(name)])
    return value


def holds_at_start(condition: str, parameters: Mapping) -> bool:
    """The condition at t = 0 when it depends on time and parameters only, else ``False``."""
    names = {"t": TIME, **{k: sp.Symbol(k) for k in parameters if NAME.fullmatch(k)}}
    try:
        expr = parse_condition(condition, names)
    except Exception:  # noqa: BLE001 - a signal's name: decided by the first instant's resolution
        return False
    value = expr.subs({TIME: 0, **{sp.Symbol(k): v for k, v in parameters.items()}})
    return bool(value) if value in (sp.true, sp.false) else False


def units_by_prefix(names, prefixes: Mapping[str, str]) -> dict:
    """name → unit for each of ``names`` that starts with one of
    ``prefixes`` (prefix → unit; the longest prefix wins): the units a
    builder gives the signals and states it names (``v_C1`` → V)."""
    ordered = sorted(prefixes, key=len, reverse=True)
    units = {}
    for name in names:
        prefix = next((p for p in ordered if name.startswith(p)), None)
        if prefix is not None:
            units[name] = prefixes[prefix]
    return units


class Netlist:
    """Components between named nodes (``self._parts``: name → :class:`Part`, in the order added)."""

    def __init__(self, name: str, what: str, example: str):
        self.name = checked_name(name, what, example)
        self._parts: dict[str, Part] = {}

    @property
    def nodes(self) -> tuple:
        """The nodes named so far, the reference ``"0"`` included if used, in order of appearance."""
        seen = {}
        for part in self._parts.values():
            for n in part.nodes:
                seen.setdefault(n, None)
        return tuple(seen)

    @property
    def components(self) -> tuple:
        """The components' names, in the order added."""
        return tuple(self._parts)


class NetlistBuilder:
    """One build of a netlist: its bond graph, each node ``n`` a junction
    ``node_<n>`` of kind ``node_junction`` (``"0"``, the reference, none),
    each two-node component on a junction ``branch_<name>`` of the other
    kind; the parameters' defaults, the signals, the initial values and the
    automata collected as the components are built.

    ``number_or_parameter`` and ``expression_value`` turn a component's
    value into a symbol: a number becomes a parameter (named after the
    component, its value the default), a parameter name its symbol, an
    expression of ``t`` as text is parsed (other names in it are parameters
    or declared inputs, which the model checks), an input its symbol."""

    def __init__(self, netlist: Netlist, parameters: dict, inputs: Mapping, node_junction, branch_junction,
                 input_class):
        self.given = parameters
        self.inputs = dict(inputs)
        self.graph = BondGraph(netlist.name)
        self.defaults: dict[str, float] = {}
        self.signals: dict[str, str] = {}
        self.automata: list = []
        self.node_bond: dict[str, str] = {}
        self.junctions = {n: self.graph.add(node_junction(f"node_{n}")) for n in netlist.nodes if n != REFERENCE}
        self._branch_junction, self._input_class = branch_junction, input_class

    # -- names and values

    def number_or_parameter(self, value, default_name, what) -> sp.Expr:
        """The symbol of ``value`` (a number: the parameter ``default_name`` with that default; a
        parameter name; a sympy expression; ``("-", value)`` its negative); ``what`` names it in errors."""
        if isinstance(value, tuple) and value[0] == "-":
            return -self.number_or_parameter(value[1], default_name, what)
        if isinstance(value, str):
            return sp.Symbol(parameter_name(value, what))
        if isinstance(value, sp.Expr):
            return value
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise InvalidGraphError(f"{what}: give a number or a parameter name, got {value!r}") from None
        if not math.isfinite(number):
            raise InvalidGraphError(f"{what}: {number} is not a finite number")
        self.defaults.setdefault(default_name, number)
        return sp.Symbol(default_name)

    def expression_value(self, value, what: str, default_name) -> sp.Expr:
        """A source's value: an input's symbol, an expression of ``t`` parsed, else :meth:`number_or_parameter`;
        ``what`` names the source in errors (``"source 'V1'"``)."""
        if isinstance(value, self._input_class):
            return self.graph.inputs.get(value.name) or self.graph.input(value.name)
        if isinstance(value, str) and (value == "t" or not NAME.fullmatch(value)):
            names = {"t": TIME, **self.graph.inputs}
            try:
                return parse_expression(value, names)
            except GuardSyntaxError as error:
                first_line = str(error).splitlines()[0]
                raise GuardSyntaxError(f"the value of {what} is not an expression of t: {first_line}",
                                       value, error.position) from None
        return self.number_or_parameter(value, default_name, f"value of {what}")

    # -- graph pieces

    def node(self, n):
        """The junction of node ``n`` (``None`` for the reference)."""
        return None if n == REFERENCE else self.junctions[n]

    def note(self, n, bond):
        """Remember ``bond`` as the first bond on node ``n`` (its signals read that bond's variables)."""
        if n != REFERENCE:
            self.node_bond.setdefault(n, bond.name)

    def branch(self, part, element):
        """Bond ``element(sign)`` between the part's first two nodes (on a
        branch junction when neither is the reference); returns the sign ``s``
        with which the element's bond variables give the part's across and
        through variables (``v = s·e``, ``i = s·f`` of a circuit; ``F = s·e``,
        ``v(n1) − v(n2) = s·f`` of a mechanism)."""
        a, b = part.nodes[:2]
        if a != REFERENCE and b != REFERENCE:
            junction = self.graph.add(self._branch_junction(f"branch_{part.name}"))
            self.note(a, self.graph.connect(self.node(a), junction))
            self.note(b, self.graph.connect(junction, self.node(b)))
            self.graph.connect(junction, element(1))
            return 1
        if b == REFERENCE:
            self.note(a, self.graph.connect(self.node(a), element(1)))
            return 1
        self.note(b, self.graph.connect(self.node(b), element(-1)))
        return -1
