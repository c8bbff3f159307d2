"""The parts of numba that are not its public interface, in one place.

The native backend (:mod:`codegen.native`) hands LLVM IR to numba's own code
generator (the CPU target's codegen: its target machine, optimisation passes
and symbol resolution), keeps a library's object code and loads it again;
the numba backend builds a ``CFunc`` whose disk cache is guarded before it
compiles; :mod:`codegen.jit` reads the file names of numba's disk cache.  None
of that is public numba, so it may change in any numba release: everything
of it is reached through this module only.

:func:`native_unsupported` says whether this numba is one the code was
written for (:data:`KNOWN_VERSIONS`) and has every internal the native
backend calls; when it is not, the native backend reports itself unavailable
with that reason and numba's front end compiles instead (slower to compile,
the same results) — never a crash.  The numba backend needs only
:func:`make_cfunc`, which falls back to the public ``numba.cfunc``.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import pickle

__all__ = ["KNOWN_VERSIONS", "cache_directory", "cache_files", "cached_signatures", "compile_library",
           "compiler_lock", "disk_cache", "host_cpu", "is_dispatcher", "load_cached", "load_library",
           "make_cfunc", "native_unsupported", "serialize_library"]

#: the numba releases (major, minor) whose internals this module was written and tested for
KNOWN_VERSIONS = tuple((0, minor) for minor in range(58, 69))

# (module, attribute path) of every internal the native backend calls
_NATIVE_INTERNALS = (
    ("numba.core.registry", "cpu_target.target_context.codegen"),
    ("numba.core.compiler_lock", "global_compiler_lock"),
)
_LIBRARY_METHODS = ("create_library", "unserialize_library")


def _version() -> tuple[int, int] | None:
    import numba

    try:
        major, minor = numba.__version__.split(".")[:2]
        return int(major), int(minor)
    except ValueError:
        return None


def _resolve(module: str, path: str):
    value = importlib.import_module(module)
    for name in path.split("."):
        value = getattr(value, name)
    return value


@functools.cache
def native_unsupported() -> str | None:
    """Why numba's internals cannot be used here (no numba, an unknown
    version, a missing internal), or ``None`` when they can."""
    if importlib.util.find_spec("numba") is None:
        return "numba is not installed"
    import numba

    version = _version()
    if version not in KNOWN_VERSIONS:
        known = ", ".join(f"{a}.{b}" for a, b in (KNOWN_VERSIONS[0], KNOWN_VERSIONS[-1]))
        return (f"numba {numba.__version__} is not a version whose internals the native backend was written for "
                f"({known.replace(', ', ' to ')})")
    for module, path in _NATIVE_INTERNALS:
        try:
            _resolve(module, path)
        except (ImportError, AttributeError):
            return f"numba {numba.__version__} has no {module}.{path}"
    generator = _codegen()
    for method in _LIBRARY_METHODS:
        if not callable(getattr(generator, method, None)):
            return f"numba {numba.__version__}'s code generator has no {method}"
    return None


def _codegen():
    return _resolve("numba.core.registry", "cpu_target.target_context.codegen")()


def compiler_lock():
    """numba's global compiler lock (a context manager): LLVM is not re-entrant."""
    return _resolve("numba.core.compiler_lock", "global_compiler_lock")


def host_cpu() -> tuple[str, str]:
    """The CPU name and features numba compiles for (``NUMBA_CPU_NAME`` /
    ``NUMBA_CPU_FEATURES`` may override the host's)."""
    generator = _codegen()
    try:
        return generator._get_host_cpu_name(), generator._get_host_cpu_features()
    except AttributeError:  # another numba version: the host's own
        from llvmlite import binding

        return binding.get_host_cpu_name(), binding.get_host_cpu_features().flatten()


def compile_library(name: str, module):
    """A finalised code library of LLVM IR ``module`` (object caching on, so
    :func:`serialize_library` can keep it).  Call under :func:`compiler_lock`."""
    library = _codegen().create_library(name)
    library.enable_object_caching()
    library.add_ir_module(module)
    library.finalize()
    return library


def serialize_library(library) -> tuple[bytes, bytes]:
    """``(object code, bitcode)`` of a library made by :func:`compile_library`."""
    _, _kind, (object_code, bitcode) = library.serialize_using_object_code()
    return bytes(object_code), bytes(bitcode)


def load_library(name: str, object_code: bytes, bitcode: bytes):
    """The library :func:`serialize_library` gave, loaded (no compilation).  Call under :func:`compiler_lock`."""
    return _codegen().unserialize_library((name, "object", (object_code, bitcode)))


def make_cfunc(function, argument_types: tuple, result_type, guard=None):
    """``function`` compiled by numba as a C callback of the given numba
    types (``error_model="numpy"``), kept in numba's disk cache; ``guard``
    (the disk-cache guard of :mod:`codegen.jit`) sees it before it compiles,
    so an unreadable cache file is rebuilt, not raised."""
    try:
        from numba.core.ccallback import CFunc
    except ImportError:  # another numba version: the public decorator (its cache unguarded)
        import numba

        return numba.cfunc(result_type(*argument_types), cache=True, error_model="numpy")(function)
    compiled = CFunc(function, (argument_types, result_type), locals={}, options={"error_model": "numpy"})
    compiled.enable_caching()
    if guard is not None:
        guard(compiled)
    compiled.compile()
    return compiled


def is_dispatcher(value) -> bool:
    """Is ``value`` a numba dispatcher (an ``@njit`` function)?"""
    from numba.core.dispatcher import Dispatcher

    return isinstance(value, Dispatcher)


def disk_cache(compiled):
    """The disk cache object of a dispatcher or ``CFunc`` (with its
    ``load_overload``/``save_overload``), or ``None``."""
    cache = getattr(compiled, "_cache", None)
    if cache is None or not hasattr(cache, "load_overload") or not hasattr(cache, "save_overload"):
        return None
    return cache


def load_cached(cache, signature, target_context):
    """``cache.load_overload(signature, target_context)`` (numba's disk cache ``cache``: the compiled result, or
    ``None``) without the refresh of ``target_context`` numba makes first: its lowering and typing registries
    (numba's modules of implementations, imported and installed: 0.2–0.3 s, the most of a process's first
    use of numba) serve compilation only, and numba's compiler refreshes the contexts itself before it
    compiles; machine code loaded from the cache needs numba's runtime (NRT) and its helpers' symbols, which
    this initialises.  Another numba version (no such internals): numba's own load."""
    load = getattr(cache, "_load_overload", None)
    guard = getattr(cache, "_guard_against_spurious_io_errors", None)
    try:
        from numba.core.runtime import rtsys
    except ImportError:
        rtsys = None
    if load is None or guard is None or rtsys is None or not callable(getattr(rtsys, "initialize", None)):
        return cache.load_overload(signature, target_context)
    rtsys.initialize(target_context)
    with guard():
        return load(signature, target_context)
    return None  # (the guard swallowed an error: not found)


def cache_files(cache) -> list:
    """The index and data files of one function in numba's disk cache ``cache``."""
    try:
        folder = cache._cache_path
        base = cache._cache_file._index_name[: -len(".nbi")]
    except AttributeError:  # another numba version: all files of the function's module
        folder = getattr(cache, "_cache_path", None)
        base = getattr(cache._py_func, "__module__", None) if hasattr(cache, "_py_func") else None
        if not folder or not base:
            return []
    try:
        names = os.listdir(folder)
    except OSError:
        return []
    return [os.path.join(folder, n) for n in names if n.startswith(base + ".") and n.endswith((".nbi", ".nbc"))]


def cache_directory(cache) -> str:
    """The directory of numba's disk cache ``cache`` (for messages)."""
    return getattr(cache, "_cache_path", None) or "numba's cache"


def cached_signatures(dispatcher) -> list:
    """The signatures (tuples of numba types) of ``dispatcher``'s machine
    code in numba's disk cache index; empty when there is none or it
    cannot be read."""
    cache = getattr(dispatcher, "_cache", None)
    try:
        return [key[0] for key in cache._cache_file._load_index()]
    except (AttributeError, TypeError, ValueError, OSError, EOFError, pickle.UnpicklingError):
        return []  # (an unreadable index, another numba version: nothing known to be cached)
