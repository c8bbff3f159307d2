"""Helpers shared by the model modules."""

from __future__ import annotations

from collections.abc import Mapping

from bondgraph.errors import InvalidGraphError, UnknownParameterError

__all__ = ["merged"]


def merged(defaults: Mapping, overrides: Mapping) -> dict:
    """``defaults`` updated by ``overrides``; unknown names and non-numbers are errors."""
    unknown = set(overrides) - set(defaults)
    if unknown:
        raise UnknownParameterError(unknown, defaults)
    values = dict(defaults)
    for name, value in overrides.items():
        if isinstance(defaults[name], bool) or isinstance(defaults[name], int) and not isinstance(value, float):
            values[name] = value
            continue
        try:
            values[name] = float(value)
        except (TypeError, ValueError):
            raise InvalidGraphError(f"parameter {name!r} must be a number, got {value!r}") from None
    return values
