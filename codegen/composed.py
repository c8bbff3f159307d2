"""Callers of block functions built from their text without compiling it.

:func:`codegen.source.composed_source` writes a function that only calls
block functions in turn, each on its slice of ``out``
(``f(x, t, p, u, out[a:b])``, the slices following each other from 0), or,
raw, returns the concatenation of their lists (``f(x, t, p, u, xdot) + …``).
A scene's mode has three such callers of some sixty calls each, one new set
for every mode; compiling their text took a millisecond a mode at a
thousand contacts.  :func:`composed_function` reads the calls off the text,
which must be exactly what ``composed_source`` writes (else ``None``: the
caller compiles it as any other generated function), and returns a loop over
them: the same calls, on the same slices, in the same order.

Nothing of the text runs: the only names it contributes are the block
functions', each of which must be among the ``functions`` handed in (the
blocks already compiled and checked), and the only numbers the slices'.
The function's code carries the module's file name and the caller's first
line, as the compiled caller's did (a failure inside a block is traced back
to ``x`` and ``t`` of the ``<hbg mode …>`` frame).
"""

from __future__ import annotations

import ast
import re

__all__ = ["composed_function"]

_DEF = re.compile(r"def (?P<name>[A-Za-z_][A-Za-z0-9_]*)\(x, t, p, u, (?P<last>out|xdot)\):\n")
_CALL = re.compile(r"    (?P<name>[A-Za-z_][A-Za-z0-9_]*)\(x, t, p, u, out\[(?P<start>\d+):(?P<end>\d+)\]\)")
_RAW_CALL = re.compile(r"(?P<name>[A-Za-z_][A-Za-z0-9_]*)\(x, t, p, u, xdot\)")


def composed_function(text: str, functions: dict, where: str, first_line: int = 1):
    """The caller whose source ``text`` :func:`~codegen.source.composed_source` wrote (arguments
    ``x, t, p, u`` and ``out``, or ``xdot`` for a raw one), calling the block functions named in it
    from ``functions`` (name → function); ``where`` and ``first_line`` as for
    :func:`codegen.safety.execute`.  ``None`` when ``text`` is not such a caller or names a function
    ``functions`` lacks."""
    head = _DEF.match(text)
    if head is None or '"""' not in text:
        return None
    close = text.rindex('"""') + 3
    try:
        doc = ast.literal_eval(text[head.end():close].strip())
    except (SyntaxError, ValueError):
        return None
    lines = text[close:].strip("\n").split("\n")
    if head.group("last") == "xdot":
        calls = _raw_calls(lines)
        make = _raw_caller
    else:
        calls = _calls(lines)
        make = _caller
    if calls is None or not all(call[0] in functions for call in calls):
        return None
    bound = tuple((functions[call[0]], *call[1:]) for call in calls)
    caller = make(bound)
    name = head.group("name")
    caller.__code__ = caller.__code__.replace(co_filename=where, co_name=name, co_firstlineno=first_line)
    caller.__name__ = caller.__qualname__ = name
    caller.__doc__ = doc if isinstance(doc, str) else None
    return caller


def _calls(lines: list) -> list | None:
    """``[(name, start, end)]`` of the call lines of a caller on ``out``, the slices following each other
    from 0, then ``return out``; ``None`` if the lines are anything else."""
    if not lines or lines[-1] != "    return out":
        return None
    calls, at = [], 0
    for line in lines[:-1]:
        call = _CALL.fullmatch(line)
        if call is None or int(call.group("start")) != at or int(call.group("end")) < at:
            return None
        at = int(call.group("end"))
        calls.append((call.group("name"), int(call.group("start")), at))
    return calls


def _raw_calls(lines: list) -> list | None:
    """``[(name,)]`` of the functions a raw caller's one line ``return f(x, t, p, u, xdot) + …`` (or
    ``return []``) calls; ``None`` if the lines are anything else."""
    if len(lines) != 1 or not lines[0].startswith("    return "):
        return None
    body = lines[0][len("    return "):]
    if body == "[]":
        return []
    calls = []
    for part in body.split(" + "):
        call = _RAW_CALL.fullmatch(part)
        if call is None:
            return None
        calls.append((call.group("name"),))
    return calls


def _caller(calls: tuple):
    def caller(x, t, p, u, out):
        for function, start, end in calls:
            function(x, t, p, u, out[start:end])
        return out

    return caller


def _raw_caller(calls: tuple):
    def caller(x, t, p, u, xdot):
        values: list = []
        for (function,) in calls:
            values += function(x, t, p, u, xdot)
        return values

    return caller
