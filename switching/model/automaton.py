"""Local finite state automata that switch controlled junctions.

An :class:`Automaton` owns one or more controlled junctions.  Each of its
states sets them on or off (and may carry a restitution coefficient ``e`` for
a pinnacle contact); each :class:`Transition` ``source → target`` fires when
its guard holds.  A guard is evaluated

* **a priori** — on the state ``x`` before any jump (time-scale abstraction:
  a collision is detected on the velocities before it), or
* **a posteriori** — on ``x⁺ = g(x)``, the state the current candidate mode
  would jump to (parameter abstraction: a diode or a stiction condition is
  judged on the consequences of the switch, impulses included).

Example — an ideal diode as a controlled 1-junction ``D``::

    >>> from switching import Automaton
    >>> diode = Automaton("diode", {"off": {"D": False}, "on": {"D": True}}, initial="off")
    >>> _ = diode.add_transition("off", "on", "v_D >= V_th", "a posteriori")
    >>> _ = diode.add_transition("on", "off", "i_D <= I_th", "a posteriori")
    >>> [str(tr) for tr in diode.transitions]
    ['off → on when v_D >= V_th (a posteriori)', 'on → off when i_D <= I_th (a posteriori)']
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import sympy as sp
from sympy.core.relational import Relational
from sympy.logic.boolalg import BooleanAtom, BooleanFunction

from bondgraph.errors import UnknownNameError
from bondgraph.symbols import as_expr, check_name

from ..errors import ModelDefinitionError

__all__ = ["Automaton", "Transition", "A_PRIORI", "A_POSTERIORI"]

A_PRIORI = "a priori"
A_POSTERIORI = "a posteriori"
_WHEN = {
    "a priori": A_PRIORI,
    "a_priori": A_PRIORI,
    "apriori": A_PRIORI,
    "prior": A_PRIORI,
    "a posteriori": A_POSTERIORI,
    "a_posteriori": A_POSTERIORI,
    "aposteriori": A_POSTERIORI,
    "posterior": A_POSTERIORI,
}


@dataclass(frozen=True)
class Transition:
    """``source → target`` when ``guard`` holds, evaluated ``when`` (a priori / a posteriori).

    ``guard`` is a sympy condition or a text (parsed without executing code
    once the model knows its names)."""

    source: str
    target: str
    guard: object
    when: str = A_PRIORI
    pulses: bool = True

    @property
    def a_posteriori(self) -> bool:
        return self.when == A_POSTERIORI

    def __str__(self) -> str:
        return f"{self.source} → {self.target} when {self.guard} ({self.when}{'' if self.pulses else ', no pulses'})"


def _setting_items(setting, automaton: str, state: str) -> list:
    """The ``(junction, on)`` pairs of one state's setting (a mapping of junction names)."""
    if not isinstance(setting, Mapping):
        raise ModelDefinitionError(
            f"automaton {automaton!r}: state {state!r} must map junction names to True (on) or False (off), "
            f"got {setting!r}", [automaton])
    for junction in setting:
        if not isinstance(junction, str):
            raise ModelDefinitionError(
                f"automaton {automaton!r}: state {state!r} sets {junction!r}, which is not a junction name",
                [automaton])
    return list(setting.items())


def _on_off(value, automaton: str, state: str, junction: str) -> bool:
    """A junction setting: ``True`` (on) or ``False`` (off) — numpy's booleans too, nothing else (the text
    ``'off'`` is true to Python, and 1/0 hide a misplaced value)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise ModelDefinitionError(
        f"automaton {automaton!r}: state {state!r} sets junction {junction!r} to {value!r}; give True (on) or "
        "False (off)", [automaton])


class Automaton:
    """A local finite state automaton driving controlled junctions.

    Parameters
    ----------
    name : str
        Unique name (a mode shows it as ``name=state``).
    states : mapping
        state name → {controlled junction name → on (True) / off (False)}.
        Every state must set the same junctions.
    initial : str
        The initial state.
    restitution : mapping, optional
        state name → coefficient ``e`` (number, parameter name or sympy
        expression): entering a mode that has this state, the jump is
        ``x⁺ = x + (1 + e)(g(x) − x)`` (Newton's rule; ``e = 0`` is the plastic
        conservation-of-state jump).
    values : mapping, optional
        state name → {symbol name → value}: mode-dependent constants used in
        the bond graph (e.g. the direction ``sigma`` of a Coulomb friction
        source ``−sigma·mu·N``: +1 sliding forward, −1 backward, 0 stuck).
        Every state must set the same names.
    aliases : mapping, optional
        other name → state: names a state is also read by wherever a state is
        named as input (a mode's text or mapping, :class:`InMode`, model
        files), never shown — outputs show the state's own name.  They keep
        the old names of renamed states readable: a circuit's diode reads
        ``on``/``off`` as ``conducting``/``blocking``.
    """

    def __init__(
        self,
        name: str,
        states: Mapping[str, Mapping[str, bool]],
        initial: str,
        restitution: Mapping[str, object] | None = None,
        values: Mapping[str, Mapping[str, object]] | None = None,
        aliases: Mapping[str, str] | None = None,
    ):
        self.name = check_name(name, "automaton name")
        if not states:
            raise ModelDefinitionError(f"automaton {name!r} has no states")
        self.states: dict[str, dict[str, bool]] = {}
        junctions = None
        for state, setting in states.items():
            check_name(state, f"state name of automaton {name!r}")
            setting = {j: _on_off(v, name, state, j) for j, v in _setting_items(setting, name, state)}
            if junctions is None:
                junctions = set(setting)
            elif set(setting) != junctions:
                raise ModelDefinitionError(
                    f"automaton {name!r}: state {state!r} sets junctions {sorted(setting)}, "
                    f"but other states set {sorted(junctions)}; every state must set the same junctions",
                    [name],
                )
            self.states[state] = setting
        self.junctions: tuple[str, ...] = tuple(sorted(junctions or ()))
        if initial not in self.states:
            raise ModelDefinitionError(
                f"automaton {name!r}: initial state {initial!r} is not one of {list(self.states)}", [name]
            )
        self.initial = initial
        self.restitution: dict[str, sp.Expr] = {}
        for state, e in dict(restitution or {}).items():
            self._check_state(state, "restitution")
            self.restitution[state] = as_expr(e, f"restitution of {name}={state}")
        self.values: dict[str, dict[str, sp.Expr]] = {}
        names = None
        for state, table in dict(values or {}).items():
            self._check_state(state, "values")
            table = {check_name(k, "value name"): as_expr(v, f"value of {k} in {name}={state}") for k, v in table.items()}
            if names is not None and set(table) != names:
                raise ModelDefinitionError(
                    f"automaton {name!r}: state {state!r} sets values {sorted(table)}, others set {sorted(names)}",
                    [name],
                )
            names = set(table)
            self.values[state] = table
        if self.values and set(self.values) != set(self.states):
            missing = sorted(set(self.states) - set(self.values))
            raise ModelDefinitionError(f"automaton {name!r}: states {missing} set no values; every state must", [name])
        self.aliases: dict[str, str] = self._checked_aliases(aliases or {})
        self.transitions: list[Transition] = []

    def _checked_aliases(self, aliases: Mapping) -> dict:
        """``aliases`` (other name → state) checked: each a valid name that is no state, each naming a state."""
        for alias, state in aliases.items():
            check_name(alias, f"alias of a state of automaton {self.name!r}")
            if alias in self.states:
                raise ModelDefinitionError(f"automaton {self.name!r}: alias {alias!r} is the name of a state; an "
                                           "alias is another name for a state", [self.name])
            self._check_state(state, f"alias {alias!r}")
        return dict(aliases)

    def state_named(self, name: str) -> str:
        """The state ``name`` names: a state by its own name or by one of its :attr:`aliases`
        (:class:`~bondgraph.errors.UnknownNameError` listing the states otherwise)."""
        if name in self.states:
            return name
        if name in self.aliases:
            return self.aliases[name]
        also = f" (also read: {', '.join(f'{a} as {s}' for a, s in self.aliases.items())})" if self.aliases else ""
        raise UnknownNameError(f"automaton {self.name!r} has no state {name!r}; its states are "
                               f"{list(self.states)}{also}", name)

    def _check_state(self, state: str, what: str) -> None:
        if state not in self.states:
            raise ModelDefinitionError(
                f"automaton {self.name!r}: {what} names unknown state {state!r}; states are {list(self.states)}",
                [self.name],
            )

    def add_transition(self, source: str, target: str, guard, when: str = A_PRIORI, *, pulses: bool = True) -> Transition:
        """Add ``source → target`` firing when ``guard`` holds (``when``: ``"a priori"`` or ``"a posteriori"``).

        Transitions from one state are tried in the order they were added.

        ``pulses=False`` marks a transition whose jump abstracts a fast but
        continuous approach rather than a collision — e.g. a sliding velocity
        below a sticking threshold ``v_th`` taken as zero (the paper's
        Eq. 25).  The state still jumps (``x⁺ = g(x)``), but the a posteriori
        guards of the mode it leads to judge the finite values only: the
        Dirac pulses of that jump, artefacts of the threshold, would
        otherwise dominate every comparison (Lemma 5.3).  When several
        automata step at once, pulses are dropped only if every transition
        taken is ``pulses=False``."""
        self._check_state(source, "a transition")
        self._check_state(target, "a transition")
        if source == target:
            raise ModelDefinitionError(f"automaton {self.name!r}: transition from {source!r} to itself", [self.name])
        key = str(when).strip().lower()
        if key not in _WHEN:
            raise ModelDefinitionError(
                f"automaton {self.name!r}: a guard is evaluated 'a priori' or 'a posteriori', not {when!r}",
                [self.name],
            )
        if not isinstance(guard, (str, Relational, BooleanFunction, BooleanAtom)):
            raise ModelDefinitionError(
                f"automaton {self.name!r}: guard {guard!r} must be a text or a sympy condition", [self.name]
            )
        if not isinstance(pulses, bool):
            raise ModelDefinitionError(
                f"automaton {self.name!r}: pulses= must be True or False, not {pulses!r}", [self.name]
            )
        transition = Transition(source, target, guard, _WHEN[key], pulses)
        self.transitions.append(transition)
        return transition

    def transitions_from(self, state: str) -> list[Transition]:
        return [tr for tr in self.transitions if tr.source == state]

    def __repr__(self) -> str:
        return f"Automaton({self.name!r}, states={list(self.states)}, initial={self.initial!r})"
