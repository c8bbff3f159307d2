"""The watch for Zeno behaviour: events accumulating in geometrically shrinking time."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["ZenoWatch"]


class ZenoWatch:
    """Detects events accumulating in geometrically shrinking time.

    Zeno is declared when the last ``window`` gaps between events shrink by a
    steady ratio (within 5 %), the latest gap is below ``min_gap`` (so a
    sequence that a resting rule would still end is not cut short), and the
    Aitken extrapolation of the event times — exact for a geometric sequence —
    falls before ``t_end``.  Three gaps at round-off level also count.

    ``simulate`` takes ``min_gap`` = 1e-9 of the horizon unless told: a
    resting rule of a physical model acts on flights far longer than that,
    and a true Zeno sequence with gap ratio ``e`` is still declared after
    about ``log(1e9)/log(1/e)`` events (the bouncing ball with e = 0.95: 334),
    its accumulation time exact to round-off (the gaps stay geometric down
    to that size)."""

    def __init__(self, window: int, t_end: float, min_gap: float):
        self.window = window
        self.t_end = t_end
        self.min_gap = min_gap
        self.times: list[float] = []

    def quiet(self, times: list) -> bool:
        """Would :meth:`add` of each of ``times`` [s] (in order) find nothing?  It does where each gap
        is at least ``min_gap`` and above round-off (both are needed for Zeno): then the times are
        added, as :meth:`add` would, and True returned; else nothing changes (False: add them one by
        one, which decides).  A kernel call's instants, checked at once."""
        if not times:
            return True
        watched = [self.times[-1], *times] if self.times else times
        floor = self.min_gap
        # gaps of at least min_gap > 0 make the times increase, so |t| is largest at an end, and where
        # min_gap is above round-off there, a gap of min_gap is above it at every time between
        above_round_off = floor > 16 * math.ulp(max(abs(watched[0]), abs(watched[-1])) + 1.0)
        previous = watched[0]
        for t in watched[1:]:
            gap = t - previous
            if not (gap >= floor and (above_round_off or gap > 16 * math.ulp(abs(t) + 1.0))):
                return False
            previous = t
        if times:
            self.times.extend(times)
            del self.times[:-(self.window + 2)]
        return True

    def quiet_rows(self, times, counts, skip):
        """:meth:`quiet` of many fresh watches at once: row ``r`` of ``times`` (R, E) [s] holds a run's
        instants, ``counts[r]`` of them, the first ``skip[r]`` (0 or 1) not watched; True where each of a
        row's watched gaps passes :meth:`quiet`'s test (the same rule, on arrays; this watch is not changed)."""
        times = np.asarray(times, dtype=float)
        columns = np.arange(1, times.shape[1])
        watched = (columns[None, :] - 1 >= np.asarray(skip)[:, None]) & (columns[None, :] < np.asarray(counts)[:, None])
        with np.errstate(invalid="ignore", over="ignore"):
            gaps = times[:, 1:] - times[:, :-1]
            clear = (gaps >= self.min_gap) & (gaps > 16 * np.spacing(np.abs(times[:, 1:]) + 1.0))
        return np.all(clear | ~watched, axis=1)

    def add(self, t: float):
        """Return the estimated accumulation time if Zeno behaviour is seen
        (plain floats: this runs at every event)."""
        times = self.times
        times.append(t)
        if len(times) > self.window + 2:
            del times[0]  # only the recent events matter: bounded memory
        gaps = [b - a for a, b in zip(times, times[1:])]
        tiny = 16 * math.ulp(abs(t) + 1.0)
        if len(gaps) >= 3 and gaps[-1] <= tiny and gaps[-2] <= tiny and gaps[-3] <= tiny:
            return t  # events one ulp apart: accumulated already
        if len(times) < self.window + 2 or min(gaps) <= 0:
            return None
        ratios = [b / a for a, b in zip(gaps, gaps[1:])]
        if not ratios:
            return None
        if gaps[-1] < self.min_gap and max(ratios) < 0.995 and \
                max(ratios) - min(ratios) <= 0.05 * (sum(ratios) / len(ratios)):
            t2, t1, t0 = times[-1], times[-2], times[-3]
            denominator = t2 - 2 * t1 + t0
            accumulation = t2 - (t2 - t1) ** 2 / denominator if denominator != 0 else t2
            if accumulation <= self.t_end:
                return accumulation
        return None
