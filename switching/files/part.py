"""One model file's tables → a :class:`Part`: its bond graph (with the
sub-model instances it places), automata with their guards parsed, signals,
parameters with their values, inputs and initial state — all sympy, nothing
executed.

The steps, each failing at the line of its culprit:

1. names are declared and checked: parameters, inputs, states (of the storage
   elements and displacements), bond variables, mode constants, signals, and
   those of the sub-model instances (each placed in a scratch graph to learn
   them);
2. every expression is parsed (:meth:`switching.files.read.Reader.parse`)
   and may use only the names allowed at its place: a law ``t``, parameters,
   states, inputs, bond variables and mode constants; a signal also the
   signals before it; a guard every signal; a restitution coefficient, a mode
   constant's value or an initial value only parameters;
3. the graph is built with the toolkit's own constructors, in the order of
   ``[elements]`` (which fixes the state vector), then ``[bonds]``,
   ``[displacements]`` and ``[ports]``;
4. each instance of a sub-model file brings its automata, signals, parameter
   values, inputs and initial values, renamed into the instance; then come this
   file's own automata, signals, inputs and initial state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import sympy as sp

from bondgraph import GY, TF, BondGraph, C, I, One, R, Se, Sf, Zero
from bondgraph import t as TIME
from bondgraph.errors import HybridBondGraphError

from .automaton_table import AUTOMATON_KEYS, read_automaton
from .errors import MAX_ELEMENTS, ModelFileError
from .instances import (Entry, bring_instance, graph_share_bind, instance_mapping, share_bind,
                        sub_graph)
from .source import Source, did_you_mean, is_number, kind_of
from .specs import LAW_NAMES, SIGNAL_NAMES, AutomatonSpec, InModeSpec, Parameter, Part, TransitionSpec

__all__ = ["Part", "Parameter", "TransitionSpec", "AutomatonSpec", "InModeSpec", "build_part",
           "LAW_NAMES", "SIGNAL_NAMES"]

_ELEMENT_KEYS = {
    "Se": ("value",),
    "Sf": ("value",),
    "C": ("capacitance", "effort_law", "state"),
    "I": ("inertance", "flow_law", "state"),
    "R": ("resistance", "effort_law", "flow_law"),
    "TF": ("modulus",),
    "GY": ("modulus",),
    "0": ("controlled",),
    "1": ("controlled",),
}
_INSTANCE_KEYS = ("component", "file", "share", "bind", "parameters", "args")

# ------------------------------------------------------------------ names


@dataclass
class _Names:
    """The names of one part, by kind (for the checks of each expression)."""

    parameters: set = field(default_factory=set)
    states: set = field(default_factory=set)
    inputs: set = field(default_factory=set)
    bond_variables: set = field(default_factory=set)
    constants: set = field(default_factory=set)
    signals: set = field(default_factory=set)

    def law(self) -> set:
        return {"t"} | self.parameters | self.states | self.inputs | self.bond_variables | self.constants

    def owner(self, name: str) -> str:
        """What ``name`` already names in the part (one owner a name, :mod:`bondgraph.namespace`)."""
        kinds = (("the time", {"t"}), ("a state", self.states), ("an input", self.inputs),
                 (f"a bond variable (the {'effort' if name.startswith('e_') else 'flow'} of bond {name[2:]!r})",
                  self.bond_variables), ("a mode constant", self.constants), ("a parameter", self.parameters))
        return next((what for what, names in kinds if name in names), "another quantity")

    def symbols(self) -> dict:
        every = self.law() | self.signals
        return {name: (TIME if name == "t" else sp.Symbol(name)) for name in every}


class _PartBuilder:
    """Builds one :class:`Part` from its source (the steps of the module docstring)."""

    def __init__(self, reader, src: Source, part: Part, depth: int):
        self.reader = reader
        self.src = src
        self.part = part
        self.depth = depth
        self.data = src.data
        self.names = _Names()
        self.entries: list[Entry] = []

    def build(self) -> None:
        self._declare_parameters()
        self._declare_inputs()
        self._read_entries()
        bonds = self._read_bonds()
        self._declare_other_names(bonds)
        symbols = self.names.symbols()
        self._build_elements(symbols, bonds)
        self._connect(bonds)
        self._displacements()
        self._ports()
        self._sub_model_extras()
        self._automata_and_signals(symbols)
        self._inputs(symbols)
        self._initial_state(symbols)

    # ---------------------------------------------------------- declarations

    def _declare_parameters(self):
        src = self.src
        table = src.table(self.data.get("parameters", {}), ("parameters",), "[parameters]",
                          example='R = 1.0 or R = { value = 1.0, unit = "ohm" }')
        for name, spec in table.items():
            keys = ("parameters", name)
            src.name(name, keys, "parameter name", expression=True)
            culprit = f"parameter {name!r}"
            if isinstance(spec, dict):
                src.table(spec, keys, "the table", allowed=("value", "unit", "description", "allow_infinite"),
                          required=("value",), culprit=culprit)
                value = spec["value"]
                unit, description = spec.get("unit"), spec.get("description")
                allow_infinite = spec.get("allow_infinite", False)
                for key, item in (("unit", unit), ("description", description)):
                    if item is not None:
                        src.text_value(item, keys + (key,), key, f"parameter {name!r}")
                if not isinstance(allow_infinite, bool):
                    raise src.error("allow_infinite must be true or false", keys, culprit)
            else:
                value, unit, description, allow_infinite = spec, None, None, False
            if not is_number(value):
                raise src.error(f"the value must be a number, not {kind_of(value)} "
                                '(write R = 1.0, or R = { value = 1.0, unit = "ohm" })', keys, culprit)
            value = float(value)
            if math.isnan(value) or (math.isinf(value) and not allow_infinite):
                raise src.error(f"the value is {value}: a parameter needs a finite number"
                                + ("" if math.isnan(value) else " (or allow_infinite = true where that is physical)"),
                                keys, culprit)
            self.part.parameters[name] = Parameter(value, unit, description, allow_infinite, (src, keys))
        self.names.parameters |= set(self.part.parameters)

    def _declare_inputs(self):
        table = self.src.table(self.data.get("inputs", {}), ("inputs",), "[inputs]",
                               example='u = "V0*sin(2*pi*f*t)"')
        for name in table:
            self.src.name(name, ("inputs", name), "input name", expression=True)
        self.names.inputs |= set(table)

    def _read_entries(self):
        src = self.src
        table = src.table(self.data.get("elements", {}), ("elements",), "[elements]",
                          example='R1 = { type = "R", resistance = "R" }')
        count = 0
        for name, spec in table.items():
            keys = ("elements", name)
            src.name(name, keys, "element name")
            culprit = f"element {name!r}"
            if not isinstance(spec, dict):
                raise src.error(f"an element is a table such as {{ type = \"R\", resistance = \"R\" }}, "
                                f"not {kind_of(spec)}", keys, culprit)
            if "component" in spec or "file" in spec:
                culprit = f"sub-model instance {name!r}"
                src.table(spec, keys, "the table", allowed=_INSTANCE_KEYS, culprit=culprit)
                sub = self.reader.sub_part(src, keys, culprit, spec, self.depth)
                graph = sub if isinstance(sub, BondGraph) else sub.graph
                count += len(graph.elements)
                entry = Entry(name, keys, spec, "instance", sub)
            else:
                if "type" not in spec:
                    raise src.error("an element needs type = one of " + ", ".join(map(repr, _ELEMENT_KEYS))
                                    + ", or component = / file = for a sub-model instance", keys, culprit)
                kind = spec["type"]
                if kind not in _ELEMENT_KEYS:
                    raise src.error(f"unknown type {kind!r}{did_you_mean(kind, _ELEMENT_KEYS)}; types: "
                                    + ", ".join(map(repr, _ELEMENT_KEYS)), keys + ("type",), culprit)
                src.table(spec, keys, "the table", allowed=("type",) + _ELEMENT_KEYS[kind], culprit=culprit)
                count += 1
                entry = Entry(name, keys, spec, kind)
            if count > MAX_ELEMENTS:
                raise src.error(f"the model has more than {MAX_ELEMENTS} elements (sub-models included)",
                                keys, culprit)
            self.entries.append(entry)
        self._scratch_names()

    def _scratch_names(self):
        """Learn the names each instance contributes by placing it in a scratch graph."""
        for entry in self.entries:
            if entry.kind != "instance":
                continue
            scratch = BondGraph("scratch")
            share, bind = share_bind(self.src, entry)
            bound = {k: sp.Dummy(k) for k in bind}  # the names only matter here, not the bound values
            graph_share, graph_bind = graph_share_bind(entry, share, bound)
            try:
                instance = scratch.add_submodel(sub_graph(entry), entry.name, bind=graph_bind, share=graph_share)
            except HybridBondGraphError as exc:
                raise self.src.error(str(exc), entry.keys, f"sub-model instance {entry.name!r}") from None
            mapping = instance_mapping(self.src, entry, instance, share, bound)
            self.names.states |= {s.name for s in scratch.states}
            self.names.bond_variables |= {s.name for s in scratch.bond_symbols()}
            self.names.inputs |= set(scratch.inputs)
            self.names.parameters |= {s.name for s in scratch.parameters}  # (a Dummy is no parameter)
            if isinstance(entry.sub, Part):
                sub = entry.sub
                for name in sub.parameters:
                    target = mapping.get(name)
                    if isinstance(target, sp.Symbol) and not isinstance(target, sp.Dummy):
                        self.names.parameters.add(target.name)
                self.names.constants |= {mapping[c].name for c in sub.constants}
                self.names.signals |= {f"{entry.name}/{s}" for s in sub.signals}
                self.names.inputs |= {mapping[i].name for i in sub.inputs
                                      if isinstance(mapping[i], sp.Symbol) and not isinstance(mapping[i], sp.Dummy)}
            self.names.parameters -= self.names.constants

    def _read_bonds(self) -> list:
        src = self.src
        table = src.table(self.data.get("bonds", {}), ("bonds",), "[bonds]", example='b1 = "V -> j1"')
        bonds = []
        for name, arrow in table.items():
            keys = ("bonds", name)
            src.name(name, keys, "bond name")
            culprit = f"bond {name!r}"
            if not isinstance(arrow, str) or arrow.count("->") != 1:
                raise src.error(f"a bond is written \"tail -> head\" (power flows from tail to head), "
                                f"not {arrow!r}", keys, culprit)
            tail, head = (s.strip() for s in arrow.split("->"))
            bonds.append((name, tail, head, keys))
        return bonds

    def _declare_other_names(self, bonds):
        src, names = self.src, self.names
        for name, _, _, _ in bonds:
            names.bond_variables |= {f"e_{name}", f"f_{name}"}
        for entry in self.entries:
            if entry.kind in ("C", "I"):
                state = entry.spec.get("state")
                if state is None:
                    state = f"{'q' if entry.kind == 'C' else 'p'}_{entry.name}"
                else:
                    src.name(state, entry.keys + ("state",), "state name", expression=True)
                names.states.add(state)
        table = src.table(self.data.get("displacements", {}), ("displacements",), "[displacements]",
                          example='theta = { of = "omega" }')
        for name in table:
            src.name(name, ("displacements", name), "displacement name", expression=True)
        names.states |= set(table)
        automata = src.table(self.data.get("automata", {}), ("automata",), "[automata]")
        for auto_name, spec in automata.items():
            keys = ("automata", auto_name)
            spec = src.table(spec, keys, "the table", allowed=AUTOMATON_KEYS, culprit=f"automaton {auto_name!r}")
            values = src.table(spec.get("values", {}), keys + ("values",), "values",
                               example="values = { stuck = { sigma = 0 }, slide = { sigma = 1 } }")
            for state, table_ in values.items():
                table_ = src.table(table_, keys + ("values", state), f"values of state {state!r}")
                for constant in table_:
                    src.name(constant, keys + ("values", state), "mode constant name", expression=True)
                    names.constants.add(constant)
                    self.part.constants.add(constant)
        clash = names.constants & set(self.part.parameters)
        if clash:
            name = sorted(clash)[0]
            raise src.error(f"{name!r} is a mode constant (set by automaton states) and cannot also be a "
                            "parameter; remove it from [parameters]", ("parameters", name))
        names.parameters -= names.constants
        signals = src.table(self.data.get("signals", {}), ("signals",), "[signals]", example='v = "q_C/C"')
        for name in signals:
            src.name(name, ("signals", name), "signal name", expression=True)
        names.signals |= set(signals)

    # ---------------------------------------------------------- the graph

    def _build_elements(self, symbols, bonds):
        other = self.names.states | self.names.inputs | self.names.bond_variables | {"t"}
        for name, parameter in self.part.parameters.items():
            if name in other:
                raise self.src.error(f"{name!r} is already {self.names.owner(name)}; a name has one owner: "
                                     "rename the parameter", parameter.where[1], f"parameter {name!r}")
        for name in self.data.get("inputs", {}):
            self.part.graph.input(name)
        bonds_of: dict[str, list] = {}
        for name, tail, head, _ in bonds:
            bonds_of.setdefault(tail, []).append(name)
            bonds_of.setdefault(head, []).append(name)
        for entry in self.entries:
            if entry.kind == "instance":
                self._place(entry, symbols)
            else:
                element = self._element(entry, symbols, bonds_of.get(entry.name, []))
                self.part.graph.add(element)

    def _element(self, entry, symbols, bonds):
        src, spec, keys, kind, name = self.src, entry.spec, entry.keys, entry.kind, entry.name
        culprit = f"{kind if kind not in '01' else kind + '-junction'} {name!r}"
        law = self.names.law()

        def value(key, what, allowed=law):
            return self.reader.parse(src, keys + (key,), culprit, spec[key], symbols, allowed, what)

        def one_of(*options):
            given = [k for k in options if k in spec]
            if len(given) != 1:
                raise src.error(f"give exactly one of {', '.join(options)}"
                                + (f" (got {', '.join(given)})" if given else ""), keys, culprit)
            return given[0]

        try:
            if kind in ("Se", "Sf"):
                if "value" not in spec:
                    raise src.error("a source needs value = a number or an expression", keys, culprit)
                return (Se if kind == "Se" else Sf)(name, value("value", "the value"))
            if kind in ("C", "I"):
                linear, nonlinear = ("capacitance", "effort_law") if kind == "C" else ("inertance", "flow_law")
                key = one_of(linear, nonlinear)
                state = spec.get("state")
                cls = C if kind == "C" else I
                if key == linear:
                    return cls(name, value(linear, f"the {linear}"), state=state)
                return cls(name, **{nonlinear: value(nonlinear, f"the {nonlinear}")}, state=state)
            if kind == "R":
                key = one_of("resistance", "effort_law", "flow_law")
                if key == "resistance":
                    return R(name, value("resistance", "the resistance"))
                if len(bonds) != 1:
                    raise src.error(f"an R with a law needs exactly one bond (its law is written in that bond's "
                                    f"{'flow f_' if key == 'effort_law' else 'effort e_'}<bond>); it has "
                                    f"{len(bonds)}", keys, culprit)
                own = sp.Symbol(f"{'f' if key == 'effort_law' else 'e'}_{bonds[0]}")
                other = f"{'e' if key == 'effort_law' else 'f'}_{bonds[0]}"
                expr = value(key, f"the {key}", law - {other})
                return R(name, **{key: lambda x: expr.xreplace({own: x})})
            if kind in ("TF", "GY"):
                if "modulus" not in spec:
                    raise src.error("a TF or GY needs modulus = a number or an expression", keys, culprit)
                return (TF if kind == "TF" else GY)(name, value("modulus", "the modulus"))
            controlled = spec.get("controlled", False)
            if not isinstance(controlled, bool):
                raise src.error(f"controlled must be true or false, not {kind_of(controlled)}", keys, culprit)
            return (Zero if kind == "0" else One)(name, controlled=controlled)
        except ModelFileError:
            raise
        except HybridBondGraphError as exc:
            raise src.error(str(exc), keys, culprit) from None

    def _place(self, entry, symbols):
        src, culprit = self.src, f"sub-model instance {entry.name!r}"
        share, bind_text = share_bind(self.src, entry)
        law = self.names.law()
        bound = {k: self.reader.parse(src, entry.keys + ("bind", k), culprit, v, symbols, law, f"bind {k}")
                 for k, v in bind_text.items()}
        graph_share, graph_bind = graph_share_bind(entry, share, bound)
        graph = self.part.graph
        if len(graph.elements) + len(sub_graph(entry).elements) > MAX_ELEMENTS:
            raise src.error(f"the model has more than {MAX_ELEMENTS} elements (sub-models included)",
                            entry.keys, culprit)
        try:
            entry.instance = graph.add_submodel(sub_graph(entry), entry.name, bind=graph_bind,
                                                share=graph_share)
        except HybridBondGraphError as exc:
            raise src.error(str(exc), entry.keys, culprit) from None
        entry.mapping = instance_mapping(self.src, entry, entry.instance, share, bound)

    def _endpoint(self, ref: str, keys, culprit: str) -> str:
        """An element name, or ``instance.port`` resolved to the element behind the port."""
        graph = self.part.graph
        if "." in ref:
            instance_name, _, port = ref.partition(".")
            entry = next((e for e in self.entries if e.name == instance_name and e.kind == "instance"), None)
            if entry is None:
                instances = [e.name for e in self.entries if e.kind == "instance"]
                raise self.src.error(f"{ref!r}: there is no sub-model instance {instance_name!r}"
                                     f"{did_you_mean(instance_name, instances)}", keys, culprit)
            ports = sub_graph(entry).ports
            if port not in ports:
                raise self.src.error(f"{ref!r}: instance {instance_name!r} has no port {port!r}; its ports: "
                                     f"{', '.join(ports) or '(none)'}", keys, culprit)
            return entry.instance.port(port)
        if ref not in graph.elements:
            raise self.src.error(f"{ref!r} is no element of this model{did_you_mean(ref, graph.elements)}; "
                                 "a bond joins two elements (or instance.port of a sub-model)", keys, culprit)
        return ref

    def _connect(self, bonds):
        graph = self.part.graph
        for name, tail, head, keys in bonds:
            culprit = f"bond {name!r}"
            tail_name = self._endpoint(tail, keys, culprit)
            head_name = self._endpoint(head, keys, culprit)
            try:
                graph.connect(tail_name, head_name, name=name)
            except HybridBondGraphError as exc:
                raise self.src.error(str(exc), keys, culprit) from None

    def _displacements(self):
        src, graph = self.src, self.part.graph
        for name, spec in self.data.get("displacements", {}).items():
            keys = ("displacements", name)
            culprit = f"displacement {name!r}"
            if isinstance(spec, str):
                spec = {"of": spec}
            src.table(spec, keys, "the table", allowed=("of", "bond", "sign"), example='{ of = "v" }', culprit=culprit)
            if ("of" in spec) == ("bond" in spec):
                raise src.error("give either of = an element, junction or bond, or bond = a bond", keys, culprit)
            sign = spec.get("sign", 1)
            if sign not in (1, -1) or isinstance(sign, bool):
                raise src.error(f"sign must be 1 or -1, not {sign!r}", keys, culprit)
            try:
                if "bond" in spec:
                    bond = src.text_value(spec["bond"], keys, "bond", culprit)
                    if bond not in graph.bonds:
                        raise src.error(f"no bond {bond!r}{did_you_mean(bond, graph.bonds)}", keys, culprit)
                    graph.displacement(name, graph.bonds[bond], sign)
                else:
                    of = src.text_value(spec["of"], keys, "of", culprit)
                    graph.displacement(name, self._endpoint(of, keys, culprit) if "." in of else of, sign)
            except ModelFileError:
                raise
            except HybridBondGraphError as exc:
                raise src.error(str(exc), keys, culprit) from None

    def _ports(self):
        src = self.src
        table = src.table(self.data.get("ports", {}), ("ports",), "[ports]", example='in = "j1"')
        for name, ref in table.items():
            keys = ("ports", name)
            src.name(name, keys, "port name")
            ref = src.text_value(ref, keys, "the element", f"port {name!r}")
            element = self._endpoint(ref, keys, f"port {name!r}")
            self.part.graph.port(name, element)

    # ---------------------------------------------------------- instances' automata, signals, values

    def _sub_model_extras(self):
        """Bring each instance's automata, signals, parameter values, inputs and
        initial state into this part, renamed."""
        declared = set(self.part.parameters)  # this file's own declarations
        provided: dict[str, tuple] = {}  # parameter → (Parameter, instance) given by a sub-model
        for entry in self.entries:
            if entry.kind == "instance":
                bring_instance(self.src, self.part, entry, declared, provided)

    # ---------------------------------------------------------- own automata and signals

    def _automata_and_signals(self, symbols):
        src, part, names = self.src, self.part, self.names
        law = names.law()
        # signals first: guards use them
        signal_values = {}
        for name, signal in part.signals.items():  # the instances' ones, already in this part's names
            signal_values[name] = sp.Symbol(name) if isinstance(signal, InModeSpec) else signal
        instance_signals = set(part.signals)
        for name, spec in self.data.get("signals", {}).items():
            keys = ("signals", name)
            culprit = f"signal {name!r}"
            if name in law:
                raise src.error(f"{name!r} is already {names.owner(name)}; a name has one owner: rename the "
                                "signal", keys, culprit)
            if name in instance_signals:
                raise src.error("a sub-model instance already has a signal of this name", keys, culprit)
            allowed = law | set(signal_values)
            names_now = {**symbols, **signal_values}
            if isinstance(spec, dict):
                src.table(spec, keys, "the table", allowed=("expression", "in_mode"), required=("expression", "in_mode"),
                          culprit=culprit)
                expr = self.reader.parse(src, keys, culprit, spec["expression"], names_now, allowed,
                                         "the expression", numbers=False, expected=SIGNAL_NAMES.replace("signal", "earlier signal"))
                states = src.table(spec["in_mode"], keys, "in_mode", example='in_mode = { friction = "stuck" }')
                for automaton, state in states.items():
                    src.text_value(state, keys, f"the state of {automaton!r}", culprit)
                part.signals[name] = InModeSpec(expr, dict(states))
                signal_values[name] = sp.Symbol(name)
            else:
                expr = self.reader.parse(src, keys, culprit, spec, names_now, allowed, "the expression",
                                         numbers=False, expected=SIGNAL_NAMES.replace("signal", "earlier signal"))
                part.signals[name] = expr
                signal_values[name] = expr
        guard_names = {**symbols, **signal_values}
        guard_allowed = law | set(signal_values)
        for name, spec in self.data.get("automata", {}).items():
            part.automata.append(read_automaton(self.reader, src, part.graph, names.parameters, name, spec, symbols,
                                                guard_names, guard_allowed))
        for automaton in part.automata:
            for state, table in automaton.values.items():
                for constant in table:
                    part.constants.add(constant)

    # ---------------------------------------------------------- inputs, initial state

    def _inputs(self, symbols):
        src = self.src
        allowed = {"t"} | self.names.parameters
        in_laws = {s.name for el in self.part.graph.elements.values() for e in el.expressions() for s in e.free_symbols}
        for name, value in self.data.get("inputs", {}).items():
            keys = ("inputs", name)
            if name not in in_laws:
                raise src.error("this input is used by no element; remove it or use it in a law", keys,
                                f"input {name!r}")
            self.part.inputs[name] = self.reader.parse(src, keys, f"input {name!r}", value, symbols, allowed,
                                                       "the input", expected="t or a declared parameter")
        missing = [name for name in self.part.graph.inputs if name not in self.part.inputs]
        if missing:
            raise src.error(f"input(s) {', '.join(missing)} have no value; give each as an expression of t in "
                            '[inputs], e.g. u = "sin(t)"', ("inputs",) if "inputs" in self.data else ())

    def _initial_state(self, symbols):
        src = self.src
        table = src.table(self.data.get("initial_state", {}), ("initial_state",), "[initial_state]",
                          example="q_C = 0.0")
        states = {s.name for s in self.part.graph.states}
        for name, value in table.items():
            keys = ("initial_state", name)
            if name not in states:
                raise src.error(f"{name!r} is no state of this model{did_you_mean(name, states)}; states: "
                                f"{', '.join(sorted(states))}", keys, f"initial value of {name!r}")
            self.part.initial[name] = self.reader.parse(src, keys, f"initial value of {name!r}", value, symbols,
                                                        self.names.parameters, "the initial value",
                                                        expected="a declared parameter")
            self.part.initial_where[name] = (src, keys)


def build_part(reader, src: Source, part: Part, depth: int) -> None:
    """Fill ``part`` from the tables of ``src`` (``reader`` parses expressions and reads sub-model files)."""
    _PartBuilder(reader, src, part, depth).build()
