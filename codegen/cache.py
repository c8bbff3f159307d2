"""Caches of generated source: in memory, and on disk.

On disk each entry is one ``<key>.py`` file whose first line records the
key and the SHA-256 of the rest; an entry that does not match (corrupted,
truncated, from another version) is ignored and rebuilt.  Files are written
to a temporary file in the same directory and moved into place with
``os.replace``, so several processes may share the directory: a reader sees
either the old file, the new one, or none.

The directory is ``$HBG_CACHE_DIR``, else ``$XDG_CACHE_HOME/hbg``, else
``~/.cache/hbg``; ``HBG_CACHE_DIR=off`` disables the disk cache.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

__all__ = ["SourceCache", "default_cache", "fingerprint"]

_HEADER = "# hbg-codegen key={key} sha256={digest}\n"


def fingerprint(*parts: str) -> str:
    """A short stable hash of text parts."""
    h = hashlib.sha256()
    for part in parts:
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()[:32]


class SourceCache:
    """Generated sources by key, in memory and (optionally) in ``directory``."""

    def __init__(self, directory: str | os.PathLike | None):
        self.directory = Path(directory) if directory else None
        self.memory: dict[str, str] = {}
        self.hits = {"memory": 0, "disk": 0, "built": 0, "rejected": 0}

    def _path(self, key: str) -> Path:
        return self.directory / f"{key}.py"

    def load(self, key: str) -> str | None:
        if key in self.memory:
            self.hits["memory"] += 1
            return self.memory[key]
        if self.directory is None:
            return None
        try:
            text = self._path(key).read_text()
        except (OSError, UnicodeDecodeError):
            return None
        first, _, body = text.partition("\n")
        expected = _HEADER.format(key=key, digest=hashlib.sha256(body.encode()).hexdigest()).rstrip("\n")
        if first != expected:
            self.hits["rejected"] += 1
            return None
        try:
            compile(body, str(self._path(key)), "exec")
        except SyntaxError:
            self.hits["rejected"] += 1
            return None
        self.hits["disk"] += 1
        self.memory[key] = body
        return body

    def store(self, key: str, source: str) -> None:
        self.memory[key] = source
        self.hits["built"] += 1
        if self.directory is None:
            return
        tmp = None
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            header = _HEADER.format(key=key, digest=hashlib.sha256(source.encode()).hexdigest())
            fd, tmp = tempfile.mkstemp(dir=self.directory, prefix=f".{key}.", suffix=".tmp")
            with os.fdopen(fd, "w") as handle:
                handle.write(header + source)
            os.replace(tmp, self._path(key))
            tmp = None
        except OSError:
            pass  # a read-only or full cache directory only costs speed
        finally:
            if tmp is not None and os.path.exists(tmp):
                os.unlink(tmp)


def default_cache() -> SourceCache:
    setting = os.environ.get("HBG_CACHE_DIR")
    if setting == "off":
        return SourceCache(None)
    if setting:
        return SourceCache(setting)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return SourceCache(os.path.join(base, "hbg"))
