"""The fast derivation path (issue 15) gives the results of the plain one.

For every mode a 4-ball chain visits, f, g and the guard sides derived by the
toolkit are compared with a reference derivation that takes none of the
shortcuts: every expression tidied by ``sympy.simplify`` (not ``cancel``),
the explicit equations ordered by networkx's condensation (not the iterative
Tarjan of :func:`bondgraph.algebra.dependency_components`), and the code
printed without the model-wide print memo.  Symbolic results must agree
exactly (``simplify(a − b) == 0``), generated code to the last bit.
"""

from __future__ import annotations

import networkx as nx
import numpy as np
import pytest
import sympy as sp

import bondgraph.algebra as algebra
import bondgraph.equations as equations
from codegen.source import module_namespace
from models import ball_chain
from switching.library.compiled import generate_mode_source
from switching.model.modes import ModeEquations


def networkx_components(successors: dict) -> list:
    """Strongly connected components, dependencies first, as networkx orders them."""
    graph = nx.DiGraph()
    graph.add_nodes_from(successors)
    graph.add_edges_from((v, w) for v, ws in successors.items() for w in ws)
    condensed = nx.condensation(graph)
    return [list(condensed.nodes[c]["members"]) for c in reversed(list(nx.topological_sort(condensed)))]


def simplified(expr):
    return expr if sp.count_ops(expr) > equations.SIMPLIFY_MAX_OPS else sp.simplify(expr)


@pytest.fixture(scope="module")
def visited():
    model = ball_chain.build(N=4, e=1.0)
    model.simulate(1.0, "RK45", rtol=1e-9)
    assert len(model.visited_modes) >= 4  # (from the disk cache, perhaps: derived below when asked)
    return model


def reference_mode(model, mode, monkeypatch):
    """The mode's equations derived afresh along the plain path."""
    monkeypatch.setattr(algebra, "dependency_components", networkx_components)
    monkeypatch.setattr(equations, "tidy", simplified)
    graph = model.derivation_graph
    graph.derived.entries.clear()  # derive again, not from the graph's own cache
    try:
        return ModeEquations(model, mode)
    finally:
        monkeypatch.undo()
        graph.derived.entries.clear()


def test_f_g_and_guard_sides_agree_with_the_plain_derivation(visited, monkeypatch):
    model = visited
    for mode in model.visited_modes:
        fast = model.mode_equations(mode)
        plain = reference_mode(model, mode, monkeypatch)
        for x in model.states:
            assert sp.simplify(fast.f[x] - plain.f[x]) == 0, (mode, x)
            assert sp.simplify(fast.g[x] - plain.g[x]) == 0, (mode, x)
        assert [g.text for g in fast.guards] == [g.text for g in plain.guards]
        for a, b in zip(fast.guards, plain.guards):
            for rel_a, rel_b in zip(sorted(a.condition.atoms(sp.core.relational.Relational), key=str),
                                    sorted(b.condition.atoms(sp.core.relational.Relational), key=str)):
                assert sp.simplify((rel_a.lhs - rel_a.rhs) - (rel_b.lhs - rel_b.rhs)) == 0, (mode, a.text)


def _functions(source: str) -> dict:
    namespace = module_namespace()
    exec(compile(source, "<test>", "exec"), namespace)  # noqa: S102 - the toolkit's generated code
    return namespace


def test_generated_code_with_the_print_memo_is_bitwise_the_code_without(visited):
    model = visited
    rng = np.random.default_rng(4)
    memo = model.library.print_memo
    n, p, u = len(model.states), model.parameter_array, model.input_values(0.0)
    try:
        for mode in model.visited_modes:
            me = model.mode_equations(mode)
            sizes = {"rates": n, "sides": model.compiled_mode(mode).n_sides, "jump": n}
            model.library.print_memo = memo
            with_memo = _functions(generate_mode_source(model, me))
            model.library.print_memo = None
            without = _functions(generate_mode_source(model, me))
            for _ in range(5):
                x = rng.normal(size=n)
                for name, size in sizes.items():
                    if name not in with_memo:  # no jump function: an identity jump
                        continue
                    a = with_memo[name](x, 0.3, p, u, np.empty(size))
                    b = without[name](x, 0.3, p, u, np.empty(size))
                    assert np.array_equal(a, b, equal_nan=True), (mode, name)
    finally:
        model.library.print_memo = memo
