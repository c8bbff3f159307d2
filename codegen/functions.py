"""Numerical functions from sympy expressions (plain lambdify path)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import sympy as sp

__all__ = ["vector_function"]


def vector_function(expressions: Sequence[sp.Expr], states: Sequence[sp.Symbol], time: sp.Symbol,
                    parameters: Sequence[sp.Symbol], extra: Sequence[sp.Symbol] = ()):
    """Compile ``expressions`` into ``fn(x, t, p, z=()) -> ndarray`` of shape ``(len(expressions),)``.

    ``x`` holds the values of ``states`` in order, ``p`` those of
    ``parameters``, and ``z`` those of ``extra`` (further symbols such as
    inputs; empty by default).  Common subexpressions are eliminated.  Symbols outside these
    groups are an error (they would otherwise surface as a ``NameError`` at
    call time).
    """
    expressions = [sp.sympify(e) for e in expressions]
    known = set(states) | {time} | set(parameters) | set(extra)
    free = set().union(*(e.free_symbols for e in expressions)) if expressions else set()
    unknown = free - known
    if unknown:
        raise ValueError(f"expressions use symbols with no value: {', '.join(sorted(map(str, unknown)))}")
    args = [list(states), time, list(parameters), list(extra)]
    fn = sp.lambdify(args, expressions, modules="numpy", cse=True)
    n = len(expressions)

    def evaluate(x, t, p, z=()):
        out = np.empty(n)
        out[:] = fn(x, t, p, z)
        return out

    evaluate.source_args = args
    return evaluate
