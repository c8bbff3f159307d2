"""Helpers shared by the model modules."""

from __future__ import annotations

from collections.abc import Mapping

from bondgraph.errors import InvalidGraphError, UnknownParameterError

__all__ = ["merged"]


def merged(defaults: Mapping, overrides: Mapping) -> dict:
    """``defaults`` updated by ``overrides``; unknown names and non-numbers are
    errors (a text default is a choice: the model checks its value)."""
    unknown = set(overrides) - set(defaults)
    if unknown:
        raise UnknownParameterError(unknown, defaults)
    values = dict(defaults)
    for name, value in overrides.items():
        default = defaults[name]
        try:
            if isinstance(default, str):
                if not isinstance(value, str):
                    raise TypeError
                values[name] = value
            elif isinstance(default, bool):
                if isinstance(value, str):
                    if value.lower() not in ("true", "false", "1", "0", "yes", "no"):
                        raise ValueError
                    value = value.lower() in ("true", "1", "yes")
                values[name] = bool(value)
            elif isinstance(default, int):
                number = float(value)
                if number != int(number):
                    raise ValueError
                values[name] = int(number)
            else:
                values[name] = float(value)
        except (TypeError, ValueError):
            kind = ("text" if isinstance(default, str) else "true/false" if isinstance(default, bool)
                    else "an integer" if isinstance(default, int) else "a number")
            raise InvalidGraphError(f"parameter {name!r} must be {kind}, got {value!r}") from None
    return values
