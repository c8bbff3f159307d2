"""What the netlist builders share (:mod:`models.circuits`,
:mod:`models.mechanics`): components between named nodes, their names and
values checked as they are added.

A component's name is an identifier (it names signals, parameters and
modes: ``v_D1``, ``D1=conducting``); a node's name is letters, digits and ``_``
(``"0"``, the reference: ground or the fixed frame).  A value is a number
(it becomes the parameter of the component's name), a parameter name, an
expression of ``t`` as text (parsed, never evaluated), or a declared input.
"""

from __future__ import annotations

import copy
import math
import numbers
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field

import sympy as sp

from bondgraph import BondGraph
from bondgraph.errors import InvalidGraphError, ParameterValueError, PhysicalRangeWarning
from bondgraph.namespace import LANGUAGE_WORDS, TIME_OWNER, Namespace, Owner
from bondgraph.reals import real_expression, real_number
from bondgraph.symbols import t as TIME
from switching.errors import GuardSyntaxError
from switching.language.parsing import FUNCTIONS, parse_condition, parse_expression

from ._common import Range

__all__ = ["NAME", "NODE", "REFERENCE", "BuiltFrom", "Netlist", "NetlistBuilder", "Part", "checked_argument",
           "checked_name", "checked_node", "checked_number", "holds_at_start", "parameter_name", "source_value",
           "units_by_prefix"]

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


def checked_number(value, what: str) -> float:
    """``value`` as a float when it is a finite real number — a Python or numpy
    integer or float (a complex one only with a zero imaginary part); else a
    :class:`~bondgraph.errors.ParameterValueError` naming ``what``
    (``"the period of switch 'S1'"``).  ``True``/``False`` are not numbers here."""
    if isinstance(value, (bool, sp.Basic)) or not isinstance(value, numbers.Number):
        raise ParameterValueError(f"{what}: {value!r} is not a number; give a number or a parameter name",
                                  what, value)
    number = float(real_number(value, what, what))
    if not math.isfinite(number):
        raise ParameterValueError(f"{what} is {number}: give a finite number", what, number)
    return number


#: a number or a name in a condition or expression text
_TOKEN = re.compile(r"\d+\.?\d*(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?|(?P<name>[A-Za-z_][A-Za-z0-9_]*)")

#: what a builder argument may be, by the words :func:`checked_argument` takes
_ACCEPTS = {"number": "a number", "name": "a parameter name", "expression": "an expression of t as text",
            "sympy": "a sympy expression", "input": "an Input"}


def checked_argument(value, what: str, accepts=("number", "name"), inputs: tuple = ()):
    """A builder's argument as it will be used: a number (a Python or numpy
    integer or float, finite: returned as a float), a parameter name (text),
    an expression of ``t`` (text), a sympy expression or one of the
    ``inputs`` classes, as ``accepts`` allows; anything else — ``None``,
    ``True``/``False``, a complex number, text that is no parameter name
    where an expression is not allowed — is a
    :class:`~bondgraph.errors.ParameterValueError` naming ``what``
    (``"the value of R 'R1'"``) and saying what it may be."""
    allowed = " or ".join(_ACCEPTS[a] for a in accepts)
    if isinstance(value, str):
        if "expression" in accepts or ("name" in accepts and NAME.fullmatch(value)):
            return value
        raise ParameterValueError(f"{what}: {value!r} is not a parameter name (letters, digits and '_', not "
                                  f"starting with a digit); give {allowed}", what, value)
    if isinstance(value, sp.Expr) and "sympy" in accepts:
        return real_expression(value, what)
    if inputs and isinstance(value, inputs) and "input" in accepts:
        return value
    if "number" in accepts and isinstance(value, numbers.Number) and not isinstance(value, (bool, sp.Basic)):
        return checked_number(value, what)
    raise ParameterValueError(f"{what}: give {allowed}, got {value!r}", what, value)


def source_value(value, name, inputs: tuple = ()):
    """A source's value as given, if it is a number, a text (a parameter name or an expression of ``t``),
    a sympy expression or one of the ``inputs`` classes; else an error naming the source ``name``."""
    return checked_argument(value, f"the value of source {name!r}", ("number", "name", "expression", "sympy", "input"),
                            inputs)


def holds_at_start(condition: str, parameters: Mapping) -> bool:
    """The condition at t = 0 when it depends on time and parameters only, else ``False``."""
    names = {"t": TIME, **{k: sp.Symbol(k) for k in parameters if NAME.fullmatch(k)}}
    try:
        expr = parse_condition(condition, names)
    except Exception:  # noqa: BLE001 - a signal's name: decided by the first instant's resolution
        return False
    value = expr.subs({TIME: 0, **{sp.Symbol(k): v for k, v in parameters.items()}})
    return bool(value) if value in (sp.true, sp.false) else False


def units_by_prefix(names, prefixes: Mapping[str, str], unitless=()) -> dict:
    """name → unit for each of ``names`` that starts with one of
    ``prefixes`` (prefix → unit; the longest prefix wins): the units a
    builder gives the signals and states it names (``v_C1`` → V); the
    names in ``unitless`` get none."""
    ordered = sorted(prefixes, key=len, reverse=True)
    units = {}
    for name in names:
        if name in unitless:
            continue
        prefix = next((p for p in ordered if name.startswith(p)), None)
        if prefix is not None:
            units[name] = prefixes[prefix]
    return units


class Netlist:
    """Components between named nodes (``self._parts``: name → :class:`Part`, in the order added)."""

    def __init__(self, name: str, what: str, example: str):
        self.name = checked_name(name, what, example)
        #: the word for this kind of netlist in messages (``"circuit"``)
        self.kind_word = what.split()[0]
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

    def _repr_svg_(self) -> str:
        """A notebook shows the netlist as its drawing in the states at t = 0: ``draw()``, which each kind
        of netlist defines (a circuit's schematic, a mechanism's lumped diagram)."""
        return self.draw().svg()


@dataclass(frozen=True)
class BuiltFrom:
    """What a model built from a netlist was built from (``model.built_from``): a copy of the
    :class:`Circuit` or :class:`Mechanism` as it stood at the build, the ``parameters`` given to
    ``build`` and its other keyword ``options`` (``gmin``, ``allow_floating``, the model's options);
    ``inputs`` names the inputs given as Python functions (which no file can hold)."""

    netlist: Netlist
    parameters: dict
    options: dict
    inputs: tuple = ()

    @classmethod
    def record(cls, model, netlist: Netlist, parameters, inputs, options: dict):
        """``model`` with its ``built_from`` set (a deep copy of ``netlist``: later additions to the
        netlist do not change what the model was built from)."""
        model.built_from = cls(copy.deepcopy(netlist), dict(parameters or {}), dict(options),
                               tuple(sorted(inputs or {})))
        return model


class NetlistBuilder:
    """One build of a netlist: its bond graph, each node ``n`` a junction
    ``node_<n>`` of kind ``node_junction`` (``"0"``, the reference, none),
    each two-node component on a junction ``branch_<name>`` of the other
    kind; the parameters' defaults, the signals, the initial values and the
    automata collected as the components are built.

    Names (DESIGN.md §4a, :mod:`bondgraph.namespace`): every parameter, signal and
    state the build makes is claimed in :attr:`names` with the component that
    owns it, so that two components never share one silently (a resistor
    ``S1_period`` beside a PWM switch ``S1``, whose period is the parameter
    ``S1_period``, is refused naming both).  A parameter name the user gives
    as a value (``R("R2", "a", "b", "R_x")``, ``PWM(1e-5, "D")``) is the
    user's: every value given that name shares it, and no name the build
    makes may be it (``"R1"`` given as R2's value beside a resistor ``R1``
    whose number makes the parameter ``R1`` is refused; name the shared
    value ``"R_x"`` for both).  Condition and expression texts read signals,
    states, inputs and ``t`` by their names; any other name in them is a
    parameter the user named, so a text never reads a parameter the build made
    of a component's number.  The elements and bonds the build
    adds besides the components (junctions, a diode's drop, a motor's
    armature) are named around the components' names (:meth:`internal`),
    and every signal reads its bond's variables off the bond made, never
    from a name assumed.

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
        #: name → owner of every parameter, signal and state the build makes
        self.names = Namespace(f"{netlist.kind_word} {netlist.name!r}")
        self.names.claim("t", TIME_OWNER)
        for word in LANGUAGE_WORDS:
            self.names.claim(word, Owner(f"the word {word!r} of the expression language", "", "word"))
        #: parameter name → its physical range (checked on the values the model is built with)
        self.ranges: dict[str, Range] = {}
        self.defaults: dict[str, float] = {}
        self.signals: dict[str, str] = {}
        self.automata: list = []
        #: states whose unit the prefixes would misname (a controller's, in its output's unit): left without one
        self.unitless: set[str] = set()
        self.node_bond: dict[str, str] = {}
        self._components = frozenset(netlist.components)
        self._texts: list[str] = []  # the user's conditions and expressions (claim_text_names)
        self.junctions = {n: self.graph.add(node_junction(self.internal(f"node_{n}")))
                          for n in netlist.nodes if n != REFERENCE}
        self._branch_junction, self._input_class = branch_junction, input_class

    # -- names and values

    def internal(self, base: str) -> str:
        """A new element name for something the build adds besides the components: ``base``, or
        ``base_2``, ``base_3``, … when a component or an element already has that name."""
        name, k = base, 2
        while name in self._components or name in self.graph.elements:
            name, k = f"{base}_{k}", k + 1
        return name

    def bond_name(self, base: str) -> str:
        """A new bond name ``base`` (``base_2``, … when a bond or a component has it: a component's bond
        takes the component's name)."""
        name, k = base, 2
        while name in self._components or name in self.graph.bonds:
            name, k = f"{base}_{k}", k + 1
        return name

    def signal(self, name: str, text: str, owner: str) -> None:
        """Define the signal ``name`` as ``text``, claimed for ``owner`` (``"R 'R1'"``, ``"node 'a'"``)."""
        self.names.claim(name, Owner(f"signal {name!r} of {owner}", f"rename {owner}", "signal"))
        self.signals[name] = text

    def user_parameter(self, name: str) -> str:
        """Claim ``name`` as a parameter the user named: shared by every value and text that names it,
        never a name the build makes (a component's number, ``S1_period``, ``gmin``)."""
        return self.names.claim(name, Owner(f"parameter {name!r} (a name the user gave in the {self.names.scope})",
                                            f"give another parameter name than {name!r}", "parameter"))

    def user_text(self, text: str) -> str:
        """Remember a condition or expression the user wrote (:meth:`claim_text_names` claims its names)."""
        self._texts.append(text)
        return text

    def claim_text_names(self) -> None:
        """Each name in the user's conditions and expressions that names no quantity of the build (a
        signal, state, bond variable, input, ``t``) is a parameter the user named (:meth:`user_parameter`):
        a text never reads a parameter the build made of a component's number — give that value a
        parameter name of its own to use it in a text."""
        for text in self._texts:
            for match in _TOKEN.finditer(text):
                name = match.group("name")
                if not name or name in FUNCTIONS:
                    continue
                owner = self.names.owner(name)
                if owner is None or owner.kind == "parameter":
                    self.user_parameter(name)

    def claim_graph_names(self, owners: Mapping[str, tuple]) -> None:
        """Claim the graph's states, inputs and bond variables: ``owners`` maps a state's name to what it
        is and how to rename it (``("the position of node 'a'", "rename node 'a'")``); a storage
        element's state not listed is its element's."""
        for element in self.graph.storage:
            name = element.state.name
            what, rename = owners.get(name, (f"the state of {element.kind} {element.name!r}",
                                             f"rename {element.name!r}"))
            self.names.claim(name, Owner(f"{what} (a state)", rename, "state"))
        for symbol in self.graph.displacements:
            what, rename = owners.get(symbol.name, (f"the displacement {symbol.name!r}", "rename its node"))
            self.names.claim(symbol.name, Owner(f"{what} (a state)", rename, "state"))
        graph_names = self.graph.namespace()
        for name in graph_names.names("input") + graph_names.names("bond variable"):
            self.names.claim(name, graph_names.owner(name))

    def parameters_checked(self) -> dict:
        """The parameter values the model is built with — the components' numbers, overridden by
        those given to ``build`` — each in its physical range (:attr:`ranges`: out of a required one,
        a :class:`~bondgraph.errors.ParameterValueError`; else a
        :class:`~bondgraph.errors.PhysicalRangeWarning`)."""
        values = {**self.defaults, **self.given}
        for name, allowed in self.ranges.items():
            value = values.get(name)
            if value is None or isinstance(value, (str, bool)):
                continue
            try:
                number = float(real_number(value, f"parameter {name!r}", name))
            except (TypeError, ValueError):
                continue  # the model refuses it by name
            if allowed.holds(number):
                continue
            if allowed.required:
                raise ParameterValueError(f"{self.names.scope}: {name} = {number:g} ({allowed.what}) must be "
                                          f"{allowed.requirement()}", name, number)
            warnings.warn(PhysicalRangeWarning(
                f"{self.names.scope}: {name} = {number:g} is outside the physical range {allowed.describe(name)} "
                f"({allowed.what}); the model is built, but its result may not be physical"), stacklevel=4)
        return values

    def number_or_parameter(self, value, default_name, what, *, rename: str | None = None,
                            allowed: Range | None = None) -> sp.Expr:
        """The symbol of ``value``: a number is the parameter ``default_name`` with that default, ``None``
        the parameter ``default_name`` without one (both claimed for ``what``, ``"value of 'R1'"``: how
        to take another name is ``rename``); a parameter name its symbol; a sympy expression itself;
        ``("-", value)`` its negative.  ``allowed``: the parameter's physical range."""
        if isinstance(value, tuple) and value[0] == "-":
            return -self.number_or_parameter(value[1], default_name, what, rename=rename, allowed=allowed)
        if isinstance(value, str):
            name = self.user_parameter(parameter_name(value, what))
            if allowed is not None:
                self.ranges.setdefault(name, allowed)
            return sp.Symbol(name)
        if isinstance(value, sp.Expr):
            return value
        if value is not None:
            number = checked_number(value, what)
        self.names.claim(default_name, Owner(
            f"parameter {default_name!r} (the {what})",
            rename or f"give the {what} as a parameter name of your own (text)", "parameter"))
        if allowed is not None:
            self.ranges[default_name] = allowed
        if value is not None:
            self.defaults.setdefault(default_name, number)
        return sp.Symbol(default_name)

    def expression_value(self, value, what: str, default_name) -> sp.Expr:
        """A source's value: an input's symbol, an expression of ``t`` parsed, else :meth:`number_or_parameter`;
        ``what`` names the source in errors (``"source 'V1'"``)."""
        if isinstance(value, self._input_class):
            return self.graph.inputs.get(value.name) or self.graph.input(value.name)
        if isinstance(value, str) and (value == "t" or not NAME.fullmatch(value)):
            self.user_text(value)
            names = {"t": TIME, **self.graph.inputs}
            try:
                return parse_expression(value, names)
            except GuardSyntaxError as error:
                first_line = str(error).splitlines()[0]
                raise GuardSyntaxError(f"the value of {what} is not an expression of t: {first_line}",
                                       value, error.position) from None
        return self.number_or_parameter(value, default_name, f"value of {what}",
                                        rename=f"rename {what}")

    # -- graph pieces

    def node(self, n):
        """The junction of node ``n`` (``None`` for the reference)."""
        return None if n == REFERENCE else self.junctions[n]

    def note(self, n, bond):
        """Remember ``bond`` as the first bond on node ``n`` (its signals read that bond's variables)."""
        if n != REFERENCE:
            self.node_bond.setdefault(n, bond.name)

    def branch(self, part, element) -> tuple:
        """Bond ``element(sign)`` between the part's first two nodes (on a
        branch junction when neither is the reference); returns ``(s, bond)``:
        the element's bond and the sign ``s`` with which its variables give the
        part's across and through variables (``v = s·e``, ``i = s·f`` of a
        circuit; ``F = s·e``, ``v(n1) − v(n2) = s·f`` of a mechanism)."""
        a, b = part.nodes[:2]
        if a != REFERENCE and b != REFERENCE:
            junction = self.graph.add(self._branch_junction(self.internal(f"branch_{part.name}")))
            self.note(a, self.graph.connect(self.node(a), junction))
            self.note(b, self.graph.connect(junction, self.node(b)))
            return 1, self.graph.connect(junction, element(1))
        if b == REFERENCE:
            bond = self.graph.connect(self.node(a), element(1))
            self.note(a, bond)
            return 1, bond
        bond = self.graph.connect(self.node(b), element(-1))
        self.note(b, bond)
        return -1, bond
