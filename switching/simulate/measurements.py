"""Measurements of a run over a window, exact where the run is piecewise smooth.

A converter engineer's figures of a signal ``s`` over a window ``[a, b]``
(``T = b − a``):

=================  ============================================================
``mean``           ``(1/T)·∫ s dt``
``rms``            ``√((1/T)·∫ s² dt)``
``ac_rms``         ``√(rms² − mean²)`` (the ripple's RMS)
``min``, ``max``   the least and greatest value (both sides of every instant)
``ripple``         ``max − min`` (peak to peak)
``peak``           ``max |s|``
``crest``          ``peak / rms``
``thd``            ``√(ac_rms² − c₁²/2) / (c₁/√2)`` with ``c₁`` the amplitude of
                   the fundamental (``fundamental=`` [Hz], default ``1/period``,
                   else the window's ``1/T``): every harmonic counted
                   (Parseval), not the first N
``power_factor``   of an element (a source, a load): ``mean(e·f) / (rms e · rms f)``
                   of its bond, ``signal`` naming the element
``efficiency``     ``∫ P_loads dt / ∫ P_supplied dt``, ``signal`` naming the load
                   elements (a name or a list): the power they take over the
                   power the sources connected to them deliver, each source
                   counted where it delivers on average over the window (a
                   diode's forward drop, a battery being charged: sinks, not
                   negative supply; a controller's signal states, apart from
                   the loads: not counted).  A window over which storage
                   empties can exceed 1: measure whole periods of a steady
                   state
=================  ============================================================

**Exact integrals.**  The integrals are not sums of samples: the run is
integrated piece by piece between its rows (a flow interval of one mode, no
instant inside: :mod:`switching.simulate.dense_rows`), each piece by a
:data:`GAUSS_NODES`-point Gauss–Legendre rule on the cubic Hermite
interpolant of the states (exact for polynomials of degree
``2·GAUSS_NODES − 1``; the interpolant's own error is ``O(h⁴)``, the order of
the 4th/5th-order methods' dense outputs), so a PWM square wave's mean is
``D·V`` to round-off and a sine's RMS ``V/√2`` to the run's tolerance.  A
piece longer than an eighth of a period of the highest harmonic asked is split.
``min``/``max`` search each piece's interpolant (a sampled search refined by
zooming), not only the rows.

**Windows.**  ``t_from``/``t_to`` [s] (default: the run's ends), or
``periods=N`` with ``period=T`` [s]: the last ``N·T`` of the run.

Rows at requested times (``t_eval``) with an instant between two of them, or a
run that kept no instants, cannot be integrated piecewise: refused
(:class:`MeasurementError`), saying what to run instead.
"""

from __future__ import annotations

import numpy as np

from bondgraph.elements import OnePort, Source
from bondgraph.errors import HybridBondGraphError

from .dense_rows import hermite_nodes, interpolable, row_rates
from .signal_values import signal_table

__all__ = ["MEASURES", "GAUSS_NODES", "MeasurementError", "measure", "mean_product", "spectrum", "window_of"]

#: the measurements :func:`measure` knows (the module docstring defines each)
MEASURES = ("mean", "rms", "ac_rms", "min", "max", "ripple", "peak", "crest", "thd", "power_factor", "efficiency")
#: Gauss–Legendre nodes per piece (exact for polynomials of degree 2·GAUSS_NODES − 1)
GAUSS_NODES = 4
#: pieces per period of the highest harmonic a Fourier integral resolves
PIECES_PER_PERIOD = 8
#: zoom rounds of the min/max search (each narrows the bracket 4 times: 4⁻¹⁶ of a piece)
ZOOM_ROUNDS = 16
#: the pieces whose sampled extreme is refined, per extreme
REFINED = 6


class MeasurementError(HybridBondGraphError, ValueError):
    """A measurement that cannot be taken as asked (its window, its name, the run's rows): ``argument``
    names what was wrong, ``value`` is what was given; the message says what to give."""

    def __init__(self, message: str, argument: str | None = None, value=None):
        super().__init__(message)
        self.argument = argument
        self.value = value


def window_of(trajectory, t_from=None, t_to=None, periods=None, period=None) -> tuple[float, float]:
    """``(a, b)`` [s]: the window the module docstring describes, checked inside the run."""
    t = trajectory.t
    if len(t) < 2:
        raise MeasurementError(f"the run of {trajectory.model_name!r} has {len(t)} row(s): nothing to measure",
                               "trajectory", len(t))
    start, end = float(t[0]), float(t[-1])
    if periods is not None or period is not None:
        if t_from is not None:
            raise MeasurementError("give the window either as t_from/t_to or as periods=N with period=T, not both",
                                   "t_from", t_from)
        if periods is None or period is None or not float(period) > 0 or not float(periods) > 0:
            raise MeasurementError(f"periods={periods!r} and period={period!r}: the last N periods need both, "
                                   "N > 0 and the period T > 0 [s]", "period", period)
        b = end if t_to is None else float(t_to)
        a = b - float(periods) * float(period)
    else:
        a = start if t_from is None else float(t_from)
        b = end if t_to is None else float(t_to)
    slack = 1e-12 * max(abs(start), abs(end), end - start)
    if not (start - slack <= a < b <= end + slack):
        raise MeasurementError(f"the window [{a:.9g}, {b:.9g}] s is not inside the run [{start:.9g}, {end:.9g}] s"
                               " with its start before its end: choose t_from/t_to (or fewer periods) inside it",
                               "window", (a, b))
    return max(a, start), min(b, end)


class _Pieces:
    """The run's flow pieces inside ``[a, b]``: ``lo``, ``hi`` (P,) [s] and ``row`` (P,) the row each starts
    after (its interval ``[t_row, t_row+1]``); the rows' flows computed once and the signals' values at
    the Gauss nodes kept, for every measurement of one window."""

    def __init__(self, trajectory, a: float, b: float):
        t = trajectory.t
        if not trajectory.instants_kept:
            raise MeasurementError("the run kept no instants (keep_instants=False): a jump between two rows "
                                   "cannot be told from the flow; run with keep_instants=True to measure",
                                   "keep_instants", False)
        self.modes = trajectory.mode_numbers()
        first = max(int(np.searchsorted(t, a, side="right")) - 1, 0)  # (only the rows of the window are read)
        last = min(int(np.searchsorted(t, b, side="left")) + 1, len(t))
        near = slice(first, last)
        usable = interpolable(t[near], (self.modes[0][near], self.modes[1]), trajectory.event_times)
        inside = t[near]
        rows = np.flatnonzero((inside[1:] > a) & (inside[:-1] < b) & (inside[1:] > inside[:-1]))
        bad = rows[~usable[rows]] + first
        rows = rows + first
        if len(bad):
            k = int(bad[0])
            raise MeasurementError(
                f"between the rows at t = {t[k]:.9g} s and {t[k + 1]:.9g} s the run changes mode or passes an "
                "instant, and its rows do not hold it (rows at requested times): measure a run with its steps "
                "(the default output) or samples=N, which keep every instant", "trajectory", (t[k], t[k + 1]))
        self.lo, self.hi, self.row = np.maximum(t[rows], a), np.minimum(t[rows + 1], b), rows
        self.trajectory, self.a, self.b = trajectory, a, b
        self._rates = None
        self._nodes: dict = {}

    def split(self, longest: float) -> "_Pieces":
        """These pieces split to at most ``longest`` [s] each (the rows' flows shared)."""
        splits = np.maximum(1, np.ceil((self.hi - self.lo) / longest)).astype(int)
        widths = np.repeat((self.hi - self.lo) / splits, splits)
        offsets = np.arange(splits.sum()) - np.repeat(np.cumsum(splits) - splits, splits)
        out = object.__new__(type(self))
        out.__dict__.update(self.__dict__)
        out.lo = np.repeat(self.lo, splits) + offsets * widths
        out.hi, out.row, out._nodes = out.lo + widths, np.repeat(self.row, splits), {}
        return out

    @property
    def rates(self) -> np.ndarray:
        """The flow at the rows that bound the pieces (NaN at the others)."""
        if self._rates is None:
            tr = self.trajectory
            needed = np.zeros(len(tr.t), dtype=bool)
            needed[self.row] = needed[self.row + 1] = True
            self._rates = row_rates(tr.model, tr.t, tr.x, self.modes, np.flatnonzero(needed))
        return self._rates

    def values(self, names, pieces: np.ndarray, times: np.ndarray) -> dict:
        """Each named signal at ``times`` (P, k) [s], ``k`` points inside each of the pieces ``pieces``
        (indices), the states interpolated in each piece's row interval and mode → name → (P·k,)."""
        tr = self.trajectory
        rows = self.row[pieces]
        rates = self.rates
        bad = ~(np.isfinite(rates[rows]).all(axis=1) & np.isfinite(rates[rows + 1]).all(axis=1))
        if bad.any():
            j = int(np.flatnonzero(bad)[0])
            mode = self.modes[1][self.modes[0][rows[j]]]
            raise MeasurementError(f"the flow of mode {mode.describe()} cannot be evaluated near t = "
                                   f"{tr.t[rows[j]]:.9g} s (not finite at a row): measure another window",
                                   "window", float(tr.t[rows[j]]))
        start, length = tr.t[rows][:, None], (tr.t[rows + 1] - tr.t[rows])[:, None]
        states = hermite_nodes(tr.model, tr.t, tr.x, self.modes, rows, (times - start) / length, rates)
        node_rows = np.repeat(rows, times.shape[1])
        return signal_table(tr.model, names, times.ravel(), states, (self.modes[0][node_rows], self.modes[1]))

    def nodes(self, name: str, *others: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(values, weights, times)``: the signal at the Gauss nodes of every piece, the nodes' weights [s]
        (``Σ w·s = ∫ s dt`` over the window) and times [s]; kept for the next measurement, and so are the
        ``others`` (evaluated in the same calls)."""
        missing = [n for n in (name, *others) if n not in self._nodes]
        if missing:
            x, w = np.polynomial.legendre.leggauss(GAUSS_NODES)
            half = 0.5 * (self.hi - self.lo)
            times = (0.5 * (self.lo + self.hi))[:, None] + half[:, None] * x[None, :]
            weights = (half[:, None] * w[None, :]).ravel()
            found = self.values(missing, np.arange(len(self.lo)), times)
            for n in missing:
                self._nodes[n] = found[n], weights, times.ravel()
        return self._nodes[name]

    def integral(self, name: str, power: int = 1) -> float:
        """``∫ s^power dt`` over the window."""
        values, weights, _ = self.nodes(name)
        return float(np.dot(weights, values if power == 1 else values**power))

    def extremes(self, name: str) -> tuple[float, float]:
        """``(min, max)`` of a signal over the pieces: 5 samples a piece (ends included), the best
        :data:`REFINED` pieces of each extreme zoomed on (:data:`ZOOM_ROUNDS`)."""
        grid = np.linspace(0.0, 1.0, 5)
        times = self.lo[:, None] + (self.hi - self.lo)[:, None] * grid[None, :]
        sampled = self.values([name], np.arange(len(self.lo)), times)[name].reshape(times.shape)
        low, high = float(np.min(sampled)), float(np.max(sampled))
        for sign in (1.0, -1.0):
            score = sign * sampled
            best = np.argpartition(-score.max(axis=1), min(REFINED, len(score)) - 1)[:REFINED]
            found = self._zoom(name, best, sign, score[best])
            high, low = (max(high, found), low) if sign > 0 else (high, min(low, found))
        return low, high

    def _zoom(self, name: str, pieces, sign: float, scores) -> float:
        """The extreme (``sign`` +1: max, −1: min) of the signal in ``pieces``, zooming around each one's
        best sample (``scores``: ``sign`` times the samples): 9 samples over the bracket, the next bracket
        the best one's two neighbours (a quarter as long)."""
        lo, hi = self.lo[pieces], self.hi[pieces]
        step = (hi - lo) / (scores.shape[1] - 1)
        centre = lo + step * np.argmax(scores, axis=1)
        best = float(np.max(scores))
        ends = np.arange(len(pieces))
        for _ in range(ZOOM_ROUNDS):
            left, right = np.maximum(centre - step, lo), np.minimum(centre + step, hi)
            grid = left[:, None] + (right - left)[:, None] * np.linspace(0.0, 1.0, 9)[None, :]
            values = sign * self.values([name], pieces, grid)[name].reshape(grid.shape)
            centre, step = grid[ends, np.argmax(values, axis=1)], (right - left) / 8.0
            best = max(best, float(np.max(values)))
        return sign * best


def _element_bond(trajectory, element: str) -> tuple[str, str]:
    """The effort and flow signal names of a one-port element's bond."""
    model = trajectory.model
    try:
        found = model.graph.element(element)
    except HybridBondGraphError:
        raise MeasurementError(f"power_factor and efficiency name elements: {element!r} is none of the model's "
                               f"(elements: {', '.join(model.graph.elements)})", "signal", element) from None
    if not isinstance(found, OnePort):
        raise MeasurementError(f"{element!r} is a {type(found).__name__}: power_factor is of a one-port element "
                               "(a source, R, C or I)", "signal", element)
    (bond,) = model.graph.bonds_of(element)
    return bond.effort.name, bond.flow.name


def _supplying(model, loads) -> list:
    """The sources in the parts of the bond graph that hold the ``loads`` (a controller's signal states,
    apart, supply nothing)."""
    import networkx as nx

    graph = nx.Graph()
    graph.add_nodes_from(model.graph.elements)
    graph.add_edges_from((bond.tail, bond.head) for bond in model.graph.bonds.values())
    reached = set().union(*(nx.node_connected_component(graph, load) for load in loads))
    return [name for name, element in model.graph.elements.items() if isinstance(element, Source) and name in reached]


def measure(trajectory, signal, what="mean", *, t_from=None, t_to=None, periods=None, period=None,
            fundamental=None):
    """The measurement ``what`` (a name of :data:`MEASURES`, or a list of them: a dict) of ``signal`` (a
    signal or state name; an element name for ``power_factor``, element names for ``efficiency``) over the
    window (:func:`window_of`), in the signal's units (``thd``, ``crest``, ``power_factor``, ``efficiency``:
    ratios).  ``fundamental`` [Hz]: of ``thd`` (default ``1/period``, else the window's ``1/T``)."""
    names = [what] if isinstance(what, str) else list(what)
    unknown = [n for n in names if n not in MEASURES]
    if unknown:
        raise MeasurementError(f"unknown measurement {unknown[0]!r}; the measurements are: {', '.join(MEASURES)}",
                               "what", unknown[0])
    if trajectory.model is None:
        raise MeasurementError(f"this trajectory of {trajectory.model_name!r} was unpickled without its model, "
                               "which measurements need: attach it first (trajectory.model = model)", "trajectory")
    a, b = window_of(trajectory, t_from, t_to, periods, period)
    if fundamental is None:
        fundamental = 1.0 / (float(period) if period is not None else b - a)
    pieces = _Pieces(trajectory, a, b)
    found = {name: _one(pieces, signal, name, float(fundamental)) for name in names}
    return found[names[0]] if isinstance(what, str) else found


def mean_product(trajectory, first: str, second: str, **window) -> float:
    """``(1/T)·∫ s₁·s₂ dt`` of two signals over the window (:func:`window_of`), integrated exactly piece by
    piece: a device's conduction loss ``v·i`` [W], a cross-power."""
    a, b = window_of(trajectory, window.get("t_from"), window.get("t_to"), window.get("periods"),
                     window.get("period"))
    pieces = _Pieces(trajectory, a, b)
    values, weights, _ = pieces.nodes(first, second)
    return float(np.dot(weights, values * pieces.nodes(second)[0]) / (b - a))


def _one(pieces: _Pieces, signal, name: str, fundamental: float) -> float:
    """One measurement over the window of ``pieces``."""
    span = pieces.b - pieces.a
    if name == "power_factor":
        effort, flow = _element_bond(pieces.trajectory, signal)
        values = pieces.nodes(effort, flow)[0] * pieces.nodes(flow)[0]
        power = float(np.dot(pieces.nodes(effort)[1], values))
        return power / float(np.sqrt(pieces.integral(effort, 2) * pieces.integral(flow, 2)))
    if name == "efficiency":
        loads = [signal] if isinstance(signal, str) else list(signal)
        for load in loads:
            _element_bond(pieces.trajectory, load)
        sources = _supplying(pieces.trajectory.model, loads)
        names = [f"power:{element}" for element in loads + sources]
        pieces.nodes(names[0], *names[1:])
        supplied = sum(max(-pieces.integral(f"power:{source}"), 0.0) for source in sources)
        return sum(pieces.integral(f"power:{load}") for load in loads) / supplied
    if name in ("min", "max", "ripple", "peak", "crest"):
        low, high = pieces.extremes(signal)
        peak = max(abs(low), abs(high))
        if name == "crest":
            return peak / float(np.sqrt(pieces.integral(signal, 2) / span))
        return {"min": low, "max": high, "ripple": high - low, "peak": peak}[name]
    mean = pieces.integral(signal) / span
    if name == "mean":
        return mean
    square = pieces.integral(signal, 2) / span
    if name == "rms":
        return float(np.sqrt(square))
    ac = float(np.sqrt(max(square - mean * mean, 0.0)))
    if name == "ac_rms":
        return ac
    first = _harmonics(pieces, signal, fundamental, 1)[1] / np.sqrt(2.0)  # name == "thd"
    if not first > 1e-9 * max(ac, abs(mean)):
        raise MeasurementError(f"{signal!r} has no component at the fundamental {fundamental:.9g} Hz over "
                               f"[{pieces.a:.9g}, {pieces.b:.9g}] s (its amplitude there is {first:.3g}): give the "
                               "fundamental= [Hz] of the signal, or period=", "fundamental", fundamental)
    return float(np.sqrt(max(ac * ac - first * first, 0.0)) / first)


def _harmonics(pieces: _Pieces, signal: str, fundamental: float, count: int) -> np.ndarray:
    """``|c_k|``, ``k = 0 … count`` (:func:`spectrum`) over the window of ``pieces``."""
    split = pieces.split(1.0 / (PIECES_PER_PERIOD * max(count, 4) * fundamental))
    values, weights, times = split.nodes(signal)
    phase = 2.0 * np.pi * fundamental * times
    k = np.arange(count + 1)[:, None]
    coefficients = (np.exp(-1j * k * phase[None, :]) * (weights * values)[None, :]).sum(axis=1)
    coefficients *= 2.0 / (pieces.b - pieces.a)
    coefficients[0] /= 2.0
    return np.abs(coefficients)


def spectrum(trajectory, signal: str, fundamental: float, harmonics: int = 20, *, t_from=None, t_to=None,
             periods=None, period=None) -> np.ndarray:
    """The amplitudes ``c_k`` (``harmonics + 1``,) of ``s(t) ≈ c₀ + Σ c_k·cos(2πk·f₁·t + φ_k)`` over the
    window, ``c₀`` the mean, each ``c_k = |(2/T)·∫ s·e^(−2πik·f₁t) dt|`` integrated exactly piecewise (the
    module docstring), in the signal's units.  The window should hold whole periods of ``f₁`` [Hz]."""
    if not float(fundamental) > 0:
        raise MeasurementError(f"the fundamental must be a frequency > 0 [Hz], got {fundamental!r}",
                               "fundamental", fundamental)
    if int(harmonics) < 1:
        raise MeasurementError(f"harmonics must be a whole number ≥ 1, got {harmonics!r}", "harmonics", harmonics)
    a, b = window_of(trajectory, t_from, t_to, periods, period)
    return _harmonics(_Pieces(trajectory, a, b), signal, float(fundamental), int(harmonics))
