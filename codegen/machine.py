"""Machine code of a generated function, through the backends in their order, with caches.

:func:`machine_function` gives the compiled function of a source (see
:mod:`codegen.backends`): for each backend of :func:`~codegen.backends.machine_code_backends` in
turn: from this process's memory (:data:`LOADED`: a symbol is defined once
per backend and process), else its kept machine
code in the cache directory (``<symbol><suffix>``, e.g. ``.native``), else
compiled now and kept there.  A backend that refuses the source
(:class:`codegen.native.Untranslatable`) hands it to the next silently; a
fault of a backend's translator hands it on with a ``RuntimeWarning`` (the
next compiles the same results, slower).  Kept machine code that cannot be
read is deleted and compiled again, with a :class:`codegen.cache.CacheWarning`;
a directory that cannot be written costs speed only.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

from .backends import NATIVE_ENVIRONMENT, Backend, CompiledFunction, Signature, machine_code_backends
from .cache import CacheWarning, warn_not_writable, write_atomically
from .native import Untranslatable
from .safety import PYTHON, Dialect, GeneratedCodeError

__all__ = ["LOADED", "is_compiled", "machine_function"]

#: this process's compiled functions by (backend name, symbol): a symbol is defined once per backend
LOADED: dict[tuple, CompiledFunction] = {}


def _write(path: Path, data: bytes) -> None:
    """``data`` into ``path`` by a temporary file moved into place (a reader
    sees the old file, the new one or none).  Raises ``OSError``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomically(path, data)


def _kept(backend: Backend, path: Path, symbol: str, signature: Signature, describe: str) -> CompiledFunction | None:
    """The machine code kept in ``path``, or ``None`` (none, another machine's, or damaged: then deleted)."""
    try:
        return backend.load(path.read_bytes(), symbol, signature)
    except FileNotFoundError:
        return None
    except Exception as exc:  # unreadable, damaged (CorruptFile), or machine code LLVM refuses to load
        warnings.warn(f"machine code of {describe} could not be read ({path}: {exc}); deleted it and compiling again",
                      CacheWarning, stacklevel=5)
        try:
            os.unlink(path)
        except OSError:
            pass
        return None


def _compiled(backend: Backend, last: bool, source: str, function_name: str, signature: Signature, symbol: str,
              options: dict, describe: str) -> CompiledFunction | None:
    """``backend``'s compilation, or ``None`` when it refuses the source or
    fails (with a warning) and is not the ``last`` backend to try."""
    try:
        return backend.compile(source, function_name, signature, symbol=symbol, **options)
    except Untranslatable:
        if last:
            raise
        return None
    except GeneratedCodeError:
        raise
    except Exception as exc:
        if last:
            raise  # the last resort's own errors are its caller's
        warnings.warn(f"translating {describe} to machine code failed ({type(exc).__name__}: {exc}); numba "
                      f"compiles it instead (slower to compile, the same results). Set {NATIVE_ENVIRONMENT}=0 to "
                      f"always use numba, and please report this.", RuntimeWarning, stacklevel=5)
        return None


def machine_function(source: str, function_name: str, signature: Signature, symbol: str, *,
                     dialect: Dialect = PYTHON, calls=(), directory: str | os.PathLike | None = None,
                     describe: str = "a generated function") -> CompiledFunction:
    """The machine code of function ``function_name`` of module ``source``
    as C symbol ``symbol`` (unique to the source: it keys the caches) of
    ``signature``; ``calls`` the functions the source may call (see
    :meth:`codegen.backends.Backend.compile`); ``directory`` the cache
    directory (``None``: none); ``describe`` names the function in warnings.
    Raises :class:`~codegen.safety.GeneratedCodeError` for a source the
    generator never writes, ``ImportError`` without numba, and the last
    backend's (numba's) errors."""
    directory = Path(directory) if directory is not None else None
    backends = machine_code_backends()
    if not backends:
        raise ImportError("the compiled methods need numba: pip install '.[fast]' (or pip install numba)")
    options = {"dialect": dialect, "calls": calls, "directory": directory}
    for backend in backends:
        if (backend.name, symbol) in LOADED:
            return LOADED[backend.name, symbol]
        path = directory / (symbol + backend.file_suffix) if directory is not None and backend.file_suffix else None
        function = _kept(backend, path, symbol, signature, describe) if path is not None else None
        if function is None:
            function = _compiled(backend, backend is backends[-1], source, function_name, signature, symbol, options,
                                 describe)
            if function is None:
                continue
            if path is not None:
                data = function.serialise()
                try:
                    if data is not None:
                        _write(path, data)
                except OSError as exc:
                    warn_not_writable(path.parent, exc, stacklevel=4)
        LOADED[backend.name, symbol] = function
        return function
    raise AssertionError("the last backend neither compiled nor raised")  # (numba compiles or raises)


def is_compiled(symbol: str, directory: str | os.PathLike | None) -> bool:
    """Is the function ``symbol`` loaded in this process, or machine code of
    it (for this machine) in ``directory`` for a backend that would be tried?"""
    if any(name == symbol for _, name in LOADED):
        return True
    if directory is None:
        return False
    return any(backend.cached(Path(directory), symbol) for backend in machine_code_backends())
