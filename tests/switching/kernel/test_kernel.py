"""The model-independent kernel (switching.kernel.loop) on its own: its rules
agree with the Python path's references, and a mode's function is called
through its address with the operations and array sizes it declares."""

import itertools
import math

import numpy as np
import pytest

pytest.importorskip("numba")

from codegen.runtime import Hyper, decide  # noqa: E402
from switching.kernel import loop as kernel  # noqa: E402
from checkout import ROOT

_OPS = ["<", "<=", ">", ">=", "==", "!="]


def test_the_kernels_comparison_is_codegen_runtime_decide():
    """The guard band (rtol·max(|l|, |r|, scale) + atol, ``<=`` including it,
    ``<`` excluding it) and impulses dominating finite parts: the same
    decision as the reference on every case, edges of the band included."""
    rtol, atol = 1e-9, 1e-12
    finite = [0.0, 1.0, 1.0 + 5e-10, 1.0 + 2e-9, -1.0, 1e-13, -3e-12, math.inf, -math.inf, math.nan]
    impulses = [0.0, 1.0, -1.0, 1e-20]
    scales = [0.0, 10.0, math.inf]
    checked = 0
    for (k, op), lf, rf, li, sc in itertools.product(enumerate(_OPS), finite, finite[:5], impulses, scales):
        expected = decide(op, Hyper(li, lf), Hyper(0.0, rf), rtol, atol, sc if math.isfinite(sc) else 0.0)
        got = kernel.decide(k, li, lf, 0.0, rf, sc, rtol, atol)
        assert got == expected, (op, li, lf, rf, sc)
        checked += 1
    assert checked == 6 * 10 * 5 * 4 * 3


def test_the_kernels_dense_output_coefficients_are_scipys():
    from scipy.integrate._ivp.rk import RK45

    assert np.array_equal(kernel.RK_P, RK45.P)
    assert np.array_equal(kernel.RK_A, RK45.A[:, :5]) and np.array_equal(kernel.RK_B, RK45.B)
    assert np.array_equal(kernel.RK_C, RK45.C) and np.array_equal(kernel.RK_E, RK45.E)


def test_a_mode_function_is_called_through_its_address():
    """The bouncing ball's flight: op 0 (rates), 3 (jump: the identity in
    flight), 2 (a guard holds during flow: y ≤ 0 while falling) through the
    same function pointer the kernel calls."""
    import numba

    from models import bouncing_ball
    from switching.library.jit_model import CompiledModel

    model = bouncing_ball.build()
    compiled = CompiledModel(model, [model.mode("flight")])
    record = compiled.record
    assert record.fns[0] == compiled.functions[0].address

    @numba.njit
    def call(record, op, x, s, out):
        return kernel.call(record.fns[0], op, 0, 0.0, 1e-9, 1e-12, x, x, record.p, record.u, x, s, s,
                            record.radix, record.radix, out)

    assert [s.name for s in model.states] == ["p", "y"] and model.parameter_array[2] == 1.0  # m = 1 kg
    out, s = np.zeros(2), np.zeros(64)
    x = np.array([-2.0, 0.5])  # momentum p = m·v (falling at 2 m/s), height 0.5 m
    assert call(record, 0, x, s, out) == 0
    rates = model.compiled_mode("flight")._rates(x.tolist(), 0.0, model.parameter_array.tolist(), [], np.zeros(2))
    np.testing.assert_array_equal(out, rates)
    assert call(record, 3, x, s, out) == 1 and list(out) == list(x)
    assert call(record, 2, x, s, out) == 0  # in the air
    assert call(record, 2, np.array([-2.0, -1e-3]), s, out) == 1  # below the floor, falling: the guard holds
    assert call(record, 2, np.array([2.0, -1e-3]), s, out) == 0  # below it but rising: no guard holds


_KERNEL_RUN = """
import json, sys, warnings
warnings.simplefilter("always")
from switching.library.jit_model import kernel
from models import bouncing_ball
model = bouncing_ball.build()
model.simulate(2.0, "RK45")
run = model.simulate(2.0, "RK45-jit")
k = kernel()
from switching.kernel import implicit
explicit = [str(signature[-1]) for signature in k.run.overloads]
print(json.dumps({"cache": k.run._cache._cache_path, "t": list(run.t), "compiled": len(k.run.stats.cache_misses),
                  "last_arguments": explicit, "implicit_loaded": len(implicit.rosenbrock_step.signatures)}))
"""


@pytest.mark.slow  # compiles the kernel's run again (~20 s)
def test_unreadable_cache_files_of_the_kernel_are_deleted_and_it_is_compiled_again(tmp_path):
    """The kernel's numba cache (once per installation) cannot fail a run:
    an index of garbage is deleted with a CacheWarning, ``run`` compiled
    again, and the next process loads it silently."""
    import json
    import os
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    root = ROOT
    environment = dict(os.environ, HBG_CACHE_DIR=str(tmp_path / "hbg"), NUMBA_CACHE_DIR=str(tmp_path / "numba"))

    def process():
        done = subprocess.run([sys.executable, "-c", _KERNEL_RUN], env=environment, cwd=root, capture_output=True,
                              text=True, timeout=900)
        assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
        return json.loads(done.stdout.splitlines()[-1]), done.stderr

    installed = Path(kernel.run._cache._cache_path)  # this installation's cache (the kernel compiled or loaded)
    probe = subprocess.run([sys.executable, "-c", "from switching import kernel; print(kernel.run._cache._cache_path)"],
                           env=environment, cwd=root, capture_output=True, text=True, check=True)
    private = Path(probe.stdout.strip())
    private.mkdir(parents=True, exist_ok=True)
    from switching.kernel import MODULES

    for name in MODULES:  # the kernel's modules' cache files
        for path in installed.glob(f"{name}.*"):
            shutil.copy2(path, private / path.name)
    for index in private.glob("loop.run-*.nbi"):  # (earlier versions of the file leave theirs too)
        index.write_bytes(os.urandom(300))
    first, warned = process()
    assert first["cache"] == str(private) and first["compiled"] == 1
    # an explicit run compiles run's explicit specialisation alone: the implicit method is not typed into it (its
    # step's dispatcher would load its cache file, copied above, if it were)
    assert first["last_arguments"] == ["none"] and first["implicit_loaded"] == 0
    assert "CacheWarning" in warned and "could not be read" in warned
    second, quiet = process()
    assert second["compiled"] == 0 and "CacheWarning" not in quiet
    np.testing.assert_array_equal(second["t"], first["t"])
