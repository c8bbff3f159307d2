"""Line numbers of the keys of a TOML text.

TOML readers (``tomllib``, ``tomli``) return plain dicts without positions, so
an error about a value found after parsing could not say where it is.  A
:class:`KeyLines` index recovers the line by a light scan of the text itself:

* a table header ``[a.b]`` sets the current table; an array-of-tables header
  ``[[a.b]]`` sets it to ``a.b`` *and the index of that element* (0, 1, … in
  order of appearance), as the reader's lists do;
* a line ``key = …`` (bare, ``"quoted"`` or ``'literal'`` keys, dotted keys
  such as ``states.on = …``) records the key under the current table;
* lines inside multi-line strings (``\"\"\"``, ``'''``) are skipped.

:meth:`KeyLines.line` answers with the line of the longest recorded prefix of a
key path, so a value inside an inline table (``R = { type = "R", … }``) or a
multi-line array is reported at the line of its key.  The scan assumes a text
that the TOML reader accepted; it never raises.

Example::

    >>> lines = KeyLines('a = 1\\n[elements]\\nR = { type = "R" }\\n[[t]]\\nx = 1\\n[[t]]\\nx = 2\\n')
    >>> lines.line(("elements", "R", "type")), lines.line(("t", 1, "x")), lines.line(("nowhere",))
    (3, 7, None)
"""

from __future__ import annotations

import re

__all__ = ["KeyLines", "parse_key"]

_BARE = re.compile(r"[A-Za-z0-9_-]+")
_BASIC_ESCAPES = {"b": "\b", "t": "\t", "n": "\n", "f": "\f", "r": "\r", '"': '"', "\\": "\\"}


def parse_key(text: str, pos: int = 0) -> tuple[tuple[str, ...], int] | None:
    """The dotted key starting at ``pos`` in ``text`` and the position after it
    (and after the spaces that follow), or None if there is no key there."""
    parts = []
    n = len(text)
    while True:
        while pos < n and text[pos] in " \t":
            pos += 1
        if pos >= n:
            return None
        c = text[pos]
        if c == '"':
            part, pos = _basic_string(text, pos + 1)
        elif c == "'":
            end = text.find("'", pos + 1)
            if end < 0:
                return None
            part, pos = text[pos + 1:end], end + 1
        else:
            m = _BARE.match(text, pos)
            if not m:
                return None
            part, pos = m.group(), m.end()
        if part is None:
            return None
        parts.append(part)
        while pos < n and text[pos] in " \t":
            pos += 1
        if pos < n and text[pos] == ".":
            pos += 1
            continue
        return tuple(parts), pos


def _basic_string(text: str, pos: int) -> tuple[str | None, int]:
    out = []
    while pos < len(text):
        c = text[pos]
        if c == '"':
            return "".join(out), pos + 1
        if c == "\\" and pos + 1 < len(text):
            escape = text[pos + 1]
            if escape in _BASIC_ESCAPES:
                out.append(_BASIC_ESCAPES[escape])
                pos += 2
                continue
            if escape in "uU":
                width = 4 if escape == "u" else 8
                try:
                    out.append(chr(int(text[pos + 2:pos + 2 + width], 16)))
                except ValueError:
                    return None, pos
                pos += 2 + width
                continue
            return None, pos
        out.append(c)
        pos += 1
    return None, pos


class KeyLines:
    """Where each key of a TOML text is written (1-based line numbers)."""

    def __init__(self, text: str):
        self._lines: dict[tuple, int] = {}
        self._exact: dict[tuple, int] = {}
        table: tuple = ()
        counts: dict[tuple, int] = {}
        in_string = None  # the delimiter of the multi-line string we are in
        for number, line in enumerate(text.splitlines(), 1):
            if in_string is not None:
                if line.count(in_string) % 2 == 1:
                    in_string = None
                continue
            stripped = line.lstrip()
            if not stripped or stripped.startswith("#"):
                continue
            if stripped.startswith("[["):
                found = parse_key(stripped, 2)
                if found:
                    path = found[0]
                    counts[path] = counts.get(path, -1) + 1
                    table = path + (counts[path],)
                    self._record(table, number)
                continue
            if stripped.startswith("["):
                found = parse_key(stripped, 1)
                if found:
                    table = found[0]
                    self._record(table, number)
                continue
            found = parse_key(stripped)
            if found and found[1] < len(stripped) and stripped[found[1]] == "=":
                self._record(table + found[0], number)
                rest = stripped[found[1] + 1:]
                for delimiter in ('"""', "'''"):
                    if rest.count(delimiter) % 2 == 1:
                        in_string = delimiter
                        break

    def _record(self, path: tuple, number: int) -> None:
        # a table or key first written here; its parents appear here at the latest
        self._exact.setdefault(path, number)
        for k in range(1, len(path) + 1):
            self._lines.setdefault(path[:k], number)

    def line(self, path) -> int | None:
        """The line of ``path`` (a tuple of keys and array indices), or of its
        longest recorded prefix; None if not even its first key is recorded."""
        path = tuple(path)
        while path:
            if path in self._lines:
                return self._lines[path]
            path = path[:-1]
        return None

    def exact(self, path) -> int | None:
        """The line where ``path`` itself is written as a key or table header (None if nowhere)."""
        return self._exact.get(tuple(path))

    def first(self, path) -> int | None:
        """The first line where ``path`` or a key below it is written (None if nowhere)."""
        return self._lines.get(tuple(path))
