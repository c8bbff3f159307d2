"""The error of model files and the limits that keep reading a file cheap.

Every problem found in a model file raises :class:`ModelFileError`, whose
message starts with ``<file>:<line>:`` and names the element, bond,
automaton, transition, signal or parameter at fault, then says what is
expected.  It derives from the toolkit's base
:class:`~bondgraph.errors.HybridBondGraphError` and from ``ValueError``.

Limits (a hostile or broken file is refused before it costs much):

=========================  ==================================================
:data:`MAX_FILE_BYTES`      size of one file
:data:`MAX_EXPRESSION_CHARS` characters of one expression or condition
:data:`MAX_EXPRESSION_TOKENS` numbers, names and operators of one expression
:data:`MAX_PARSE_WORK`      sum over all files of one load of the *squared*
                            token counts of the expressions: sympy's canonical
                            ordering makes an expression cost about the square
                            of its length, so this bounds the parsing time of
                            any load to a few seconds, while a model of
                            thousands of short expressions stays well inside
:data:`MAX_ELEMENTS`        elements of the whole model, sub-models included
:data:`MAX_DEPTH`           nesting of sub-model files
:data:`MAX_FILES`           distinct files one load reads
=========================  ==================================================

:mod:`switching.language.parsing` adds its own limits on every expression (numbers
finite in double precision, nesting depth, exact fractions).
"""

from __future__ import annotations

import re

from bondgraph.errors import HybridBondGraphError

__all__ = [
    "ModelFileError",
    "MAX_FILE_BYTES",
    "MAX_EXPRESSION_CHARS",
    "MAX_EXPRESSION_TOKENS",
    "MAX_PARSE_WORK",
    "MAX_ELEMENTS",
    "MAX_DEPTH",
    "MAX_FILES",
    "count_tokens",
]

#: Bytes of one model file (the largest shipped model saved flat is a few kB).
MAX_FILE_BYTES = 1_000_000
#: Characters of one expression or condition.
MAX_EXPRESSION_CHARS = 10_000
#: Numbers, names and operators of one expression or condition.
MAX_EXPRESSION_TOKENS = 1_000
#: Sum of the squared token counts of every expression one load parses.
MAX_PARSE_WORK = 4_000_000
#: Elements of the whole model, sub-model instances included.
MAX_ELEMENTS = 20_000
#: Nesting depth of sub-model files.
MAX_DEPTH = 16
#: Distinct files read by one load.
MAX_FILES = 256

_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_/]*|\d+\.?\d*(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?|\*\*|[<>=!]=|&&|\|\||\S",
                    re.ASCII)


def count_tokens(text: str) -> int:
    """Numbers, names and operators in ``text`` (as the expression parser counts
    them, a hierarchical name being one)."""
    return len(_TOKEN.findall(text))


class ModelFileError(HybridBondGraphError, ValueError):
    """A model file that cannot be read, or a model that cannot be written.

    ``path`` is the file, ``line`` the 1-based line (None when the problem is
    not at one place, e.g. a missing table), ``culprit`` what is at fault
    (``"element 'R1'"``, ``"bond 'b3'"``, ``"transition 2 of automaton 'diode'"``),
    ``message`` the problem and what is expected.  An error in a sub-model file
    names that file, and its message ends with where each including file places it."""

    def __init__(self, message: str, path=None, line: int | None = None, culprit: str = ""):
        where = f"{path}:{line}: " if path is not None and line is not None else f"{path}: " if path is not None else ""
        subject = f"{culprit}: " if culprit else ""
        super().__init__(f"{where}{subject}{message}")
        self.message = message
        self.path = None if path is None else str(path)
        self.line = line
        self.culprit = culprit
