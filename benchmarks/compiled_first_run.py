"""What a new user pays for the compiled path: ``hbg run`` in new processes.

    python benchmarks/compiled_first_run.py [--model falling-rod] [--repeats 1]

Each row is one new process running ``hbg run MODEL`` with the CLI's
defaults (``--samples 500``: ``simulate(..., samples=500)``, from the
kernel's dense output on the compiled path), timed from outside (wall time of the whole
command: Python start-up, imports, derivations, compilation, the run, the
summary).  States of the caches:

  cold          an empty toolkit cache (``HBG_CACHE_DIR``) and, for the
                compiled path, an empty numba cache for the kernel
                (``NUMBA_CACHE_DIR``: as on a new installation): the kernel
                and the visited modes' functions are compiled;
  kernel cached an empty toolkit cache, the kernel in this installation's
                numba cache (``switching/__pycache__``): only the modes'
                functions are compiled;
  second        the same command again in a new process: everything loaded.

Then the compile time of each mode's function (a new process per model,
the kernel cached), the kernel's own reload time after numba's import, and
where a second process's time goes (the phases of the run, caches warm).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HBG = [sys.executable, "-m", "models.cli"]


def timed_run(arguments, environment) -> tuple[float, str]:
    start = time.perf_counter()
    done = subprocess.run(HBG + arguments, env=environment, cwd=ROOT, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(done.stderr)
    resolved = [line.split(":")[-1].strip() for line in done.stdout.splitlines() if "resolved in Python" in line]
    return seconds, (resolved[0] if resolved else "-")


MODE_TIMES = """
import sys, time
sys.path.insert(0, {root!r})
import numba
from models import {module} as family
model = family.build()
model.simulate({t_end}, "RK45", rtol=1e-6)
from switching.library.jit_model import kernel, mode_function
start = time.perf_counter(); k = kernel(); k.run  # the module; its functions load on first call
for mode in model.visited_modes:
    start = time.perf_counter()
    mode_function(model, mode)
    print(f"  {{mode.label:<40}} {{time.perf_counter() - start:.3f}} s")
"""

KERNEL_LOAD = """
import sys, time
sys.path.insert(0, {root!r})
import numba
from models import bouncing_ball
model = bouncing_ball.build()
model.simulate(2.5, "RK45", rtol=1e-6)
compiled = model.compiled_model()  # the modes' functions (cached)
import numpy as np
from switching.library.jit_model import kernel
k = kernel()
start = time.perf_counter()
k.workspace_sizes(compiled.record, 2, 3, 10)  # loads workspace_sizes
middle = time.perf_counter()
model.simulate(2.5, "RK45-jit", rtol=1e-6, output="events")  # loads run
print(f"{{middle - start:.3f}} {{time.perf_counter() - middle:.3f}}")
"""

# where a second process's time goes (caches warm): seconds since the process started, after each phase
PHASES = """
import time
start = time.perf_counter()
import sys
sys.path.insert(0, {root!r})
marks = []
def mark(name):
    marks.append((name, time.perf_counter() - start))
from models import {module} as family
mark("models imported")
model = family.build()
mark("model built")
if {compiled}:
    import numba
    mark("numba imported")
    from switching.library.jit_model import kernel
    kernel()
    mark("kernel module")
model.simulate({t_end}, {method!r}, samples=500)  # hbg run's default rows
mark("run done")
print(", ".join(f"{{name}} {{seconds:.3f}}" for name, seconds in marks))
"""


def main(argv=None):
    parser = argparse.ArgumentParser()
    parser.add_argument("--model", default="falling-rod")
    parser.add_argument("--repeats", type=int, default=1, help="rounds of the whole table (medians)")
    args = parser.parse_args(argv)
    rows: dict = {}
    for _ in range(args.repeats):
        for method in ("RK45", "RK45-jit"):
            with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as numba_cache, \
                    tempfile.TemporaryDirectory() as cache2:
                base = {**os.environ, "HBG_CACHE_DIR": cache}
                command = ["run", args.model] + (["--method", method] if method != "RK45" else [])
                if method == "RK45-jit":
                    rows.setdefault((method, "cold (new installation)"), []).append(
                        timed_run(command, {**base, "NUMBA_CACHE_DIR": numba_cache}))
                    base = {**os.environ, "HBG_CACHE_DIR": cache2}
                rows.setdefault((method, "cold" if method == "RK45" else "kernel cached, toolkit cache empty"),
                                []).append(timed_run(command, base))
                rows.setdefault((method, "second process"), []).append(timed_run(command, base))
    print(f"hbg run {args.model} (CLI defaults: --samples 500), wall time of the command")
    print(f"  {'method':<9} {'caches':<36} {'seconds':>8}  instants resolved in Python")
    for (method, state), runs in rows.items():
        seconds = statistics.median(r[0] for r in runs)
        print(f"  {method:<9} {state:<36} {seconds:>8.2f}  {runs[-1][1]}")

    module = args.model.replace("-", "_")
    t_end = {"falling_rod": 0.5, "bouncing_ball": 2.5}.get(module, 1.0)
    for name, end in ((module, t_end), ("bouncing_ball", 2.5)):
        with tempfile.TemporaryDirectory() as cache:
            print(f"\ncompiling each visited mode's function ({name}; codegen.native, or numba with HBG_NATIVE=0; "
                  "the first pays the code generator's set-up):")
            done = subprocess.run([sys.executable, "-c", MODE_TIMES.format(root=str(ROOT), module=name, t_end=end)],
                                  env={**os.environ, "HBG_CACHE_DIR": cache}, capture_output=True, text=True,
                                  check=True)
            print(done.stdout.rstrip())
    with tempfile.TemporaryDirectory() as cache:
        environment = {**os.environ, "HBG_CACHE_DIR": cache}
        script = KERNEL_LOAD.format(root=str(ROOT))
        subprocess.run([sys.executable, "-c", script], env=environment, capture_output=True, text=True, check=True)
        done = subprocess.run([sys.executable, "-c", script], env=environment, capture_output=True, text=True,
                              check=True)
        sizes, first = (float(v) for v in done.stdout.split())
        print(f"\nthe kernel reloaded from numba's cache in a new process (after numba's import and set-up): "
              f"workspace_sizes {sizes:.3f} s, then run + the first RK45-jit run {first:.3f} s")
    print(f"\na second process, caches warm ({module}; seconds since the process started; best of 3):")
    with tempfile.TemporaryDirectory() as cache:
        environment = {**os.environ, "HBG_CACHE_DIR": cache}
        for method in ("RK45", "RK45-jit"):
            script = PHASES.format(root=str(ROOT), module=module, t_end=t_end, method=method,
                                   compiled=method.endswith("-jit"))
            runs = [subprocess.run([sys.executable, "-c", script], env=environment, capture_output=True, text=True,
                                   check=True).stdout.strip() for _ in range(4)][1:]  # the first fills the caches
            best = min(runs, key=lambda line: float(line.rsplit(" ", 1)[1]))
            print(f"  {method:<9} {best}")

if __name__ == "__main__":
    main()
