"""Sub-model instances of a model file: a component or another file placed
under a name, some of its parameters and inputs shared with this file or
bound to expressions here, everything else renamed ``<instance>/<name>``."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import sympy as sp

from bondgraph import BondGraph

from .source import Source, did_you_mean, is_number
from .specs import AutomatonSpec, InModeSpec, Parameter, Part

__all__ = ["Entry", "sub_graph", "share_bind", "inner_names", "graph_share_bind", "instance_mapping",
           "bring_instance", "renamed_automaton"]


@dataclass
class Entry:
    """One entry of [elements]: an element, or an instance of a sub-model."""

    name: str
    keys: tuple
    spec: dict
    kind: str  # element type, or "instance"
    sub: object = None  # BondGraph (component) or Part (file)
    instance: object = None  # the placed Instance
    mapping: dict = field(default_factory=dict)  # inner symbol name → expression in this part


def sub_graph(entry: Entry) -> BondGraph:
    """The bond graph of the instance's sub-model (a component's, or a file part's)."""
    return entry.sub if isinstance(entry.sub, BondGraph) else entry.sub.graph

def share_bind(src: Source, entry: Entry) -> tuple[list, dict]:
    """The instance's ``share`` (names kept as they are) and ``bind`` (name → expression here), checked."""
    keys, culprit = entry.keys, f"sub-model instance {entry.name!r}"
    share = entry.spec.get("share", [])
    if not isinstance(share, list) or not all(isinstance(s, str) for s in share):
        raise src.error('share must be an array of names, e.g. share = ["g"]', keys, culprit)
    bind = src.table(entry.spec.get("bind", {}), keys + ("bind",), "bind", example='bind = { k = "k_spring" }')
    inner = inner_names(entry)
    for name in list(share) + list(bind):
        if name not in inner:
            raise src.error(f"{name!r} is no parameter or input of the sub-model{did_you_mean(name, inner)}; "
                            f"its parameters and inputs: {', '.join(sorted(inner)) or '(none)'}", keys, culprit)
    both = set(share) & set(bind)
    if both:
        raise src.error(f"{sorted(both)} are both shared and bound; choose one", keys, culprit)
    return list(share), dict(bind)

def inner_names(entry: Entry) -> set:
    """The parameters and inputs of the sub-model (what share/bind may name)."""
    graph = sub_graph(entry)
    names = {s.name for s in graph.parameters} | set(graph.inputs)
    if isinstance(entry.sub, Part):
        names |= set(entry.sub.parameters) | set(entry.sub.inputs)
        names -= entry.sub.constants
    return names

def graph_share_bind(entry: Entry, share, bind):
    """The part of ``share`` and ``bind`` that names the graph's own parameters and inputs."""
    graph = sub_graph(entry)
    known = {s.name for s in graph.parameters} | set(graph.inputs)
    return [s for s in share if s in known], {k: v for k, v in bind.items() if k in known}

def instance_mapping(src: Source, entry: Entry, instance, share, bound: dict) -> dict:
    """inner name → expression in this part, for every symbol of the sub-model."""
    graph = sub_graph(entry)
    mapping = {}
    inner = [s.name for s in graph.states] + [s.name for s in graph.bond_symbols()]
    inner += list(graph.inputs) + [s.name for s in graph.parameters]
    for name in inner:
        mapping[name] = instance.symbol(name)
    if isinstance(entry.sub, Part):
        sub = entry.sub
        extra = set(sub.parameters) | set(sub.inputs) | sub.constants
        for name in extra - set(mapping):
            if name in bound:
                mapping[name] = bound[name]
            elif name in share:
                mapping[name] = sp.Symbol(name)
            else:
                mapping[name] = sp.Symbol(f"{entry.name}/{name}")
        for name in sub.signals:
            mapping[name] = sp.Symbol(f"{entry.name}/{name}")
        for name in sub.constants:
            if not isinstance(mapping[name], sp.Symbol) or isinstance(mapping[name], sp.Dummy):
                raise src.error(f"{name!r} is a mode constant of the sub-model; it cannot be bound",
                                     entry.keys, f"sub-model instance {entry.name!r}")
    return mapping


def bring_instance(src: Source, part: Part, entry: Entry, declared: set, provided: dict) -> None:
    """Bring one instance's parameter values, automata, signals, inputs and
    initial state into ``part``, renamed into the instance.  ``provided``
    (parameter → (Parameter, instance name)) collects the values sub-models
    give, so that two instances sharing a parameter must agree on it; a
    parameter this file declares itself (``declared``) keeps its own value."""
    culprit = f"sub-model instance {entry.name!r}"
    mapping = entry.mapping
    symbol_map = {sp.Symbol(k): v for k, v in mapping.items()}
    values = src.table(entry.spec.get("parameters", {}), entry.keys + ("parameters",), "parameters",
                       example="parameters = { m = 2.0 }")
    sub = entry.sub
    defaults = dict(sub.parameters) if isinstance(sub, Part) else {}
    inner = inner_names(entry)
    for name, value in values.items():
        if name not in inner:
            raise src.error(f"parameters: {name!r} is no parameter of the sub-model"
                            f"{did_you_mean(name, inner)}", entry.keys, culprit)
        if not is_number(value) or not math.isfinite(value):
            raise src.error(f"parameters: {name} must be a finite number, not {value!r}", entry.keys, culprit)
        old = defaults.get(name)
        defaults[name] = replace(old, value=float(value)) if old else Parameter(float(value), where=(src, entry.keys))
    for name, parameter in defaults.items():
        target = mapping.get(name, sp.Symbol(f"{entry.name}/{name}"))
        if not isinstance(target, sp.Symbol) or target.name in declared:
            continue  # bound to an expression, or this file's own declaration wins
        earlier = provided.get(target.name)
        if earlier is not None:
            if earlier[0].value != parameter.value:
                raise src.error(
                    f"shared parameter {target.name!r} has the value {earlier[0].value} in instance "
                    f"{earlier[1]!r} and {parameter.value} here; declare it in [parameters] to choose",
                    entry.keys, culprit)
            continue
        provided[target.name] = (parameter, entry.name)
        part.parameters[target.name] = parameter
    if not isinstance(sub, Part):
        return
    for spec in sub.automata:
        part.automata.append(renamed_automaton(src, spec, entry, symbol_map))
    for name, signal in sub.signals.items():
        if isinstance(signal, InModeSpec):
            states = {f"{entry.name}/{a}": s for a, s in signal.states.items()}
            part.signals[f"{entry.name}/{name}"] = InModeSpec(signal.expression.xreplace(symbol_map), states)
        else:
            part.signals[f"{entry.name}/{name}"] = signal.xreplace(symbol_map)
    for name, expr in sub.inputs.items():
        target = mapping[name]
        if isinstance(target, sp.Symbol) and target.name not in part.inputs:
            part.inputs[target.name] = expr.xreplace(symbol_map)
    for name, expr in sub.initial.items():
        part.initial[mapping[name].name] = expr.xreplace(symbol_map)
        if name in sub.initial_where:
            part.initial_where[mapping[name].name] = sub.initial_where[name]
    part.constants |= {mapping[c].name for c in sub.constants}


def renamed_automaton(src: Source, spec: AutomatonSpec, entry: Entry, symbol_map: dict) -> AutomatonSpec:
    """A sub-model's automaton inside instance ``entry``: its name, junctions and symbols prefixed."""
    prefix = entry.name
    states = {s: {f"{prefix}/{j}": on for j, on in setting.items()} for s, setting in spec.states.items()}
    values = {s: {symbol_map[sp.Symbol(k)].name: v.xreplace(symbol_map) for k, v in table.items()}
              for s, table in spec.values.items()}
    transitions = [replace(tr, condition=tr.condition.xreplace(symbol_map), text=None, where=(src, entry.keys))
                   for tr in spec.transitions]
    return AutomatonSpec(f"{prefix}/{spec.name}", states, spec.initial,
                         {s: e.xreplace(symbol_map) for s, e in spec.restitution.items()}, values,
                         transitions, (src, entry.keys), dict(spec.aliases))
