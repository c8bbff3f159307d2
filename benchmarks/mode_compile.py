"""Compile time of each visited mode's function: codegen.native against numba's front end.

    python benchmarks/mode_compile.py [MODEL ...]

For every shipped model (or those named), a short Python run finds the
visited modes; each mode's generated source (switching.library.jit_model) is then
compiled twice in this process, with nothing cached: by
:func:`codegen.native.compile_function` (translated to LLVM IR, optimised
and compiled by numba's code generator) and by numba itself (a ``CFunc`` of
the same source, as with ``HBG_NATIVE=0``).  The first compile of each
kind also pays its code generator's set-up (both are warmed up first on a
throw-away mode).  Issue 14's target: one more mode of a model in ≤ 1 s.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import models  # noqa: E402
from codegen.cache import SourceCache  # noqa: E402


def visited_model(name: str):
    family = models.load(name)
    model = family.build(**({"N": 4} if name == "ball_chain" else {}))
    model.cache = SourceCache(None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.simulate(getattr(family, "T_END", 1.0), "RK45")
    return model


def main(names) -> None:
    from numba.core.ccallback import CFunc

    from codegen.backends import BACKENDS
    from switching.kernel import loop as kernel
    from switching.library.jit_model import MODE_DIALECT, mode_calls, mode_function_source, mode_signature

    signature = (kernel.MODE_SIGNATURE.args, kernel.MODE_SIGNATURE.return_type)
    serial = iter(range(10**9))

    def native(source):
        start = time.perf_counter()
        BACKENDS["native"].compile(source, "mode", mode_signature(), symbol=f"hbg_benchmark_{next(serial)}",
                                   dialect=MODE_DIALECT, calls=mode_calls())
        return time.perf_counter() - start

    def numba(source):
        namespace: dict = {}
        exec(compile(source, "<mode source>", "exec"), namespace)  # the generated module (our own text)
        start = time.perf_counter()
        CFunc(namespace["mode"], signature, locals={}, options={"error_model": "numpy"}).compile()
        return time.perf_counter() - start

    warm = mode_function_source(*_first_mode(visited_model("bouncing_ball")))
    native(warm), numba(warm)
    print(f"{'model':<22}{'mode':<34}{'lines':>6}{'native [s]':>12}{'numba [s]':>11}{'ratio':>7}")
    totals = [0.0, 0.0]
    for name in names:
        model = visited_model(name)
        for mode in sorted(model.visited_modes, key=lambda m: m.label):
            source = mode_function_source(model, mode)
            a, b = native(source), numba(source)
            totals[0] += a
            totals[1] += b
            print(f"{name:<22}{mode.label:<34}{source.count(chr(10)):>6}{a:>12.3f}{b:>11.3f}{b / a:>7.1f}")
    print(f"{'all':<56}{totals[0]:>12.3f}{totals[1]:>11.3f}{totals[1] / totals[0]:>7.1f}")


def _first_mode(model):
    return model, sorted(model.visited_modes, key=lambda m: m.label)[0]


if __name__ == "__main__":
    main(sys.argv[1:] or list(models.MODELS))
