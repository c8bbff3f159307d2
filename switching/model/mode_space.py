"""The modes of a model's automata: a mode named in any of its spellings, its
junction configuration, its constants, its restitution and the transitions
leaving it.  A mode is one state per automaton, ``(s_1, …, s_n)``; the model
has ``∏ |S_a|`` of them, named here, never enumerated."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from itertools import chain, compress
from operator import attrgetter, contains, getitem, methodcaller

import sympy as sp

from bondgraph.errors import UnknownNameError, did_you_mean

from ..errors import ModelDefinitionError
from .modes import Mode


class ModeSpace:
    """The modes of ``automata`` (in their order) with the parsed guards of
    their transitions, ``guards[(automaton name, transition)] = (condition, text)``."""

    def __init__(self, automata: Sequence, guards: Mapping):
        self.automata = tuple(automata)
        self.names = tuple(a.name for a in self.automata)
        self.guards = guards
        self._leaving: dict = {}  # (automaton, state, its transitions' count) → guards_from's entries
        self._modes: dict = {}  # states → the mode's one object (known_mode)

    def mode(self, spec) -> Mode:
        """A mode from a :class:`Mode`, a tuple of states, a mapping
        {automaton: state}, or text: as outputs show it,
        ``"contact=free, friction=stuck"`` (``|`` between the pairs too), or
        the states alone joined by ``|``, ``"free|stuck"``.  Automata not
        named in a mapping or in ``automaton=state`` text keep their initial state.
        A state may be named by one of its automaton's aliases (an old name,
        ``fr_law=sliding`` for ``fr_law=stuck``); the mode has the state's own name."""
        if isinstance(spec, Mode):
            states = spec.states
        elif isinstance(spec, str) and "=" in spec:
            return self.mode(self.pairs(spec))
        elif isinstance(spec, str):
            states = tuple(spec.split("|")) if spec else ()
        elif isinstance(spec, Mapping):
            unknown = set(spec) - set(self.names)
            if unknown:
                raise UnknownNameError(f"no automaton named {sorted(unknown)}; automata: {list(self.names)}")
            states = tuple(spec.get(a.name, a.initial) for a in self.automata)
        else:
            states = tuple(spec)
        if len(states) != len(self.automata):
            raise UnknownNameError(f"mode {spec!r} has {len(states)} state(s) but the model has "
                                   f"{len(self.automata)} automata ({', '.join(self.names)})")
        named = tuple(a.state_named(s) for a, s in zip(self.automata, states))
        if isinstance(spec, Mode) and named == spec.states and spec.automata == self.names:
            return self._modes.setdefault(named, spec)
        return self.known_mode(named)

    def known_mode(self, states: tuple) -> Mode:
        """The mode of ``states`` (one per automaton, in their order, each by its own name): one object per
        mode, so that a map keyed by modes finds its key by identity and a run holds no copies of a mode
        (the modes met are few: each is derived)."""
        found = self._modes.get(states)
        if found is None:
            found = self._modes[states] = Mode(states, self.names)
        return found

    def pairs(self, text: str) -> dict:
        """``"a=s, b=t"`` (or ``"a=s|b=t"``) → ``{"a": "s", "b": "t"}``; an automaton named twice is an error."""
        pairs = {}
        for item in re.split(r"\s*[,|]\s*", text.strip()):
            automaton, equals, state = (part.strip() for part in item.partition("="))
            if not equals or not automaton or not state:
                raise UnknownNameError(f"mode {text!r}: {item!r} is not automaton=state; write a mode as "
                                       f"{self.example()!r} or its states joined by |", text)
            if automaton not in self.names:
                raise UnknownNameError(f"mode {text!r}: no automaton named {automaton!r}"
                                       f"{did_you_mean(automaton, self.names)}; automata: {', '.join(self.names)}",
                                       automaton)
            if automaton in pairs:
                raise UnknownNameError(f"mode {text!r} names automaton {automaton!r} twice", automaton)
            pairs[automaton] = state
        return pairs

    def example(self) -> str:
        """The initial mode as outputs show it (for messages)."""
        return ", ".join(f"{a.name}={a.initial}" for a in self.automata)

    def junction_words(self, mode) -> dict:
        """Controlled junction name → the state of the automaton that switches it in ``mode`` (any
        spelling :meth:`mode` takes), the word the mode shows it by (``{"S1": "closed", "D1":
        "conducting"}``): what drawings and equations write for the junction's state, so that they say
        what the run says (``draw_bond_graph(model.graph, model.configuration_of(m),
        words=model.mode_space.junction_words(m))``).  Only an automaton whose
        states are the junctions' on and off (a switch, a diode, a clutch: two states, one turning its
        junctions on, the other off) words them; the others' junctions are on or off (a ball's
        ``contact=impact`` and ``contact=rest`` both hold the floor's junction on)."""
        states = self.mode(mode).states
        return {j: state for a, state in zip(self.automata, states) if _words_on_off(a) for j in a.junctions}

    def configuration_of(self, mode: Mode) -> dict:
        """Controlled junction name → on (``True``) or off, as the states of ``mode`` set them."""
        # (each automaton's setting in turn, later ones winning, as updates would: a scene's thousand
        # automata without a Python loop over them)
        return dict(chain.from_iterable(map(methodcaller("items"), map(getitem, map(attrgetter("states"),
                                                                                   self.automata), mode.states))))

    def mode_values(self, mode: Mode) -> dict:
        """Mode-dependent constants set by the automaton states of ``mode`` (symbol → value)."""
        values: dict = {}
        if not any(map(attrgetter("values"), self.automata)):  # (most models: no automaton sets constants)
            return values
        for automaton, state in zip(self.automata, mode.states):
            for name, value in automaton.values.get(state, {}).items():
                values[sp.Symbol(name)] = value
        return values

    def restitution_of(self, mode: Mode):
        """The restitution coefficient ``e`` of the mode's jump (``x⁺`` of the
        impacted velocities ``= −e ·`` their value before), ``None`` if no state
        carries one; two different coefficients in one mode are an error."""
        found = {}
        holding = map(contains, map(attrgetter("restitution"), self.automata), mode.states)
        for automaton, state in compress(zip(self.automata, mode.states), holding):  # (those whose state has one)
            found[f"{automaton.name}={state}"] = automaton.restitution[state]
        if not found:
            return None
        values = set(found.values())
        if len(values) > 1:
            raise ModelDefinitionError(
                f"mode {mode.describe()} combines different restitution coefficients "
                + ", ".join(f"{k}: e = {v}" for k, v in found.items())
                + "; one jump cannot apply two; use one coefficient or separate the contacts",
                list(found),
            )
        return values.pop()

    def guards_from(self, mode: Mode) -> list:
        """(automaton, transition, condition, text) of every transition leaving ``mode``."""
        out = []
        for automaton, state in zip(self.automata, mode.states):
            out += self.leaving(automaton, state)[1]
        return out

    def leaving(self, automaton, state: str) -> tuple:
        """``(key, entries)``: :meth:`guards_from`'s entries of the transitions leaving ``state`` of
        ``automaton``, kept under ``key`` (a scene's modes repeat a thousand of them; the same list
        while the automaton has the same transitions)."""
        key = (automaton.name, state, len(automaton.transitions))
        found = self._leaving.get(key)
        if found is None:
            found = self._leaving[key] = (key, [(automaton.name, tr, *self.guards[(automaton.name, tr)])
                                                for tr in automaton.transitions_from(state)])
        return found


def _words_on_off(automaton) -> bool:
    """Whether ``automaton``'s states name its junctions' on and off: two states, each turning every
    junction the same way, one on and one off."""
    settings = {tuple(set(setting.values())) for setting in automaton.states.values()}
    return len(automaton.states) == 2 and settings == {(True,), (False,)}
