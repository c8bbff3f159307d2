"""Causality assignment per configuration: the sequential causality
assignment procedure (SCAP).

Causality says, for every bond, which end imposes the *effort* (the other end
imposes the flow).  The causal stroke is drawn at the end that receives the
effort.  Rules enforced:

* Se imposes effort, Sf imposes flow;
* an *on* 0-junction has exactly one bond that brings the effort in, an *on*
  1-junction exactly one bond that brings the flow in;
* an *off* controlled 0-junction imposes (zero) effort on all its bonds, an
  off 1-junction (zero) flow; a bond between two off junctions of the same kind
  carries nothing (``dead``: e = f = 0) and has no stroke;
* TF passes the causality through (one of its bonds has its effort imposed by
  the TF), GY flips it (both or neither);
* storage prefers integral causality (C imposes effort, I imposes flow); one
  forced into derivative causality is *dependent*;
* an open port (:meth:`bondgraph.BondGraph.open_view`) takes the causality the
  rest of the graph imposes, unless the user fixed it (then it acts as a source).

Procedure: off junctions and sources first, propagating after each; then each
storage element in integral causality, falling back to derivative causality if
propagation conflicts; then each R in its preferred causality (or the other);
then any bond still open (junction structure loops).  A conflict that sources
alone create is an error naming the sources and the junction where they meet.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import sympy as sp

from .algebra import dependency_components
from .elements import GY, TF, Junction, OpenPort, R, Se, Sf, Storage, Zero
from .errors import CausalityConflictError
from .floating import floating_part

__all__ = ["Causality", "assign_causality", "causality_violations"]


@dataclass(frozen=True)
class Causality:
    """The causal assignment of one configuration.

    ``effort_by[bond]`` is the element that imposes the bond's effort;
    ``dead`` are bonds with no causality (between two off junctions of one
    kind); ``independent`` / ``dependent`` split the storage states into
    integral and derivative causality (displacements are always
    independent); ``algebraic_loops`` lists, for each algebraic loop, the
    elements in it; ``relations`` holds the explicit causal equations
    (:class:`bondgraph.relations.CausalRelations`).
    """

    configuration: dict
    effort_by: dict
    dead: frozenset
    independent: tuple
    dependent: tuple
    algebraic_loops: tuple
    relations: object = field(repr=False, compare=False)

    def imposes_effort(self, bond: str, element: str) -> bool:
        return self.effort_by.get(bond) == element

    def stroke_at(self, graph, bond: str) -> str | None:
        """The element at whose end the causal stroke is drawn (it receives the effort)."""
        if bond in self.dead:
            return None
        return graph.bonds[bond].other(self.effort_by[bond])

    def is_dependent(self, state: sp.Symbol) -> bool:
        return state in self.dependent


class _Conflict(Exception):
    def __init__(self, message, elements):
        super().__init__(message)
        self.elements = tuple(dict.fromkeys(elements))


_JUNCTION_WORDS = {"0": ("effort", "flows"), "1": ("flow", "efforts")}


class _SCAP:
    """Mutable state of one run of the procedure."""

    def __init__(self, graph, config, rank_storage: bool = False):
        self.g = graph
        self.config = config
        self.rank_storage = rank_storage
        self.effort_by: dict[str, str] = {}
        self.origin: dict[str, str] = {}
        self.queue: deque[str] = deque()
        self.log: list[str] | None = None
        self.dead: set[str] = set()
        self.bonds_of = {name: [b.name for b in graph.bonds_of(name)] for name in graph.elements}

    # -- primitive
    def is_on(self, name: str) -> bool:
        el = self.g.elements[name]
        return not (isinstance(el, Junction) and el.controlled and not self.config[name])

    def assign(self, bond: str, effort_by: str, origin: str) -> None:
        current = self.effort_by.get(bond)
        if current is not None:
            if current != effort_by:
                b = self.g.bonds[bond]
                raise _Conflict(
                    f"bond {bond!r} ({b.tail} → {b.head}): {current!r} imposes its effort "
                    f"(because of {self.origin[bond]!r}) but {effort_by!r} must impose it "
                    f"(because of {origin!r})",
                    [self.origin[bond], origin, current, effort_by],
                )
            return
        self.effort_by[bond] = effort_by
        self.origin[bond] = origin
        if self.log is not None:
            self.log.append(bond)
        b = self.g.bonds[bond]
        self.queue.append(b.tail)
        self.queue.append(b.head)

    def propagate(self) -> None:
        while self.queue:
            name = self.queue.popleft()
            el = self.g.elements[name]
            if isinstance(el, Junction) and self.is_on(name):
                self._junction_rule(name, el)
            elif isinstance(el, (TF, GY)):
                self._two_port_rule(name, el)

    def trial(self, bond: str, effort_by: str, origin: str) -> bool:
        """Assign and propagate; undo everything and return False on a conflict."""
        self.log = []
        try:
            self.assign(bond, effort_by, origin)
            self.propagate()
            return True
        except _Conflict:
            for b in self.log:
                del self.effort_by[b]
                del self.origin[b]
            self.queue.clear()
            return False
        finally:
            self.log = None

    # -- rules
    def _junction_rule(self, name: str, el: Junction) -> None:
        is_zero = isinstance(el, Zero)
        bonds = [b for b in self.bonds_of[name] if b not in self.dead]
        other = {b: self.g.bonds[b].other(name) for b in bonds}

        # strong bond: brings the junction's common variable in
        def strong(b):
            by = self.effort_by.get(b)
            return by is not None and ((by != name) if is_zero else (by == name))

        def weak_by(b):  # who imposes the effort on a weak bond
            return name if is_zero else other[b]

        def strong_by(b):
            return other[b] if is_zero else name

        strongs = [b for b in bonds if strong(b)]
        common, summed = _JUNCTION_WORDS[el.kind]
        if len(strongs) > 1:
            culprits = [self.origin[b] for b in strongs]
            raise _Conflict(
                f"{el.kind}-junction {name!r} gets its {common} from more than one bond: "
                + ", ".join(f"{b!r} (from {self.origin[b]!r})" for b in strongs)
                + f"; only one element may fix a junction's {common}",
                culprits + [name],
            )
        open_ = [b for b in bonds if b not in self.effort_by]
        if strongs:
            for b in open_:
                self.assign(b, weak_by(b), self.origin[strongs[0]])
        elif len(open_) == 1:
            origins = [self.origin[b] for b in bonds if b in self.origin]
            self.assign(open_[0], strong_by(open_[0]), origins[0] if origins else name)
        elif not open_ and bonds:
            raise _Conflict(
                f"{el.kind}-junction {name!r}: every bond fixes its own {summed[:-1]} "
                f"({', '.join(repr(self.origin[b]) for b in bonds)}), so nothing fixes the junction's "
                f"{common} and the {summed} cannot balance",
                [self.origin[b] for b in bonds] + [name],
            )

    def _two_port_rule(self, name: str, el) -> None:
        b_in, b_out = (b.name for b in self.g.two_port_bonds(name))
        for known, unknown in ((b_in, b_out), (b_out, b_in)):
            if known in self.effort_by and unknown not in self.effort_by:
                by_me = self.effort_by[known] == name
                # TF: exactly one side has its effort imposed by the TF; GY: both or neither
                by_me_other = (not by_me) if isinstance(el, TF) else by_me
                self.assign(unknown, name if by_me_other else self.g.bonds[unknown].other(name), self.origin[known])

    # -- storage order
    def _storage_order(self) -> list[str]:
        """Storage elements in the order they are offered integral causality.

        Insertion order, except that when modulated two-ports are present
        (or ``rank_storage`` says the whole graph has some: an island of it,
        see :mod:`bondgraph.islands`, is ranked as the whole graph would be),
        elements whose integral causality would make a modulated TF/GY
        *divide* by its modulus (``f1 = f2/m``: singular where ``m`` = 0, e.g.
        a rod's ``l sin θ``) come later, and those whose integral causality
        conflicts already come last.  For a rod pinned at its tip this
        keeps the rotation independent, as in the paper's Eq. (20).
        """
        g = self.g
        names = [n for n, el in g.elements.items() if isinstance(el, Storage)]
        modulated = {n for n, el in g.elements.items() if isinstance(el, (TF, GY)) and el.modulated}
        if not modulated and not self.rank_storage:
            return names
        scores = {}
        for name in names:
            b = self.bonds_of[name][0]
            if b in self.effort_by:
                scores[name] = 0
                continue
            el, other = g.elements[name], g.bonds[b].other(name)
            self.log = []
            try:
                self.assign(b, name if el.kind == "C" else other, name)
                self.propagate()
                scores[name] = sum(
                    1
                    for tp in modulated
                    if (b_in := g.two_port_bonds(tp)[0].name) in self.log and self.effort_by[b_in] != tp
                )
            except _Conflict:
                scores[name] = len(modulated) + 1
            finally:
                for bond in self.log:
                    del self.effort_by[bond]
                    del self.origin[bond]
                self.queue.clear()
                self.log = None
        return sorted(names, key=lambda n: scores[n])  # stable: ties keep insertion order

    # -- phases
    def run(self) -> None:
        g = self.g
        for b in g.bonds.values():  # bonds between two off junctions of the same kind carry nothing
            ends = [g.elements[b.tail], g.elements[b.head]]
            if all(isinstance(e, Junction) and not self.is_on(e.name) for e in ends) and ends[0].kind == ends[1].kind:
                self.dead.add(b.name)
        try:
            for name, el in g.elements.items():
                if isinstance(el, Junction) and not self.is_on(name):
                    for b in self.bonds_of[name]:
                        if b in self.dead:
                            continue
                        by = name if isinstance(el, Zero) else g.bonds[b].other(name)
                        self.assign(b, by, name)
                    self.propagate()
            for name, el in g.elements.items():
                if isinstance(el, (Se, Sf)):
                    b = self.bonds_of[name][0]
                    self.assign(b, name if isinstance(el, Se) else g.bonds[b].other(name), name)
                    self.propagate()
                elif isinstance(el, OpenPort) and el.imposes is not None:
                    # an open port whose causality the user fixed acts as a source;
                    # an unfixed one takes what the rest imposes (bonds still open, last)
                    b = self.bonds_of[name][0]
                    self.assign(b, name if el.imposes == "effort" else g.bonds[b].other(name), name)
                    self.propagate()
        except _Conflict as c:
            raise CausalityConflictError(
                f"causality conflict in configuration {_fmt_config(self.config)}: {c}. "
                "Sources (or switched-off junctions) over-determine the graph; remove one of them, "
                "or add a resistance or storage element between them.",
                c.elements,
            ) from None

        for name in self._storage_order():
            el = g.elements[name]
            b = self.bonds_of[name][0]
            if b in self.effort_by:
                continue
            other = g.bonds[b].other(name)
            integral, derivative = (name, other) if el.kind == "C" else (other, name)
            if not self.trial(b, integral, name) and not self.trial(b, derivative, name):
                raise CausalityConflictError(
                    f"storage element {name!r} admits neither integral nor derivative causality in "
                    f"configuration {_fmt_config(self.config)}; the junction structure around it is inconsistent",
                    [name],
                )
        # R's with a one-way law first (linear ones work either way), so a
        # nonlinear law keeps the causality it was written for where possible
        resistors = [n for n, el in g.elements.items() if isinstance(el, R)]
        resistors.sort(key=lambda n: g.elements[n].effort_law is not None and g.elements[n].flow_law is not None)
        for name in resistors:
            el = g.elements[name]
            b = self.bonds_of[name][0]
            if b in self.effort_by:
                continue
            other = g.bonds[b].other(name)
            first, second = (name, other) if el.prefers_resistance else (other, name)
            if not self.trial(b, first, name) and not self.trial(b, second, name):
                raise CausalityConflictError(f"R {name!r} admits no causality", [name])
        for b in g.bonds.values():
            if b.name in self.effort_by or b.name in self.dead:
                continue
            if not self.trial(b.name, b.tail, b.tail) and not self.trial(b.name, b.head, b.head):
                raise CausalityConflictError(
                    f"bond {b.name!r} ({b.tail} → {b.head}) admits no causality in configuration "
                    f"{_fmt_config(self.config)}",
                    [b.tail, b.head],
                )


def _fmt_config(config) -> str:
    if not config:
        return "(no controlled junctions)"
    return "{" + ", ".join(f"{k}: {'on' if v else 'off'}" for k, v in config.items()) + "}"


def assign_causality(graph, config, *, validate: bool = True, rank_storage: bool = False) -> Causality:
    """Assign causality for ``config`` (controlled junction → on/off).

    Returns a :class:`Causality`.  Raises :class:`CausalityConflictError`
    when sources over-determine the graph,
    :class:`~bondgraph.errors.FloatingPartError` (a subclass) when part of
    it is under-determined instead (floating junctions, see
    :mod:`bondgraph.floating`), and
    :class:`~bondgraph.errors.InvalidGraphError` if the graph is malformed
    (``validate=False`` skips that check, for a graph already checked or an
    island of one; ``rank_storage``: see :meth:`_SCAP._storage_order`).
    """
    from .relations import causal_relations

    if validate:
        graph.validate()
    scap = _SCAP(graph, dict(config), rank_storage)
    try:
        scap.run()
    except CausalityConflictError:
        floating = floating_part(graph, dict(config), scap.dead)
        if floating is not None:  # under-determined, not over-determined: say so
            raise floating from None
        raise

    dependent, independent = [], []
    for el in graph.storage:
        b = scap.bonds_of[el.name][0]
        integral = (scap.effort_by[b] == el.name) == (el.kind == "C")
        (independent if integral else dependent).append(el.state)
    independent.extend(graph.displacements)

    relations = causal_relations(graph, scap.effort_by, frozenset(scap.dead), config)
    loops = _algebraic_loops(relations)
    return Causality(
        configuration=dict(config),
        effort_by=dict(scap.effort_by),
        dead=frozenset(scap.dead),
        independent=tuple(independent),
        dependent=tuple(dependent),
        algebraic_loops=loops,
        relations=relations,
    )


def _algebraic_loops(relations) -> tuple:
    """Elements of each cycle among the bond-variable relations."""
    known = relations.relations
    uses = {var: [s for s in rel.expr.free_symbols if s in known] for var, rel in known.items()}
    loops = []
    for comp in dependency_components(uses):
        if len(comp) > 1 or comp[0] in uses[comp[0]]:
            elements = sorted({known[v].element for v in comp})
            loops.append(tuple(elements))
    return tuple(sorted(loops))


def causality_violations(graph, causality: Causality) -> list[str]:
    """Check the causality rules on an assignment; returns the violations
    (empty when the assignment is valid).  Used by tests as invariants."""
    problems = []
    eb = causality.effort_by
    for name, bond in graph.bonds.items():
        if name in causality.dead:
            continue
        if eb.get(name) not in (bond.tail, bond.head):
            problems.append(f"bond {name!r} has no stroke")
    for name, el in graph.elements.items():
        bonds = [b.name for b in graph.bonds_of(name) if b.name not in causality.dead]
        on = not (isinstance(el, Junction) and el.controlled and not causality.configuration[name])
        if isinstance(el, Junction) and on:
            if isinstance(el, Zero):
                n_in = sum(eb[b] != name for b in bonds)
                if n_in != 1:
                    problems.append(f"0-junction {name!r} has {n_in} effort-imposing bonds")
            else:
                n_in = sum(eb[b] == name for b in bonds)
                if n_in != 1:
                    problems.append(f"1-junction {name!r} has {n_in} flow-imposing bonds")
        elif isinstance(el, Junction):
            for b in bonds:
                if (eb[b] == name) != isinstance(el, Zero):
                    problems.append(f"off junction {name!r} does not impose its zero on bond {b!r}")
        elif isinstance(el, Se) and eb[bonds[0]] != name:
            problems.append(f"Se {name!r} does not impose its effort")
        elif isinstance(el, Sf) and eb[bonds[0]] == name:
            problems.append(f"Sf {name!r} does not impose its flow")
        elif isinstance(el, (TF, GY)):
            b_in, b_out = (b.name for b in graph.two_port_bonds(name))
            mine = (eb[b_in] == name, eb[b_out] == name)
            if isinstance(el, TF) and mine[0] == mine[1]:
                problems.append(f"TF {name!r} does not pass causality through")
            if isinstance(el, GY) and mine[0] != mine[1]:
                problems.append(f"GY {name!r} does not flip causality")
    return problems
