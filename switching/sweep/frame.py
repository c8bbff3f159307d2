"""A sweep's parameter grid, its results as a table, and the table as a plot.

* :func:`parameter_grid` — every combination of some parameters' values
  (the parameter sets of :func:`switching.simulate_many`);
* :class:`SignalMetrics` — a picklable ``metrics`` callable: the final,
  smallest or largest value of named signals, computed in the worker;
* :func:`to_frame` — one row per run (pandas): parameters, status, event
  count, first event time, final state, metrics;
* :func:`plot_sweep` — one column of that table over the grid: a line for one
  parameter, a heat map for two.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping

import numpy as np

from bondgraph.errors import DuplicateNameError, ParameterValueError, UnknownNameError
from switching.simulate.measurements import MEASURES, measure

from .batch import DASK_EXTRA, MissingDependencyError
from .kernel_batch import BatchResult

__all__ = ["parameter_grid", "SignalMetrics", "to_frame", "plot_sweep", "require_pandas", "RUN_COLUMNS"]

#: columns of :func:`to_frame` besides the parameters, final states and metrics
RUN_COLUMNS = ("status", "error", "events", "first_event", "t_final", "wall_time")
#: prefix of the final-state columns of :func:`to_frame`
FINAL = "final_"


def _plain(value):
    """numpy scalars as Python numbers (they print and pickle plainly)."""
    return value.item() if isinstance(value, np.generic) else value


def parameter_grid(axes: Mapping[str, Iterable]) -> list[dict]:
    """Every combination of the values in ``axes`` (name → values), the first
    name varying slowest: ``parameter_grid({"mu": [1, 2], "e": [0.5, 0.8]})``
    gives ``[{"mu": 1, "e": 0.5}, {"mu": 1, "e": 0.8}, {"mu": 2, "e": 0.5}, …]``."""
    names = list(axes)
    values = [[_plain(v) for v in axes[name]] for name in names]
    for name, column in zip(names, values):
        if not column:
            raise ParameterValueError(f"parameter_grid: no values for {name!r}", name, column)
    return [dict(zip(names, combination)) for combination in itertools.product(*values)]


class SignalMetrics:
    """A ``metrics`` callable for :func:`switching.simulate_many`: for each
    spec ``"KIND:SIGNAL"`` that value of the signal (a named signal or state
    of the model, in its own units) under the spec as its name.  ``KIND``:
    ``final``, ``min`` or ``max`` over the run's samples, or a measurement of
    :data:`switching.simulate.measurements.MEASURES` (``mean``, ``rms``,
    ``ripple``, ``thd``, …: exact over the window, the run's flow integrated
    piecewise) over the window ``t_from``/``t_to`` [s] or the last
    ``periods`` of ``period`` [s] (``fundamental`` [Hz] of ``thd``) — a
    sweep's steady-state ripple: ``SignalMetrics("ripple:v_C", periods=10,
    period=1e-5)``.  It pickles (plain data), so it travels to workers;
    ``check(model)`` names unknown signals before a sweep starts."""

    SAMPLED = ("final", "min", "max")
    KINDS = SAMPLED + tuple(k for k in MEASURES if k not in ("min", "max"))

    def __init__(self, *specs: str, t_from=None, t_to=None, periods=None, period=None, fundamental=None):
        self.specs = []
        for spec in specs:
            kind, colon, signal = str(spec).partition(":")
            if not colon or kind not in self.KINDS or not signal:
                raise ParameterValueError(f"metric {spec!r}: write KIND:SIGNAL with KIND one of "
                                          f"{', '.join(self.KINDS)} (e.g. 'final:{signal or 'theta'}')",
                                          "metrics", spec)
            self.specs.append((kind, signal))
        self.window = {key: value for key, value in dict(t_from=t_from, t_to=t_to, periods=periods, period=period,
                                                         fundamental=fundamental).items() if value is not None}

    @property
    def names(self) -> list[str]:
        return [f"{kind}:{signal}" for kind, signal in self.specs]

    def check(self, model) -> None:
        """Raise :class:`~bondgraph.errors.UnknownNameError` naming every signal
        that ``model`` has neither as a signal nor as a state (nor, for
        ``power_factor`` and ``efficiency``, as an element)."""
        known = set(model.signal_names) | {s.name for s in model.states}
        elements = set(model.graph.elements)
        unknown = [signal for kind, signal in self.specs
                   if signal not in (elements if kind in ("power_factor", "efficiency") else known)]
        if unknown:
            raise UnknownNameError(f"no signal {', '.join(map(repr, unknown))} in {model.name!r}; signals: "
                                   f"{', '.join(model.signal_names)}", unknown[0])

    def __call__(self, trajectory) -> dict:
        out = {}
        for (kind, signal), name in zip(self.specs, self.names):
            if kind != "final" and (kind not in self.SAMPLED or self.window):  # (a window: min and max exact)
                out[name] = float(measure(trajectory, signal, kind, **self.window)) if len(trajectory.t) > 1 \
                    else math.nan
                continue
            values = trajectory.signal(signal) if len(trajectory.t) else np.zeros(0)
            if not len(values):
                out[name] = math.nan
            else:
                out[name] = float(values[-1] if kind == "final" else values.min() if kind == "min" else values.max())
        return out

    def __repr__(self) -> str:
        return f"SignalMetrics({', '.join(map(repr, self.names))})"


def require_pandas():
    try:
        import pandas
    except ImportError as exc:
        raise MissingDependencyError(f"to_frame needs pandas, which is not installed here: {DASK_EXTRA} "
                                     "(or pip install pandas)") from exc
    return pandas


def to_frame(results):
    """The runs of :func:`switching.simulate_many` (or the :class:`BatchResult` of
    :func:`switching.simulate_batch`) as a pandas DataFrame, one row per run in their order.  Columns: each parameter (by name; empty
    where a run did not set it), ``status`` (``ok``, ``stopped``,
    ``failed``), ``error`` (the message of a failed run), ``events`` (the
    number of instants), ``first_event`` (time of the first instant [s]),
    ``t_final`` (the last time reached [s]), ``final_<state>`` (each state at
    ``t_final``, in its own units), each metric (by name), ``wall_time`` [s].
    A failed run's ``events``, ``t_final`` and final states are those of the
    part computed; its metrics are empty.  A batch's frame has no metrics and
    no ``wall_time`` (its runs are timed together)."""
    pd = require_pandas()
    if isinstance(results, BatchResult):
        return _batch_frame(pd, results)
    results = list(results)
    parameters = list(dict.fromkeys(name for r in results for name in r.parameters))
    states = list(dict.fromkeys(name for r in results for name in r.state_names))
    metrics = list(dict.fromkeys(name for r in results for name in r.metrics))
    fixed = set(RUN_COLUMNS) | {FINAL + s for s in states}
    clashes = [name for name in metrics if name in fixed or name in parameters]
    clashes += [name for name in parameters if name in fixed]
    if clashes:
        raise DuplicateNameError(f"to_frame: column name(s) {', '.join(map(repr, clashes))} would be given twice "
                                 f"(parameters: {', '.join(parameters)}; metrics: {', '.join(metrics)}; run columns: "
                                 f"{', '.join(RUN_COLUMNS)}, {FINAL}<state>): rename the metric", clashes[0])
    rows = []
    for r in results:
        row = {name: r.parameters.get(name, math.nan) for name in parameters}
        row.update(status=r.status, error=r.error, events=r.instant_count or len(r.event_times),
                   first_event=float(r.event_times[0]) if len(r.event_times) else math.nan,
                   t_final=float(r.t[-1]) if len(r.t) else math.nan)
        final = dict(zip(r.state_names, r.x[-1])) if len(r.t) else {}
        row.update({FINAL + s: float(final[s]) if s in final else math.nan for s in states})
        row.update({name: r.metrics.get(name, math.nan) for name in metrics})
        row["wall_time"] = r.wall_time
        rows.append(row)
    columns = parameters + list(RUN_COLUMNS[:-1]) + [FINAL + s for s in states] + metrics + ["wall_time"]
    return pd.DataFrame(rows, columns=columns)


def _batch_frame(pd, batch: BatchResult):
    """:func:`to_frame` of a :func:`switching.simulate_batch`: the same columns, no metrics nor wall time
    (a batch times its runs together)."""
    parameters = list(dict.fromkeys(name for p in batch.parameters for name in p))
    columns = {name: [p.get(name, math.nan) for p in batch.parameters] for name in parameters}
    first = batch.event_times[:, 0] if batch.event_times.shape[1] else np.full(len(batch), np.nan)
    columns.update(status=batch.status, error=batch.errors, events=batch.event_counts, first_event=first,
                   t_final=batch.t)
    columns.update({FINAL + s: batch.x[:, k] for k, s in enumerate(batch.state_names)})
    return pd.DataFrame(columns)


# ------------------------------------------------------------ plot


def _axis(values):
    """Sorted distinct values of one grid parameter, their cell edges on the
    plot axis and whether the axis is numeric (else categorical, by position)."""
    distinct = list(dict.fromkeys(values))
    numeric = all(isinstance(v, (int, float, np.number)) and not isinstance(v, bool) for v in distinct)
    if not numeric:
        return distinct, np.arange(len(distinct) + 1) - 0.5, False
    distinct = sorted(distinct)
    centres = np.asarray(distinct, dtype=float)
    if len(centres) == 1:
        half = 0.5 * (abs(centres[0]) or 1.0)
        return distinct, np.array([centres[0] - half, centres[0] + half]), True
    mid = 0.5 * (centres[1:] + centres[:-1])
    return distinct, np.concatenate([[2 * centres[0] - mid[0]], mid, [2 * centres[-1] - mid[-1]]]), True


#: a second parameter with at most this many values is drawn as a family of lines, not a heat map
FAMILY = 4


def _labelled(name: str, unit) -> str:
    """``name [unit]`` as plain text (a ``$`` stays a character), the metric's signal's unit for a
    ``KIND:SIGNAL`` metric (none for the ratios)."""
    from switching.simulate.plotting import plain

    kind, colon, signal = name.partition(":")
    if colon and kind in ("thd", "crest", "power_factor", "efficiency"):
        return plain(name)
    found = unit(signal if colon else name[len(FINAL):] if name.startswith(FINAL) else name) if unit else None
    return plain(f"{name} [{found}]" if found else name)


def plot_sweep(frame, metric: str, parameters, ax=None, unit=None):
    """Plot column ``metric`` of a :func:`to_frame` table over the grid of
    ``parameters`` (one name: a line against it; two: a heat map, the first
    along x — or, when the second takes at most :data:`FAMILY` values, a
    line over the first for each of them).  Failed runs are marked with a
    red ×, not plotted as values.  ``unit(name)`` (a model's
    ``annotations.unit``): the units shown on the axes.  Returns the
    matplotlib Axes."""
    from bondgraph.drawing import pyplot

    parameters = [parameters] if isinstance(parameters, str) else list(parameters)
    if len(parameters) not in (1, 2):
        raise ParameterValueError(f"plot_sweep shows one or two parameters, got {len(parameters)}: "
                                  f"{', '.join(parameters)}", "parameters", parameters)
    for name in [metric, *parameters]:
        if name not in frame.columns:
            raise UnknownNameError(f"plot_sweep: no column {name!r}; columns: {', '.join(map(str, frame.columns))}",
                                   name)
    values = frame[metric].to_numpy()
    try:
        values = values.astype(float)
    except (TypeError, ValueError):
        raise ParameterValueError(f"plot_sweep: column {metric!r} does not hold numbers", "metric", metric) from None
    failed = (frame["status"] == "failed").to_numpy() if "status" in frame.columns else np.zeros(len(frame), bool)
    values = np.where(failed, np.nan, values)
    if frame.duplicated(subset=parameters).any():
        raise ParameterValueError(f"plot_sweep: several runs share values of {', '.join(parameters)}: "
                                  "give every parameter that varies", "parameters", parameters)
    plt = pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(6.4, 4.4))
    if len(parameters) == 2 and len(set(frame[parameters[1]])) <= FAMILY < len(set(frame[parameters[0]])):
        return _family(frame, metric, parameters, values, failed, ax, unit)
    xs, x_edges, x_numeric = _axis(frame[parameters[0]])
    xpos = {v: (v if x_numeric else k) for k, v in enumerate(xs)}
    if len(parameters) == 1:
        order = np.argsort([xs.index(v) for v in frame[parameters[0]]], kind="stable")
        x = np.array([xpos[v] for v in frame[parameters[0]]], dtype=float)[order]
        ax.plot(x, values[order], "o-", ms=3, lw=1.2, label=metric)
        ax.set_ylabel(_labelled(metric, unit))
        if failed.any():
            ax.plot(x[failed[order]], np.zeros(int(failed.sum())), "x", color="tab:red", ms=7,
                    transform=ax.get_xaxis_transform(), clip_on=False, label="failed")
            ax.legend(loc="best", fontsize=8)
        ax.set_title(f"{metric} over {parameters[0]}", fontsize=10)
    else:
        ys, y_edges, y_numeric = _axis(frame[parameters[1]])
        ypos = {v: (v if y_numeric else k) for k, v in enumerate(ys)}
        grid = np.full((len(ys), len(xs)), np.nan)
        for xv, yv, value in zip(frame[parameters[0]], frame[parameters[1]], values):
            grid[ys.index(yv), xs.index(xv)] = value
        ax.set_facecolor("0.88")  # cells without a value (failed runs) stay grey
        mesh = ax.pcolormesh(x_edges, y_edges, np.ma.masked_invalid(grid), shading="flat", cmap="viridis")
        ax.figure.colorbar(mesh, ax=ax, label=_labelled(metric, unit))
        if failed.any():
            fx = [xpos[v] for v, bad in zip(frame[parameters[0]], failed) if bad]
            fy = [ypos[v] for v, bad in zip(frame[parameters[1]], failed) if bad]
            ax.plot(fx, fy, "x", color="tab:red", ms=7, label="failed")
            ax.legend(loc="upper right", fontsize=8)
        ax.set_ylabel(_labelled(parameters[1], unit))
        if not y_numeric:
            ax.set_yticks(range(len(ys)), [str(v) for v in ys])
        ax.set_title(f"{metric} over {parameters[0]} × {parameters[1]}", fontsize=10)
    ax.set_xlabel(_labelled(parameters[0], unit))
    if not x_numeric:
        ax.set_xticks(range(len(xs)), [str(v) for v in xs])
    return ax


def _family(frame, metric, parameters, values, failed, ax, unit):
    """``metric`` over the first parameter, a line for each value of the second (few of them)."""
    first, second = parameters
    xs, _, numeric = _axis(frame[first])
    for level in _axis(frame[second])[0]:
        rows = (frame[second] == level).to_numpy()
        order = np.argsort([xs.index(v) for v in frame[first][rows]], kind="stable")
        x = np.array([v if numeric else xs.index(v) for v in frame[first][rows]], dtype=float)[order]
        ax.plot(x, values[rows][order], "o-", ms=3, lw=1.2, label=f"{second} = {level:.6g}"
                if isinstance(level, (int, float, np.number)) else f"{second} = {level}")
        bad = failed[rows][order]
        if bad.any():
            ax.plot(x[bad], np.zeros(int(bad.sum())), "x", color="tab:red", ms=7, transform=ax.get_xaxis_transform(),
                    clip_on=False)
    ax.legend(loc="best", fontsize=8)
    ax.set_xlabel(_labelled(first, unit))
    ax.set_ylabel(_labelled(metric, unit))
    ax.set_title(f"{metric} over {first}, a line per {second}", fontsize=10)
    if not numeric:
        ax.set_xticks(range(len(xs)), [str(v) for v in xs])
    return ax
