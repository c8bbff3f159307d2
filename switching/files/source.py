"""One model file as text: its TOML data, where each key is written, and the
checks every table and value of a model file goes through (types, allowed keys,
names), each failing with a :class:`~switching.files.errors.ModelFileError`
at the line of the culprit."""

from __future__ import annotations

import re
from pathlib import Path

from bondgraph.errors import did_you_mean
from bondgraph.symbols import NAME_PATTERN

from .errors import ModelFileError
from ..language.parsing import FUNCTIONS
from .tomllines import KeyLines

try:  # Python 3.11+
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["Source", "RESERVED_NAMES", "kind_of", "did_you_mean", "is_number"]

#: names an expression reads as something else than a symbol of the model
RESERVED_NAMES = frozenset({"t", "pi", "and", "or", "not", "true", "false"} | set(FUNCTIONS))


def kind_of(value) -> str:
    """The TOML type of a value, as a reader would name it."""
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int):
        return "an integer"
    if isinstance(value, float):
        return "a float"
    if isinstance(value, str):
        return "a text"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, dict):
        return "a table"
    return f"a {type(value).__name__}"


def is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


class Source:
    """One model file: its text, its TOML data and where each key is written."""

    def __init__(self, path: Path | None, text: str, display: str):
        self.path = path
        self.display = display
        self.text = text
        self.lines = KeyLines(text)
        try:
            self.data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            line = _decode_error_line(str(exc))
            raise ModelFileError(f"not valid TOML: {exc}; see https://toml.io for the syntax",
                                 display, line) from None
        except RecursionError:
            raise ModelFileError("not readable: arrays or tables nested too deeply", display) from None

    def error(self, message: str, keys=(), culprit: str = "") -> ModelFileError:
        return ModelFileError(message, self.display, self.lines.line(keys) if keys else None, culprit)

    def table(self, value, keys, what: str, allowed=None, required=(), example: str = "",
              culprit: str = "") -> dict:
        """``value`` checked to be a table with only ``allowed`` keys and every ``required`` one."""
        if not isinstance(value, dict):
            hint = f", e.g. {example}" if example else ""
            raise self.error(f"{what} must be a table{hint}, not {kind_of(value)}", keys, culprit)
        if allowed is not None:
            for key in value:
                if key not in allowed:
                    raise self.error(
                        f"unknown key {key!r}{did_you_mean(key, allowed)}; expected: {', '.join(allowed)}"
                        if culprit else
                        f"unknown key {key!r} in {what}{did_you_mean(key, allowed)}; expected: {', '.join(allowed)}",
                        tuple(keys) + (key,), culprit,
                    )
        for key in required:
            if key not in value:
                raise self.error(f"{what} needs the key {key!r}", keys, culprit)
        return value

    def text_value(self, value, keys, what: str, culprit: str = "") -> str:
        if not isinstance(value, str):
            raise self.error(f"{what} must be a text, not {kind_of(value)}", keys, culprit)
        return value

    def name(self, value, keys, what: str, expression: bool = False) -> str:
        """``value`` checked to be a valid name; ``expression``: a name that
        expressions use, which must not be a word of the expression grammar."""
        if not isinstance(value, str) or not NAME_PATTERN.fullmatch(value):
            raise self.error(
                f"{value!r} is not a valid {what}: use letters, digits and '_' (not starting with a digit), "
                "'/' between hierarchy levels",
                keys,
            )
        if expression and value in RESERVED_NAMES:
            raise self.error(f"{value!r} cannot be a {what}: expressions read it as "
                             f"{'time' if value == 't' else 'a word or function of the grammar'}; rename it", keys)
        return value


def _decode_error_line(message: str):
    m = re.search(r"line (\d+)", message)
    return int(m.group(1)) if m else None
