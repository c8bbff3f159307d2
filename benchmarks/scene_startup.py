"""Time from model to result on an empty cache: what a user meets first.

    python benchmarks/scene_startup.py [N ...]

Each row runs in a new process with an empty disk cache (``HBG_CACHE_DIR``
set to a fresh temporary directory), so nothing derived earlier helps:

* ``ball_chain.build(N=N, e=1.0).simulate(1.0, "RK45", rtol=1e-9)`` — the
  ideal chain derives one mode per pinnacle (N modes); printed: the whole
  run, the CPU time of the child, and the time per derived mode (which should
  not grow faster than linearly in N: each mode holds N − 1 contact guards).
* the falling rod's default run (``models.falling_rod.RUN``), as
  ``hbg run falling-rod`` does it.

Issue 15's targets: N = 50 in ≤ 3 s, N = 200 in ≤ 30 s, the falling rod in
≤ 2 s.  The machine's load matters: compare CPU seconds when it is busy.
The chain's instant passes N − 1 pinnacles, so its step cap is raised to 2N
(the default, 1000, stops N = 1000 at its last pinnacle).

Issue 46 (a scene's cost per mode flat in N; targets: N = 1000 in 30 s,
N = 500 in 12 s, a mode at N = 1000 within 1.5 times one at N = 50).
``python benchmarks/scene_startup.py 50 200 500 1000`` (run seconds on a
shared two-core machine; before: commit 43e65e8)::

    N      modes   before [s]   ms/mode   after [s]   ms/mode
    50        50        2.44         49        1.45         29
    200      200       11.33         57        6.64         33
    500      500       53.84        108       26.63         53
    1000    1000      165 *        165       98.81         99

(* CPU seconds of the child: it ran beside another N = 1000 run, 257 s of
wall time; with the default step cap it stops at its last pinnacle.)

What grew with N per mode, and what was done (each the same modes, instants
and states to the bit): the disk cache listed its whole directory at every
store (now only when a store could have put it over its cap); the islands of
a configuration were found by a walk of every element and bond (now from the
graph's cells, joined across the on junctions only); the generated module's
text was searched again for its functions (now handed over as assembled);
every function's docstring escaped the thousand state entries again (now
once per argument list); a mode's storage co-energies, its rates' symbols
and its rate-free guard comparisons were derived again (now kept); guards on
plain numbers made Hyper values; the cyclic garbage collector walked every
earlier mode's objects while a mode was prepared (now it waits until the
mode is made).  Left: a mode's module is still written whole — every
function lists every state, ``rates``, ``phi`` and ``jump`` print every
state's entry and META every guard (≈ 1.6 kB per ball a mode: 1.6 MB a mode
at N = 1000, over the cache's 500 MB cap after 300 modes) — so generating,
hashing, storing and compiling it, and deciding every guard at each
pinnacle, still cost O(N) a mode.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_CHILD = r"""
import json, sys, time
start = time.perf_counter()
sys.path.insert(0, {root!r})
from models import ball_chain, falling_rod
imported = time.perf_counter()
if {n} > 0:
    model = ball_chain.build(N={n}, e=1.0)
    model.max_steps_per_instant = max(1000, 2 * {n})  # (the instant passes N - 1 pinnacles)
    model.simulate(1.0, "RK45", rtol=1e-9)
else:
    model = falling_rod.build()
    run = dict(falling_rod.RUN)
    model.simulate(run.pop("t_end"), run.pop("method", "RK45"), **run)
done = time.perf_counter()
print(json.dumps({{"import": imported - start, "run": done - imported, "cpu": time.process_time(),
                  "modes": model.derivation_count}}))
"""


def measure(n: int) -> dict:
    with tempfile.TemporaryDirectory() as cache:
        out = subprocess.run([sys.executable, "-c", _CHILD.format(root=str(ROOT), n=n)], capture_output=True,
                             text=True, check=True, env={"HBG_CACHE_DIR": cache, "PATH": "/usr/bin:/bin"})
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(sizes) -> None:
    print(f"{'scene':<18} {'import [s]':>10} {'run [s]':>9} {'cpu [s]':>8} {'modes':>6} {'per mode [ms]':>14}")
    for n in sizes:
        row = measure(n)
        name = f"ball chain N={n}" if n else "falling rod"
        per_mode = 1e3 * row["run"] / max(row["modes"], 1)
        print(f"{name:<18} {row['import']:>10.2f} {row['run']:>9.2f} {row['cpu']:>8.2f} {row['modes']:>6d} "
              f"{per_mode:>14.0f}")


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [0, 10, 20, 50])
