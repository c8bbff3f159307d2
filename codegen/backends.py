"""One contract for the backends that turn a generated function into something to call.

A generated function is the source of a module (only what the code
generator writes, checked in its :class:`~codegen.safety.Dialect`) and the
name of one function in it, with a C :class:`Signature`.  A :class:`Backend`
compiles it into a :class:`CompiledFunction`:

* ``"python"``: the module executed; a Python callable, no machine code;
* ``"numba"``: numba's front end (a ``cfunc``; 0.3–3 s a function): machine
  code at :attr:`CompiledFunction.address`, kept by numba itself in its cache
  files beside the module (``directory/__pycache__``);
* ``"native"``: :mod:`codegen.native` translates the source to LLVM IR and
  numba's code generator compiles it (tens of milliseconds): machine code at
  :attr:`CompiledFunction.address`, kept by :meth:`CompiledFunction.serialise`
  as bytes that :meth:`Backend.load` loads in another process of the same
  machine (:func:`codegen.native.machine_key`).

Every backend answers :meth:`Backend.available` (with its reason in
:meth:`Backend.unavailable`) and :meth:`Backend.compile`; :data:`BACKENDS`
holds one of each by name.  :func:`machine_code_backends` is the order in
which machine code is tried: ``native`` first when it is available and the
environment variable ``HBG_NATIVE`` does not turn it off (``0``, ``off``,
``no``, ``false``), then ``numba``, whose front end compiles whatever the
translator refuses.  :func:`codegen.machine.machine_function` follows that
order with the in-memory and on-disk caches.
"""

from __future__ import annotations

import abc
import ctypes
import os
from dataclasses import dataclass
from pathlib import Path

from . import numba_internals
from .safety import PYTHON, Dialect, execute

__all__ = ["BACKENDS", "NATIVE_ENVIRONMENT", "Backend", "CompiledFunction", "Signature", "machine_code_backends",
           "native_enabled"]

NATIVE_ENVIRONMENT = "HBG_NATIVE"  # "0": no native backend; numba's front end compiles instead


def native_enabled() -> bool:
    """Does the environment let the native backend compile (``HBG_NATIVE`` unset or not ``0``/``off``/…)?"""
    return os.environ.get(NATIVE_ENVIRONMENT, "1").strip().lower() not in ("0", "off", "no", "false")


HEAD_BYTES = 65536  # what :meth:`Backend.cached` reads of a kept form: its header, whole

_C_TYPES = {"f": ctypes.c_double, "i": ctypes.c_int64, "u": ctypes.c_uint8}


@dataclass(frozen=True)
class Signature:
    """The C signature of a compiled function: each argument's kind (``"f"``
    float64, ``"i"`` int64, ``("ptr", "f"|"i"|"u")`` a pointer to
    float64/int64/uint8 data) and the result's kind (``"f"`` or ``"i"``)."""

    arguments: tuple
    result: str

    def c_prototype(self):
        """The ctypes function type of this signature."""
        arguments = [ctypes.POINTER(_C_TYPES[k[1]]) if isinstance(k, tuple) else _C_TYPES[k]
                     for k in self.arguments]
        return ctypes.CFUNCTYPE(_C_TYPES[self.result], *arguments)

    def numba_types(self) -> tuple:
        """``(argument types, result type)`` in numba's types."""
        from numba import types

        scalar = {"f": types.float64, "i": types.int64, "u": types.uint8}
        arguments = tuple(types.CPointer(scalar[k[1]]) if isinstance(k, tuple) else scalar[k] for k in self.arguments)
        return arguments, scalar[self.result]


class CompiledFunction:
    """What a backend made of one generated function.

    :attr:`backend` names the backend; :attr:`name` is the function's symbol;
    :attr:`address` the address of its machine code (an ``int``; ``None``
    for the Python backend), valid while this object lives; :attr:`function`
    something Python can call (the function itself, or a ctypes wrapper of
    the machine code); :attr:`origin` is ``"compiled"`` (in this process) or
    ``"loaded"`` (from a serialised form); :attr:`handle` the backend's own
    object (a :class:`codegen.native.NativeFunction`, a numba ``CFunc``, the
    module's namespace), kept alive with this one.  :meth:`serialise` gives the bytes
    :meth:`Backend.load` takes in another process, or ``None`` when the
    backend keeps its own cache (numba)."""

    def __init__(self, backend: str, name: str, handle, *, address: int | None = None, function=None,
                 signature: Signature | None = None, origin: str = "compiled", serialiser=None):
        self.backend, self.name, self.handle, self.origin = backend, name, handle, origin
        self.address, self.signature = address, signature
        self._function, self._serialiser = function, serialiser

    @property
    def function(self):
        if self._function is None and self.address is not None and self.signature is not None:
            self._function = self.signature.c_prototype()(self.address)
        return self._function

    def serialise(self) -> bytes | None:
        return self._serialiser() if self._serialiser is not None else None

    def __repr__(self) -> str:
        return f"<CompiledFunction {self.name} by {self.backend} ({self.origin})>"


class Backend(abc.ABC):
    """A way to compile a generated function (see the module).  Subclasses set
    :attr:`name`, :attr:`file_suffix` (their serialised form's file in a cache
    directory, or ``None`` when they keep none) and implement the methods."""

    name = ""
    file_suffix: str | None = None
    makes_machine_code = True

    def unavailable(self) -> str | None:
        """Why this backend cannot compile here, or ``None`` when it can."""
        return None

    def available(self) -> bool:
        return self.unavailable() is None

    @abc.abstractmethod
    def compile(self, source: str, function_name: str, signature: Signature, *, symbol: str,
                dialect: Dialect = PYTHON, calls=(), directory: str | os.PathLike | None = None) -> CompiledFunction:
        """Function ``function_name`` of module ``source`` compiled as C
        symbol ``symbol``.  ``calls`` are the functions the source may call
        besides math and numpy (a translating backend translates them too);
        ``directory`` is where a backend that keeps its own cache keeps it
        (``None``: nowhere).  Raises :class:`codegen.native.Untranslatable`
        (native: the source is outside what it translates) and
        :class:`~codegen.safety.GeneratedCodeError` (a source the generator
        never writes)."""

    def load(self, data: bytes, symbol: str, signature: Signature | None = None) -> CompiledFunction | None:
        """The function ``symbol`` (of ``signature``) that :meth:`CompiledFunction.serialise`
        gave as ``data``, or ``None`` when ``data`` is for another machine;
        raises :class:`codegen.native_file.CorruptFile` for damaged data."""
        return None

    def loads_here(self, head: bytes) -> bool:
        """Do the first bytes of a serialised form say it loads on this machine (not verified)?"""
        return False

    def cached(self, directory: Path, symbol: str) -> bool:
        """Does ``directory`` hold this backend's machine code of ``symbol`` for this machine?"""
        if self.file_suffix is None:
            return False
        try:
            with open(directory / (symbol + self.file_suffix), "rb") as handle:
                return self.loads_here(handle.read(HEAD_BYTES))
        except OSError:
            return False


class PythonBackend(Backend):
    """The module executed (its own imports run): a Python function, no machine code."""

    name = "python"
    file_suffix = None
    makes_machine_code = False

    def compile(self, source, function_name, signature, *, symbol, dialect=PYTHON, calls=(), directory=None):
        namespace = execute(source, {}, f"<{symbol}>", dialect)
        return CompiledFunction(self.name, symbol, namespace, function=namespace[function_name],
                                signature=signature)


class NumbaBackend(Backend):
    """numba's front end: the module written under ``directory`` and imported
    (:func:`codegen.jit.load_module`), its function compiled as a ``cfunc``
    kept in numba's own cache files there (guarded: an unreadable one is
    rebuilt).  A module already imported keeps its compiled function."""

    name = "numba"
    file_suffix = None

    def unavailable(self):
        from .jit import available

        return None if available() else "numba is not installed (pip install '.[fast]')"

    def compile(self, source, function_name, signature, *, symbol, dialect=PYTHON, calls=(), directory=None):
        from .jit import guard_cache, load_module

        module = load_module(symbol, source, directory, dialect)
        compiled = getattr(module, "compiled", None)
        if compiled is None:
            compiled = numba_internals.make_cfunc(getattr(module, function_name), *signature.numba_types(),
                                                  guard=lambda function: guard_cache(symbol, function))
            module.compiled = compiled
        return CompiledFunction(self.name, symbol, compiled, address=compiled.address, signature=signature)

    def cached(self, directory, symbol):
        try:
            return any(n.startswith(symbol + ".") and n.endswith(".nbi") for n in os.listdir(directory / "__pycache__"))
        except OSError:
            return False


class NativeBackend(Backend):
    """:mod:`codegen.native`: the source translated to LLVM IR and compiled
    by numba's code generator; available where numba's internals are the
    ones it was written for (:func:`codegen.numba_internals.native_unsupported`)."""

    name = "native"
    file_suffix = ".native"

    def unavailable(self):
        return numba_internals.native_unsupported()

    def _wrap(self, compiled, signature=None) -> CompiledFunction:
        from . import native_file

        return CompiledFunction(self.name, compiled.name, compiled, address=compiled.address, signature=signature,
                                origin=compiled.origin, serialiser=lambda: native_file.dumps(compiled))

    def compile(self, source, function_name, signature, *, symbol, dialect=PYTHON, calls=(), directory=None):
        from . import native

        compiled = native.compile_function(source, function_name, list(signature.arguments), signature.result,
                                           symbol, dialect=dialect, calls=calls)
        return self._wrap(compiled, signature)

    def load(self, data, symbol, signature=None):
        from . import native_file

        compiled = native_file.loads(data, symbol)
        return None if compiled is None else self._wrap(compiled, signature)

    def loads_here(self, head):
        from . import native_file

        return native_file.header_matches_machine(head)


#: one backend of each kind, by name
BACKENDS: dict[str, Backend] = {backend.name: backend for backend in (PythonBackend(), NumbaBackend(), NativeBackend())}


def machine_code_backends() -> list[Backend]:
    """The backends to try, in order, for a function whose machine code is
    called: ``native`` (unless ``HBG_NATIVE`` turns it off or it is
    unavailable here), then ``numba`` (when installed)."""
    order = [BACKENDS["native"]] if native_enabled() else []
    order.append(BACKENDS["numba"])
    return [backend for backend in order if backend.available()]
