"""The check every generated module passes before it runs.

Generated source is built from a model's names and expressions, and a model
may come from a stranger's file.  Names reach the source only as sanitized
identifiers, and other text (names, descriptions, units, labels) only through
:func:`codegen.source.docstring` or ``repr``; this module is the second line
of defence, so that a future escaping mistake fails closed.

The source is compiled (which runs nothing) and every code object in it —
the module's, each function's, anything nested — is checked before the
module runs:

* every name it reads or writes as a global, an attribute or an import is on
  an allow-list: the math functions and the few builtins of arithmetic
  (:data:`SAFE_BUILTINS`), the names of the generated module's namespace
  (``H`` and its functions, ``np``, ``carray``... as its dialect allows:
  :class:`Dialect`), an array's ``shape``/``size``/``ndim``, and the
  functions and ``META``/``RECORD`` the module itself defines.  So no
  ``open``, ``exec``, ``getattr``, ``__import__``, ``np.save``, no attribute
  with a leading ``_`` (``__class__``, ``__globals__``), no import but those
  of the dialect;
* no operation the generator never writes: imports inside a function,
  classes, ``with``, ``del``, ``global`` stores, attribute stores,
  ``yield``/``await``, and (except in the compiled dialect's
  ``for k in range(...)`` and in the iteration of a numeric inverse, a
  function named ``_inverse_law_…``: :mod:`codegen.inverse`) no loop.

The check reads the compiled code's own tables (names, opcodes): it costs a
small fraction of the compilation, whatever the size of the module (a
200-contact scene's modes are ~170 kB of source each).
:func:`execute` compiles, checks and runs a module in a namespace: the one way
generated code runs.
"""

from __future__ import annotations

import dis
import functools
import hashlib
import importlib
import math
import types
from dataclasses import dataclass

from bondgraph.errors import HybridBondGraphError

__all__ = ["ARRAY_ATTRIBUTES", "Dialect", "GeneratedCodeError", "PYTHON", "SAFE_BUILTINS", "check_code",
           "check_source", "compile_checked", "execute"]


class GeneratedCodeError(HybridBondGraphError):
    """A generated module holds something the code generator never writes (a
    name such as ``open`` or ``__class__``, an import, a loop...).  It is not
    run.  ``where`` names the module, ``line`` the line (0 when unknown)."""

    def __init__(self, message: str, where: str = "", line: int = 0):
        super().__init__(message)
        self.where = where
        self.line = line


#: builtins generated code may name: arithmetic and conversions, nothing that reaches files,
#: objects' internals or the interpreter
SAFE_BUILTINS = frozenset({"abs", "max", "min", "float", "int", "bool", "round", "range", "len", "pow", "divmod"})

#: attributes of arrays generated code may read
ARRAY_ATTRIBUTES = frozenset({"shape", "size", "ndim"})

#: module-level names every generated module may define
_DEFINED = frozenset({"META", "RECORD", "__doc__"})

_MATH = frozenset(name for name in dir(math) if not name.startswith("_"))


@dataclass(frozen=True)
class Dialect:
    """What a kind of generated module may hold besides arithmetic: the
    ``imports`` it runs at module level, as ``(module, name, asname)``
    triples (``name`` ``None`` for ``import module``, ``"*"`` for ``from
    module import *``), and whether ``for k in range(...)`` loops occur."""

    imports: tuple = ()
    loops: bool = False

    @functools.cached_property
    def names(self) -> frozenset:
        """Every global or attribute name code of this dialect may use."""
        names = set(SAFE_BUILTINS | ARRAY_ATTRIBUTES | _MATH | _namespace_names())
        for module, name, asname in self.imports:
            names |= {module, module.split(".")[0]}
            if name == "*":
                names |= {n for n in dir(importlib.import_module(module)) if not n.startswith("_")}
            else:
                names |= {n for n in (name, asname) if n}
        return frozenset(names)


#: the dialect of the Python per-mode, signal and derivative modules (no imports, no loops)
PYTHON = Dialect()


@functools.cache
def _namespace_names() -> frozenset:
    """The names of :func:`codegen.source.module_namespace` and the functions of ``H``."""
    from .runtime import H
    from .source import module_namespace

    return frozenset(module_namespace()) | frozenset(n for n in dir(H) if not n.startswith("_"))


def _opcodes(*names) -> frozenset:
    return frozenset(dis.opmap[name] for name in names if name in dis.opmap)


_IMPORTS = _opcodes("IMPORT_NAME", "IMPORT_FROM", "IMPORT_STAR")
_NEVER = _opcodes("LOAD_BUILD_CLASS", "SETUP_WITH", "BEFORE_WITH", "BEFORE_ASYNC_WITH", "SETUP_ASYNC_WITH",
                  "YIELD_VALUE", "YIELD_FROM", "GET_AWAITABLE", "GET_AITER", "GET_ANEXT", "DELETE_NAME",
                  "DELETE_GLOBAL", "DELETE_ATTR", "DELETE_FAST", "DELETE_DEREF", "STORE_GLOBAL", "STORE_ATTR",
                  "RETURN_GENERATOR", "SEND")
_LOOPS = _opcodes("JUMP_BACKWARD", "JUMP_BACKWARD_NO_INTERRUPT", "POP_JUMP_BACKWARD_IF_TRUE",
                  "POP_JUMP_BACKWARD_IF_FALSE", "POP_JUMP_BACKWARD_IF_NONE", "POP_JUMP_BACKWARD_IF_NOT_NONE",
                  "JUMP_ABSOLUTE", "FOR_ITER")


def _refuse(where: str, code, what: str) -> GeneratedCodeError:
    line = code.co_firstlineno
    return GeneratedCodeError(
        f"generated module {where} holds {what} (in {code.co_name!r}, from line {line}), which the code generator "
        "never writes; it is not run. If the module came from the disk cache, the entry was altered: it is "
        "discarded and built again. Otherwise this is a bug of the code generator: please report it with the "
        "model.", where, line)


def check_code(code: types.CodeType, where: str = "<generated>", dialect: Dialect = PYTHON,
               also: frozenset = frozenset()) -> None:
    """Check the compiled module ``code`` and every code object in it (see
    the module docstring); ``also``: further names it may use (functions of
    the same generated module compiled apart).  Raises
    :class:`GeneratedCodeError` naming the function, its first line and what was found."""
    defined = _DEFINED | {c.co_name for c in code.co_consts if isinstance(c, types.CodeType)}
    allowed = dialect.names | defined | also
    stack = [(code, True)]
    while stack:
        current, module_level = stack.pop()
        unknown = [n for n in current.co_names if n not in allowed or (n.startswith("__") and n != "__doc__")]
        if unknown:
            raise _refuse(where, current, f"the name(s) {', '.join(map(repr, sorted(set(unknown))))}")
        operations = frozenset(current.co_code[::2])
        found = operations & (_NEVER | (frozenset() if module_level and dialect.imports else _IMPORTS))
        if found:
            raise _refuse(where, current, "the operation(s) " + ", ".join(sorted(dis.opname[op] for op in found)))
        if not dialect.loops and operations & _LOOPS and (module_level or not _may_loop(current)):
            raise _refuse(where, current, "a loop")
        stack.extend((c, False) for c in current.co_consts if isinstance(c, types.CodeType))


def _may_loop(code: types.CodeType) -> bool:
    """Is ``code`` the iteration of a numeric inverse (:mod:`codegen.inverse`), the one
    generated function with loops in a dialect without them?  Its name starts with
    :data:`codegen.inverse.HELPER_PREFIX`, which no sanitized user name does; its names are
    checked as any other's."""
    from .inverse import HELPER_PREFIX

    return code.co_name.startswith(HELPER_PREFIX)


#: digests of the (source, dialect) pairs that passed, so that a source is compiled for the check once per process
_PASSED: set = set()
_PASSED_MAX = 100_000


def _compiled(source: str, where: str, first_line: int = 1) -> types.CodeType:
    """``source`` compiled (nothing runs), or a :class:`GeneratedCodeError`."""
    try:
        return compile("\n" * (first_line - 1) + source, where, "exec")
    except (SyntaxError, ValueError) as exc:  # (ValueError: a NUL byte)
        line = getattr(exc, "lineno", 0) or 0
        raise GeneratedCodeError(
            f"generated module {where} does not compile (line {line}: {exc}); it is not run. If it came from the "
            "disk cache, the entry is discarded and built again; otherwise please report it with the model.",
            where, line) from None


def check_source(source: str, where: str = "<generated>", dialect: Dialect = PYTHON,
                 also: frozenset = frozenset()) -> None:
    """Compile ``source`` and check it (:func:`check_code`; ``also`` as there); a source that
    passed with the same dialect is not compiled again for the check."""
    digest = hashlib.blake2b(source.encode("utf-8", "surrogatepass"), digest_size=20).digest() + \
        repr(dialect).encode() + repr(sorted(also)).encode()
    if digest in _PASSED:
        return
    check_code(_compiled(source, where), where, dialect, also)
    if len(_PASSED) >= _PASSED_MAX:
        _PASSED.clear()
    _PASSED.add(digest)


def compile_checked(source: str, where: str = "<generated>", dialect: Dialect = PYTHON, first_line: int = 1,
                    also: frozenset = frozenset()) -> types.CodeType:
    """``source`` compiled (``where`` its file name, its line numbers starting
    at ``first_line``) and checked (:func:`check_code`): code that may run."""
    code = _compiled(source, where, first_line)
    check_code(code, where, dialect, also)
    return code


def execute(source: str, namespace: dict, where: str = "<generated>", dialect: Dialect = PYTHON,
            first_line: int = 1, also: frozenset = frozenset()) -> dict:
    """Compile and check ``source`` (:func:`compile_checked`), then run it in
    ``namespace``; returns the namespace."""
    exec(compile_checked(source, where, dialect, first_line, also), namespace)  # checked: only what we write
    return namespace
