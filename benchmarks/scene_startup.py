"""Time from model to result on an empty cache: what a user meets first.

    python benchmarks/scene_startup.py [--warm] [N ...]

Each row runs in a new process with an empty disk cache (``HBG_CACHE_DIR``
set to a fresh temporary directory), so nothing derived earlier helps:

* ``ball_chain.build(N=N, e=1.0).simulate(1.0, "RK45", rtol=1e-9)`` — the
  ideal chain derives one mode per pinnacle (N modes); printed: the whole
  run, the CPU time of the child, and the time per derived mode (which should
  not grow faster than linearly in N: each mode holds N − 1 contact guards).
* the falling rod's default run (``models.falling_rod.RUN``), as
  ``hbg run falling-rod`` does it.

With ``--warm`` each row runs a second process on the cache the first filled:
a user's second run, which derives nothing and reads every mode from disk.

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
mode is made).

Then (commits 136648c, 1ed25cf, bf9aa2a; CPU seconds of the child, the
machine shared with two other workers at a load of 2–3, before and after
measured one after the other under that load; before: commit ae326a3)::

    N      modes   before cpu [s]   ms/mode   after cpu [s]   ms/mode
    50        50             2.38        48            1.85        37
    200      200             7.56        38            6.15        31
    500      500            27.79        56           21.21        42
    1000    1000           102.65       103           66.52        67

(the CPU seconds include the imports, ≈ 0.6 s; wall seconds in the same
runs, before → after: 1.52 → 2.25 (a load spike), 9.03 → 8.17, 39.76 →
29.30, 145.1 → 95.3.)  A scene's mode module was
written whole (≈ 1.6 kB a ball: 1.6 MB a mode at N = 1000); now its rates
call blocks of ``STATE_BLOCK`` states as its guard sides call blocks of
automata, every block is stored in the disk cache once under its own key
instead of inside each module, and its functions' docstrings state the
arrays' shapes (a 160-ball mode's functions: 5.7 kB, were ≈ 200 kB; the
module is now mostly ``META``, ≈ 280 B a guard).  Each pinnacle decided
every guard one by one (now all at once on arrays, the few that may hold one
by one); each mode built and printed every guard's ``META`` entry again (now
kept per guard and offset); a block's source walked the whole state vector
for the few states it reads.  Where the time goes at N = 1000 now (wall ms
a mode, timers around each part, 67 s in all): derivation
(``ModeEquations``) 25, generation 17.5, guards at the pinnacles 6.5 (of
which the ``sides`` functions 4.7), the disk cache's stores 3, compiling 3,
``CompiledMode`` 1; besides, the model's build 4.8 s and ≈ 7 s more (the
initial state's projection, the collector after each mode, the instant's
bookkeeping).

Then (issue 46, session 20; CPU seconds of the child, before ``f158bbd`` and
after measured one after the other on the same machine, load ≈ 1; per mode
is run seconds over modes, its N = 50 figure carrying the build and the
first mode)::

    N      modes   before cpu [s]   ms/mode   after cpu [s]   ms/mode
    50        50             2.38        30       1.79–2.10     24–29
    200      200             7.05        32            4.99        22
    500      500            22.40        44           15.14        29
    1000    1000            62.29        62           36.28        36

(a mode at N = 1000 is 1.2–1.5 times one at N = 50, was 2.1.)  What a mode
no longer visits state by state or guard by guard (each the same modules to
the byte: the disk caches of a 60-ball chain and the falling rod compared
file by file): the cyclic collector pauses for a whole instant, not for each
mode (1000 balls: 5.0 → 1.6 s of collection); the islands' causality and
equations are merged lazily, the fields a mode hardly reads (every bond's
effort and flow, every implicit rate, the causal relations) when first read;
a mode's bond values when an expression reads a bond; the guard forms of an
automaton state are shared by the modes, and a block of sixteen automata's
guard entries, comparisons and triples are taken at once; kept derivations
(island pieces, triples, side blocks) are found by their objects, not by
hashing tuples of expressions; the jump map copies the identity and asks
only the constrained states; the dependent states are found by place, not
by comparing sympy symbols (two million ``__eq__`` calls at N = 1000); a
normalised configuration is not normalised and sorted again.  Building: the
guard parser no longer looks at every known name for each guard, the
signals parse against a ``ChainMap``.

Then (issue 46, session 22; ``python benchmarks/scene_startup.py 50 200 500 1000``, before
``5d14d6d`` and after run alternately, two rounds; run seconds, a machine whose speed moved by
15 % within minutes)::

    N      modes   before [s]    after [s]
    50        50   1.42–1.58     1.24–1.54
    200      200   4.66–5.86     4.33–5.26
    500      500  15.23–16.27   14.98–15.22
    1000    1000  42.66–42.84   37.53–38.66

A scene's module wrote ``META``'s every guard entry, automaton state and independent state (≈ 330
bytes a contact: 310 kB a mode at N = 1000, and a disk cache of 314 MB after the run); it now names
the guard tables of its blocks of automata, stored once like the blocks
(:mod:`switching.library.guard_tables`): 6.4 kB a mode at N = 400, the 500-ball run's cache 83 →
17 MB.  Besides: a point-mass collision's jump is projected without sympy's 1 × 1 matrices; the
jump's generated function looks at the states it moves, not at every state; the guard conjunctions
are assembled a table at a time; storage of one slope form shares one tolerance function; the
parser no longer looks at every known name for each ``p2/m``.  Each new file costs ≈ 0.4 ms on this
machine's disk (``tempfile.mkstemp``), five a mode: 6 % of the N = 1000 run.

A second run on the cache the first filled (``--warm``; CPU seconds of the second child, one run each,
the figures of the first child beside them)::

    N      before: first / second [s]    after: first / second [s]
    300          8.2–11.9 / 18.2–19.6              11.1 / 3.8
    500              16.8 / 56.9                   11.7 / 7.0
    1000                                           35.0 / 18.5

A scene's second run was slower than its first: each mode's ``META`` (100–300 kB) was read back with
``ast.literal_eval``, and each of the few hundred blocks its module calls was compiled for the safety
check as it was read (again when it ran; most never do): now a block read is checked by its name, the
hash of its text, and compiled, and checked, when it first runs.

Then (issue 46, session 23; before ``74d8c89``, after ``7674fcb``; run seconds, alternately, the
machine's speed moving by a quarter between rounds)::

    N      modes   before [s]     after [s]
    500      500   12.25–20.42    13.03–15.73
    1000    1000   34.09–45.16    32.06–42.91

and ``python benchmarks/scene_startup.py 50 200 500 1000`` after, twice: 1.14–1.16 / 3.61–4.15 /
11.49–12.84 / 33.85–34.36 s (23 / 18–21 / 23–26 / 34 ms a mode).  A derived expression is tidied
(``cancel`` or ``simplify`` in the budget) once per shape and renamed for the others
(:mod:`bondgraph.shape_memo`: 1996 calls at N = 500, 1.32 → 0.13 s); a jump's pulse runs the rule on
the states it moves (0.66 ms → 15 µs a call at 1000 states).  The disk cache's writes, timed around
each (``write_atomically``): 5218 files, 0.83 s of the N = 1000 run (0.16 ms a file, 2.4 %); the
"0.4 ms a file, 6 %" above came from sampling (py-spy pauses the process, which lengthens its system
calls), and a run with the disk cache off (``HBG_CACHE_DIR=off``) is 0.7 s shorter.

Then (issue 46, session 24; ``python benchmarks/scene_startup.py 50 200 500 1000``, before
(``b4da884``) and after (``HEAD``) run at the same time, one on each core, so that both meet the
machine's speed of the moment)::

    N      modes   before [s]   ms/mode   after [s]   ms/mode
    50        50        1.23        25        1.28        26
    200      200        4.31        22        3.78        19
    500      500       12.41        25       11.15        22
    1000    1000       29.95        30       23.99        24

(a mode at N = 1000 costs 0.9 times one at N = 50, whose figure carries the build and the first
mode.)  What a mode no longer does over its thousand automata, islands or blocks (every generated
module and block the same text as before: their digest compared at N = 200): its block callers
(``sides``, ``sides_raw``, ``rates``: sixty calls each) are read, not compiled
(:mod:`codegen.composed`), and the blocks they call are handed over with the module's parts, not
searched for in its text; the islands' causality and equations are merged by swapping the islands that
changed into the previous configuration's merge (:mod:`bondgraph.island_merge`: the same entries in the
same order); the guard forms start from the previous mode's, automaton by automaton; the guards are
decided only where they may hold, the rest passed over in one numpy step; the islands kept, the on
junctions, the configuration, the restitution and the side blocks are found without a Python loop over
them all; an island's displacements are found by its bonds; a block is looked up by its first and last
objects before all of them.

Left: a mode's own work, the same at any N (≈ 20 ms: the new island's causality, equations and jump
map in sympy, the printing of its three new blocks, the compiling of its one or two that run, the
collector's pass over what the instant made: ≈ 2 ms), and what the build does once per contact
(parsing its guards: ≈ 1 ms each, most of it sympy's canonical form of a conjunction).
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


def measure(n: int, warm: bool = False) -> dict:
    """The child's figures on an empty disk cache; with ``warm``, besides, ``warm run`` and ``warm cpu``:
    those of a second child on the cache the first filled (a user's second run: nothing derived)."""
    with tempfile.TemporaryDirectory() as cache:
        rows = []
        for _ in range(2 if warm else 1):
            out = subprocess.run([sys.executable, "-c", _CHILD.format(root=str(ROOT), n=n)], capture_output=True,
                                 text=True, check=True, env={"HBG_CACHE_DIR": cache, "PATH": "/usr/bin:/bin"})
            rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
    if warm:
        rows[0].update({"warm run": rows[1]["run"], "warm cpu": rows[1]["cpu"]})
    return rows[0]


def main(sizes, warm: bool = False) -> None:
    print(f"{'scene':<18} {'import [s]':>10} {'run [s]':>9} {'cpu [s]':>8} {'modes':>6} {'per mode [ms]':>14}"
          + (f" {'warm run [s]':>13} {'warm cpu [s]':>13}" if warm else ""))
    for n in sizes:
        row = measure(n, warm)
        name = f"ball chain N={n}" if n else "falling rod"
        per_mode = 1e3 * row["run"] / max(row["modes"], 1)
        print(f"{name:<18} {row['import']:>10.2f} {row['run']:>9.2f} {row['cpu']:>8.2f} {row['modes']:>6d} "
              f"{per_mode:>14.0f}" + (f" {row['warm run']:>13.2f} {row['warm cpu']:>13.2f}" if warm else ""))


if __name__ == "__main__":
    arguments = [a for a in sys.argv[1:] if a != "--warm"]
    main([int(a) for a in arguments] or [0, 10, 20, 50], warm="--warm" in sys.argv[1:])
