"""A bond graph whose element laws have symbols replaced by expressions.

``with_laws_substituted(graph, {u: 12·Heaviside(t − 0.001, 1)})`` is a copy of
``graph`` in which every element law, value and modulus that reads ``u`` reads
the expression instead: the equations derived from the copy are those of the
graph with ``u = 12·Heaviside(t − 0.001, 1)``.  Structure, bonds, states and
declared inputs are the graph's own; ``graph`` itself is not changed.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields

import sympy as sp

from .elements import copy_with

__all__ = ["with_laws_substituted"]


def _substituted_fields(element, substitution: Mapping) -> dict:
    """The law fields of ``element`` (every sympy field but its state) that read a symbol of
    ``substitution``, each with the symbols replaced."""
    changes = {}
    for f in fields(element):
        value = getattr(element, f.name)
        if f.name == "state" or not isinstance(value, sp.Basic) or not value.has(*substitution):
            continue
        changes[f.name] = value.xreplace(dict(substitution))
    return changes


def with_laws_substituted(graph, substitution: Mapping[sp.Symbol, sp.Expr]):
    """A copy of ``graph`` whose element laws read ``substitution[s]`` wherever they read ``s``
    (``graph`` itself when no law reads any of them)."""
    from .graph import BondGraph

    elements = {}
    for name, element in graph.elements.items():
        changes = _substituted_fields(element, substitution) if substitution else {}
        elements[name] = copy_with(element, **changes) if changes else element
    if all(elements[name] is element for name, element in graph.elements.items()):
        return graph
    copy = BondGraph(graph.name)
    copy.elements = elements
    copy.bonds = dict(graph.bonds)
    copy.displacements = dict(graph.displacements)
    copy.inputs = dict(graph.inputs)
    copy.ports = dict(graph.ports)
    copy._bonds_of = {k: list(v) for k, v in graph._bonds_of.items()}
    return copy
