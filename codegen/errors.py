"""The code generator's own error, apart so that every module of :mod:`codegen` can raise it."""

from __future__ import annotations

from bondgraph.errors import HybridBondGraphError

__all__ = ["UnprintableExpressionError"]


class UnprintableExpressionError(HybridBondGraphError, ValueError):
    """An expression that numerical code cannot compute (``sp.Function('foo')(x)``, a matrix...)."""
