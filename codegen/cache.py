"""Caches of generated source: in memory, and on disk.

On disk each entry is one ``<key>.py`` file whose first line records the
key and the SHA-256 of the rest; an entry that does not match (corrupted,
truncated, from another version) is ignored and rebuilt.  Files are written
to a temporary file in the same directory and moved into place with
``os.replace``, so several processes may share the directory: a reader sees
either the old file, the new one, or none (a miss).

The directory is ``$HBG_CACHE_DIR``, else ``$XDG_CACHE_HOME/hbg``, else
``~/.cache/hbg``; ``HBG_CACHE_DIR=off`` disables the disk cache.  A
directory that cannot be written costs speed only: a :class:`CacheWarning`
names it once per process, and the compiled methods then compile their mode
functions in a private temporary directory (see :func:`codegen.jit.load_module`).

Size cap.  The directory holds at most ``$HBG_CACHE_MAX_MB`` megabytes
(default 500; ``inf`` for no cap).  An entry is everything filed under one
key: ``<key>.py``, and for a mode's compiled function its module
``jit/hbg_mode_<key>.py`` with its machine code ``jit/hbg_mode_<key>.native``
(:mod:`codegen.native`) or numba's ``jit/__pycache__/hbg_mode_<key>.*``
(``.nbi``/``.nbc``).  (A compiled kernel that is model-independent is kept
by numba beside its own module, once per installation.  Modules
``hbg_model_<key>`` of earlier versions, one kernel per model, are entries
too, evicted alike.)
Whenever an entry is stored and the directory is then over the cap, whole
entries are deleted, least recently used first (a load from disk refreshes the entry's
modification time), down to 90 % of the cap.  Entries used in the last
:data:`GRACE_SECONDS` are never deleted (another process may be loading
them), so the cap may be exceeded for a while.  A store lists the directory
again only when what the cache stored since its last listing could fill half
the room that listing left, or :data:`GRACE_SECONDS` after it (so a scene that
stores a thousand modes lists it a few times, not a thousand).  Only files named like
entries are counted or deleted: anything else in the directory is left alone.
A file deleted under another process's feet is a miss there, not an error.
"""

from __future__ import annotations

import ast
import hashlib
import math
import os
import re
import tempfile
import time
import warnings
from pathlib import Path

from .safety import PYTHON, Dialect, GeneratedCodeError, check_source

__all__ = ["CacheWarning", "SourceCache", "cache_entries", "default_cache", "default_max_bytes", "fingerprint",
           "warn_not_writable"]

_HEADER = "# hbg-codegen key={key} sha256={digest}\n"

DEFAULT_MAX_MB = 500.0
GRACE_SECONDS = 60.0  # entries used more recently than this are not evicted
LOW_WATER = 0.9  # an eviction frees space down to this fraction of the cap

# the files of one entry, by sub-directory of the cache directory (group 1: the key)
_ENTRY_FILES = {
    "": re.compile(r"^\.?([0-9a-f]{32})\.(?:py|.*\.tmp)$"),
    "jit": re.compile(r"^\.?hbg_mode(?:l)?_([0-9a-f]{32})\.(?:py|native|.*\.tmp)$"),
    os.path.join("jit", "__pycache__"): re.compile(r"^hbg_mode(?:l)?_([0-9a-f]{32})\."),
}


class CacheWarning(UserWarning):
    """The disk cache could not be used as intended (not writable, or a file
    in it unreadable): only speed is lost."""


_warned_directories: set[Path] = set()


def warn_not_writable(directory: str | os.PathLike, error: BaseException, stacklevel: int = 3) -> None:
    """A :class:`CacheWarning` that ``directory`` cannot be written, once per
    process for it and everything below it."""
    path = Path(directory).absolute()
    if any(path == seen or seen in path.parents for seen in _warned_directories):
        return
    _warned_directories.add(path)
    reason = getattr(error, "strerror", None) or str(error) or type(error).__name__
    warnings.warn(
        f"the hbg cache directory {path} is not writable ({reason}): nothing generated now is kept for later runs "
        f"(the compiled *-jit methods compile the mode functions it does not hold yet in a private temporary "
        f"directory, again in every process). Set HBG_CACHE_DIR to a writable directory, or HBG_CACHE_DIR=off to run "
        f"without a disk cache.",
        CacheWarning,
        stacklevel=stacklevel,
    )


def fingerprint(*parts: str) -> str:
    """A short stable hash of text parts."""
    h = hashlib.sha256()
    for part in parts:
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()[:32]


def default_max_bytes() -> float:
    """The size cap from ``$HBG_CACHE_MAX_MB`` (megabytes, default 500; ``inf``: none)."""
    setting = os.environ.get("HBG_CACHE_MAX_MB", "").strip()
    if not setting:
        return DEFAULT_MAX_MB * 1e6
    try:
        value = float(setting)
    except ValueError:
        value = math.nan
    if not value >= 0:  # also NaN
        warnings.warn(f"HBG_CACHE_MAX_MB={setting!r} is not a size in megabytes; using {DEFAULT_MAX_MB:g}",
                      CacheWarning, stacklevel=3)
        return DEFAULT_MAX_MB * 1e6
    return value * 1e6


def cache_entries(directory: str | os.PathLike) -> dict[str, list]:
    """The entries in a cache directory: ``{key: [bytes, newest mtime, [(path, bytes), …]]}``.
    Files that vanish while they are listed are left out."""
    root = Path(directory)
    entries: dict[str, list] = {}
    for sub, pattern in _ENTRY_FILES.items():
        try:
            listing = os.scandir(root / sub)
        except OSError:
            continue
        with listing:
            for item in listing:
                match = pattern.match(item.name)
                if match is None:
                    continue
                try:
                    st = item.stat(follow_symlinks=False)
                except OSError:
                    continue
                if not item.is_file(follow_symlinks=False):
                    continue
                entry = entries.setdefault(match.group(1), [0, 0.0, []])
                entry[0] += st.st_size
                entry[1] = max(entry[1], st.st_mtime)
                entry[2].append((item.path, st.st_size))
    return entries


def write_atomically(path: Path, data: str | bytes) -> None:
    """``data`` (text or bytes) into ``path`` by a temporary file beside it,
    moved into place: a reader sees the old file, the new one or none, and a
    failed write leaves no temporary behind.  Raises ``OSError``."""
    path = Path(path)
    fd, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb" if isinstance(data, bytes) else "w") as handle:
            handle.write(data)
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)


#: characters of generated source a cache with a directory holds in memory (the older are read again from disk)
MEMORY_CHARACTERS = 64 * 2**20


class SourceCache:
    """Generated sources by key, in memory and (optionally) in ``directory``,
    which is kept under ``max_bytes`` (default :func:`default_max_bytes`) by
    evicting the least recently used entries."""

    def __init__(self, directory: str | os.PathLike | None, max_bytes: float | None = None):
        self.directory = Path(directory) if directory else None
        self.max_bytes = default_max_bytes() if max_bytes is None else float(max_bytes)
        self.memory: dict[str, str] = {}  # (with a directory: the latest, within MEMORY_CHARACTERS; see _keep)
        self._in_memory = 0  # characters held in memory
        self.hits = {"memory": 0, "disk": 0, "built": 0, "rejected": 0}
        self.evicted = 0  # entries this cache deleted to keep under max_bytes
        self.scans = 0  # listings of the directory by :meth:`evict` (each costs a stat of every entry's files)
        self._scanned: tuple | None = None  # (bytes the last listing found, time of it) (:meth:`_may_be_over`)
        self._stored_since = 0  # bytes this cache stored since that listing

    def _path(self, key: str) -> Path:
        return self.directory / f"{key}.py"

    def load(self, key: str, dialect: Dialect = PYTHON, calls: str | None = None, check: bool = True) -> str | None:
        """The source stored under ``key``: from memory, else from disk if its
        header matches and it passes :func:`codegen.safety.check_source` (in
        its ``dialect``; ``calls``, a pattern: the names matching it that the
        source holds may be called too, functions stored apart that its
        caller puts beside it); ``None`` for a miss.  An entry on disk
        that fails the check was altered: it is deleted, with a
        :class:`CacheWarning`, and its caller builds it again.  ``check=False``:
        not compiled for the check now, for a source its caller checks itself
        and that is checked when it is compiled to run
        (:func:`codegen.safety.compile_checked`), if it ever is (a scene's
        block functions, named by the hash of their text: most never run)."""
        if key in self.memory:
            self.hits["memory"] += 1
            return self.memory[key]
        if self.directory is None:
            return None
        path = self._path(key)
        try:
            text = path.read_text()
        except (OSError, UnicodeDecodeError):
            return None
        first, _, body = text.partition("\n")
        expected = _HEADER.format(key=key, digest=hashlib.sha256(body.encode()).hexdigest()).rstrip("\n")
        if first != expected:
            self.hits["rejected"] += 1
            return None
        try:
            if check:
                check_source(body, str(path), dialect, frozenset(re.findall(calls, body)) if calls else frozenset())
        except GeneratedCodeError as exc:
            self.hits["rejected"] += 1
            warnings.warn(f"cache entry {path} was altered and is not run ({exc}); deleted it, building it again",
                          CacheWarning, stacklevel=2)
            try:
                path.unlink()
            except OSError:
                pass
            return None
        self.hits["disk"] += 1
        self._keep(key, body)
        try:
            os.utime(path)  # recently used: the last to be evicted
        except OSError:
            pass
        return body

    def _keep(self, key: str, text: str) -> None:
        """Hold ``text`` in memory under ``key``.  A cache with a directory holds the latest sources within
        :data:`MEMORY_CHARACTERS` and reads older ones again from the directory (a scene stores a module and
        its blocks per mode: a thousand modes' texts would stay in the process for good); one without a
        directory holds them all (memory is all it has)."""
        held = self.memory.pop(key, None)
        if held is not None:
            self._in_memory -= len(held)
        self.memory[key] = text
        self._in_memory += len(text)
        if self.directory is None:
            return
        while self._in_memory > MEMORY_CHARACTERS and len(self.memory) > 1:
            self._in_memory -= len(self.memory.pop(next(iter(self.memory))))

    def store(self, key: str, source: str) -> None:
        self._keep(key, source)
        self.hits["built"] += 1
        if self.directory is None:
            return
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            header = _HEADER.format(key=key, digest=hashlib.sha256(source.encode()).hexdigest())
            write_atomically(self._path(key), header + source)
        except OSError as exc:  # a read-only or full cache directory only costs speed
            warn_not_writable(self.directory, exc)
            return
        self._stored_since += len(header) + len(source.encode())
        if self._may_be_over():
            self.evict(keep=key)

    def _may_be_over(self) -> bool:
        """Could the directory be over the cap?  Yes unless the last listing
        (:meth:`evict`) left room for twice what this cache stored since, and
        is younger than :data:`GRACE_SECONDS`: the files other writers add
        (other processes, the compiled modules) are counted by the next
        listing.  A scene that stores one mode after another so lists the
        directory a few times, not once per mode (each listing stats every
        entry: the modes of a scene would cost their number squared)."""
        if self._scanned is None or not math.isfinite(self.max_bytes):
            return True
        found, when = self._scanned
        return 2 * self._stored_since > self.max_bytes - found or time.time() - when > GRACE_SECONDS

    def record(self, key: str):
        """The Python literal (numbers, strings, lists, dicts) stored under
        ``key`` by :meth:`write_record`, read from disk afresh (another process
        may have written it since); ``None`` if there is none or it is unreadable."""
        body = None
        if self.directory is not None:
            held = self.memory.pop(key, None)
            self._in_memory -= 0 if held is None else len(held)
            body = self.load(key)
        elif key in self.memory:
            body = self.memory[key]
        if body is None or not body.startswith("RECORD = "):
            return None
        try:
            return ast.literal_eval(body[len("RECORD = "):])
        except (ValueError, SyntaxError, MemoryError, RecursionError):
            return None

    def write_record(self, key: str, value) -> None:
        """Store a Python literal under ``key`` (an entry like any other:
        evicted with the least recently used)."""
        self.store(key, f"RECORD = {value!r}\n")

    def remember(self, key: str, items) -> list:
        """Add ``items`` (strings) to the set stored under ``key`` and return
        the whole set, sorted.  The set only grows: what is on disk is read
        again just before writing the union (two processes adding at once may
        still lose one's addition, which is then added again by its next run)."""
        known = self.record(key)
        known = set(known) if isinstance(known, list) and all(isinstance(i, str) for i in known) else set()
        union = known | set(items)
        if union != known or self.directory is None and key not in self.memory:
            self.write_record(key, sorted(union))
        return sorted(union)

    def evict(self, keep: str | None = None) -> int:
        """Delete least recently used entries while the directory is over the
        cap (down to 90 % of it); never ``keep`` nor entries used in the last
        :data:`GRACE_SECONDS`.  Returns the number of entries deleted."""
        if self.directory is None or not math.isfinite(self.max_bytes):
            return 0
        entries = cache_entries(self.directory)
        total = sum(size for size, _, _ in entries.values())
        self.scans += 1
        self._scanned, self._stored_since = (total, time.time()), 0
        if total <= self.max_bytes:
            return 0
        target = LOW_WATER * self.max_bytes
        now = time.time()
        deleted = 0
        for key, (_, newest, files) in sorted(entries.items(), key=lambda item: item[1][1]):
            if total <= target:
                break
            if key == keep or now - newest < GRACE_SECONDS:
                continue
            for path, size in files:
                try:
                    os.unlink(path)
                except FileNotFoundError:
                    pass  # another process evicted it first
                except OSError:
                    continue  # not ours to delete after all: still counts
                total -= size
            deleted += 1
        self.evicted += deleted
        self._scanned = (total, self._scanned[1])
        return deleted


def default_cache() -> SourceCache:
    setting = os.environ.get("HBG_CACHE_DIR")
    if setting == "off":
        return SourceCache(None)
    if setting:
        return SourceCache(setting)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return SourceCache(os.path.join(base, "hbg"))
