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

Each row names its method (``--method RK45``): the CLI's default is ``auto``,
which runs ``RK45-jit`` once the kernel and the modes are cached, so the
"RK45" rows of earlier tables (before issue 46's second round) compared the
compiled path with itself in the second process.

Measured (issue 46, falling rod, ``--repeats 3``, medians; a 2-core machine
shared with two other workers' test runs, load average ~2, so a row moves
by ±0.2 s between runs; this environment sets ``PYTHONDONTWRITEBYTECODE=1``:
every import compiles its module, for both paths):

  second process, wall time of hbg run     before (6e04426)   after (7fb1f7e)
    RK45      (the Python path)                 1.49 s             1.28 s
    RK45-jit                                    2.09 s             1.79 s
    ratio                                       1.40               1.40

The CPU time of the first ``simulate`` of a process with the CLI's imports
done (``models.cli``, ``models.spice``), caches warm, median of 5 processes:

                                   before (6e04426)   after (7fb1f7e)
    falling rod    RK45               0.060 s             0.058 s
                   RK45-jit           0.410 s             0.361 s
    bouncing ball  RK45               0.080 s             0.080 s
                   RK45-jit           0.441 s             0.359 s

Where the compiled path's extra 0.3 s of a second process goes (after):
``import numba`` 0.12 s; the kernel's modules 0.04 s (88 dispatchers made,
the sources hashed for the cache stamp); the modes' functions 0.02 s; the
kernel's three cached functions loaded (workspace_sizes, run, merged_rows:
their environments import numba's array implementations) and numba's runtime
initialised (it compiles its atomic helpers) 0.05–0.07 s; and the
interpreter's exit, which tears numba's modules down: 0.36 s against 0.25 s.
Numba's refresh of its target and typing contexts (its registries of
implementations imported and installed, ~0.2 s), which every load from its
disk cache made first, is no longer made (``codegen.numba_internals.
load_cached``; numba's compiler refreshes them itself before it compiles):
the kernel's environments still import part of those modules, so the first
run's CPU time fell by 0.05–0.08 s.  The rest is numba's own import and
exit, which the Python path does not pay at all: the compiled path's second
process stays ~1.3–1.4× the Python path's while it imports numba.

The interpreter's exit (issue 46): ``hbg`` (``models.cli.command``) freezes the run's objects
(``gc.freeze``) before the process exits, so the exit no longer walks them with the cyclic collector.
``--repeats 3``, falling rod, this machine (2 cores, quiet), before (2641e17) and after:

  second process, wall time of hbg run       before      after
    RK45      (the Python path)               1.21 s      0.91 s
    RK45-jit                                  1.89 s      1.29 s
    ratio                                     1.56        1.42

The exit alone, timed from the end of ``main`` to the process's end: 0.28 -> 0.03 s (RK45), 0.45 ->
0.04 s (RK45-jit).  What still separates the paths is numba's import (0.15–0.19 s on its own, which
checking whether the kernel is cached already pays: ``models.cli.run._compile_notice``) and the
kernel's load from its cache (~0.13 s with the first run): the target, no slower than the Python path,
is not reached while the compiled path imports numba.

``auto`` (the CLI's default) now counts that load (issue 46, session 24): in a process that has not
run the kernel, a run expected to take less than loading it (``switching.library.jit_model.
load_seconds``: numba's import and the kernel's load, ≈ 0.3 s) runs in Python, until the Python runs
so chosen add up to the load's cost (then the kernel is loaded: a sweep of short runs pays it once).
An ``RK45-jit`` run chosen by ``auto`` records its work as a Python RK45 run does (the same steps), so
the second process knows what a Python run costs.  ``--repeats 3``, falling rod, medians::

  hbg run falling-rod                            seconds
    RK45      second process                       0.90
    RK45-jit  second process                       1.25
    auto      kernel cached, toolkit cache empty   2.59   (chose RK45-jit: compiles the modes)
    auto      second process                       0.97   (chose RK45: expected ≈ 0.009 s)

and five alternating pairs of ``hbg run falling-rod --method RK45`` / ``--method auto``: 0.94–1.05 s
/ 0.98–1.02 s: the default command's second process costs what the Python path costs.  An explicit
``--method RK45-jit`` still pays numba's import (1.25 s, 1.39× the Python path).

The kernel's load imports no more of numba than numba's own import (issue 46, session 25).  Loading
a compiled function from numba's cache rebuilds its environments, and each environment imports the
module it was compiled from: the kernel had three of numba's own, from ``x ** 2`` (``numba.cpython.
numbers``), ``np.searchsorted`` (``numba.np.arraymath``) and ``reshape``/``np.empty``
(``numba.np.arrayobj``), which with what they import are 15 modules beyond ``import numba``.  Now the
squares are products, the search is written out, the workspaces' two-dimensional views are made
directly (``switching.kernel.views``) and the merged rows' arrays are made in Python
(``switching.library.kernel_rows``).  The first ``RK45-jit`` run of the bouncing ball in a new
process (caches warm, after a Python run; CPU seconds, five alternating pairs, no ``.pyc`` files in
either tree): 0.32–0.48 s before (7c37dd7), 0.22–0.25 s after; ``hbg run falling-rod`` (six
alternating rounds, seconds): RK45 1.15 / RK45-jit 1.46 before, 1.14 / 1.42 after (the CLI's
own imports load part of those modules anyway).  What remains is numba's import itself.
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


def timed_run(arguments, environment) -> tuple[float, str, str]:
    """``(wall seconds, instants resolved in Python, what auto chose)`` of ``hbg`` with ``arguments``."""
    start = time.perf_counter()
    done = subprocess.run(HBG + arguments, env=environment, cwd=ROOT, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(done.stderr)
    lines = done.stdout.splitlines()
    resolved = [line.split(":")[-1].strip() for line in lines if "resolved in Python" in line]
    chosen = [line.split("method chosen by auto:")[1].split(":")[0].strip() for line in lines
              if "method chosen by auto:" in line]
    return seconds, (resolved[0] if resolved else "-"), (chosen[0] if chosen else "")


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
        for method in ("RK45", "RK45-jit", "auto"):
            with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as numba_cache, \
                    tempfile.TemporaryDirectory() as cache2:
                base = {**os.environ, "HBG_CACHE_DIR": cache}
                command = ["run", args.model, "--method", method]  # (the CLI's default is auto)
                if method == "RK45-jit":
                    rows.setdefault((method, "cold (new installation)"), []).append(
                        timed_run(command, {**base, "NUMBA_CACHE_DIR": numba_cache}))
                    base = {**os.environ, "HBG_CACHE_DIR": cache2}
                rows.setdefault((method, "cold" if method == "RK45" else "kernel cached, toolkit cache empty"),
                                []).append(timed_run(command, base))
                rows.setdefault((method, "second process"), []).append(timed_run(command, base))
    print(f"hbg run {args.model} (CLI defaults: --samples 500), wall time of the command")
    print(f"  {'method':<9} {'caches':<36} {'seconds':>8}  instants resolved in Python  (auto: its choice)")
    for (method, state), runs in rows.items():
        seconds = statistics.median(r[0] for r in runs)
        chosen = f"  ({runs[-1][2]})" if runs[-1][2] else ""
        print(f"  {method:<9} {state:<36} {seconds:>8.2f}  {runs[-1][1]}{chosen}")

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
