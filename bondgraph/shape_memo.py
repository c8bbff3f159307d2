"""A derivation step's results reused for expressions of the same shape.

A scene repeats one piece many times over: the 1000-ball chain's contact
jump is the same expression for every pair of balls, its symbols renamed.
A step that tidies an expression (``cancel``, ``simplify``: milliseconds
each) is run once per *shape* and its result renamed for the others.

Two expressions have the same shape when one is the other with its symbols
renamed *in order*: the symbols sorted by name are mapped onto placeholders
``_shape000000, _shape000001, …`` (carrying the same assumptions) in that
order, and the two placeholder forms are equal.  sympy orders the arguments
of a sum or a product, and the generators of a polynomial, by the symbols'
names; a renaming that keeps their order therefore keeps every such choice,
and the renamed result is the one the step gives the expression itself —
the same terms in the same order, so the generated code, and its rounding,
are the same.  An expression holding symbols of another kind (``Dummy``,
``Wild``) or two symbols of one name is not memoised.
"""

from __future__ import annotations

import sympy as sp

__all__ = ["NotKept", "ShapeMemo"]

_PREFIX = "_shape"


class NotKept(Exception):
    """Raised by a step for a ``result`` that is not to be kept for the shape (a time budget ran out)."""

    def __init__(self, result):
        super().__init__("a step's result not to be kept")
        self.result = result


class ShapeMemo:
    """``step(expr)`` kept by the shape of ``expr`` (see the module): at most
    ``size`` shapes, the earliest added dropped first.  A step may answer
    by raising :class:`NotKept` (a time budget ran out): its result is
    returned and not kept, and the next expression of the shape runs the
    step again."""

    def __init__(self, size: int = 4096):
        self.size = size
        self.entries: dict = {}
        self.hits = 0

    def __call__(self, step, expr: sp.Expr) -> sp.Expr:
        renaming = _in_order(expr)
        if renaming is None:
            return step(expr)
        forward, backward = renaming
        shape = expr.xreplace(forward)
        found = self.entries.get(shape)
        if found is not None:
            self.hits += 1
            return found.xreplace(backward)
        try:
            result = step(expr)
        except NotKept as unkept:
            return unkept.result
        if len(self.entries) >= self.size:
            try:
                del self.entries[next(iter(self.entries))]
            except (KeyError, RuntimeError, StopIteration):  # (another thread's derivation dropped it first)
                pass
        self.entries[shape] = result.xreplace(forward)
        return result


def _in_order(expr):
    """``(forward, backward)``: the renaming of ``expr``'s symbols onto the
    placeholders in the order of their names, and back; ``None`` when it
    holds a symbol of another kind or two of one name."""
    symbols = expr.free_symbols
    if any(type(symbol) is not sp.Symbol for symbol in symbols):
        return None
    ordered = sorted(symbols, key=lambda symbol: symbol.name)
    if any(a.name == b.name for a, b in zip(ordered, ordered[1:])):
        return None
    placeholders = [sp.Symbol(f"{_PREFIX}{k:06d}", **symbol.assumptions0) for k, symbol in enumerate(ordered)]
    return dict(zip(ordered, placeholders)), dict(zip(placeholders, ordered))
