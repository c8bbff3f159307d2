"""A progress bar for long runs: ``simulate(..., progress=True)`` and ``hbg run``.

The run calls the bar with the time ``t`` [s] it has reached (after every
step in Python, at every return of the compiled kernel); the bar shows
``(t − t0)/(t_end − t0)`` as ``[#####     ]  42.0 %  t = 0.42 s`` on one line of
its stream, redrawn at most every :data:`REDRAW` seconds, and only once the
run has taken :data:`AFTER` seconds (a short run shows nothing).
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
        self.stream.write(f"\r[{bar:<{WIDTH}}] {100 * done:5.1f} %  t = {t:.6g} s")
        self.stream.flush()
        self.shown = True

    def close(self) -> None:
        """Clear the bar's line (if it was drawn)."""
        if self.shown:
            self.stream.write("\r" + " " * (WIDTH + 40) + "\r")
            self.stream.flush()
            self.shown = False
