"""A progress bar for long runs: ``simulate(..., progress=True)`` and ``hbg run``.

The run calls the bar with the time ``t`` [s] it has reached (after every
step in Python, at every return of the compiled kernel); the bar shows
``(t − t0)/(t_end − t0)`` as ``[#####     ]  42.0 %  t = 0.42 s  1.2 s/s  ETA 3 s``
on one line of its stream — the simulated seconds per second of computing
since the start and the time left at that rate — redrawn at most every
:data:`REDRAW` seconds, and only once the run has taken :data:`AFTER`
seconds (a short run shows nothing).
"""

from __future__ import annotations

import sys
import time

__all__ = ["AFTER", "REDRAW", "ProgressBar"]

#: seconds a run takes before the bar appears
AFTER = 2.0
#: seconds between redraws
REDRAW = 0.2
#: characters of the bar
WIDTH = 30


class ProgressBar:
    """The bar of one run from ``t0`` to ``t_end`` [s] on ``stream`` (default
    stderr); ``terminal_only``: draw only when the stream is a terminal (the
    command line's choice: a file or a pipe gets no control characters)."""

    def __init__(self, t0: float, t_end: float, stream=None, terminal_only: bool = False, after: float = AFTER):
        self.t0, self.t_end = float(t0), float(t_end)
        self.stream = sys.stderr if stream is None else stream
        isatty = getattr(self.stream, "isatty", lambda: False)
        self.active = isatty() or not terminal_only
        self.after = after
        self.start = time.perf_counter()
        self.last = 0.0
        self.shown = False

    def __call__(self, t: float) -> None:
        if not self.active:
            return
        now = time.perf_counter()
        if now - self.start < self.after or now - self.last < REDRAW:
            return
        self.last = now
        span = self.t_end - self.t0
        done = min(1.0, max(0.0, (t - self.t0) / span)) if span > 0 else 1.0
        bar = "#" * int(WIDTH * done)
        self.stream.write(f"\r[{bar:<{WIDTH}}] {100 * done:5.1f} %  t = {t:.6g} s{_pace(t - self.t0, span, now - self.start)}")
        self.stream.flush()
        self.shown = True

    def close(self) -> None:
        """Clear the bar's line (if it was drawn)."""
        if self.shown:
            self.stream.write("\r" + " " * (WIDTH + 70) + "\r")
            self.stream.flush()
            self.shown = False


def _pace(simulated: float, span: float, seconds: float) -> str:
    """``  <rate> s/s  ETA <left>``: simulated seconds per second of computing over ``seconds`` of it, and the
    time the rest of ``span`` takes at that rate (nothing before any progress)."""
    if simulated <= 0.0 or seconds <= 0.0:
        return ""
    rate = simulated / seconds
    left = max(span - simulated, 0.0) / rate
    return f"  {rate:.3g} s/s  ETA {_duration(left)}"


def _duration(seconds: float) -> str:
    """``42 s``, ``3 min 20 s``, ``2 h 05 min``."""
    if seconds < 60:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{int(seconds // 60)} min {int(seconds % 60):02d} s"
    return f"{int(seconds // 3600)} h {int(seconds % 3600 // 60):02d} min"
