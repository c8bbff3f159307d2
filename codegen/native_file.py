"""The kept form of a natively compiled function (:mod:`codegen.native`): bytes for a cache file.

A header — the format, :func:`machine_key` (what machine code depends on),
the lengths and SHA-256 of the two parts — then the object code, then the
module's bitcode.  :func:`loads` gives the function back in another process
of the same machine, ``None`` for code of another machine, and raises
:class:`CorruptFile` for bytes that do not match their own header (nothing
of them is loaded then).
"""

from __future__ import annotations

import functools
import hashlib

from . import numba_internals
from .native import NativeFunction, load_function

__all__ = ["CorruptFile", "dumps", "header_matches_machine", "loads", "machine_key"]

_MAGIC = b"hbg-native 1\n"


class CorruptFile(Exception):
    """Kept machine code that cannot be read (truncated, corrupted)."""


@functools.cache
def machine_key() -> str:
    """What machine code depends on: numba's and llvmlite's versions and the host CPU and its features."""
    import llvmlite
    import numba

    cpu, features = numba_internals.host_cpu()
    return "|".join((numba.__version__, llvmlite.__version__, cpu, features))


def dumps(function: NativeFunction) -> bytes:
    """``function``'s machine code with its header."""
    object_code, bitcode = function.serialize()
    digest = hashlib.sha256(object_code + bitcode).hexdigest()
    header = _MAGIC + f"{machine_key()}\n{len(object_code)} {len(bitcode)} {digest}\n".encode()
    return header + object_code + bitcode


def loads(data: bytes, name: str) -> NativeFunction | None:
    """Function ``name`` from what :func:`dumps` gave, or ``None`` when it
    holds code for another machine (other numba, llvmlite or CPU).  Raises
    :class:`CorruptFile` when ``data`` does not match its own header."""
    if not data.startswith(_MAGIC):
        raise CorruptFile("not a machine-code file of this toolkit")
    try:
        machine, sizes, rest = data[len(_MAGIC):].split(b"\n", 2)
        length_object, length_bitcode, digest = sizes.decode().split()
        length_object, length_bitcode = int(length_object), int(length_bitcode)
    except ValueError:
        raise CorruptFile("a damaged header") from None
    if machine.decode(errors="replace") != machine_key():
        return None
    if len(rest) != length_object + length_bitcode or hashlib.sha256(rest).hexdigest() != digest:
        raise CorruptFile("truncated or corrupted (its length or SHA-256 does not match its header)")
    return load_function(name, rest[:length_object], rest[length_object:])


def header_matches_machine(head: bytes) -> bool:
    """Do the first bytes of a kept function say it is for this machine (its header only; not verified)?"""
    return head.startswith(_MAGIC) and head[len(_MAGIC):].split(b"\n", 1)[0].decode(errors="replace") == machine_key()
