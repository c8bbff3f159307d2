"""The cost of a compiled call around its kernel: a warm ``simulate`` against the kernel alone.

    python benchmarks/warm_call.py [--repeats N] [--calls N] [--no-cold]

A parameter study, a fit, a sensitivity sweep or a Monte Carlo ensemble call the same model
thousands of times, so what a warm call spends outside the kernel (checking the options, setting the
run up, recording, building the trajectory) is their whole overhead (issue 46).  Rows:

  call         ``model.simulate(t_end, "RK45-jit", ...)`` on a model that has run before (warm);
  kernel       the same run's kernel calls alone (``CompiledModel.run`` with the very arguments the
               call gave it, captured from one call and replayed);
  ratio        call / kernel: the target is 1.5 on the bouncing ball;
  overhead     call − kernel.

Cases:
  ball          the bouncing ball, 20 bounces (t_end 4.02 s), rtol 1e-8, every step kept;
  ball events   the same, ``output="events"`` (the start, the instants, the end);
  ball sweep    the same as ``ball`` with another restitution each call (a parameter study);
  boost         the boost converter, 10 periods (1 ms, 20 instants), rtol 1e-8.

Each figure is the least of ``--repeats`` rounds (the least disturbed on a shared machine) of the mean
of ``--calls`` calls; the rounds interleave the call and its kernel, so a change of load moves both.
``--no-cold`` skips the first calls in new processes (a warm disk cache: imports, build, first call).

Figures (2 shared cores under load, least of 9 rounds of 300 calls over several runs; ``python
benchmarks/warm_call.py --repeats 9 --calls 300``), before issue 46's second bullet and after:

    case          before: call   kernel  ratio     after: call   kernel  ratio
    ball               377 µs    98 µs   3.85          179 µs    96 µs   1.87
    ball events        317 µs    97 µs   3.28          183 µs    94 µs   1.95
    ball sweep         374 µs    61 µs   6.10          207 µs    60 µs   3.45
    boost              978 µs   192 µs   5.09          293 µs   192 µs   1.53

    first call in a new process (kernel and modes in numba's disk cache): 0.65–0.95 s before and
    after; the compiled row merge adds its load, 6–9 ms (0.5 s to compile once per installation).
    The sweep's kernel is replayed with the values of the last call (its own count of bounces), and
    its call includes setting the values (set_parameter_values and the initial state: 25 µs).

The Python around the kernel, cut again (issue 46: the call's Python to at most half its kernel, a
ratio of 1.5 on the ball).  The same command with ``--repeats 9 --calls 300``, the code before
(f158bbd) and after run alternately at the same load (2 shared cores), four runs each (their range):

    case          before: call   kernel  ratio       after: call   kernel  ratio      overhead µs
    ball          170–174 µs     87–90   1.94–1.97    141–144 µs    87–88   1.62–1.65   83–85 -> 54–57
    ball events   174–176 µs     85–88   2.00–2.06    142–146 µs    84–86   1.68–1.71   88–91 -> 58–60
    ball sweep    188–190 µs     55–57   3.33–3.43    171–175 µs    55      3.07–3.19  132–135 -> 115–20
    boost         274–284 µs     173–182 1.56–1.61    242–245 µs    173–176 1.39–1.41  100–106 -> 68–72

    The ball is at 1.62, not 1.5.  What remains is spread thin (after, below): the run's set-up, one
    CompiledInstant record per instant (two row views each: ~0.35 µs an instant), the merge of the
    kernel's rows, the Zeno watch's look at each gap, the trajectory.  The sweep's call also sets the
    values (the initial state projected again, the kernel record's parameters) and its start's guard
    sides are new each call.  First call in a new process: 0.42 s before and after.

    Parts of a warm ball call, timed in place as below (µs of a call, before -> after; the whole call
    185 -> 158 with the timers, CompiledModel.run ~93 in both):

    part of the call                                                    before   after
    the kernel's output recorded (Recorder.block)                         17.9     9.2
        the merge (KernelResult.rows: its import no longer run each call)  7.0     4.1
        the time in each mode: summed when first asked (ModeTimes)        ~3.5      —
        the rows' modes: one fancy index of an object array              ~2.2    ~0.9
    the instants' records (20 CompiledInstant)                             9.3     8.1
    their checks (instants_pass: the Zeno watch, max_events)               3.1     3.0
    the events read from the kernel's buffers (arrays -> event_columns)    2.8    ~1.5
    the kernel call's keywords (kernel_arguments)                          2.2     1.4
    the start (HybridRun._start)                                          10.8     4.8
        its guard sides (kept for the very same start: preflight)          7.7     2.6
    the result (HybridRun._finish)                                         9.6     7.4
        the trajectory (Recorder.trajectory; an events run's columns       6.2     4.7
        filled once, not concatenated: ball events 11.1 -> 8.3)
    the run's set-up (prepared_run)                                       20.2    15.6
        the options (checked_options: the key hashed once)                 3.0     2.5
        HybridRun.__init__ (tolerances 3.0 -> 2.1)                        10.9     8.8
        the step bound                                                     2.0     1.7

What a warm ball call spent, timed in place (µs of a call, each wrapped in a timer, both at the
same load; the kernel through CompiledModel.run: 114 before, 101 after, which no longer rebuilds
its record for new tolerances each call), at the change before (issue 46's second bullet):

    part of the call                                            before   after
    the kernel's output recorded (Zeno watch, time in modes)      193      40
        (after: the merge 18, the instants' records 10, their checks 3, the flow's loop 9)
    the start (its guard check)                                    32      10
    the result (the trajectory: 19, 6)                             24       9
    the run's set-up (the states' tolerances: 7, 3)                20       9
    the options and the step bound                                  6       5

The instants made when first read and one object per mode (issue 46, the target reached).  The same
command with ``--repeats 9 --calls 300 --no-cold``, the code before (2641e17, a worktree) and after run
alternately, two runs each (their range):

    case          before: call   kernel  ratio       after: call   kernel  ratio      overhead µs
    ball          143–150 µs     88–90   1.62–1.67    129–134 µs    87–89   1.48–1.49   55–60 -> 42–44
    ball events   145–150 µs     86–88   1.68–1.70    131–135 µs    84–87   1.55        59–62 -> 46–48
    ball sweep    171–181 µs     56–57   3.08–3.16    161–162 µs    55–56   2.90–2.93  115–124 -> 106–107
    boost         244–245 µs     175–178 1.38–1.39    229–234 µs    173–175 1.32–1.34   67–69 -> 56–59

    Other runs of the after code on the same machine read 1.48–1.52 for the ball: the target, 1.5, is
    reached, with no room to spare.  What changed:

    * a kernel call's instants are kept as one record of the call (times, mode numbers and one copied
      block of states: switching.simulate.resolution.KernelInstants) and made CompiledInstant records
      when the trajectory's ``events`` are first read (a parameter study reading final states, events
      counts or metrics makes none): 20 records, ~5 µs a call;
    * one object per mode (ModeSpace.known_mode, the mode keeping its hash): a dict of modes finds its
      key by identity, and a run holds no new Mode per instant (the boost converter's memory per extra
      period with no instants kept, tests/switching/simulate/test_extremes.py: 805 -> 585 B);
    * the Zeno watch's gap test needs no ``math.ulp`` per gap where ``zeno_min_gap`` is above round-off
      at the latest time (1.8 -> 0.7 µs for 20 instants); the recorder's boundary is the call's last
      instant, not a ``max`` over all.

    Left: what remains is the run's set-up (options, tolerances, step bound: ~12 µs), the start's check
    of the guard sides (~2.5 µs), the merge of the kernel's rows (a numba call returning five arrays:
    ~2.7 µs), the events' columns and the rows' modes (~2.4 µs), the trajectory (~5 µs).  The sweep
    also sets the values and projects the initial state again each call (~15 µs: the initial state's
    expressions substituted by sympy).

The run's set-up taken whole (issue 46, session 26; ``switching.simulate.set_up``, DESIGN §7d).  The
kernel had become faster (78.7 -> 74.9 µs) and the ball's ratio had risen back to 1.54.  A warm call
still spent ~10 µs asking five memos (the options, the clocks' step bound, the states' tolerances, the
starting mode, the start's guard sides) whether what each was made of had changed; now a run whose
options and model are as they were for the model's last run takes that run's set-up whole.  The same
command with ``--repeats 9 --calls 300 --no-cold``, the code before (8df5551, a worktree) and after
run at the same time, one per core, two rounds (their range):

    case          before: call   kernel  ratio       after: call   kernel  ratio      overhead µs
    ball          114–115 µs     74–75   1.54        105–109 µs    73–77   1.42–1.43   40 -> 31–32
    ball events   116–117 µs     72–73   1.60–1.61   106–109 µs    72–73   1.48–1.49   44 -> 35–36
    ball sweep    142–143 µs     47–48   3.01–3.02   143–144 µs    47–48   3.02–3.07   95–96 -> 96
    boost         195–196 µs     141–146 1.35–1.38   179 µs        143     1.25        50–54 -> 36

    The sweep sets new values each call, so it takes nothing: its runs only note their values (a set-up
    is kept once a run has the values of the run before), ~0.9 µs a call over the code before (the same
    loop with the set-up's look-ups stubbed out, in one process); a batch's runs neither take nor keep one
    (``simulate_batch`` of 1600 balls: 59.1 µs a run against 59.8 with them stubbed out).

    In a new process (the ball's first five calls, five processes of each, alternately): the first call
    308–373 ms after, 315–503 ms before (its compiled functions loaded: the set-up is not what it pays);
    the second 568–793 µs after, 670–973 before; the third, the first to take a kept set-up, 169–184 µs
    after, 223–354 before.
"""

from __future__ import annotations

import argparse
import itertools
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from models import boost_converter, bouncing_ball  # noqa: E402
from switching.library.jit_model import CompiledModel  # noqa: E402

BALL_END = 4.02  # 20 bounces


def captured_kernel(run):
    """The kernel calls ``run()`` makes, as a function replaying them with the same arguments."""
    calls = []
    original = CompiledModel.run

    def spy(self, *args, **kwargs):
        calls.append((self, args, kwargs))
        return original(self, *args, **kwargs)

    CompiledModel.run = spy
    try:
        run()
    finally:
        CompiledModel.run = original

    def kernel():
        for compiled, args, kwargs in calls:
            original(compiled, *args, **kwargs)
    return kernel


def cases():
    ball = bouncing_ball.build()
    boost = boost_converter.build()
    swept = bouncing_ball.build()
    values = {symbol.name: value for symbol, value in swept.parameter_values.items()}
    restitutions = itertools.cycle(np.linspace(0.8, 0.82, 101))

    def sweep():
        swept.set_parameter_values({**values, "e": next(restitutions)})
        return swept.simulate(BALL_END, "RK45-jit", rtol=1e-8)

    return [
        ("ball", lambda: ball.simulate(BALL_END, "RK45-jit", rtol=1e-8)),
        ("ball events", lambda: ball.simulate(BALL_END, "RK45-jit", rtol=1e-8, output="events")),
        ("ball sweep", sweep),
        ("boost", lambda: boost.simulate(1e-3, "RK45-jit", rtol=1e-8)),
    ]


def least_mean(fns, calls: int, repeats: int) -> list:
    """The least over ``repeats`` interleaved rounds of the mean time [s] of ``calls`` calls of each."""
    best = [np.inf] * len(fns)
    for _ in range(repeats):
        for k, fn in enumerate(fns):
            started = time.perf_counter()
            for _ in range(calls):
                fn()
            best[k] = min(best[k], (time.perf_counter() - started) / calls)
    return best


COLD = """
import sys, time
sys.path.insert(0, {root!r})
started = time.perf_counter()
from models import bouncing_ball
imported = time.perf_counter()
ball = bouncing_ball.build()
built = time.perf_counter()
ball.simulate({t_end}, "RK45-jit", rtol=1e-8)
first = time.perf_counter()
ball.simulate({t_end}, "RK45-jit", rtol=1e-8)
second = time.perf_counter()
print(imported - started, built - imported, first - built, second - first)
"""


def cold() -> str:
    """The first and second call in a new process (the disk caches warm from the runs above)."""
    out = subprocess.run([sys.executable, "-c", COLD.format(root=str(ROOT), t_end=BALL_END)], capture_output=True,
                         text=True, check=True).stdout.split()
    imported, built, first, second = map(float, out)
    return (f"ball in a new process: import {imported:.2f} s, build {built * 1e3:.1f} ms, first call "
            f"{first * 1e3:.2f} ms, second call {second * 1e6:.0f} µs")


def main(argv=None):
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--calls", type=int, default=500)
    parser.add_argument("--no-cold", action="store_true", help="skip the first calls in new processes")
    args = parser.parse_args(argv)
    print(f"{'case':<12} {'call':>9} {'kernel':>9} {'ratio':>6} {'overhead':>9}")
    for name, call in cases():
        call()  # warm: modes compiled or loaded, the kernel's buffers allocated
        kernel = captured_kernel(call)
        call_time, kernel_time = least_mean([call, kernel], args.calls, args.repeats)
        print(f"{name:<12} {call_time * 1e6:>7.1f}µs {kernel_time * 1e6:>7.1f}µs {call_time / kernel_time:>6.2f} "
              f"{(call_time - kernel_time) * 1e6:>7.1f}µs")
    if not args.no_cold:
        print(cold())


if __name__ == "__main__":
    main()
