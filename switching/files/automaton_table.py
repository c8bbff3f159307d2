"""One automaton of a model file (``[automata.<name>]``) → an
:class:`~switching.files.specs.AutomatonSpec`: its states and the controlled
junctions each switches, its restitution coefficients and mode constants,
its transitions with their guards parsed without executing anything."""

from __future__ import annotations

from bondgraph import BondGraph

from ..model.automaton import A_POSTERIORI, A_PRIORI
from .source import Source, did_you_mean, kind_of
from .specs import SIGNAL_NAMES, AutomatonSpec, TransitionSpec

__all__ = ["read_automaton", "known_state"]

AUTOMATON_KEYS = ("initial", "states", "restitution", "values", "transitions", "aliases")
TRANSITION_KEYS = ("from", "to", "guard", "when", "pulses")
WHEN = {"a priori": A_PRIORI, "a posteriori": A_POSTERIORI}


def read_automaton(reader, src: Source, graph: BondGraph, parameters: set, name: str, spec, symbols: dict,
                   guard_names: dict, guard_allowed: set) -> AutomatonSpec:
    """The automaton ``[automata.<name>]`` of ``src``: its states (each switching controlled junctions of
    ``graph``), initial state, restitution coefficients and mode constants (expressions of ``parameters``)
    and its transitions with their guards parsed (names from ``guard_names``, of which ``guard_allowed``
    may appear); every error names the line of its culprit."""
    keys = ("automata", name)
    culprit = f"automaton {name!r}"
    src.name(name, keys, "automaton name")
    src.table(spec, keys, "the table", allowed=AUTOMATON_KEYS, required=("initial", "states"), culprit=culprit)
    states_table = src.table(spec["states"], keys + ("states",), "states",
                             example="states = { on = { sw = true }, off = { sw = false } }")
    if not states_table:
        raise src.error("an automaton needs at least one state", keys, culprit)
    states = {}
    for state, setting in states_table.items():
        skeys = keys + ("states", state)
        src.name(state, skeys, "state name")
        setting = src.table(setting, skeys, f"state {state!r}", example="{ sw = true }")
        for junction, on in setting.items():
            if not isinstance(on, bool):
                raise src.error(f"junction {junction!r} is switched on (true) or off (false), not {on!r}",
                                skeys, culprit)
            element = graph.elements.get(junction)
            if element is None or element.kind not in ("0", "1") or not element.controlled:
                what = "no element" if element is None else "not a controlled junction"
                controlled = graph.controlled_junctions
                raise src.error(f"state {state!r} switches {junction!r}, which is {what} of this model"
                                f"{did_you_mean(junction, controlled)}; controlled junctions: "
                                f"{', '.join(controlled) or '(none)'}", skeys, culprit)
        states[state] = dict(setting)
    initial = spec["initial"]
    if initial not in states:
        raise src.error(f"initial state {initial!r} is not one of its states {list(states)}",
                        keys + ("initial",), culprit)
    restitution = {}
    for state, value in src.table(spec.get("restitution", {}), keys + ("restitution",), "restitution").items():
        known_state(src, state, states, keys + ("restitution",), culprit)
        restitution[state] = reader.parse(src, keys + ("restitution",), culprit, value, symbols, parameters,
                                               f"the restitution coefficient of state {state!r}",
                                               expected="a declared parameter")
    values = {}
    for state, table in spec.get("values", {}).items():
        known_state(src, state, states, keys + ("values",), culprit)
        values[state] = {k: reader.parse(src, keys + ("values", state), culprit, v, symbols, parameters,
                                              f"mode constant {k!r} of state {state!r}",
                                              expected="a declared parameter")
                         for k, v in table.items()}
    transitions = []
    items = spec.get("transitions", [])
    if not isinstance(items, list):
        raise src.error("transitions is an array of tables: [[automata.NAME.transitions]]",
                        keys + ("transitions",), culprit)
    for k, item in enumerate(items):
        tkeys = keys + ("transitions", k)
        tculprit = f"transition {k + 1} of automaton {name!r}"
        src.table(item, tkeys, "the table", allowed=TRANSITION_KEYS, required=("from", "to", "guard"),
                  culprit=tculprit)
        for end in ("from", "to"):
            known_state(src, item[end], states, tkeys + (end,), tculprit)
        if item["from"] == item["to"]:
            raise src.error(f"from and to are both {item['from']!r}; a transition leads to another state",
                            tkeys, tculprit)
        when = item.get("when", "a priori")
        if when not in WHEN:
            raise src.error(f"when must be 'a priori' or 'a posteriori', not {when!r}", tkeys + ("when",),
                            tculprit)
        pulses = item.get("pulses", True)
        if not isinstance(pulses, bool):
            raise src.error(f"pulses must be true or false, not {kind_of(pulses)}", tkeys + ("pulses",), tculprit)
        text = src.text_value(item["guard"], tkeys + ("guard",), "the guard", tculprit)
        condition = reader.parse(src, tkeys + ("guard",), tculprit, text, guard_names, guard_allowed,
                                      "the guard", condition=True, numbers=False,
                                      expected=SIGNAL_NAMES)
        transitions.append(TransitionSpec(item["from"], item["to"], condition, text, WHEN[when], pulses,
                                          (src, tkeys)))
    aliases = read_aliases(src, spec.get("aliases", {}), states, keys + ("aliases",), culprit)
    return AutomatonSpec(name, states, initial, restitution, values, transitions, (src, keys), aliases)


def read_aliases(src: Source, table, states, keys, culprit) -> dict:
    """``aliases = { on = "conducting" }``: other names the states are read by (an old name of a renamed
    state), each a name that is no state, naming one of ``states``."""
    aliases = src.table(table, keys, "aliases", example='aliases = { on = "conducting", off = "blocking" }')
    for alias, state in aliases.items():
        src.name(alias, keys, "alias")
        if alias in states:
            raise src.error(f"alias {alias!r} is the name of a state; an alias is another name for a state",
                            keys, culprit)
        known_state(src, state, states, keys, culprit)
    return dict(aliases)

def known_state(src: Source, state, states, keys, culprit) -> None:
    """A state named at ``keys`` must be one of ``states``."""
    if state not in states:
        raise src.error(f"unknown state {state!r}{did_you_mean(state, states)}; states: "
                             f"{', '.join(states)}", keys, culprit)
