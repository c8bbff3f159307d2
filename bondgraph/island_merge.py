"""The derivations of a configuration's islands merged into the whole graph's.

:func:`merge_causality` and :func:`merge_equations` give one
:class:`~bondgraph.causality.Causality` and one
:class:`~bondgraph.equations.ConfigurationEquations` of the whole graph from
those of its islands (:mod:`bondgraph.islands`), ordered as the whole
graph's own derivation orders them.  The fields a mode of a scene hardly
reads — every bond's effort and flow, the implicit rates, the causal
relations and assignment — are merged when first read.

A scene's next configuration holds nearly every island of the one before: a
pinnacle of the ball chain switches one contact, so two islands leave and one
comes, or the reverse.  Given the merge of a configuration before
(``previous``), a merge starts from its dictionaries and swaps in only the
islands that changed, instead of walking a thousand islands again.  Every
state, dependent state and port is in exactly one island of either
configuration, so a swapped island's entries take the places of those it
replaces: the result holds the same entries in the same order as a merge
from scratch (which is made whenever that does not hold, or more than
:data:`SWAP_LIMIT` islands changed).
"""

from __future__ import annotations

from itertools import compress, count
from operator import is_not

from .causality import Causality
from .equations import ConfigurationEquations

__all__ = ["SWAP_LIMIT", "merge_causality", "merge_equations"]

#: a merge swaps islands into the previous one while at most this many changed (else it merges them all)
SWAP_LIMIT = 32


def _swap(previous, parts: list):
    """``(removed, added)``: the islands of the merge ``previous`` between the longest start and end it
    shares with ``parts`` (by identity) and those of ``parts`` there, or ``None`` when there is no
    previous merge or more than :data:`SWAP_LIMIT` islands changed.  (A window may hold islands of both:
    swapped out and in again, they change nothing.)"""
    before = None if previous is None else previous.__dict__.get("_islands")
    if before is None:
        return None
    shortest = min(len(before), len(parts))
    # (the thousand islands of a scene's configuration compared without a Python loop over them)
    start = next(compress(count(), map(is_not, before, parts)), shortest)
    end = min(next(compress(count(), map(is_not, reversed(before), reversed(parts))), shortest), shortest - start)
    removed, added = before[start:len(before) - end], parts[start:len(parts) - end]
    if len(removed) + len(added) > SWAP_LIMIT:
        return None
    return list(removed), list(added)


def _kept_for_next(merged, parts: list, **pools):
    """Keep on ``merged`` its islands (the list it was made from, not copied: never changed) and its unordered
    merged dictionaries, for the next merge's swap."""
    object.__setattr__(merged, "_islands", parts)
    for name, value in pools.items():
        object.__setattr__(merged, name, value)
    return merged


def _swapped(pool: dict, field: str, removed: list, added: list) -> dict:
    """``pool`` (a merged dictionary of ``field`` of the islands) without ``removed``'s entries and with
    ``added``'s: a copy."""
    pool = dict(pool)
    for part in removed:
        for key in getattr(part, field):
            del pool[key]
    for part in added:
        pool.update(getattr(part, field))
    return pool


def merge_causality(graph, config: dict, parts: list, previous=None):
    """One :class:`~bondgraph.causality.Causality` of the whole graph from
    those of its islands (``parts``), ordered as the whole graph's own: its
    states' split now, the rest (:class:`_MergedCausality`) when first read.
    ``previous``: the merge of another configuration of the graph (see the module)."""
    swap = _swap(previous, parts)
    if swap is None:
        dependent_set: set = set()
        for part in parts:
            if part.dependent:
                dependent_set.update(part.dependent)
    else:
        dependent_set = set(previous._dependent_set)
        for part in swap[0]:
            dependent_set.difference_update(part.dependent)
        for part in swap[1]:
            dependent_set.update(part.dependent)
    dependent_set = frozenset(dependent_set)
    if swap is not None and dependent_set == previous._dependent_set:
        independent, dependent = previous.independent, previous.dependent
    else:
        storage = graph.derived.memo("storage elements", lambda: graph.storage)  # (a walk of every element)
        independent = [el.state for el in storage if el.state not in dependent_set]
        independent.extend(graph.displacements)
        independent, dependent = tuple(independent), tuple(el.state for el in storage if el.state in dependent_set)
    merged = _MergedCausality.of(graph, config, parts, independent, dependent)
    return _kept_for_next(merged, parts, _dependent_set=dependent_set)


def _rate_symbols(graph) -> dict:
    """State → the symbol of its rate, kept with the graph's derivations (a copy)."""
    from .symbols import rate_symbol

    return dict(graph.derived.memo("rate symbols", lambda: {s: rate_symbol(s) for s in graph.states}))


class _Merged:
    """A merged derivation whose fields named in ``_LAZY`` are merged from the islands' when first read:
    a mode of a scene of a thousand islands reads a few of them, and each is a dictionary of the whole
    graph.  Made by ``of``; a subclass's ``_merge(graph, parts)`` gives every lazy field at once."""

    _LAZY: tuple = ()

    def __getattr__(self, name):  # (only for a field not set yet)
        if name in type(self)._LAZY and "_parts" in self.__dict__:
            graph, parts = self.__dict__.pop("_graph"), self.__dict__.pop("_parts")
            for field_name, value in self._merge(graph, parts).items():
                object.__setattr__(self, field_name, value)
            return self.__dict__[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")


def _made(cls, whole, parts: list, **fields):
    """An object of the merged dataclass ``cls`` with ``fields`` set now and the lazy ones merged later from
    the islands' ``parts`` of the graph ``whole``."""
    merged = object.__new__(cls)
    for name, value in {**fields, "_graph": whole, "_parts": parts}.items():
        object.__setattr__(merged, name, value)
    return merged


class _MergedCausality(_Merged, Causality):
    """A :class:`~bondgraph.causality.Causality` merged from its islands': ``effort_by``, ``dead``,
    ``algebraic_loops`` and ``relations`` when first read."""

    _LAZY = ("effort_by", "dead", "algebraic_loops", "relations")

    @classmethod
    def of(cls, graph, config: dict, parts: list, independent: tuple, dependent: tuple):
        return _made(cls, graph, parts, configuration=dict(config), independent=independent, dependent=dependent)

    def _merge(self, graph, parts: list) -> dict:
        from .relations import CausalRelations

        effort_by, dead, loops = {}, set(), []
        relations, rates, constraints = {}, {}, {}
        for part in parts:
            effort_by.update(part.effort_by)
            dead |= part.dead
            loops.extend(part.algebraic_loops)
            relations.update(part.relations.relations)
            rates.update(part.relations.rates)
            constraints.update(part.relations.constraints)
        return {"effort_by": {b: effort_by[b] for b in graph.bonds if b in effort_by}, "dead": frozenset(dead),
                "algebraic_loops": tuple(sorted(loops)),
                "relations": CausalRelations(relations, rates, constraints, _rate_symbols(graph))}


def _pools(parts: list) -> dict:
    """The merged dictionaries of the islands ``parts``: their constraints, rates, the rates of their
    dependent states and of their inputs, and ``port → (input, output)``, in the islands' order."""
    constraints, rates, dependent_rates, input_rates, port_values = {}, {}, {}, {}, {}
    for part in parts:
        if part.constraints:
            constraints.update(part.constraints)
        rates.update(part.rates)
        if part._dependent_rates:
            dependent_rates.update(part._dependent_rates)
        if part.input_rates:
            input_rates.update(part.input_rates)
        for port in part.port_inputs:
            port_values[port] = (part.port_inputs[port], part.port_outputs[port])
    return {"constraints": constraints, "rates": rates, "dependent_rates": dependent_rates,
            "input_rates": input_rates, "port_values": port_values}


def _swapped_pools(previous, parts: list, removed: list, added: list) -> dict | None:
    """:func:`_pools` of ``parts`` from those of the merge ``previous`` with ``removed`` swapped for ``added``
    (``rates`` in the order of the states already); ``None`` when the swapped islands do not hold the same
    states (then every island is merged again)."""
    gone = {x for part in removed for x in part.rates}
    if gone != {x for part in added for x in part.rates}:
        return None
    rates = dict(previous.rates)
    for part in added:
        rates.update(part.rates)
    pools = previous._pools
    if any(part.input_rates for part in (*removed, *added)):  # (an input may be read by several islands)
        input_rates: dict = {}
        for part in parts:
            if part.input_rates:
                input_rates.update(part.input_rates)
    else:
        input_rates = pools["input_rates"]
    port_values = dict(pools["port_values"])
    for part in removed:
        for port in part.port_inputs:
            del port_values[port]
    for part in added:
        for port in part.port_inputs:
            port_values[port] = (part.port_inputs[port], part.port_outputs[port])
    return {"constraints": _swapped(pools["constraints"], "constraints", removed, added), "rates": rates,
            "dependent_rates": _swapped(pools["dependent_rates"], "_dependent_rates", removed, added),
            "input_rates": input_rates, "port_values": port_values}


def merge_equations(graph, config: dict, causality, parts: list, previous=None):
    """One :class:`~bondgraph.equations.ConfigurationEquations` of the whole
    graph from those of its islands, with the whole graph's ``causality``
    (:func:`merge_causality` of the islands'): its states' rates and
    constraints now, its bonds' values and implicit rates
    (:class:`_MergedEquations`) when first read.  ``previous``: the merge of
    another configuration of the graph (see the module)."""
    states = graph.derived.memo("states", lambda: tuple(graph.states))  # (a walk of every element)
    swap = _swap(previous, parts)
    pools = None if swap is None else _swapped_pools(previous, parts, *swap)
    if pools is None:
        pools = _pools(parts)
        rates = {x: pools["rates"][x] for x in states}
    else:
        rates = pools["rates"]
    constraints, port_values, input_rates = pools["constraints"], pools["port_values"], pools["input_rates"]
    open_ports = [p for p in graph.open_ports if p in port_values]
    merged = _MergedEquations.of(
        graph, parts,
        graph_name=graph.name,
        configuration=dict(config),
        states=states,
        independent=causality.independent,
        dependent=causality.dependent,
        rate_symbols=_rate_symbols(graph),
        constraints={x: constraints[x] for x in causality.dependent},
        rates=rates,
        causality=causality,
        _dependent_rates=pools["dependent_rates"],
        graph=graph,
        substitutions={},
        port_inputs={p: port_values[p][0] for p in open_ports},
        port_outputs={p: port_values[p][1] for p in open_ports},
        input_rates={u: input_rates[u] for u in sorted(input_rates, key=lambda s: s.name)},
    )
    return _kept_for_next(merged, parts, _pools={**pools, "rates": None})


class _MergedEquations(_Merged, ConfigurationEquations):
    """A :class:`~bondgraph.equations.ConfigurationEquations` merged from its islands': ``implicit_rates``,
    ``efforts`` and ``flows`` when first read."""

    _LAZY = ("implicit_rates", "efforts", "flows")

    @classmethod
    def of(cls, whole, parts: list, **fields):
        return _made(cls, whole, parts, **fields)

    def implicit_rates_of(self, states) -> dict:
        """:meth:`ConfigurationEquations.implicit_rates_of <bondgraph.equations.ConfigurationEquations.
        implicit_rates_of>`, read from the islands that hold dependent states while the implicit rates are
        not merged (the states a constraint reads are in its island: those the jump map asks about), else
        from them all."""
        parts = self.__dict__.get("_parts")
        if parts is None:
            return super().implicit_rates_of(states)
        found, constrained = {}, [part.implicit_rates for part in parts if part.dependent]
        for x in states:
            for implicit in constrained:
                if x in implicit:
                    found[x] = implicit[x]
                    break
            else:
                if x in self._independent_states():
                    return super().implicit_rates_of(states)  # (not in an island with a constraint: all merged)
        return found

    def _independent_states(self) -> frozenset:
        """The independent states as a set, made once."""
        kept = self.__dict__.get("_independent_set")
        if kept is None:
            kept = frozenset(self.independent)
            object.__setattr__(self, "_independent_set", kept)
        return kept

    def _merge(self, graph, parts: list) -> dict:
        implicit, efforts, flows = {}, {}, {}
        for part in parts:
            implicit.update(part.implicit_rates)
            efforts.update(part.efforts)
            flows.update(part.flows)
        return {"implicit_rates": {x: implicit[x] for x in self.independent},
                "efforts": {b: efforts[b] for b in graph.bonds}, "flows": {b: flows[b] for b in graph.bonds}}
