"""Solving systems of explicit equations ``v = expr(v', knowns)`` by their
sparse structure.

The dependency graph of the unknowns is split into strongly connected
components, taken in topological order: an acyclic unknown is a plain
substitution of already-solved ones (no matrices, linear cost for a chain);
a component with a cycle (an algebraic loop) is solved on its own as a small
linear system ``A v = b``.  A nonlinear loop is handed to ``sympy.solve`` and
must have exactly one solution, found within the budget of
:mod:`bondgraph.budget` (with its numbers as symbols, :mod:`bondgraph.solving`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import sympy as sp

from .budget import ENVIRONMENT_VARIABLE
from .errors import AlgebraicLoopError
from .solving import SolveFailure, lambert_solution, singular, solve

__all__ = ["dependency_components", "solve_explicit"]


def _substitute(expr: sp.Expr, solved: Mapping[sp.Symbol, sp.Expr]) -> sp.Expr:
    subs = {s: solved[s] for s in expr.free_symbols if s in solved}
    return expr.xreplace(subs) if subs else expr


def solve_explicit(
    equations: Mapping[sp.Symbol, sp.Expr],
    owner: Callable[[sp.Symbol], str] = lambda v: str(v),
    what: str = "algebraic loop",
) -> dict[sp.Symbol, sp.Expr]:
    """Solve ``{v: expr}`` (each unknown defined once) for every unknown in
    terms of the other symbols.  ``owner(v)`` names the element behind ``v``
    for error messages.  Raises :class:`AlgebraicLoopError` for a loop that is
    singular or nonlinear without a unique solution."""
    unknowns = set(equations)
    deps = {v: [s for s in expr.free_symbols if s in unknowns] for v, expr in equations.items()}
    solved: dict[sp.Symbol, sp.Expr] = {}
    for members in dependency_components(deps):
        if len(members) == 1:
            (v,) = members
            if v not in deps[v]:
                solved[v] = _substitute(equations[v], solved)
                continue
        solved.update(_solve_loop(sorted(members, key=str), equations, solved, owner, what))
    return solved


def dependency_components(successors: dict) -> list[list]:
    """The strongly connected components of the graph ``{v: [w, …]}`` (edge
    ``v → w``: ``v`` depends on ``w``), each listed after every component it
    reaches — the order to solve them in (Tarjan's algorithm, iterative:
    linear in the size of the graph, no recursion limit for long chains)."""
    index: dict = {}
    low: dict = {}
    on_stack: set = set()
    stack: list = []
    out: list = []
    for root in successors:
        if root in index:
            continue
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        work = [(root, iter(successors[root]))]
        while work:
            v, edges = work[-1]
            for w in edges:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(successors[w])))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[v])
                if low[v] == index[v]:
                    component = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        component.append(w)
                        if w == v:
                            break
                    out.append(component)
    return out


def _solve_loop(members, equations, solved, owner, what) -> dict:
    residuals = [v - _substitute(equations[v], solved) for v in members]
    elements = sorted({owner(v) for v in members})
    try:
        A, b = sp.linear_eq_to_matrix(residuals, members)
    except (ValueError, NotImplementedError):  # sympy raises NonlinearError(ValueError)
        A = None
    if A is not None:
        if singular(A, f"deciding whether the {what} through {', '.join(elements)} is singular"):
            raise AlgebraicLoopError(
                f"{what} through {', '.join(elements)} is singular (its equations are linearly dependent): "
                "the junction structure leaves these variables undetermined. Add a storage or resistive element "
                "to the loop, or check the bond directions.",
                elements,
            )
        solution = A.LUsolve(b)
        return {v: sp.cancel(solution[i]) if len(members) <= 4 else solution[i] for i, v in enumerate(members)}
    return _solve_nonlinear_loop(residuals, list(members), elements, what)


def _solve_nonlinear_loop(residuals, members, elements, what) -> dict:
    """Eliminate the unknowns that appear linearly, one at a time; what is
    left must have a unique closed-form solution (a polynomial of degree ≥ 2
    in one unknown has several, and is refused at once)."""
    eliminated: dict[sp.Symbol, sp.Expr] = {}
    residuals = list(residuals)
    progress = True
    while progress and residuals:
        progress = False
        for i, r in enumerate(residuals):
            for v in members:
                if v in eliminated or not r.has(v):
                    continue
                coeff = sp.diff(r, v)
                if coeff.has(*members) or coeff == 0:
                    continue
                value = -r.xreplace({v: 0}) / coeff
                eliminated = {k: e.xreplace({v: value}) for k, e in eliminated.items()}
                eliminated[v] = value
                residuals = [x.xreplace({v: value}) for j, x in enumerate(residuals) if j != i]
                progress = True
                break
            if progress:
                break
    remaining = [v for v in members if v not in eliminated]
    solution: dict[sp.Symbol, sp.Expr] = {}
    if remaining:
        for r in residuals:
            for v in remaining:
                poly = sp.Poly(sp.numer(sp.together(r)), v) if r.is_polynomial(v) else None
                if poly is not None and poly.degree() >= 2:
                    raise AlgebraicLoopError(
                        f"nonlinear {what} through {', '.join(elements)} reduces to a polynomial of degree "
                        f"{poly.degree()} in {v}, which has several solutions, not exactly one: it cannot be "
                        "solved symbolically. Break the loop with a storage element, or give the resistive law "
                        "in the causality the loop needs.",
                        elements,
                    )
        lambert = lambert_solution(residuals[0], remaining[0]) if len(residuals) == len(remaining) == 1 else None
        try:
            if lambert is not None:  # an exponential law in series with a resistance: Lambert's W
                solutions = [{remaining[0]: lambert}]
            else:
                solutions = solve(residuals, remaining, f"solving the {what} through {', '.join(elements)}")
            found = f"has {len(solutions)} closed-form solution(s), not exactly one"
            over_budget = False
        except SolveFailure as failure:
            solutions, found = [], f"has no closed-form solution that sympy finds: {failure.reason}"
            over_budget = failure.over_budget
        if len(solutions) != 1 or set(solutions[0]) != set(remaining):
            numbers = ("; giving the numbers of its laws as parameters (symbols, with values among the model's "
                       "parameters) helps sympy find one" if any(r.atoms(sp.Number) - {sp.S.One, sp.S.NegativeOne}
                                                                 for r in residuals) else "")
            if over_budget:
                numbers += f"; or raise the budget ({ENVIRONMENT_VARIABLE})"
            raise AlgebraicLoopError(
                f"nonlinear {what} through {', '.join(elements)} {found}, so it cannot be solved symbolically "
                f"(equations: {', '.join(f'{r} = 0' for r in residuals)}). Break the loop with a storage element, "
                f"or give the resistive law in the causality the loop needs{numbers}.",
                elements,
            )
        solution = solutions[0]
    out = {v: e.xreplace(solution) for v, e in eliminated.items()}
    out.update(solution)
    return out
