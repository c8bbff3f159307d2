"""The disk cache cannot fail a run (issue 21): a size cap with
least-recently-used eviction (an entry's numba files go with it), unreadable
numba ``.nbi``/``.nbc`` files deleted and compiled again, and an unwritable
cache directory answered by a warning and a private directory.

The end-to-end tests share one compiled kernel of the bouncing ball (built
once, in a subprocess, in the session's cache directory, where
``tests/switching/library/test_compiled.py`` finds it again) and each run a fresh process on a
copy of it.  Unwritable directories are ``chmod 0o555``; root ignores
permissions, so as root the subprocess (or the test) first installs
:func:`deny_writes`, which makes every write under the directory fail with
``PermissionError`` as the kernel would."""

import json
import os
import pickle
import re
import shutil
import subprocess
import sys
import textwrap
import time
import uuid
import warnings
from pathlib import Path

import numpy as np
import pytest

from codegen import cache as cache_module
from codegen.cache import CacheWarning, SourceCache, cache_entries, default_max_bytes
from checkout import ROOT

ROOT_USER = hasattr(os, "geteuid") and os.geteuid() == 0
TIMEOUT = 600


# ------------------------------------------------------------------ helpers


def deny_writes(directory, setattr=None):
    """Make every write under ``directory`` fail with ``PermissionError``
    (creating, replacing, deleting or touching files, making directories),
    as a read-only directory does for anyone but root.  ``setattr``: the
    monkeypatch's, to undo it after a test."""
    import builtins
    import errno
    import io
    import os

    if setattr is None:
        setattr = builtins.setattr
    top = os.path.realpath(directory)

    def inside(path):
        if isinstance(path, int):
            return False
        try:
            real = os.path.realpath(os.fspath(path))
        except TypeError:
            return False
        return real == top or real.startswith(top + os.sep)

    def deny(path):
        raise PermissionError(errno.EACCES, "Permission denied", os.fspath(path))

    real_open, real_io_open = os.open, io.open

    def os_open(path, flags, mode=0o777, *, dir_fd=None):
        if flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_TRUNC) and inside(path):
            deny(path)
        return real_open(path, flags, mode, dir_fd=dir_fd)

    def open_(file, mode="r", *args, **kwargs):
        if not isinstance(file, int) and any(c in mode for c in "wax+") and inside(file):
            deny(file)
        return real_io_open(file, mode, *args, **kwargs)

    setattr(os, "open", os_open)
    setattr(io, "open", open_)
    setattr(builtins, "open", open_)
    real_mkdir = os.mkdir

    def mkdir(path, *args, **kwargs):
        if inside(path):
            if os.path.exists(path):
                raise FileExistsError(errno.EEXIST, "File exists", os.fspath(path))
            deny(path)
        return real_mkdir(path, *args, **kwargs)

    setattr(os, "mkdir", mkdir)
    for name in ("replace", "rename", "unlink", "remove", "utime", "rmdir"):
        real = getattr(os, name)

        def guarded(path, *args, _real=real, **kwargs):
            if inside(path) or (args and inside(args[0])):
                deny(path)
            return _real(path, *args, **kwargs)

        setattr(os, name, guarded)


def make_read_only(directory, monkeypatch=None):
    """``chmod 0o555`` every directory under ``directory`` (files stay
    readable); as root, :func:`deny_writes` is needed as well (in-process
    with ``monkeypatch``; a subprocess gets :func:`read_only_prelude`)."""
    for where, dirs, files in os.walk(directory):
        for name in files:
            os.chmod(os.path.join(where, name), 0o444)
        os.chmod(where, 0o555)
    if ROOT_USER and monkeypatch is not None:
        deny_writes(directory, monkeypatch.setattr)


def make_writable(directory):
    for where, dirs, files in os.walk(directory):
        os.chmod(where, 0o755)


def read_only_prelude(directory) -> str:
    """Source a subprocess runs first so that ``directory`` is read-only for
    it even as root."""
    if not ROOT_USER:
        return ""
    import inspect

    return inspect.getsource(deny_writes) + f"\ndeny_writes({str(directory)!r})\ndel deny_writes\n"


def run_python(script: str, cache_dir, **env) -> subprocess.CompletedProcess:
    """``script`` run by a new interpreter with ``HBG_CACHE_DIR=cache_dir`` and numba's files beside their
    modules (a ``NUMBA_CACHE_DIR`` of the environment, a common setting, would put them elsewhere)."""
    environment = {**os.environ, "HBG_CACHE_DIR": str(cache_dir), "PYTHONPATH": str(ROOT), **env}
    environment.pop("NUMBA_CACHE_DIR", None)
    return subprocess.run([sys.executable, "-c", script], cwd=ROOT, env=environment, capture_output=True, text=True,
                          timeout=TIMEOUT)


def snapshot(directory) -> dict:
    """Every file under ``directory`` with its size and modification time."""
    out = {}
    for where, dirs, files in os.walk(directory):
        for name in files:
            st = os.stat(os.path.join(where, name))
            out[os.path.relpath(os.path.join(where, name), directory)] = (st.st_size, st.st_mtime_ns)
    return out


def tree_bytes(directory) -> int:
    return sum(size for size, _ in snapshot(directory).values())


# ------------------------------------------------------------------ size cap, eviction


def _text(key: str, kb: int = 100) -> str:
    return f"RECORD = {key!r}\n" + "#" * (kb * 1000) + "\n"  # (a module the check lets through)


def _fake_entry(directory: Path, key: str, kb: int, age: float, kernel: bool = False) -> list:
    """An entry ``key``: its source of about ``kb`` kilobytes (written through
    the cache) and, for a kernel, a module and numba's index and data files
    of as much each; all ``age`` seconds old."""
    SourceCache(directory, max_bytes=float("inf")).store(key, _text(key, kb))
    paths = [directory / f"{key}.py"]
    if kernel:
        jit = directory / "jit"
        (jit / "__pycache__").mkdir(parents=True, exist_ok=True)
        paths.append(jit / f"hbg_model_{key}.py")
        paths.append(jit / "__pycache__" / f"hbg_model_{key}.run-921.py311.nbi")
        paths.append(jit / "__pycache__" / f"hbg_model_{key}.run-921.py311.1.nbc")
        for path in paths[1:]:
            path.write_bytes(b"\0" * (kb * 1000))
    stamp = time.time() - age
    for path in paths:
        os.utime(path, (stamp, stamp))
    return paths


def _key(i: int) -> str:
    return f"{i:032x}"


def test_a_store_over_the_cap_evicts_least_recently_used_entries_with_their_numba_files(tmp_path):
    entries = {_key(i): _fake_entry(tmp_path, _key(i), 100, 3600 - 100 * i, kernel=(i % 2 == 0)) for i in range(10)}
    # not entries: never counted, never deleted
    (tmp_path / "notes.txt").write_bytes(b"n" * 400_000)
    (tmp_path / "jit" / "helper.py").write_text("# mine\n")
    (tmp_path / "jit" / "__pycache__" / "helper.cpython-311.pyc").write_bytes(b"p" * 1000)
    before = sum(size for size, _, _ in cache_entries(tmp_path).values())
    assert set(cache_entries(tmp_path)) == set(entries)
    assert len(cache_entries(tmp_path)[_key(0)][2]) == 4  # the source, the module and numba's two files

    cache = SourceCache(tmp_path, max_bytes=2_000_000)
    assert cache.load(_key(0)) == _text(_key(0))  # the oldest, used now
    cache.store(_key(99), "Y = 1\n")
    after = cache_entries(tmp_path)
    total = sum(size for size, _, _ in after.values())
    print(f"cache {before / 1e6:.2f} MB in {len(entries)} entries; cap 2 MB: {total / 1e6:.2f} MB in {len(after)} "
          f"after {cache.evicted} evictions")
    assert 1.2e6 < total <= 1.8e6 and cache.evicted > 0
    # least recently used first: key 1 was the oldest after the load of key 0 (even keys: kernels, 4 files, 400 kB)
    survivors = sorted(after)
    assert _key(0) in survivors and _key(99) in survivors
    evicted = sorted(set(entries) - set(after))
    assert evicted == [_key(i) for i in range(1, 1 + len(evicted))]
    for key in evicted:
        assert not any(path.exists() for path in entries[key])  # numba's files went with the source
    for key in survivors:
        assert all(path.exists() for path in entries.get(key, []))
    assert (tmp_path / "notes.txt").exists() and (tmp_path / "jit" / "helper.py").exists()
    assert (tmp_path / "jit" / "__pycache__" / "helper.cpython-311.pyc").exists()


def test_entries_in_use_are_not_evicted_and_no_cap_means_none(tmp_path):
    for i in range(4):
        _fake_entry(tmp_path, _key(i), 100, age=1.0, kernel=True)  # all used within the grace period
    cache = SourceCache(tmp_path, max_bytes=100_000)
    cache.store(_key(9), "Y = 1\n")
    assert cache.evicted == 0 and len(cache_entries(tmp_path)) == 5
    unlimited = SourceCache(tmp_path, max_bytes=float("inf"))
    for i in range(4):
        _fake_entry(tmp_path, _key(i), 100, age=7200, kernel=True)
    unlimited.store(_key(10), "Y = 2\n")
    assert unlimited.evicted == 0 and len(cache_entries(tmp_path)) == 6
    cache.store(_key(11), "Y = 3\n")
    assert cache.evicted == 4 and set(cache_entries(tmp_path)) == {_key(9), _key(10), _key(11)}


def test_a_store_lists_the_directory_only_when_it_could_be_over_the_cap(tmp_path):
    """A scene's modes stored one after another do not list the directory once each
    (a listing stats every entry), and the cap still holds for the cache's own stores."""
    roomy = SourceCache(tmp_path, max_bytes=10_000_000)
    for i in range(100):
        roomy.store(_key(i), _text(_key(i), 1))
    assert roomy.scans == 1 and roomy.evicted == 0
    tight = SourceCache(tmp_path / "tight", max_bytes=500_000)
    for i in range(8):  # 100 kB each: listed again as the room the last listing left fills
        scans = tight.scans
        tight.store(_key(i), _text(_key(i), 100))
        total = sum(size for size, _, _ in cache_entries(tmp_path / "tight").values())
        assert total <= 500_000 or tight.scans == scans + 1  # (entries this young are not evicted)
    assert 1 < tight.scans < 8


def test_the_cap_comes_from_HBG_CACHE_MAX_MB(monkeypatch):
    monkeypatch.delenv("HBG_CACHE_MAX_MB", raising=False)
    assert default_max_bytes() == 500e6
    monkeypatch.setenv("HBG_CACHE_MAX_MB", "1.5")
    assert default_max_bytes() == 1.5e6 and SourceCache(None).max_bytes == 1.5e6
    monkeypatch.setenv("HBG_CACHE_MAX_MB", "inf")
    assert default_max_bytes() == float("inf")
    monkeypatch.setenv("HBG_CACHE_MAX_MB", "lots")
    with pytest.warns(CacheWarning, match="HBG_CACHE_MAX_MB='lots'"):
        assert default_max_bytes() == 500e6


def test_a_file_evicted_under_a_reader_is_a_miss(tmp_path, monkeypatch):
    writer, reader = SourceCache(tmp_path), SourceCache(tmp_path)
    writer.store(_key(1), "A = 1\n")
    (tmp_path / f"{_key(1)}.py").unlink()  # another process evicted it
    assert reader.load(_key(1)) is None
    # files listed for eviction that another process deletes first
    _fake_entry(tmp_path, _key(2), 100, 3600, kernel=True)
    listing = cache_entries(tmp_path)
    for path, _ in listing[_key(2)][2]:
        os.unlink(path)
    monkeypatch.setattr(cache_module, "cache_entries", lambda directory: listing)
    assert SourceCache(tmp_path, max_bytes=1000).evict() == 1


def test_processes_storing_loading_and_evicting_at_once_never_fail(tmp_path):
    """Four processes share a directory with a cap of a few entries: every
    load is the right text or a miss."""
    script = textwrap.dedent(
        """
        import random, sys, time
        from codegen import cache as c
        c.GRACE_SECONDS = 0.0
        cache = c.SourceCache(sys.argv[1], max_bytes=200_000)
        rng = random.Random(int(sys.argv[2]))
        text = lambda k: f"RECORD = {k!r}\\n" + "#" * 20_000 + "\\n"
        hits = misses = 0
        end = time.time() + 2.0
        while time.time() < end:
            key = f"{rng.randrange(40):032x}"
            cache.memory.clear()
            got = cache.load(key)
            if got is None:
                misses += 1
                cache.store(key, text(key))
            else:
                assert got == text(key), key
                hits += 1
        print(hits, misses, cache.evicted)
        """
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    procs = [subprocess.Popen([sys.executable, "-c", script, str(tmp_path), str(seed)], cwd=ROOT, env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for seed in range(4)]
    results = [p.communicate(timeout=120) for p in procs]
    for p, (out, err) in zip(procs, results):
        assert p.returncode == 0, err
    counts = [list(map(int, out.split())) for out, _ in results]
    assert all(hits > 0 and evicted > 0 for hits, _, evicted in counts)
    assert sum(size for size, _, _ in cache_entries(tmp_path).values()) <= 200_000 + 4 * 21_000
    print("hits, misses, evictions per process:", counts)


# ------------------------------------------------------------------ numba's files: one small module


from codegen.safety import Dialect  # noqa: E402

TINY = textwrap.dedent(
    """
    from numba import njit

    @njit(cache=True)
    def twice(x):
        return 2.0 * x

    @njit(cache=True)
    def thrice(x):
        return 3.0 * twice(x) / 2.0
    """
)
TINY_DIALECT = Dialect(imports=(("numba", "njit", None),))  # (a generated module may hold only what it is allowed)


@pytest.fixture
def numba_beside_modules(monkeypatch):
    """numba's index and data files in ``__pycache__`` beside their modules, as without ``NUMBA_CACHE_DIR``
    (numba read the variable at its import: its setting is undone too)."""
    numba_config = pytest.importorskip("numba.core.config")
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setattr(numba_config, "CACHE_DIR", "")


def _tiny(directory):
    from codegen.jit import load_module

    name = f"hbg_test_tiny_{uuid.uuid4().hex[:12]}"
    return name, load_module(name, TINY, directory, TINY_DIALECT)


def _reload(name, directory):
    from codegen.jit import load_module

    del sys.modules[name]
    return load_module(name, TINY, directory, TINY_DIALECT)


def test_unreadable_numba_index_and_data_files_are_deleted_and_compiled_again(tmp_path, numba_beside_modules):
    pytest.importorskip("numba")
    from codegen import jit

    name, module = _tiny(tmp_path)
    assert module.twice(2.0) == 4.0 and module.thrice(2.0) == 6.0
    pycache = tmp_path / "__pycache__"
    for case in ("garbage index", "garbage data", "truncated data"):
        files = sorted(pycache.glob(f"{name}.*"))
        assert {p.suffix for p in files} == {".nbi", ".nbc"}
        for path in files:
            if case == "garbage index" and path.suffix == ".nbi":
                path.write_bytes(os.urandom(300))
            elif case == "garbage data" and path.suffix == ".nbc":
                path.write_bytes(b"\x80\x04garbage" + os.urandom(300))
            elif case == "truncated data" and path.suffix == ".nbc":
                path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
        jit._rebuilt.discard(name)
        with pytest.warns(CacheWarning, match=f"(?s){name} in .*could not be read.*deleted them and compiling again"):
            module = _reload(name, tmp_path)
            assert module.thrice(2.0) == 6.0 and module.twice(1.5) == 3.0
        assert module.twice.stats.cache_misses and module.thrice.stats.cache_misses  # compiled, not loaded
        for path in pycache.glob(f"{name}.*.nbi"):  # written anew, readable
            with open(path, "rb") as handle:
                assert isinstance(pickle.load(handle), str)
        with warnings.catch_warnings():
            warnings.simplefilter("error", CacheWarning)
            module = _reload(name, tmp_path)
            assert module.thrice(2.0) == 6.0
        assert not module.thrice.stats.cache_misses and module.thrice.stats.cache_hits  # loaded


def test_an_unwritable_cache_directory_warns_and_the_module_still_works(tmp_path, monkeypatch, numba_beside_modules):
    pytest.importorskip("numba")
    from codegen import jit

    monkeypatch.setattr(cache_module, "_warned_directories", set())
    read_only = tmp_path / "ro"
    (read_only / "jit").mkdir(parents=True)
    make_read_only(read_only, monkeypatch)
    try:
        with pytest.warns(CacheWarning) as caught:
            cache = SourceCache(read_only)
            cache.store(_key(1), "A = 1\n")
            assert cache.load(_key(1)) == "A = 1\n"  # kept in memory
            name, module = _tiny(read_only / "jit")
            assert module.thrice(2.0) == 6.0
        (message,) = [str(w.message) for w in caught if issubclass(w.category, CacheWarning)]  # once for all below
        assert f"{read_only}" in message and "not writable" in message and "HBG_CACHE_DIR" in message
        assert Path(module.__file__).parent == jit._private
        assert sorted(os.listdir(read_only)) == ["jit"] and os.listdir(read_only / "jit") == []
    finally:
        make_writable(read_only)


def test_a_cache_directory_that_cannot_exist_warns_and_off_uses_a_private_directory(tmp_path, monkeypatch,
                                                                                   numba_beside_modules):
    """A path below a regular file cannot be created even by root."""
    pytest.importorskip("numba")
    from codegen import jit

    monkeypatch.setattr(cache_module, "_warned_directories", set())
    (tmp_path / "file").write_text("")
    with pytest.warns(CacheWarning, match=f"{tmp_path / 'file' / 'cache' / 'jit'} is not writable .*HBG_CACHE_DIR"):
        name, module = _tiny(tmp_path / "file" / "cache" / "jit")
    assert module.twice(1.0) == 2.0 and Path(module.__file__).parent == jit._private
    assert oct(jit._private.stat().st_mode & 0o777) == "0o700"
    with warnings.catch_warnings():
        warnings.simplefilter("error", CacheWarning)
        name, module = _tiny(None)  # HBG_CACHE_DIR=off: no warning, the private directory
    assert Path(module.__file__).parent == jit._private


# ------------------------------------------------------------------ compiled mode functions, fresh processes
# numba's front end compiles them here (HBG_NATIVE=0: the fallback for sources codegen.native does not translate),
# so its cache files are what is tested; the machine-code files of codegen.native are tested further below
NUMBA_FRONT_END = {"HBG_NATIVE": "0"}

BALL = textwrap.dedent(
    """
    import json, sys, time, warnings
    warnings.simplefilter("always")
    import models.bouncing_ball as bouncing_ball
    model = bouncing_ball.build()
    model.simulate(2.0, "RK45")  # both modes visited: the functions tests/switching/library/test_compiled.py compiles too
    start = time.perf_counter()
    run = model.simulate(2.0, "RK45-jit")
    seconds = time.perf_counter() - start
    names = sorted(n for n in sys.modules if n.startswith("hbg_mode_"))
    functions = [sys.modules[n].compiled for n in names]  # each mode's compiled function (switching.library.jit_model)
    print(json.dumps({"modules": names, "files": [sys.modules[n].__file__ for n in names], "seconds": seconds,
                      "t": list(run.t), "x": run.x.tolist(), "compiled": [int(f.cache_hits == 0) for f in functions]}))
    """
)


@pytest.fixture(scope="module")
def ball_kernel(tmp_path_factory):
    """The bouncing ball's compiled mode functions (for the RK45-jit kernel),
    compiled (or found) in the session's cache directory by a subprocess:
    their module names, the reference run and a function copying their
    entries to a new directory."""
    pytest.importorskip("numba")
    setting = os.environ.get("HBG_CACHE_DIR", "off")
    session = tmp_path_factory.mktemp("ball-cache") if setting == "off" else Path(setting)
    done = run_python(BALL, session, **NUMBA_FRONT_END)
    assert done.returncode == 0, done.stderr
    reference = json.loads(done.stdout)
    names = reference["modules"]
    assert len(names) >= 2  # flight, impact (and those other tests' runs of the model met, remembered)
    print(f"ball functions: {'compiled' if any(reference['compiled']) else 'loaded'} in {reference['seconds']:.1f} s")

    def copy(destination: Path) -> Path:
        (destination / "jit" / "__pycache__").mkdir(parents=True)
        for path in session.glob("*.py"):
            shutil.copy2(path, destination / path.name)
        for name in names:
            shutil.copy2(session / "jit" / f"{name}.py", destination / "jit" / f"{name}.py")
            for path in (session / "jit" / "__pycache__").glob(f"{name}.*"):
                shutil.copy2(path, destination / "jit" / "__pycache__" / path.name)
            assert name[len("hbg_mode_"):] in cache_entries(destination)
        return destination

    return names, reference, copy


def _same_run(result, reference):
    np.testing.assert_allclose(result["t"], reference["t"], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(result["x"], reference["x"], rtol=1e-10, atol=1e-10)


def test_a_kernel_with_unreadable_numba_files_is_compiled_again_in_a_new_process(ball_kernel, tmp_path):
    """The issue's case, on the two modes' compiled functions: garbage in
    one's index, the other's machine code truncated."""
    names, reference, copy = ball_kernel
    cache = copy(tmp_path)
    pycache = cache / "jit" / "__pycache__"
    (index,) = pycache.glob(f"{names[0]}.mode-*.nbi")
    index.write_bytes(os.urandom(400))
    (data,) = pycache.glob(f"{names[1]}.mode-*.1.nbc")
    data.write_bytes(data.read_bytes()[:1000])
    done = run_python(BALL, cache, **NUMBA_FRONT_END)
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    assert "CacheWarning" in done.stderr and "could not be read" in done.stderr
    result = json.loads(done.stdout)
    assert result["compiled"] == [1, 1] + [0] * (len(names) - 2)
    _same_run(result, reference)
    again = run_python(BALL, cache, **NUMBA_FRONT_END)  # the rebuilt files load, silently
    assert again.returncode == 0 and "CacheWarning" not in again.stderr, again.stderr
    assert json.loads(again.stdout)["compiled"] == [0] * len(names)
    print(f"rebuilt in {result['seconds']:.1f} s, then loaded in {json.loads(again.stdout)['seconds']:.2f} s")


@pytest.mark.slow
def test_a_kernel_whose_numba_files_are_all_garbage_is_compiled_again(ball_kernel, tmp_path):
    names, reference, copy = ball_kernel
    cache = copy(tmp_path)
    files = list((cache / "jit" / "__pycache__").glob("hbg_mode_*"))
    for path in files:
        path.write_bytes(os.urandom(200))
    done = run_python(BALL, cache, **NUMBA_FRONT_END)
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.count("could not be read") == len(names)  # one warning for each module
    _same_run(json.loads(done.stdout), reference)
    print(f"{len(files)} files of garbage; compiled again in {json.loads(done.stdout)['seconds']:.1f} s")


def test_a_read_only_cache_holding_the_kernel_still_spares_the_compilation(ball_kernel, tmp_path):
    names, reference, copy = ball_kernel
    cache = copy(tmp_path / "ro")
    make_read_only(cache)
    try:
        before = snapshot(cache)
        done = run_python(read_only_prelude(cache) + BALL, cache, **NUMBA_FRONT_END)
        assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
        assert "CacheWarning" in done.stderr and re.search(f"{re.escape(str(cache))}(/jit)? is not writable", done.stderr)
        assert "HBG_CACHE_DIR" in done.stderr
        result = json.loads(done.stdout)
        assert result["compiled"] == [0] * len(names)  # numba's files were adopted, not compiled again
        assert all(Path(file).parent != cache / "jit" for file in result["files"])
        _same_run(result, reference)
        assert {k: size for k, (size, _) in snapshot(cache).items()} == {k: size for k, (size, _) in before.items()}
    finally:
        make_writable(cache)


@pytest.mark.slow
def test_an_empty_read_only_cache_directory_still_runs_the_compiled_methods(tmp_path):
    pytest.importorskip("numba")
    cache = tmp_path / "ro"
    cache.mkdir()
    make_read_only(cache)
    try:
        done = run_python(read_only_prelude(cache) + BALL, cache, **NUMBA_FRONT_END)
        assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
        assert done.stderr.count("CacheWarning") == 1 and f"{cache} is not writable" in done.stderr
        assert os.listdir(cache) == []
        print(f"compiled in a private directory in {json.loads(done.stdout)['seconds']:.1f} s")
    finally:
        make_writable(cache)


def test_eviction_takes_a_real_kernel_whole(ball_kernel, tmp_path):
    """numba's real file names are associated with a mode function's entry."""
    names, reference, copy = ball_kernel
    cache = copy(tmp_path)
    name = names[0]
    key = name[len("hbg_mode_"):]
    entries = cache_entries(cache)
    size, _, files = entries[key]
    on_disk = [p for p in (cache / "jit" / "__pycache__").iterdir() if p.name.startswith(name)]
    assert len(files) == 2 + len(on_disk) and all(p.suffix in (".nbi", ".nbc") for p in on_disk)
    total = tree_bytes(cache)
    old = time.time() - 3600
    for where, _, names in os.walk(cache):
        for n in names:
            os.utime(os.path.join(where, n), (old, old))
    SourceCache(cache, max_bytes=size / 2).store(_key(7), "Z = 1\n")
    assert key not in cache_entries(cache)
    assert not any(p.name.startswith(name) for p in (cache / "jit" / "__pycache__").iterdir())
    assert not (cache / "jit" / f"{name}.py").exists()
    print(f"ball cache copy {total / 1e6:.2f} MB ({len(entries)} entries, the kernel {size / 1e6:.2f} MB in "
          f"{len(files)} files); cap {size / 2e6:.2f} MB: {tree_bytes(cache) / 1e6:.3f} MB left")


def test_a_cache_with_a_directory_holds_only_its_latest_sources_in_memory(tmp_path, monkeypatch):
    import codegen.cache as c

    monkeypatch.setattr(c, "MEMORY_CHARACTERS", 25_000)
    cache = c.SourceCache(tmp_path)
    texts = {f"{k:032x}": f"RECORD = {k}\n" + "#" * 10_000 + "\n" for k in range(5)}
    for key, text in texts.items():
        cache.store(key, text)
    assert list(cache.memory) == list(texts)[-2:]  # the latest, within the bound
    keys = list(texts)
    assert cache.load(keys[0]) == texts[keys[0]] and cache.hits["disk"] == 1  # an older one read again from disk
    assert cache.load(keys[-1]) == texts[keys[-1]] and cache.hits["memory"] == 1  # the latest still held
    for key, text in texts.items():
        assert cache.load(key) == text
    assert sum(map(len, cache.memory.values())) <= 25_000
    alone = c.SourceCache(None)
    for key, text in texts.items():
        alone.store(key, text)
    assert list(alone.memory) == list(texts)  # memory is all it has
