"""codegen.native: generated mode functions translated to LLVM IR without
numba's front end.  numba is the reference of the meaning: a source compiled
both ways must give the same bits, for crafted sources exercising each rule
and for the mode functions of the shipped models; anything outside the
subset is refused with a message naming it; the machine code is kept on disk
and loaded by a new process; and numba still compiles what is refused."""

from __future__ import annotations

import ctypes
import json
import os
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("numba")

from numba import types  # noqa: E402
from numba.core.ccallback import CFunc  # noqa: E402

import models  # noqa: E402
from codegen import native  # noqa: E402
from codegen.cache import SourceCache, cache_entries  # noqa: E402
from codegen.native import Untranslatable, compile_function  # noqa: E402
from codegen.safety import GeneratedCodeError  # noqa: E402
from switching.library.jit_model import MODE_DIALECT, mode_calls  # noqa: E402
from checkout import ROOT

_NUMBA = {"f": types.float64, "i": types.int64, "u": types.uint8}
_CTYPES = {"f": ctypes.c_double, "i": ctypes.c_int64, "u": ctypes.c_uint8}
HEADER = "import math\nfrom math import *\nimport numpy as np\nfrom numba import carray\n\n"
_serial = iter(range(10**9))
#: what the sources below may hold: what a generated mode function holds (imports, loops)
IMPORTS = MODE_DIALECT


def numba_type(kind):
    return types.CPointer(_NUMBA[kind[1]]) if isinstance(kind, tuple) else _NUMBA[kind]


def c_type(kind):
    return ctypes.POINTER(_CTYPES[kind[1]]) if isinstance(kind, tuple) else _CTYPES[kind]


def both(source: str, entry: str, signature: list, result: str):
    """The C functions of ``entry`` compiled by codegen.native and by numba (ctypes callables)."""
    compiled = compile_function(source, entry, signature, result, f"hbg_test_native_{next(_serial)}",
                                dialect=IMPORTS)
    namespace: dict = {}
    exec(compile(source, "<test source>", "exec"), namespace)
    reference = CFunc(namespace[entry], (tuple(numba_type(k) for k in signature), _NUMBA[result]), locals={},
                      options={"error_model": "numpy"})
    reference.compile()
    prototype = ctypes.CFUNCTYPE(_CTYPES[result], *[c_type(k) for k in signature])
    return prototype(compiled.address), prototype(reference.address), compiled


def pointer(array):
    return array.ctypes.data_as(ctypes.POINTER(np.ctypeslib.as_ctypes_type(array.dtype)))


def same_bits(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


ARITHMETIC = HEADER + textwrap.dedent(
    """
    def f(n, a, b, x_, out_):
        x = carray(x_, (4,))
        out = carray(out_, (16,))
        out[0] = a**3 + (b*b + 0.5)**(-3) + a**1.5 + a**(3/2) + 2**a
        out[1] = a % b if b != 0 else 0.0  # (numba raises ZeroDivisionError for b == 0; this gives nan)
        out[2] = max(a, b, x[0])
        out[3] = min(a, x[1])
        out[4] = abs(a) + floor(b) + ceil(a)
        out[5] = 1.0 if np.isfinite(a / b) else 0.0
        out[6] = atan2(a, b) + hypot(a, b) + sqrt(abs(a)) + exp(-abs(b)) + log(abs(a) + 1) + sin(a)*cos(b) + tanh(a)
        k = n
        if a > b:
            k = a
        out[7] = k
        s = 0.0
        for j in range(x.shape[0]):
            s = s + x[j]*j
        out[8] = s
        out[9] = -a
        out[10] = 2/n if n != 0 else inf
        out[11] = (a if a > 0 and b > 0 else b) + pi
        out[12] = n**2 + abs(n)
        out[13] = max(n, 1) + min(a, n)
        out[14] = float(n) / 3 + expm1(b) + log1p(abs(a)) + copysign(1.0, b)
        out[15] = e**b + tan(a) + asinh(b) + float('inf') * 0
        return n*2 + (1 if a < b or not b > 0 else 0)
    """
)
ARITHMETIC_SIGNATURE = ["i", "f", "f", ("ptr", "f"), ("ptr", "f")]
SPECIAL = [0.0, -0.0, 1.0, -1.0, 0.5, -2.5, 3.0, 1e300, -1e-300, np.inf, -np.inf, np.nan, 7.25, -7.25]


def test_arithmetic_has_numbas_meaning_bit_for_bit():
    """Literal integer powers (numba's unrolled products), other powers, ``%``
    with Python's sign rule, ``max``/``min`` with NaN, integer results of
    floor/ceil, a variable widened from int to float where branches meet, a
    loop, conditional expressions and short-circuit booleans."""
    ours, reference, _ = both(ARITHMETIC, "f", ARITHMETIC_SIGNATURE, "i")
    rng = np.random.default_rng(7)
    cases = [(n, a, b) for n in (-3, 0, 5) for a in SPECIAL for b in SPECIAL]
    cases += [(int(rng.integers(-9, 9)), *rng.normal(size=2) * 10.0 ** rng.integers(-5, 5, size=2)) for _ in range(300)]
    with np.errstate(all="ignore"):
        for n, a, b in cases:
            x = np.array([a, b, a * b, -a])
            out_ours, out_reference = np.full(16, 0.125), np.full(16, 0.125)
            got = ours(n, a, b, pointer(x), pointer(out_ours))
            expected = reference(n, a, b, pointer(x), pointer(out_reference))
            assert got == expected and same_bits(out_ours, out_reference), (n, a, b, out_ours, out_reference)


def test_the_unit_step_as_printed_is_numbas_and_pythons_bit_for_bit():
    """``Heaviside(x, h0)`` as the code generator prints it (conditional expressions, ``nan`` for NaN),
    translated and compiled by numba: the same bits, and the values plain Python gives."""
    import sympy as sp

    from codegen.source import Argument, module_namespace
    from switching.library.jit_model import generated_statements

    a = sp.Symbol("a")
    outputs = [sp.Heaviside(a, 1), sp.Heaviside(a), 2 * sp.Heaviside(1 - 3 * a, 0) + sp.Heaviside(2 * a - 1, 1)]
    statements = generated_statements({}, "h", (Argument("a", (a,), scalar=True),), outputs)
    source = HEADER + "def f(a, out_):\n    out = carray(out_, (3,))\n" + textwrap.indent(
        "\n".join(statements), "    ") + "\n    return 0\n"
    ours, reference, _ = both(source, "f", ["f", ("ptr", "f")], "i")
    python = {}
    exec("def f(a, out):\n" + textwrap.indent("\n".join(statements), "    ") + "\n    return out\n",
         {**module_namespace()}, python)  # (the generated statements, run as the Python path runs them)
    for value in SPECIAL + [1 / 3]:
        out_ours, out_reference = np.full(3, 0.125), np.full(3, 0.125)
        assert ours(value, pointer(out_ours)) == reference(value, pointer(out_reference)) == 0
        assert same_bits(out_ours, out_reference), (value, out_ours, out_reference)
        assert same_bits(out_ours, python["f"](value, np.empty(3))), value


def test_mode_functions_of_a_law_that_keeps_its_step_agree_with_numba_bit_for_bit():
    from test_codegen import one_way_damper

    model = one_way_damper()
    model.cache = SourceCache(None)
    model.simulate(9.0, "RK45")
    assert any("nan))" in model.compiled_mode(m).source for m in model.visited_modes)  # (the step is printed)
    assert_modes_agree_with_numba(model)


def test_zero_to_a_negative_literal_power_is_infinite():
    """The one place where the meaning differs from numba's on purpose: numba
    computes ``x**-k`` as ``1/x**k`` under Python's error model, so ``0.0**-2``
    raises inside the C function, which then returns 0 with its outputs half
    written; here it is ``inf`` (IEEE, as numba's ``error_model="numpy"`` gives
    for ``1/0.0``), which the kernel reports as a non-finite state."""
    source = HEADER + "def p(a):\n    return a**(-2) + a**(-3)\n"
    compiled = compile_function(source, "p", ["f"], "f", f"hbg_test_native_{next(_serial)}", dialect=IMPORTS)
    power = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_double)(compiled.address)
    assert power(0.0) == np.inf and np.isnan(power(-0.0))  # inf + (-inf)
    assert power(2.0) == 0.25 + 0.125


def test_integer_and_byte_arrays_and_short_circuits():
    source = HEADER + textwrap.dedent(
        """
        def g(which, q_, target_):
            q = carray(q_, (3,))
            target = carray(target_, (2,))
            if target[0] < 0 and (q[0] != 0) and not (q[1] != 0):
                target[0] = which
            elif q[2] != 0 or which > 3:
                target[0] = -which
            target[1] = q[2] + 1
            return target[0]
        """
    )
    signature = ["i", ("ptr", "u"), ("ptr", "i")]
    ours, reference, _ = both(source, "g", signature, "i")
    for which in (-1, 0, 2, 5):
        for bits in range(8):
            for first in (-1, 0, 4):
                q = np.array([bits & 1, bits >> 1 & 1, bits >> 2 & 1], dtype=np.uint8)
                t_ours, t_reference = np.array([first, 9], dtype=np.int64), np.array([first, 9], dtype=np.int64)
                assert ours(which, pointer(q), pointer(t_ours)) == reference(which, pointer(q), pointer(t_reference))
                assert same_bits(t_ours, t_reference)


def test_the_kernels_comparison_translated_is_codegen_runtime_decide():
    """The guard decision the mode functions call (switching.kernel.loop.decide,
    translated from its Python source with the helpers it calls) against the
    Python path's reference, on the cases tests/switching/simulate/test_kernel.py checks the
    kernel with: band edges, impulses, infinities and NaN."""
    import itertools
    import math

    from codegen.runtime import Hyper, decide

    source = HEADER + "from switching.kernel.loop import decide as _dec, larger as _larger\n\n"
    source += textwrap.dedent(
        """
        def d(op, li, lf, ri, rf, sc, sc2, rtol, atol):
            return 1 if _dec(op, li, lf, ri, rf, _larger(sc, sc2), rtol, atol) else 0
        """)
    compiled = compile_function(source, "d", ["i"] + ["f"] * 8, "i", f"hbg_test_native_{next(_serial)}",
                                dialect=IMPORTS, calls=mode_calls())
    function = ctypes.CFUNCTYPE(ctypes.c_int64, ctypes.c_int64, *[ctypes.c_double] * 8)(compiled.address)
    rtol, atol = 1e-9, 1e-12
    finite = [0.0, 1.0, 1.0 + 5e-10, 1.0 + 2e-9, -1.0, 1e-13, -3e-12, math.inf, -math.inf, math.nan]
    for (k, op), lf, rf, li, sc in itertools.product(enumerate(["<", "<=", ">", ">=", "==", "!="]), finite,
                                                     finite[:5], [0.0, 1.0, -1.0, 1e-20], [0.0, 10.0, math.inf]):
        expected = decide(op, Hyper(li, lf), Hyper(0.0, rf), rtol, atol, sc if math.isfinite(sc) else 0.0)
        assert function(k, li, lf, 0.0, rf, sc, -1.0, rtol, atol) == int(expected), (op, li, lf, rf, sc)


@pytest.mark.parametrize("body, message", [
    ("    while a > 0:\n        a = a - 1\n    return 0", "While statement"),
    ("    x = carray(x_, (1,))\n    x[0] = 's'\n    return 0", "constant 's'"),
    ("    x_ = 1.0\n    return 0", "pointer parameter 'x_' reassigned"),
    ("    if a > 0:\n        y = carray(x_, (1,))\n    else:\n        y = 1.0\n    return 1 if y else 0",
     "'y' is not bound the same way on every path"),
    ("    if a > 0:\n        z = 1.0\n    return 1 if z > 0 else 0", "'z' is not bound the same way on every path"),
    ("    return 1 if 0 < a < 1 else 0", "chained or unsupported comparison"),
    ("    x = carray(x_, (1,))\n    return 1 if x[-1] > 0 else 0", "index -1"),
    ("    if a > 0:\n        return 1", "may end without a return"),
    ("    return 1 if a > 123456789012345678901234567890 else 0", "constant 123456789012345678901234567890"),
    ("    for k in range(3):\n        a = k\n    return 0", "'a' changes its kind in a loop"),
])
def test_what_is_outside_the_subset_is_refused_by_name(body, message):
    source = HEADER + "def h(a, x_):\n" + body + "\n"
    with pytest.raises(Untranslatable, match=message.replace("(", r"\(")) as raised:
        compile_function(source, "h", ["f", ("ptr", "f")], "i", f"hbg_test_native_{next(_serial)}",
                         dialect=IMPORTS)
    if "line" in str(raised.value):
        assert "line " in str(raised.value)


@pytest.mark.parametrize("body, message", [
    ("    print(a)\n    return 0", "the name(s) 'print' (in 'h', from line 6)"),
    ("    import os\n    return 0", "the name(s) 'os' (in 'h', from line 6)"),
    ("    return np.save(a)", "the name(s) 'save' (in 'h', from line 6)"),
])
def test_what_the_generator_never_writes_is_refused_before_translation(body, message):
    source = HEADER + "def h(a, x_):\n" + body + "\n"
    with pytest.raises(GeneratedCodeError, match=message.replace("(", r"\(").replace(")", r"\)")):
        compile_function(source, "h", ["f", ("ptr", "f")], "i", f"hbg_test_native_{next(_serial)}",
                         dialect=IMPORTS)


# ------------------------------------------------------------------ the shipped models' mode functions

D = ctypes.POINTER(ctypes.c_double)
MODE_PROTOTYPE = ctypes.CFUNCTYPE(ctypes.c_int64, ctypes.c_int64, ctypes.c_int64, ctypes.c_double, ctypes.c_double,
                                  ctypes.c_double, D, D, D, D, D, D, D, ctypes.POINTER(ctypes.c_int64),
                                  ctypes.POINTER(ctypes.c_uint8), D)
ARRAYS = ("x", "xp", "p", "u", "d", "s", "post")


def call_mode(function, op, which, t, arrays):
    return function(op, which, t, 1e-9, 1e-12, *[pointer(arrays[n]) for n in ARRAYS], pointer(arrays["target"]),
                    pointer(arrays["q"]), pointer(arrays["out"]))


def assert_modes_agree_with_numba(model, trials: int = 60):
    """Every visited mode's function, compiled both ways, gives the same bits
    for every operation on random states (zero pulses a third of the time)."""
    from switching.kernel import loop as kernel
    from switching.library.jit_model import mode_function_source, native_signature

    rng = np.random.default_rng(11)
    signature = (kernel.MODE_SIGNATURE.args, kernel.MODE_SIGNATURE.return_type)
    for mode in model.visited_modes:
        source = mode_function_source(model, mode)
        compiled = compile_function(source, "mode", *native_signature(), f"hbg_test_native_{next(_serial)}",
                                    dialect=IMPORTS, calls=mode_calls())
        namespace: dict = {}
        exec(compile(source, "<mode source>", "exec"), namespace)
        reference = CFunc(namespace["mode"], signature, locals={}, options={"error_model": "numpy"})
        reference.compile()
        ours, theirs = MODE_PROTOTYPE(compiled.address), MODE_PROTOTYPE(reference.address)
        n_guards = len(model.compiled_mode(mode).guards)
        for trial in range(trials):
            base = {n: rng.normal(size=512) * 10.0 ** rng.integers(-3, 3) for n in ARRAYS + ("out",)}
            if trial % 3 == 0:
                base["d"][:] = 0.0
            base["target"] = np.full(64, -1, dtype=np.int64)
            base["q"] = rng.integers(0, 2, size=512).astype(np.uint8)
            t = float(rng.normal())
            for op, which in [(0, 0), (1, 0), (2, 0), (3, 0), (4, 0), (4, 1)] + [(5, g) for g in range(n_guards)]:
                a = {k: v.copy() for k, v in base.items()}
                b = {k: v.copy() for k, v in base.items()}
                with np.errstate(all="ignore"):
                    got, expected = call_mode(ours, op, which, t, a), call_mode(theirs, op, which, t, b)
                assert got == expected and all(same_bits(a[k], b[k]) for k in a), (mode.label, op, which, trial)


def visited(name: str, **parameters):
    family = models.load(name)
    model = family.build(**parameters)
    model.cache = SourceCache(None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.simulate(getattr(family, "T_END", 1.0), "RK45")
    return model


@pytest.mark.parametrize("name", ["bouncing_ball", "diode_circuit", "parallel_capacitors", "colliding_balls"])
def test_mode_functions_of_small_models_agree_with_numba_bit_for_bit(name):
    assert_modes_agree_with_numba(visited(name))


@pytest.mark.slow
@pytest.mark.parametrize("name", [m for m in models.MODELS
                                  if m not in ("bouncing_ball", "diode_circuit", "parallel_capacitors",
                                               "colliding_balls")])
def test_mode_functions_of_every_shipped_model_agree_with_numba_bit_for_bit(name):
    assert_modes_agree_with_numba(visited(name, **({"N": 4} if name == "ball_chain" else {})))


@pytest.mark.slow
def test_mode_functions_of_model_files_and_law_switches_agree_with_numba():
    from switching.files.modelfile import load_model

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bondgraph"))  # (where the law switches live)
    from test_law_switches import bang_bang, sign_block

    files = [load_model(path) for path in sorted(models.EXAMPLES.glob("*.toml"))]
    assert len(files) >= 2
    for model in files + [sign_block(c=0.5, F=1.0), bang_bang()]:
        model.cache = SourceCache(None)
        model.simulate(3.0, "RK45")
        assert_modes_agree_with_numba(model, trials=30)


# ------------------------------------------------------------------ in the compiled methods

RUN = textwrap.dedent(
    """
    import json, warnings
    warnings.simplefilter("always")
    import models.bouncing_ball as bouncing_ball
    from codegen import machine
    model = bouncing_ball.build()
    model.simulate(2.0, "RK45")
    run = model.simulate(2.0, "RK45-jit")
    print(json.dumps({"origins": sorted(f.origin for f in machine.LOADED.values() if f.backend == "native"),
                      "t": run.t.tolist(), "x": run.x.tolist()}))
    """
)


def run_python(script: str, cache: Path, **env) -> subprocess.CompletedProcess:
    environment = {**os.environ, "HBG_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT), **env}
    return subprocess.run([sys.executable, "-c", script], cwd=ROOT, env=environment, capture_output=True, text=True,
                          timeout=600)


def test_machine_code_is_kept_loaded_by_a_new_process_and_rebuilt_when_damaged(tmp_path):
    first = run_python(RUN, tmp_path)
    assert first.returncode == 0, first.stderr
    compiled = json.loads(first.stdout)
    assert compiled["origins"] == ["compiled", "compiled"]
    files = sorted((tmp_path / "jit").glob("hbg_mode_*.native"))
    assert len(files) == 2
    for path in files:  # one entry of the disk cache with the mode's source: evicted together
        assert path.name[len("hbg_mode_"):-len(".native")] in cache_entries(tmp_path)

    second = run_python(RUN, tmp_path)
    assert second.returncode == 0 and "Warning" not in second.stderr, second.stderr
    loaded = json.loads(second.stdout)
    assert loaded["origins"] == ["loaded", "loaded"]
    assert loaded["t"] == compiled["t"] and loaded["x"] == compiled["x"]

    damaged, foreign = files
    damaged.write_bytes(damaged.read_bytes()[:-100])  # truncated
    head, rest = foreign.read_bytes().split(b"\n", 1)
    foreign.write_bytes(head + b"\n" + b"another machine" + rest[rest.index(b"\n"):])  # compiled elsewhere
    third = run_python(RUN, tmp_path)
    assert third.returncode == 0 and "Traceback" not in third.stderr, third.stderr
    assert third.stderr.count("CacheWarning") == 1 and "could not be read" in third.stderr
    assert "truncated or corrupted" in third.stderr
    rebuilt = json.loads(third.stdout)
    assert rebuilt["origins"] == ["compiled", "compiled"]
    assert rebuilt["t"] == compiled["t"] and rebuilt["x"] == compiled["x"]
    fourth = run_python(RUN, tmp_path)  # both written anew, for this machine
    assert fourth.returncode == 0 and "Warning" not in fourth.stderr, fourth.stderr
    assert json.loads(fourth.stdout)["origins"] == ["loaded", "loaded"]


def _ball_run(cache: Path):
    from models import bouncing_ball
    from switching.library import jit_model

    model = bouncing_ball.build()
    model.cache = SourceCache(cache)
    model.simulate(2.0, "RK45")
    run = model.simulate(2.0, "RK45-jit")
    return run, [jit_model.mode_function(model, mode) for mode in sorted(model.visited_modes, key=lambda m: m.label)]


def test_numba_compiles_what_is_not_translated_with_the_same_run(tmp_path, monkeypatch):
    """``HBG_NATIVE=0``, a refused source and a fault of the translator (with
    a warning) all go to numba's front end; the run is the same to the bit."""
    from codegen import machine

    reference, functions = _ball_run(tmp_path / "native")
    assert all(f.backend == "native" and isinstance(f.handle, native.NativeFunction) for f in functions)

    monkeypatch.setenv("HBG_NATIVE", "0")
    run, functions = _ball_run(tmp_path / "numba")
    assert all(f.backend == "numba" and isinstance(f.handle, CFunc) for f in functions)
    assert same_bits(run.t, reference.t) and same_bits(run.x, reference.x)
    monkeypatch.delenv("HBG_NATIVE")

    def refuse(*args, **kwargs):
        raise Untranslatable("a construct numba knows")

    monkeypatch.setattr(machine, "LOADED", {})
    monkeypatch.setattr(native, "compile_function", refuse)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # refused: silently numba's
        run, functions = _ball_run(tmp_path / "refused")
    assert all(f.backend == "numba" and isinstance(f.handle, CFunc) for f in functions)
    assert same_bits(run.t, reference.t) and same_bits(run.x, reference.x)

    def fail(*args, **kwargs):
        raise RuntimeError("a fault of the translator")

    monkeypatch.setattr(machine, "LOADED", {})
    monkeypatch.setattr(native, "compile_function", fail)
    with pytest.warns(RuntimeWarning, match="a fault of the translator.*numba compiles it instead.*HBG_NATIVE=0"):
        run, functions = _ball_run(tmp_path / "fault")
    assert all(f.backend == "numba" and isinstance(f.handle, CFunc) for f in functions)
    assert same_bits(run.t, reference.t) and same_bits(run.x, reference.x)
