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

import re
from collections.abc import Mapping
from dataclasses import dataclass, field

import sympy as sp

from bondgraph.errors import InvalidGraphError
from bondgraph.symbols import t as TIME
from switching.language.parsing import parse_condition

__all__ = ["NAME", "NODE", "Netlist", "Part", "checked_name", "checked_node", "holds_at_start", "parameter_name",
           "source_value"]

#: a component's (and a parameter's) name
NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
#: a node's name
NODE = re.compile(r"[A-Za-z0-9_]+")


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
