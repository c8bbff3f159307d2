"""Helpers shared by the model modules."""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass

from bondgraph.errors import InvalidGraphError, ParameterValueError, PhysicalRangeWarning, UnknownParameterError
from bondgraph.reals import real_number

__all__ = ["merged", "Range", "positive", "nonnegative", "annotated"]


@dataclass(frozen=True)
class Range:
    """The physical range of one parameter: ``low <= value <= high`` (a
    bound is left out with ``None``, excluded with ``low_open``/``high_open``);
    ``what`` says what the parameter is (shown in the warning)."""

    what: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    required: bool = False  # outside: an error (the model cannot be built), not a warning

    def holds(self, value: float) -> bool:
        if self.low is not None and (value <= self.low if self.low_open else value < self.low):
            return False
        return not (self.high is not None and (value >= self.high if self.high_open else value > self.high))

    def requirement(self) -> str:
        if self.low == 0 and self.high is None:
            return "positive" if self.low_open else "zero or positive"
        return f"in {self.describe('the range')}"

    def describe(self, name: str) -> str:
        parts = []
        if self.low is not None:
            parts.append(f"{self.low:g} {'<' if self.low_open else '<='} ")
        parts.append(name)
        if self.high is not None:
            parts.append(f" {'<' if self.high_open else '<='} {self.high:g}")
        return "".join(parts)


def positive(what: str, required: bool = False) -> Range:
    return Range(what, 0.0, low_open=True, required=required)


def nonnegative(what: str, required: bool = False) -> Range:
    return Range(what, 0.0, required=required)


def merged(defaults: Mapping, overrides: Mapping, ranges: Mapping[str, Range] | None = None,
           model: str = "model") -> dict:
    """``defaults`` updated by ``overrides``; unknown names, non-numbers and
    non-finite numbers are errors (a text default is a choice: the model
    checks its value).  A value outside its :class:`Range` in ``ranges`` gives
    a :class:`~bondgraph.errors.PhysicalRangeWarning` naming ``model``, the
    parameter and the range, or, for a ``required`` range (one the model
    cannot be built outside), an :class:`~bondgraph.errors.InvalidGraphError`."""
    unknown = set(overrides) - set(defaults)
    if unknown:
        raise UnknownParameterError(unknown, defaults)
    values = dict(defaults)
    for name, value in overrides.items():
        default = defaults[name]
        if not isinstance(default, (str, bool)):
            value = real_number(value, f"parameter {name!r} of {model}", name)
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
        if isinstance(values[name], float) and not math.isfinite(values[name]):
            raise ParameterValueError(f"parameter {name!r} of {model} is {values[name]}: it needs a finite number",
                                      name, values[name])
    for name, allowed in (ranges or {}).items():
        if not allowed.holds(values[name]) and allowed.required:
            raise InvalidGraphError(f"parameter {name!r} of {model} must be {allowed.requirement()} "
                                    f"({allowed.what}), got {values[name]:g}", [name])
        if not allowed.holds(values[name]):
            warnings.warn(PhysicalRangeWarning(
                f"{model}: {name} = {values[name]:g} is outside the physical range {allowed.describe(name)} "
                f"({allowed.what}); the run goes on, but its result may not be physical"), stacklevel=3)
    return values


def annotated(units: Mapping, ranges: Mapping, defaults: Mapping, parameters) -> dict:
    """``units=`` and ``descriptions=`` for a shipped model's ``HybridModel``:
    the units of its states, signals and of those of ``parameters`` (the
    names it passes as parameters) that ``units`` lists, and what each
    parameter with a :class:`Range` is (its ``what``)."""
    return {"units": {k: v for k, v in units.items() if k not in defaults or k in parameters},
            "descriptions": {name: ranges[name].what for name in parameters if name in ranges}}
