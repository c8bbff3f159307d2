"""codegen.backends: one contract for the python, numba and native backends,
the order machine code is tried in, and the numba fallback when numba's
internals are not the ones the native backend was written for."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("numba")

from codegen import machine, numba_internals  # noqa: E402
from codegen.backends import BACKENDS, Backend, CompiledFunction, Signature, machine_code_backends  # noqa: E402
from codegen.cache import SourceCache  # noqa: E402
from codegen.safety import Dialect  # noqa: E402

SOURCE = "def h(x, y):\n    return x * y + math.sqrt(y) if y > 0.0 else -x\n"
SIGNATURE = Signature(("f", "f"), "f")
_serial = iter(range(10**9))


def same_bits(a, b) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and bool(np.all(a.view(np.int64) == b.view(np.int64)))


@pytest.fixture
def fresh_internals():
    """numba_internals' verdict computed afresh for the test and after it."""
    numba_internals.native_unsupported.cache_clear()
    yield numba_internals
    numba_internals.native_unsupported.cache_clear()


def test_every_backend_keeps_the_contract(tmp_path):
    source = "import math\n\n" + SOURCE
    assert set(BACKENDS) == {"python", "numba", "native"}
    results = {}
    dialect = Dialect(imports=(("math", None, None),))
    for name, backend in BACKENDS.items():
        assert isinstance(backend, Backend) and backend.name == name and backend.available(), backend.unavailable()
        compiled = backend.compile(source, "h", SIGNATURE, symbol=f"hbg_test_backend_{next(_serial)}",
                                   dialect=dialect, directory=tmp_path)
        assert isinstance(compiled, CompiledFunction) and compiled.backend == name and compiled.origin == "compiled"
        assert (compiled.address is None) == (name == "python")
        results[name] = [compiled.function(x, y) for x, y in [(1.5, 2.0), (-3.0, 0.0), (2.0, math.inf)]]
        data = compiled.serialise()  # native: bytes another process loads (test_native.py); numba keeps its own
        assert (data is not None) == (name == "native")
        assert backend.loads_here(data or b"") == (name == "native")
    assert results["python"] == results["numba"] == results["native"]


def test_the_order_respects_hbg_native(monkeypatch):
    assert [b.name for b in machine_code_backends()] == ["native", "numba"]
    monkeypatch.setenv("HBG_NATIVE", "0")
    assert [b.name for b in machine_code_backends()] == ["numba"]


def _ball_run(cache):
    from models import bouncing_ball
    from switching.library import jit_model

    model = bouncing_ball.build()
    model.cache = SourceCache(cache)
    model.simulate(2.0, "RK45")
    run = model.simulate(2.0, "RK45-jit")
    return run, [jit_model.mode_function(model, mode) for mode in sorted(model.visited_modes, key=lambda m: m.label)]


def _another_version(monkeypatch):
    import numba

    monkeypatch.setattr(numba, "__version__", "0.99.0")


def _a_missing_internal(monkeypatch):
    monkeypatch.setattr(numba_internals, "_NATIVE_INTERNALS",
                        numba_internals._NATIVE_INTERNALS + (("numba.core.registry", "cpu_target.no_such_internal"),))


@pytest.mark.parametrize("change, reason", [(_another_version, "numba 0.99.0 is not a version"),
                                            (_a_missing_internal, "has no numba.core.registry.cpu_target.no_such")])
def test_unknown_numba_internals_make_the_native_backend_unavailable_and_numba_compiles(
        tmp_path, monkeypatch, fresh_internals, change, reason):
    reference, functions = _ball_run(tmp_path / "native")
    assert all(f.backend == "native" for f in functions)

    change(monkeypatch)
    fresh_internals.native_unsupported.cache_clear()
    native = BACKENDS["native"]
    assert not native.available() and reason in native.unavailable()
    assert [b.name for b in machine_code_backends()] == ["numba"]
    monkeypatch.setattr(machine, "LOADED", {})
    run, functions = _ball_run(tmp_path / "fallback")  # (no crash: numba's front end compiles every mode)
    assert all(f.backend == "numba" for f in functions)
    assert same_bits(run.t, reference.t) and same_bits(run.x, reference.x)


def test_kept_machine_code_is_found_by_its_header_for_the_backends_that_would_be_tried(tmp_path, monkeypatch):
    """machine_function keeps the native code in the directory; is_compiled
    finds it there (its whole header read: the machine key is long) while
    the native backend would be tried, and not with HBG_NATIVE=0."""
    symbol = f"hbg_test_kept_{next(_serial)}"
    dialect = Dialect(imports=(("math", None, None),))
    compiled = machine.machine_function("import math\n\n" + SOURCE, "h", SIGNATURE, symbol, dialect=dialect,
                                        directory=tmp_path)
    assert compiled.backend == "native" and (tmp_path / f"{symbol}.native").is_file()
    assert compiled.function(1.5, 2.0) == 1.5 * 2.0 + math.sqrt(2.0)
    monkeypatch.setattr(machine, "LOADED", {})
    assert machine.is_compiled(symbol, tmp_path)
    monkeypatch.setenv("HBG_NATIVE", "0")
    assert not machine.is_compiled(symbol, tmp_path)  # numba's front end never compiled it


def test_a_backend_must_compile():
    """The contract's ``compile`` is abstract: a backend that does not define it cannot be made."""
    class Incomplete(Backend):
        name = "incomplete"

    with pytest.raises(TypeError, match="abstract"):
        Incomplete()
