"""A conflicting configuration seen through vanishing resistances.

Two kinds of configuration have no equations of their own, and both are
seen through resistances that vanish or grow.

A configuration whose sources over-determine the graph (a causality
conflict: a voltage source shorted through closed switches and conducting
diodes) has no equations.  Put a resistance ``ε`` in series with every
*on* controlled 1-junction (an ideal switch or diode conducting): the
conflict is gone, the loop the sources drive carries a current of order
``1/ε``, and every bond variable becomes a rational function of ``ε``.  Its
limit as ``ε → 0⁺`` is what the ideal configuration would do at the instant
it is entered: a bond variable of order ``1/ε`` tends to ``±∞`` (the
impulse direction of the conflict: the diode whose current that impulse
reverses turns off, as PLECS's switch consistency iteration decides it); one
of order 1 to its finite value.

:func:`regularized_equations` derives the ``ε`` configuration;
:func:`leading_term` splits an expression of ``ε`` into its order and
leading coefficient, which the simulator evaluates at the state.

A configuration that leaves part of the graph *under*-determined (nodes
that float: a bridge rectifier's load while all four diodes block; a free
loop current through ideal switches in parallel) has states whose rates are
defined and bond variables that are not.  Put ``1/ε`` in series with every
blocking controlled 1-junction (a leak across it) and ``ε`` with every
conducting one: in the limit ``ε → 0⁺`` every bond variable has a value —
a floating node the potential the vanishing leaks give it, the same for
any leak that vanishes evenly — and the rates keep their own
(:func:`floating_limit`).  This is SPICE's ``GMIN`` taken to its limit
exactly, not at 1e-12.
"""

from __future__ import annotations

import sympy as sp

from .elements import One, R
from .graph import BondGraph

__all__ = ["EPSILON", "regularized_graph", "regularized_equations", "leading_term", "limit", "limit_graph",
           "floating_limit"]

#: the vanishing series resistance of every conducting ideal switch
EPSILON = sp.Symbol("epsilon_conflict", positive=True)


def _copy(graph, name: str) -> BondGraph:
    """A copy of ``graph``: its elements, bonds (by name), displacements and inputs."""
    copy = BondGraph(name)
    for element in graph.elements.values():
        copy.add(element)
    for bond in graph.bonds.values():
        copy.connect(bond.tail, bond.head, name=bond.name)
    copy.displacements = dict(graph.displacements)
    copy.inputs = dict(graph.inputs)
    return copy


def regularized_graph(graph, config: dict) -> BondGraph:
    """A copy of ``graph`` with a resistance :data:`EPSILON` bonded to every controlled 1-junction that
    ``config`` turns on (its elements, bonds, displacements and inputs kept, by name)."""
    copy = _copy(graph, f"{graph.name} (regularized)")
    for name, element in graph.elements.items():
        if isinstance(element, One) and element.controlled and config.get(name, True):
            copy.connect(name, R(f"{name}/conflict_resistance", EPSILON))
    return copy


def regularized_equations(graph, config: dict):
    """The :class:`~bondgraph.equations.ConfigurationEquations` of ``config`` on :func:`regularized_graph`:
    every bond variable of ``graph`` an expression of the states, parameters, inputs, ``t`` and
    :data:`EPSILON`.  Raises as :meth:`BondGraph.equations` does when the resistances do not remove the
    conflict (sources that over-determine the graph without any switch)."""
    return regularized_graph(graph, config).equations(dict(config))


def leading_term(expr: sp.Expr) -> tuple[list, list]:
    """``(numerator, denominator)`` coefficients of ``expr`` as a ratio of polynomials in
    :data:`EPSILON`, lowest order first: the limit ``ε → 0⁺`` is decided by the first non-zero
    coefficient of each at the state (order of the numerator's minus the denominator's: below 0
    an infinity of the sign of their ratio, 0 their ratio, above 0 zero)."""
    numerator, denominator = sp.fraction(sp.together(sp.sympify(expr)))
    coefficients = []
    for part in (numerator, denominator):
        poly = sp.Poly(sp.expand(part), EPSILON)
        coefficients.append(list(reversed(poly.all_coeffs())))
    return coefficients[0], coefficients[1]


def limit(expr: sp.Expr) -> sp.Expr:
    """``expr`` (a rational function of :data:`EPSILON`) as ``ε → 0⁺``: the ratio of the lowest-order
    coefficients of its numerator and denominator that are not identically zero.  Raises
    ``ValueError`` where the limit is infinite or ``expr`` is no rational function of ``ε``."""
    expr = sp.sympify(expr)
    if not expr.has(EPSILON):
        return expr
    numerator, denominator = leading_term(expr)

    def lowest(coefficients):
        for order, c in enumerate(coefficients):
            c = sp.cancel(c)
            if c != 0:
                return order, c
        return None, sp.Integer(0)

    n_order, n = lowest(numerator)
    d_order, d = lowest(denominator)
    if n_order is None:
        return sp.Integer(0)
    if d_order is None or n_order < d_order:
        raise ValueError(f"{expr} grows without bound as the regularization vanishes")
    return sp.cancel(n / d) if n_order == d_order else sp.Integer(0)


def limit_graph(graph, config: dict) -> tuple[BondGraph, dict]:
    """``(graph, configuration)`` in which every controlled 1-junction conducts: in series with a
    resistance :data:`EPSILON` where ``config`` turns it on, ``1/ε`` where it turns it off (an ideal
    switch as the limit of a vanishing and of a growing resistance); controlled 0-junctions as in
    ``config``."""
    copy = _copy(graph, f"{graph.name} (limit)")
    limited = dict(config)
    for name, element in graph.elements.items():
        if isinstance(element, One) and element.controlled:
            on = config.get(name, True)
            copy.connect(name, R(f"{name}/limit_resistance", EPSILON if on else 1 / EPSILON))
            limited[name] = True
    return copy, limited


def floating_limit(graph, config: dict, jump_law: str):
    """``(equations, jump map)`` of an under-determined ``config`` (floating nodes, a free loop
    current) as the limit of :func:`limit_graph` when ``ε → 0⁺``: the rates, constraints, efforts and
    flows of every bond of ``graph`` are the limits of the regularized ones — a floating node's
    potential the one the vanishing leaks give it (a bridge's blocking diodes share the voltage
    across them equally), a free loop's current the one the vanishing resistances divide.  Raises
    ``ValueError`` where a limit does not exist (a rate that grows without bound: a capacitor shorted,
    whose charge jumps) or the expressions are no rational functions of ``ε``."""
    from dataclasses import replace

    regularized, limited = limit_graph(graph, config)
    equations = regularized.equations(limited, open_ports=False)
    jump = regularized.jump_map(limited, jump_law)
    if jump.expressions is None or any(sp.sympify(v).has(EPSILON) for v in jump.expressions.values()):
        raise ValueError("the jump map into the configuration depends on the regularization")

    def table(mapping, keys=None):
        return {k: limit(v) for k, v in mapping.items() if keys is None or k in keys}

    equations = replace(
        equations, graph_name=graph.name, configuration=dict(config), constraints=table(equations.constraints),
        implicit_rates=table(equations.implicit_rates), rates=table(equations.rates),
        efforts=table(equations.efforts, graph.bonds), flows=table(equations.flows, graph.bonds),
        _dependent_rates=table(equations._dependent_rates))
    return equations, jump
