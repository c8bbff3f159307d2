"""The explicit causal equations of one configuration.

Given a causal assignment, every bond variable (``e_b``, ``f_b``) is the
output of exactly one element equation, ``var = expr(other vars, states, t,
inputs, parameters, rates of dependent states)``.  Port conventions: a
one-port's effort is its bond's effort and its flow is the bond flow measured
*into* it (``s·f_b`` with ``s = ±1`` by the bond's direction); sources deliver
their value: ``Sf`` pushes its flow *out* of itself.

* C integral:   ``e_b = Φ(q)``, rate ``dq/dt = s f_b``
* C derivative: ``f_b = s·dq/dt``, constraint ``q = Φ⁻¹(e_b)``
* I integral:   ``f_b = s·Φ(p)``, rate ``dp/dt = e_b``
* I derivative: ``e_b = dp/dt``, constraint ``p = Φ⁻¹(s f_b)``
* displacement: rate ``dx/dt = sign · f_bond``
"""

from __future__ import annotations

from dataclasses import dataclass

import networkx as nx
import sympy as sp

from .elements import GY, TF, C, I, Junction, R, Se, Sf, Storage, Zero
from .symbols import rate_symbol

__all__ = ["Relation", "CausalRelations", "causal_relations"]


@dataclass(frozen=True)
class Relation:
    """``var = expr``, contributed by ``element``."""

    var: sp.Symbol
    expr: sp.Expr
    element: str


@dataclass(frozen=True)
class CausalRelations:
    """All explicit equations of one causal assignment.

    ``relations``: bond variable → its :class:`Relation`;
    ``rates``: independent state → ``dx/dt`` as an expression of bond variables;
    ``constraints``: dependent state → its value as an expression of bond variables;
    ``rate_symbols``: state → the symbol standing for its time derivative.
    """

    relations: dict
    rates: dict
    constraints: dict
    rate_symbols: dict

    def dependency_graph(self) -> nx.DiGraph:
        """Edges ``var → v`` for every bond variable ``v`` that ``var``'s expression uses."""
        graph = nx.DiGraph()
        graph.add_nodes_from(self.relations)
        for var, rel in self.relations.items():
            for s in rel.expr.free_symbols:
                if s in self.relations:
                    graph.add_edge(var, s)
        return graph


def causal_relations(graph, effort_by: dict, dead: frozenset, config: dict) -> CausalRelations:
    """Build the explicit equations of every element for a causal assignment."""
    rels: dict[sp.Symbol, Relation] = {}
    rates: dict[sp.Symbol, sp.Expr] = {}
    constraints: dict[sp.Symbol, sp.Expr] = {}
    rate_symbols = {s: rate_symbol(s) for s in graph.states}

    def put(var, expr, element):
        rels[var] = Relation(var, sp.sympify(expr), element)

    for name in dead:
        b = graph.bonds[name]
        put(b.effort, 0, f"{b.tail}|{b.head}")
        put(b.flow, 0, f"{b.tail}|{b.head}")

    for name, el in graph.elements.items():
        bonds = [b for b in graph.bonds_of(name) if b.name not in dead]
        if isinstance(el, Junction):
            _junction(el, name, bonds, effort_by, config, put)
        elif isinstance(el, (TF, GY)):
            b1, b2 = graph.two_port_bonds(name)
            m = el.modulus
            if isinstance(el, TF):
                if effort_by[b1.name] == name:
                    put(b1.effort, m * b2.effort, name)
                    put(b2.flow, m * b1.flow, name)
                else:
                    put(b2.effort, b1.effort / m, name)
                    put(b1.flow, b2.flow / m, name)
            else:
                if effort_by[b1.name] == name:
                    put(b1.effort, m * b2.flow, name)
                    put(b2.effort, m * b1.flow, name)
                else:
                    put(b2.flow, b1.effort / m, name)
                    put(b1.flow, b2.effort / m, name)
        else:
            (b,) = bonds
            s = b.sign_at(name)
            if isinstance(el, Se):
                put(b.effort, el.value, name)
            elif isinstance(el, Sf):
                put(b.flow, -s * el.value, name)
            elif isinstance(el, R):
                if effort_by[b.name] == name:
                    put(b.effort, el.effort(s * b.flow), name)
                else:
                    put(b.flow, s * el.flow(b.effort), name)
            elif isinstance(el, Storage):
                x, dx = el.state, rate_symbols[el.state]
                integral = (effort_by[b.name] == name) == isinstance(el, C)
                if isinstance(el, C):
                    if integral:
                        put(b.effort, el.output(x), name)
                        rates[x] = s * b.flow
                    else:
                        put(b.flow, s * dx, name)
                        constraints[x] = el.state_for(b.effort)
                elif isinstance(el, I):
                    if integral:
                        put(b.flow, s * el.output(x), name)
                        rates[x] = b.effort
                    else:
                        put(b.effort, dx, name)
                        constraints[x] = el.state_for(s * b.flow)
    for sym, disp in graph.displacements.items():
        rates[sym] = disp.sign * graph.bonds[disp.bond].flow
    return CausalRelations(rels, rates, constraints, rate_symbols)


def _signed(sign: int, expr: sp.Expr) -> sp.Expr:
    """``sign·expr`` for ``sign = ±1`` (no product built for +1)."""
    return expr if sign > 0 else -expr


def _junction(el, name, bonds, effort_by, config, put) -> None:
    is_zero = isinstance(el, Zero)
    if el.controlled and not config[name]:
        for b in bonds:
            put(b.effort if is_zero else b.flow, 0, name)
        return
    if is_zero:
        (strong,) = [b for b in bonds if effort_by[b.name] != name]
        for b in bonds:
            if b is not strong:
                put(b.effort, strong.effort, name)
        total = sp.Add(*(_signed(b.sign_at(name), b.flow) for b in bonds if b is not strong))
        put(strong.flow, _signed(-strong.sign_at(name), total), name)
    else:
        (strong,) = [b for b in bonds if effort_by[b.name] == name]
        for b in bonds:
            if b is not strong:
                put(b.flow, strong.flow, name)
        total = sp.Add(*(_signed(b.sign_at(name), b.effort) for b in bonds if b is not strong))
        put(strong.effort, _signed(-strong.sign_at(name), total), name)
