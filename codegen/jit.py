"""Loading generated numba code (optional extra ``fast``): modules written to
the cache directory and imported from there, so numba's own on-disk cache
applies, and that cache made unable to fail a run.

A caller generates, per mode of a model, one function of a fixed C signature
from the mode's symbolic equations; the compiled kernel that calls them is
the caller's own, compiled once per installation.  This module supplies what
generated numba code needs: the source of a guard decision
(:func:`tree_expression`), :func:`load_module` and :func:`guard_cache`; the
numba backend of :mod:`codegen.backends` compiles through them.

A module is written to the cache directory (``jit/`` in it) and imported from
there, so numba's own on-disk cache applies: a second process loads machine
code instead of compiling it.  That cache cannot fail a run: unreadable
``.nbi``/``.nbc`` files are deleted and the functions compiled again
(:func:`guard_cache`), and a cache directory that cannot be written sends the
module to a private temporary directory (compiled in every process), each
with a :class:`codegen.cache.CacheWarning`.  The size cap and
least-recently-used eviction of :mod:`codegen.cache` cover these files too.
"""

from __future__ import annotations

import atexit
import functools
import importlib.util
import os
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

from . import numba_internals
from .cache import CacheWarning, warn_not_writable, write_atomically
from .decision import OPS
from .safety import PYTHON, Dialect, compile_checked

__all__ = ["available", "guard_cache", "load_module", "tree_expression"]



@functools.cache
def available() -> bool:
    """Is numba installed (``pip install .[fast]``)?"""
    return importlib.util.find_spec("numba") is not None


def tree_expression(tree, finite: str, impulse: str | None = None, offset: int = 0, scale: str | None = None) -> str:
    """Source deciding a guard tree: ``("const", truth)``, ``("and"|"or", [trees])``,
    ``("not", tree)`` or a comparison ``(kind, k, op, text)`` of comparison
    number ``k`` and operator ``op`` (``<``, ``<=``, ``>``, ``>=``, ``==``, ``!=``),
    decided by the functions ``_dec`` and ``_larger`` the generated module imports.

    Comparison ``k`` reads its left/right finite parts and round-off scale
    from ``finite[3k], finite[3k+1], finite[3k+2]`` and, when ``impulse``
    names an array, the sides' impulse areas from ``impulse[offset + 2k],
    impulse[offset + 2k + 1]``; with ``scale`` naming another array of triples,
    the larger of the two scales counts (a priori and a posteriori)."""
    kind = tree[0]
    if kind == "const":
        return "True" if tree[1] else "False"
    if kind in ("and", "or"):
        return "(" + f" {kind} ".join(tree_expression(t, finite, impulse, offset, scale) for t in tree[1]) + ")"
    if kind == "not":
        return f"(not {tree_expression(tree[1], finite, impulse, offset, scale)})"
    _, k, op, _text = tree
    a, b, c = 3 * k, 3 * k + 1, 3 * k + 2
    if impulse is None:
        ia = ib = "0.0"
    else:
        ia, ib = f"{impulse}[{offset + 2 * k}]", f"{impulse}[{offset + 2 * k + 1}]"
    sc = f"{finite}[{c}]" if scale is None else f"_larger({finite}[{c}], {scale}[{c}])"
    return f"_dec({OPS[op]}, {ia}, {finite}[{a}], {ib}, {finite}[{b}], {sc}, rtol, atol)"


_private: Path | None = None  # this process's own directory for kernels (no usable cache directory)
_rebuilt: set = set()  # modules whose unreadable numba cache files were deleted (warned once each)


def _private_directory() -> Path:
    """A directory of this process alone (mode 0700), removed at exit: compiled
    kernels live there when there is no usable cache directory, so nothing of
    another user's (a planted module or pickle) is ever loaded."""
    global _private
    if _private is None:
        _private = Path(tempfile.mkdtemp(prefix="hbg-jit-"))
        atexit.register(shutil.rmtree, _private, ignore_errors=True)
    return _private


def _unwritable(directory: Path) -> OSError | None:
    """Why ``directory`` or its ``__pycache__`` (numba's cache files) cannot
    be written, or ``None``."""
    try:
        for where in (directory, directory / "__pycache__"):
            where.mkdir(parents=True, exist_ok=True)
            fd, probe = tempfile.mkstemp(dir=where, prefix=".probe.", suffix=".tmp")
            os.close(fd)
            os.unlink(probe)
    except OSError as exc:
        return exc
    return None


def _guard_cache(module_name: str, dispatcher) -> None:
    """Make numba's disk cache of ``dispatcher`` unable to fail a run: a cache
    entry that cannot be read (corrupted or truncated ``.nbi``/``.nbc``
    files: ``UnpicklingError``, ``EOFError``, …) is deleted and the function
    compiled again; a cache entry that cannot be written is skipped.  Either
    gives one :class:`codegen.cache.CacheWarning` per module."""
    cache = numba_internals.disk_cache(dispatcher)
    if cache is None:
        return
    save = cache.save_overload

    def load_overload(sig, target_context):
        try:
            return numba_internals.load_cached(cache, sig, target_context)
        except Exception as exc:
            files = numba_internals.cache_files(cache)
            for path in files:
                try:
                    os.unlink(path)
                except OSError:
                    pass
            if module_name not in _rebuilt:
                _rebuilt.add(module_name)
                where = os.path.dirname(files[0]) if files else numba_internals.cache_directory(cache)
                warnings.warn(f"numba's cache files of compiled kernel {module_name} in {where} could not be read "
                              f"({type(exc).__name__}: {exc}); deleted them and compiling again",
                              CacheWarning, stacklevel=2)
            return None

    def save_overload(sig, data):
        try:
            save(sig, data)
        except Exception as exc:
            key = (module_name, "save")
            if key not in _rebuilt:
                _rebuilt.add(key)
                warnings.warn(f"numba's cache of compiled kernel {module_name} could not be written "
                              f"({type(exc).__name__}: {exc}); it is compiled again in the next process",
                              CacheWarning, stacklevel=2)

    cache.load_overload = load_overload
    cache.save_overload = save_overload


def _import(name: str, source: str, directory: Path, dialect: Dialect):
    """Write ``source`` to ``directory/name.py`` (unless it is there already)
    and execute it as module ``name``, its numba caches guarded.  The code
    is compiled from ``source`` itself, so no ``.pyc`` is written or read."""
    path = directory / f"{name}.py"
    code = compile_checked(source, str(path), dialect)  # (nothing of it has run: refused here if it is not ours)
    for attempt in range(3):
        try:
            current = path.read_text() if path.exists() else None
        except (OSError, UnicodeDecodeError):
            current = None
        if current != source:
            write_atomically(path, source)
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            exec(code, module.__dict__)  # checked above: only what the generator writes
        except (OSError, RuntimeError):
            # the file vanished (another process evicted it) before numba saw it: write it again
            del sys.modules[name]
            if attempt == 2:
                raise
            continue
        except BaseException:
            del sys.modules[name]
            raise
        for value in list(vars(module).values()):
            if numba_internals.is_dispatcher(value):
                _guard_cache(name, value)
        return module


guard_cache = _guard_cache


def load_module(name: str, source: str, directory: str | os.PathLike | None, dialect: Dialect = PYTHON):
    """Write ``source`` as module ``name`` under ``directory`` and import it;
    numba's ``cache=True`` then keeps the machine code in
    ``directory/__pycache__`` (``name.*.nbi``/``.nbc``), which later processes
    load instead of compiling.  Unreadable cache files are deleted and the
    functions compiled again (see :func:`_guard_cache`).

    With ``directory`` ``None`` (``HBG_CACHE_DIR=off``), or not writable (a
    :class:`codegen.cache.CacheWarning` names it), the module goes to a
    private temporary directory of this process, removed at exit: it works,
    but is compiled again by every process — unless the read-only directory
    holds its machine code already, which is then copied and loaded.

    ``source`` is checked first (:func:`codegen.safety.check_code`, in its
    ``dialect``) and refused with a :class:`~codegen.safety.GeneratedCodeError`
    if it holds anything else."""
    if not available():
        raise ImportError("the compiled methods need numba: pip install '.[fast]' (or pip install numba)")
    if name in sys.modules:
        return sys.modules[name]
    if directory is not None:
        directory = Path(directory)
        error = _unwritable(directory)
        if error is None:
            try:
                return _import(name, source, directory, dialect)
            except OSError as exc:  # e.g. the disk is full
                error = exc
        warn_not_writable(directory, error)
        return _import(name, source, _adopt(name, source, directory, _private_directory()), dialect)
    return _import(name, source, _private_directory(), dialect)


def _adopt(name: str, source: str, directory: Path, private: Path) -> Path:
    """Copy module ``name`` and numba's cache files of it from the read-only
    ``directory`` into ``private`` (times kept, so numba's source stamp still
    matches): a read-only cache still spares the compilation."""
    try:
        if (directory / f"{name}.py").read_text() != source:
            return private
        (private / "__pycache__").mkdir(exist_ok=True)
        shutil.copy2(directory / f"{name}.py", private / f"{name}.py")
        with os.scandir(directory / "__pycache__") as listing:
            for item in listing:
                if item.name.startswith(name + ".") and item.name.endswith((".nbi", ".nbc")):
                    shutil.copy2(item.path, private / "__pycache__" / item.name)
    except (OSError, UnicodeDecodeError):
        pass  # nothing (more) to adopt: compiled again
    return private
