"""A conflicting configuration seen through vanishing resistances.

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
"""

from __future__ import annotations

import sympy as sp

from .elements import One, R
from .graph import BondGraph

__all__ = ["EPSILON", "regularized_graph", "regularized_equations", "leading_term"]

#: the vanishing series resistance of every conducting ideal switch
EPSILON = sp.Symbol("epsilon_conflict", positive=True)


def regularized_graph(graph, config: dict) -> BondGraph:
    """A copy of ``graph`` with a resistance :data:`EPSILON` bonded to every controlled 1-junction that
    ``config`` turns on (its elements, bonds, displacements and inputs kept, by name)."""
    copy = BondGraph(f"{graph.name} (regularized)")
    for element in graph.elements.values():
        copy.add(element)
    for bond in graph.bonds.values():
        copy.connect(bond.tail, bond.head, name=bond.name)
    copy.displacements = dict(graph.displacements)
    copy.inputs = dict(graph.inputs)
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
