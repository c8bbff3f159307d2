"""A scene's guard table in blocks shared by its modes.

A mode's ``META['guards']`` lists every guard that may leave it: its automaton, transition, text and
condition tree, the tree's comparisons numbered ``k`` as in the ``sides`` function (triple ``k`` at
``[3k], [3k + 1], [3k + 2]``).  A mode of a scene of ``N`` contacts holds ``N`` guards, nearly all of
them the same in every mode; written out in each mode's module they made the module about 300 bytes a
guard (300 kB a mode at ``N = 1000``) and the disk cache of a run through ``N`` modes grow as ``N²``.

So a mode of a scene (:func:`switching.library.compiled.mode_module`: more than twice
``SIDE_BLOCK_AUTOMATA`` automata) writes ``META['guard_blocks']`` instead: ``((name, offset), …)``, one
pair per block of automata that has guards, in the automata's order.  The *table* ``name`` holds the
block's guard entries with their comparisons numbered from 0 (the block's first comparison), as the
text ``RECORD = (entry, …)`` whose ``sha1`` names it (``_guards_`` and 12 hex digits, like the block
functions, :func:`switching.library.compiled.block_name`); ``offset`` is the number of the block's
first comparison in the mode.  The mode's guards are the tables' entries, each tree's comparison
numbers moved by its table's offset, in turn: ``guards = Σ shift(table_b, offset_b)``.  A table is
stored in the disk cache once, under its own key, beside the block functions; ``META['comparisons']``
gives the mode's number of comparisons.
"""

from __future__ import annotations

import ast
import hashlib
import re

__all__ = ["GUARD_TABLES", "guard_table_record", "shifted_entries", "table_checked", "table_entries", "table_name"]

_TABLE_NAME = r"_guards_[0-9a-f]{12}"
#: the names of guard tables in a module's text (in its ``META``: strings, never called)
GUARD_TABLES = rf"\b{_TABLE_NAME}\b"

_RECORD = "RECORD = "


def guard_table_record(entry_texts: list) -> str:
    """The stored text of a guard table whose entries' reprs are ``entry_texts`` (each tree numbered from
    the table's first comparison): ``RECORD = (entry, …)`` and a newline."""
    return _RECORD + "(" + ", ".join(entry_texts) + ("," if len(entry_texts) == 1 else "") + ")\n"


def table_name(record: str) -> str:
    """The name of the guard table whose stored text is ``record``: a hash of it."""
    return "_guards_" + hashlib.sha1(record.encode()).hexdigest()[:12]


def table_checked(name: str, text: str) -> bool:
    """Is ``text`` the guard table ``name`` (a record whose hash is its name)?"""
    return bool(re.fullmatch(_TABLE_NAME, name)) and text.startswith(_RECORD) and table_name(text) == name


def table_entries(text: str) -> tuple:
    """The guard entries of a table's stored ``text`` (numbered from 0).  Raises ``ValueError`` on a text
    that is no table."""
    try:
        entries = ast.literal_eval(text[len(_RECORD):]) if text.startswith(_RECORD) else None
    except (SyntaxError, ValueError, TypeError, MemoryError, RecursionError) as exc:  # (literal_eval's refusals)
        raise ValueError(f"not a guard table: {exc}") from None
    if not (isinstance(entries, tuple) and all(isinstance(e, dict) and "tree" in e for e in entries)):
        raise ValueError("not a guard table: a tuple of guard entries was expected")
    return entries


def shifted_entries(entries: tuple, offset: int, shift) -> tuple:
    """``entries`` with each tree's comparison numbers moved by ``offset`` (``shift(tree, offset)``)."""
    if not offset:
        return entries
    return tuple({**entry, "tree": shift(entry["tree"], offset)} for entry in entries)
