"""The checks and the parsing of a hybrid model's definition, before anything is derived.

:class:`~switching.model.hybrid_model.HybridModel` calls these in turn as it is built: the
automata and the junctions they switch, the names a guard or signal may use,
the signals and guards (text parsed without executing it, or sympy
expressions), the inputs, the parameters the definition uses and their values,
the initial state.  Each refuses bad input with an error of the hierarchy
naming the culprit and saying what to do.
"""

from __future__ import annotations

import math
from collections import ChainMap
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import sympy as sp
from sympy.core.function import AppliedUndef
from sympy.core.relational import Relational
from sympy.logic.boolalg import BooleanAtom, BooleanFunction

from bondgraph import t as TIME
from bondgraph.errors import MissingParameterError, ParameterValueError, UnknownNameError, UnknownParameterError
from bondgraph.errors import did_you_mean
from bondgraph.namespace import Namespace, Owner, collision
from bondgraph.reals import real_number
from bondgraph.symbols import check_name, rate_symbol

from ..errors import ModelDefinitionError
from ..language.parsing import parse_condition, parse_expression

__all__ = ["InMode", "base_names", "check_automata", "check_inputs", "check_parameter_names", "check_law_switch_names", "collect_parameters",
           "computable", "initial_expressions", "initial_only_names", "initial_parameter_values",
           "initial_state",
           "model_namespace", "parameter_values", "parse_guards", "parse_signals"]


@dataclass(frozen=True)
class InMode:
    """A signal as it would be in another mode: ``expression`` evaluated with
    the equations of the current mode with some automata put in other states
    (``states``: automaton → state), at the state that mode's jump map would
    give, finite part only — the paper's ``F^{α01}`` computed from
    ``h(g^{α01}(x))`` (section 5.6), e.g. the friction force a sliding rod
    would need to stay stuck::

        signals={"F_stick": InMode("-e_tip_x", friction="stuck")}
    """

    expression: object
    states: dict

    def __init__(self, expression, **states):
        object.__setattr__(self, "expression", expression)
        object.__setattr__(self, "states", dict(states))


def computable(expr, what: str, culprit: str):
    """``expr`` if it holds no function sympy knows only by name (``sp.Function('foo')(x)``: it has no
    numerical value), else a :class:`ModelDefinitionError` naming ``what`` and the function."""
    undefined = sorted({str(f.func) for f in expr.atoms(AppliedUndef)}) if isinstance(expr, sp.Basic) else []
    if undefined:
        raise ModelDefinitionError(
            f"{what} uses the function(s) {', '.join(map(repr, undefined))}, which have no numerical definition; "
            "write them with sympy's functions (sp.exp, sp.Piecewise, ...) or make them signals", [culprit])
    return expr


def check_automata(graph, automata) -> None:
    """Unique automaton names; each controlled junction of ``graph`` switched by exactly one automaton."""
    names = [a.name for a in automata]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise ModelDefinitionError(f"automata share the name(s) {sorted(dup)}; names must be unique", sorted(dup))
    owner: dict[str, str] = {}
    controlled = set(graph.controlled_junctions)
    for automaton in automata:
        for junction in automaton.junctions:
            if junction not in graph.elements:
                raise ModelDefinitionError(
                    f"automaton {automaton.name!r} switches {junction!r}, which is not in graph {graph.name!r}",
                    [automaton.name, junction],
                )
            if junction not in controlled:
                raise ModelDefinitionError(
                    f"automaton {automaton.name!r} switches {junction!r}, which is not a controlled junction "
                    "(create it with controlled=True)",
                    [automaton.name, junction],
                )
            if junction in owner:
                raise ModelDefinitionError(
                    f"junction {junction!r} is switched by both {owner[junction]!r} and {automaton.name!r}; "
                    "one automaton per junction",
                    [owner[junction], automaton.name, junction],
                )
            owner[junction] = automaton.name
    free = sorted(controlled - set(owner))
    if free:
        raise ModelDefinitionError(
            f"controlled junction(s) {', '.join(map(repr, free))} are driven by no automaton; add one or make them "
            "plain",
            free,
        )


def check_law_switch_names(graph, law_switches: Mapping, automata) -> None:
    """The automaton and branch symbol of each law switch take no name of the user's automata or parameters."""
    taken = {a.name for a in automata}
    parameters = {p.name for p in graph.parameters}
    for sw in law_switches.values():
        if sw.name in taken:
            raise ModelDefinitionError(
                f"the law of {sw.element!r} has a discontinuity ({sw.written}) whose automaton is named "
                f"{sw.name!r}, the name of one of the model's automata; rename that automaton",
                [sw.name],
            )
        if sw.sigma.name in parameters:
            raise ModelDefinitionError(
                f"parameter {sw.sigma.name!r} has the name of the branch of law switch {sw.name!r} "
                f"({sw.written} in the law of {sw.element!r}); rename the parameter",
                [sw.sigma.name],
            )


def base_names(graph, states) -> dict:
    """The names a signal or guard may use, by name: ``t``, the states, the
    bond variables, the parameters of the graph's laws and its inputs."""
    names = {"t": TIME}
    for s in states:
        names[s.name] = s
    for bond in graph.bonds.values():
        names[bond.effort.name] = bond.effort
        names[bond.flow.name] = bond.flow
    for p in graph.parameters:
        names.setdefault(p.name, p)
    for name, sym in graph.inputs.items():
        names[name] = sym
    return names


def model_namespace(model) -> Namespace:
    """The model's one namespace (:mod:`bondgraph.namespace`) before its signals: the graph's names (``t``,
    states, inputs, bond variables), the rates ``d<state>/dt``, the values the automata's states set
    (mode constants), the branch symbols of the law switches, and the parameters of the element laws.
    :func:`parse_signals` claims the signals in it, :func:`parameter_values` checks given names against it."""
    graph, rate_symbols, automata, law_switches = model.graph, model.rate_symbols, model.automata, model.law_switches
    names = graph.namespace().copy(f"model {model.name!r}")
    for state, rate in rate_symbols.items():
        names.claim(rate.name, Owner(f"the rate of state {state.name!r}", f"rename the state {state.name!r}", "rate"))
    for automaton in automata:
        if automaton.name in law_switches:  # its states set the law's branch, claimed below
            continue
        for table in automaton.values.values():
            for key in table:
                names.claim(key, Owner(f"a value set by the states of automaton {automaton.name!r}",
                                       f"rename the value {key!r} of automaton {automaton.name!r}", "mode value"))
    for sw in law_switches.values():
        names.claim(sw.sigma.name, Owner(f"the branch of law switch {sw.name!r} ({sw.written} in the law of "
                                         f"{sw.element!r})", "", "law branch"))
    for p in sorted(graph.parameters, key=lambda s: s.name):
        owner = names.owner(p.name)
        if owner is None or owner.kind not in ("mode value", "law branch"):  # those a law reads, not parameters
            names.claim(p.name, parameter_owner(p.name))
    return names


def parameter_owner(name: str) -> Owner:
    """The owner of the parameter ``name`` in a model's namespace."""
    return Owner(f"parameter {name!r}", f"rename parameter {name!r}", "parameter")


def parse_signals(names: Mapping, signals: Mapping, namespace: Namespace | None = None) -> tuple[dict, dict]:
    """``(signals, cross)``: each signal's expression by name (a later signal
    may use an earlier one), and the :class:`InMode` signals as
    ``name → (expression, {automaton: state})``.  Each signal's name is
    claimed in ``namespace`` (:func:`model_namespace`): a signal named like a
    state, bond variable, parameter or input is a
    :class:`~bondgraph.errors.NameCollisionError` naming both."""
    parsed, cross = {}, {}
    for name, expr in signals.items():
        check_name(name, "signal name")
        if namespace is not None:
            namespace.claim(name, Owner(f"signal {name!r}", f"rename signal {name!r}", "signal"))
        elif name in names and name not in parsed:
            raise ModelDefinitionError(
                f"signal {name!r} has the name of a state, bond variable, parameter or input; rename it", [name]
            )
        if isinstance(expr, InMode):
            inner = expr.expression
            value = parse_expression(inner, ChainMap(parsed, names)) if isinstance(inner, str) else sp.sympify(inner)
            computable(value, f"signal {name!r}", name)
            cross[name] = (value, dict(expr.states))
            parsed[name] = sp.Symbol(name)
            continue
        if isinstance(expr, str):
            value = parse_expression(expr, ChainMap(parsed, names))
        elif isinstance(expr, sp.Basic) and not isinstance(expr, (Relational, BooleanFunction, BooleanAtom)):
            value = expr.xreplace({sp.Symbol(k): v for k, v in parsed.items()})
        else:
            raise ModelDefinitionError(f"signal {name!r} must be a sympy expression or a text, not {expr!r}", [name])
        parsed[name] = computable(value, f"signal {name!r}", name)
    return parsed, cross


def parse_guards(automata, names: Mapping, signals: Mapping) -> dict:
    """``(automaton name, transition) → (condition, text)`` of every transition's guard."""
    guards = {}
    for automaton in automata:
        for tr in automaton.transitions:
            if isinstance(tr.guard, str):
                condition = parse_condition(tr.guard, names)
                text = tr.guard
            else:
                condition = tr.guard.xreplace({sp.Symbol(k): v for k, v in signals.items()})
                text = str(tr.guard)
                computable(condition, f"the guard of {automaton.name}: {tr.source} → {tr.target}", automaton.name)
            guards[(automaton.name, tr)] = (condition, text)
    return guards


def check_inputs(graph, inputs: Mapping) -> dict:
    """The input functions of time, one for each input the graph declares."""
    declared = graph.inputs
    unknown = set(inputs) - set(declared)
    if unknown:
        raise UnknownNameError(f"values given for unknown input(s) {sorted(unknown)}; declared: {sorted(declared)}")
    missing = set(declared) - set(inputs)
    if missing:
        raise MissingParameterError(missing)
    for name, fn in inputs.items():
        if not callable(fn):
            raise ModelDefinitionError(f"input {name!r} must be a function of time t, got {fn!r}", [name])
    return dict(inputs)


def collect_parameters(model) -> tuple:
    """The parameters ``model``'s definition uses (laws, signals, guards,
    restitutions, mode values), sorted by name: every free symbol that is not
    time, a state, a rate, an input, a bond variable or a mode constant; each
    claimed in the model's namespace."""
    graph = model.graph
    used = set(graph.parameters)
    for value in model._signals.values():
        used |= value.free_symbols
    for condition, _ in model._guards.values():
        used |= condition.free_symbols
    for automaton in model.automata:
        for e in automaton.restitution.values():
            used |= e.free_symbols
    reserved = {TIME} | set(model.states) | set(model.rate_symbols.values()) | set(graph.inputs.values())
    reserved |= {rate_symbol(u) for u in graph.inputs.values()}
    reserved |= {sp.Symbol(name) for name in model._cross}
    for automaton in model.automata:
        for table in automaton.values.values():
            reserved |= {sp.Symbol(k) for k in table}
            for value in table.values():
                used |= value.free_symbols
    for value, overrides in model._cross.values():
        used |= value.free_symbols
        taken_in = model.mode(overrides)  # unknown automata or states fail here, at construction
        overrides.update({a: taken_in.state_of(a) for a in overrides})  # each state by its own name, not an alias
    reserved |= graph.bond_symbols()
    parameters = tuple(sorted(used - reserved, key=lambda s: s.name))
    for symbol in parameters:  # those only guards and signals use are claimed here (the laws' already are)
        if symbol.name not in model.namespace:
            model.namespace.claim(symbol.name, parameter_owner(symbol.name))
    return parameters


def parameter_values(model, values: Mapping) -> dict:
    """symbol → float of every parameter of ``model`` (all given, none
    unknown, real, finite unless the model allows it to be infinite)."""
    by_name = {s.name: s for s in model.parameter_symbols}
    given = {(k.name if isinstance(k, sp.Symbol) else str(k)): v for k, v in values.items()}
    check_parameter_names(model, given)
    unknown = set(given) - set(by_name)
    if unknown:
        raise UnknownParameterError(unknown, by_name)
    missing = set(by_name) - set(given)
    if missing:
        raise MissingParameterError(missing, _text_only_names(model, missing))
    out = {}
    for name, v in given.items():
        if not isinstance(v, float):  # (a float is real: its check and message are not made)
            v = real_number(v, f"parameter {name!r} of model {model.name!r}", name)
        try:
            value = float(v)
        except (TypeError, ValueError, OverflowError):
            raise ParameterValueError(f"parameter {name!r} must be a number, got {v!r}", name, v) from None
        if math.isnan(value) or (math.isinf(value) and name not in model.allow_infinite):
            raise ParameterValueError(
                f"parameter {name!r} of model {model.name!r} is {value}: every parameter needs a finite value"
                + ("" if math.isnan(value) else
                   f" (if {name} = {value} is physical here, build the model with allow_infinite={{{name!r}}})"),
                name, value)
        out[by_name[name]] = value
    return out


def check_parameter_names(model, names) -> None:
    """Each of ``names`` given a value as a parameter of ``model`` must not be
    owned by another quantity of its namespace (the time, a state, a bond
    variable, an input, a signal): else a
    :class:`~bondgraph.errors.NameCollisionError` naming that quantity."""
    namespace = getattr(model, "namespace", None)
    if namespace is None:
        return
    for name in names:
        owner = namespace.owner(name)
        if owner is not None and owner.kind != "parameter":
            raise collision(namespace.scope, name, owner, Owner(
                "a parameter (a value is given for it)", "rename the parameter (and the text that uses it)",
                "parameter"))


def _text_only_names(model, names) -> dict:
    """For each name met only in guard or signal text (no element law uses
    it): where it was written, and the closest known names — such a name
    is more often a mistyped signal or state than a parameter."""
    in_laws = {p.name for p in model.graph.parameters}
    known = sorted(set(model._names) | set(model._signals))
    hints = {}
    for name in names:
        if name in in_laws:
            continue
        symbol = sp.Symbol(name)
        places = [f"signal {s!r}" for s, value in model._signals.items() if symbol in value.free_symbols]
        places += [f"guard {text!r} of automaton {auto!r} ({tr.source} → {tr.target})"
                   for (auto, tr), (condition, text) in model._guards.items() if symbol in condition.free_symbols]
        if not places:
            continue
        hints[name] = (f"written in {', '.join(places)} and used by no element law: a parameter of its own, "
                       "or a mistyped name of a state or signal" + did_you_mean(name, known))
    return hints


def initial_expressions(states, initial: Mapping) -> dict:
    """state symbol → its initial value as given, a sympy number or an
    expression of parameters (text is parsed without executing code: ``"l*sin(theta0)"``).
    Unknown states and values that are neither are refused."""
    by_name = {s.name: s for s in states}
    out = {}
    for name, value in initial.items():
        key = name.name if isinstance(name, sp.Symbol) else name
        if key not in by_name:
            raise UnknownNameError(
                f"initial value for unknown state {key!r}; states are: {', '.join(by_name)}", key
            )
        if isinstance(value, str):
            value = parse_expression(value)
        elif not isinstance(value, sp.Basic):
            value = real_number(value, f"initial value of state {key!r}", key)
            try:
                value = sp.Float(float(value))
            except (TypeError, ValueError, OverflowError):
                raise ParameterValueError(f"initial value of state {key!r} must be a number or an expression of "
                                          f"parameters, got {value!r}", key, value) from None
        out[by_name[key]] = value
    return out


def initial_only_names(expressions: Mapping, parameters) -> set:
    """Names the initial expressions use that no law, guard or signal uses:
    parameters of the initial state alone (``theta0``, ``y0``), kept with
    the model but not in its generated code."""
    used = set().union(*(e.free_symbols for e in expressions.values())) if expressions else set()
    return {s.name for s in used} - {s.name for s in parameters}


def initial_parameter_values(model, values: Mapping) -> dict:
    """symbol → float of the parameters only the initial state uses (each real and finite)."""
    out = {}
    check_parameter_names(model, [k.name if isinstance(k, sp.Symbol) else str(k) for k in values])
    symbols = {s.name: s for s in getattr(model, "initial_parameters", ())}  # (the last values' symbols, taken
    # again rather than made: sp.Symbol costs ~1 µs a name)
    for name, v in values.items():
        name = name.name if isinstance(name, sp.Symbol) else str(name)
        if not isinstance(v, float):  # (a float is real: its check and message are not made)
            v = real_number(v, f"parameter {name!r} of model {model.name!r}", name)
        try:
            value = float(v)
        except (TypeError, ValueError, OverflowError):
            raise ParameterValueError(f"parameter {name!r} must be a number, got {v!r}", name, v) from None
        if not math.isfinite(value):
            raise ParameterValueError(f"parameter {name!r} of model {model.name!r} is {value}: the initial state "
                                      "needs a finite value", name, value)
        symbol = symbols.get(name)
        out[sp.Symbol(name) if symbol is None else symbol] = value
    return out


def initial_state(states, expressions: Mapping, values: Mapping) -> np.ndarray:
    """The initial state as given: an array over ``states``, each expression
    of :func:`initial_expressions` evaluated with ``values`` (symbol →
    number: the model's parameters and its initial-state parameters), zero
    where no value is given."""
    x = np.zeros(len(states))
    index = {s: k for k, s in enumerate(states)}
    for state, expr in expressions.items():
        if expr in values:  # (a parameter's value itself, y0: read without a substitution)
            value = values[expr]
        else:
            free = expr.free_symbols
            missing = sorted(s.name for s in free if s not in values)
            if missing:
                raise MissingParameterError(set(missing), {name: f"used by the initial value of state "
                                                                 f"{state.name!r} ({expr})" for name in missing})
            value = expr.xreplace(values) if free else expr
        try:
            number = float(value)
        except (TypeError, ValueError, OverflowError):
            raise ParameterValueError(f"initial value of state {state.name!r} is {value} ({expr}): it must be a "
                                      "real number; give parameter values for which it is", state.name,
                                      value) from None
        if not math.isfinite(number):
            raise ParameterValueError(f"initial value of state {state.name!r} is {number} ({expr}): it must be "
                                      "finite", state.name, number)
        x[index[state]] = number
    return x
