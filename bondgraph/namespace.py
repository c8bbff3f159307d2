"""One namespace per model: every name has one owner.

A model's quantities are reached by name: in guard and signal text, in
``parameters={...}``, in a model file, in the command line's ``--set`` and
``--signals``.  The time ``t``, the states (``q_C1``, a displacement
``x_a``), the bond variables (``e_<bond>``, ``f_<bond>``), the inputs, the
signals, the parameters and the words of the expression language share that
one flat namespace, and several layers invent names in it (the bond graph
names bond variables and states after its elements; the circuit and
mechanism builders name parameters, signals and states after their
components: ``S1_period``, ``v_D1``, ``p_m1``).

The rule (DESIGN §4): **a name has one owner.**  Every layer that makes a
name *claims* it in the model's :class:`Namespace` with an :class:`Owner`
that says what the name stands for and how to rename it; a second owner
claiming the same name is refused at once with a
:class:`~bondgraph.errors.NameCollisionError` that names both owners.  A
name that is only *used* (a law's parameter, a state read in a guard) is a
reference, not a claim: ``f_sw`` written in a signal is the flow of bond
``sw`` if the graph has that bond, and a value given for ``f_sw`` as a
parameter is refused, naming the bond.  Structural names (elements, bonds)
are unique in the bond graph itself; a builder reads the symbols of what it
made off the objects, never from a name it assumes.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

from .errors import NameCollisionError

__all__ = ["Owner", "Namespace", "TIME_OWNER", "LANGUAGE_WORDS", "collision", "graph_namespace"]

#: the words of the guard and signal language that cannot name a quantity
LANGUAGE_WORDS = ("and", "or", "not", "true", "false", "pi")


@dataclass(frozen=True)
class Owner:
    """What a name stands for (``what``: ``"the flow of bond 'sw' (j → sw)"``)
    and how its owner can take another name (``rename``: ``"rename bond 'sw'"``;
    empty when it cannot: the time, the language's words)."""

    what: str
    rename: str = ""
    #: the kind of quantity: "time", "state", "bond variable", "input", "signal", "parameter", "word", ...
    kind: str = ""


#: the owner of ``t``
TIME_OWNER = Owner("the time t", "", "time")


class Namespace:
    """name → :class:`Owner`, each name claimed once (see the module documentation).

    ``scope`` names the model or builder in messages (``"circuit 'buck'"``)."""

    def __init__(self, scope: str):
        self.scope = scope
        self._owners: dict[str, Owner] = {}

    def claim(self, name: str, owner: Owner) -> str:
        """Give ``name`` to ``owner``; returns ``name``.  Claiming a name again for
        the same owner is harmless; for another owner it is a
        :class:`~bondgraph.errors.NameCollisionError` naming both."""
        first = self._owners.get(name)
        if first is None:
            self._owners[name] = owner
        elif first != owner:
            raise collision(self.scope, name, first, owner)
        return name

    def owner(self, name: str) -> Owner | None:
        """The owner of ``name``, or ``None`` when no one has claimed it."""
        return self._owners.get(name)

    def names(self, kind: str | None = None) -> tuple[str, ...]:
        """The names claimed (of owners of ``kind`` only, when given), in the order claimed."""
        return tuple(n for n, o in self._owners.items() if kind is None or o.kind == kind)

    def copy(self, scope: str | None = None) -> "Namespace":
        other = Namespace(scope or self.scope)
        other._owners = dict(self._owners)
        return other

    def __contains__(self, name) -> bool:
        return name in self._owners

    def __iter__(self) -> Iterator[str]:
        return iter(self._owners)

    def __len__(self) -> int:
        return len(self._owners)


def collision(scope: str, name: str, first: Owner, second: Owner) -> NameCollisionError:
    """The error for ``name`` claimed by ``first`` and then by ``second``."""
    # a parameter's or signal's owner (what a user named) first: it is the one to rename
    owners = sorted((second, first), key=lambda o: o.kind not in ("parameter", "signal"))
    fixes = [o.rename for o in owners if o.rename]
    fix = " or ".join(dict.fromkeys(fixes)) if fixes else "rename one of them"
    return NameCollisionError(
        f"{scope}: the name {name!r} would be both {first.what} and {second.what}; one name has one owner: "
        f"{fix}", name, (first.what, second.what))


def graph_namespace(graph) -> Namespace:
    """The names a bond graph owns: ``t`` and the language's words, its states,
    its inputs and its bond variables (an open port's bond variables, which
    are its inputs in the derivation-time view, excepted); a collision among
    them is a :class:`~bondgraph.errors.NameCollisionError`."""
    names = Namespace(f"graph {graph.name!r}")
    names.claim("t", TIME_OWNER)
    for word in LANGUAGE_WORDS:
        names.claim(word, Owner(f"the word {word!r} of the expression language", "", "word"))
    displacements = {d.symbol: d for d in graph.displacements.values()}
    for element in graph.storage:
        names.claim(element.state.name, Owner(
            f"the state of {element.kind} {element.name!r}",
            f"rename {element.kind} {element.name!r} (or give it state='...')", "state"))
    for symbol, d in displacements.items():
        names.claim(symbol.name, Owner(f"the displacement {symbol.name!r} (the integral of the flow of bond "
                                       f"{d.bond!r})", f"rename the displacement {symbol.name!r}", "state"))
    for name in graph.inputs:
        names.claim(name, Owner(f"input {name!r}", f"rename input {name!r}", "input"))
    port_bonds = {b for _, b in graph.open_ports.values()}
    for bond in graph.bonds.values():
        if bond.name in port_bonds:
            continue
        after = bond.name in graph.elements
        rename = (f"rename element {bond.name!r} (its bond takes its name) or name the bond "
                  "(connect(..., name=...))" if after else f"rename bond {bond.name!r} (connect(..., name=...))")
        for variable, what in ((bond.effort, "effort"), (bond.flow, "flow")):
            names.claim(variable.name, Owner(f"the {what} of bond {bond.name!r} ({bond.tail} → {bond.head})",
                                             rename, "bond variable"))
    return names
