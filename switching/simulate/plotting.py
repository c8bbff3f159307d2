"""Plots of hybrid runs (matplotlib, imported on first use).

* :func:`plot_trajectory` — signals against time, each mode's interval
  shaded in its own colour, instants marked: a solid line where a pinnacle
  was passed, a dashed one where only mythical modes were passed;
* :func:`phase_portrait` — one signal against another, jumps drawn as dotted
  segments (the paper's Figs. 19–20);
* :func:`mode_graph` — the modes actually traversed and the transitions
  between them (networkx), edges labelled with how often they were taken;
* :func:`draw_bond_graph` — the bond graph as textbooks draw it, with the
  causal stroke of every bond in one mode (:mod:`bondgraph.drawing`).
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from bondgraph.drawing import draw_bond_graph, pyplot
from bondgraph.errors import HybridBondGraphError

__all__ = ["DEFAULT_PANELS", "DENSE_SAMPLES", "FLAT", "MAX_POINTS", "MAX_SPANS", "default_signals", "draw_bond_graph",
           "mode_colors", "mode_graph", "phase_portrait", "plain", "plot_trajectory", "time_unit"]


def mode_colors(modes, model=None) -> dict:
    """A colour per mode that does not depend on the run: with the
    ``model``, the mode's number ``Σ_a state_a·radix_a`` in its automata
    (the initial mode of a two-automaton model is always the first colour,
    whatever the run visited first); without, the modes in the order of
    their labels."""
    plt = pyplot()
    cmap = plt.get_cmap("tab10")
    modes = list(dict.fromkeys(modes))
    if model is not None:
        automata = {a.name: list(a.states) for a in model.automata}

        def number(mode):
            code, radix = 0, 1
            for name, state in zip(mode.automata, mode.states):
                states = automata.get(name, [state])
                code += (states.index(state) if state in states else 0) * radix
                radix *= max(len(states), 1)
            return code

        try:
            return {mode: cmap(number(mode) % 10) for mode in modes}
        except (AttributeError, TypeError):
            pass
    order = sorted(modes, key=lambda m: getattr(m, "label", str(m)))
    return {mode: cmap(order.index(mode) % 10) for mode in modes}


#: panels drawn by default (the model's declared signals, else its states)
DEFAULT_PANELS = 6
#: a panel of more samples in its window is drawn as a min–max envelope per time bin (half this many bins)
MAX_POINTS = 6000
#: the most mode intervals shaded one by one; beyond, the shading is decimated per column (_shading)
MAX_SPANS = 400
#: uniform times added between a run's rows in a panel's window of few rows (:func:`_densified`)
DENSE_SAMPLES = 2000
#: a signal whose range is below this fraction of its magnitude is drawn as constant (round-off is not a signal)
FLAT = 1e-9


def default_signals(trajectory) -> list:
    """The panels of :func:`plot_trajectory` by default: the model's own
    signals (those it declares, in order), then the states that none of them
    merely renames (``x1 = pos1``), at most :data:`DEFAULT_PANELS`."""
    model = trajectory.model
    if model is None:
        return list(trajectory.state_names)[:DEFAULT_PANELS]
    names = list(model.signal_names)
    declared = names[: len(names) - len(model.states)]
    renamed = set()
    for name in declared:
        try:
            renamed.add(model.signal_expression(name))
        except HybridBondGraphError:  # a signal the model cannot express alone: it renames nothing
            pass
    states = [s.name for s in model.states if s not in renamed]
    return (declared + states)[:DEFAULT_PANELS]


def _envelope(t, values, bins):
    """``(t, low, high)`` of ``values`` in ``bins`` equal time bins over ``t`` (empty bins left out)."""
    edges = np.linspace(t[0], t[-1], bins + 1)
    index = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, bins - 1)
    low = np.full(bins, np.inf)
    high = np.full(bins, -np.inf)
    np.minimum.at(low, index, values)
    np.maximum.at(high, index, values)
    kept = np.isfinite(low)
    centres = 0.5 * (edges[:-1] + edges[1:])
    return centres[kept], low[kept], high[kept]


def _draw_signal(ax, t, values, label, color):
    """One signal on ``ax``: the line, or its min–max envelope when it has
    more than :data:`MAX_POINTS` samples; a signal flat to round-off is
    drawn flat, with its value."""
    if len(t) > MAX_POINTS:
        centres, low, high = _envelope(t, values, MAX_POINTS // 2)
        ax.fill_between(centres, low, high, color=color, lw=0.6, alpha=0.9, label=label, step="mid")
    else:
        ax.plot(t, values, color=color, lw=1.2, label=label)
    finite = values[np.isfinite(values)]
    if len(finite):
        size = float(np.max(np.abs(finite)))
        if np.ptp(finite) <= FLAT * size or size == 0.0:
            return float(np.mean(finite))
    return None


def _intervals(trajectory):
    """(t_start, t_end, mode) of each flow interval (a new one after every instant or change of mode)."""
    t = np.asarray(trajectory.t)
    n = len(t)
    if n == 0:
        return []
    places: dict = {}
    numbers = np.fromiter((places.setdefault(m, len(places)) for m in trajectory.modes), dtype=np.int64, count=n)
    changes = np.flatnonzero(numbers[1:] != numbers[:-1]) + 1
    breaks = np.asarray([k for k in trajectory.event_index if 0 < k < n], dtype=np.int64)
    bounds = np.union1d(changes, breaks)
    starts = np.concatenate([[0], bounds])
    ends = np.concatenate([bounds, [n]]) - 1
    keep = t[ends] > t[starts]
    return [(t[a], t[b], trajectory.modes[a]) for a, b in zip(starts[keep], ends[keep])]


def _shading(spans, low, high, bins):
    """The mode intervals to shade: ``spans`` as they are when there are at most ``MAX_SPANS``, else per
    column of ``bins`` equal time bins over ``[low, high]`` the mode at the column's centre, equal
    neighbours merged (a 100 kHz converter's 10⁵ periods would be 2·10⁵ patches: minutes and gigabytes)."""
    if len(spans) <= MAX_SPANS:
        return spans
    starts = np.array([a for a, _, _ in spans])
    ends = np.array([b for _, b, _ in spans])
    edges = np.linspace(low, high, bins + 1)
    centres = 0.5 * (edges[:-1] + edges[1:])
    index = np.clip(np.searchsorted(starts, centres, side="right") - 1, 0, len(spans) - 1)
    shaded = []
    for k, i in enumerate(index):
        if not starts[i] <= centres[k] <= ends[i]:
            continue  # (the centre falls on an instant between two spans)
        mode = spans[i][2]
        if shaded and shaded[-1][2] == mode and shaded[-1][1] == edges[k]:
            shaded[-1] = (shaded[-1][0], edges[k + 1], mode)
        else:
            shaded.append((edges[k], edges[k + 1], mode))
    return shaded


#: the time axis's units: (factor, name) for a window at least as long as the key [s]
_TIME_UNITS = ((1.0, (1.0, "s")), (1e-3, (1e3, "ms")), (1e-6, (1e6, "µs")), (0.0, (1e9, "ns")))


def time_unit(span: float) -> tuple[float, str]:
    """``(factor, unit)`` to show a time window of ``span`` [s] in: s, ms, µs or ns, whichever keeps its
    ticks between 1 and 1000 units."""
    for least, unit in _TIME_UNITS:
        if span >= least:
            return unit
    return _TIME_UNITS[-1][1]


def plain(text: str) -> str:
    """``text`` as matplotlib shows it literally: a ``$`` would start mathtext (a unit ``"$/kWh"``, or
    ``"$\\frac{a}$"`` that mathtext cannot parse, failed the whole plot)."""
    return str(text).replace("$", r"\$")


#: how an instant is marked: (line style, legend entry) by what it passed
_INSTANT_STYLES = {
    "pinnacles": ("-", "instant with pinnacles"),
    "mythical": ("--", "instant through mythical modes"),
    "switch": (":", "instant (a switch, no mode passed between)"),
}


def _instant_kind(instant) -> str:
    return "pinnacles" if instant.pinnacles else "mythical" if instant.mythical else "switch"


def _units(trajectory):
    """``(unit(name), label(name))`` from the trajectory's model
    (:mod:`switching.model.annotations`); names alone without a model."""
    notes = getattr(trajectory.model, "annotations", None)
    if notes is None:
        return (lambda name: None), str
    return notes.unit, notes.label


def plot_trajectory(trajectory, signals=None, axes=None, title=None, max_instants=60, t_range=None):
    """Signals against time, one panel each (labelled with its unit where the
    model gives one, :mod:`switching.model.annotations`), the flow in each mode shaded
    (a colour per mode that stays with it from run to run), instants marked
    (when there are at most ``max_instants`` of them), jumps upright where
    the run kept each instant's rows.  Returns the figure.

    ``signals``: names, a panel each; an entry that is itself a list of
    names draws those in one panel, with a legend (``[["v1", "v2"], "x1"]``);
    default :func:`default_signals` (the model's own signals, else its
    states, at most :data:`DEFAULT_PANELS`).  ``t_range=(a, b)`` [s]: draw
    only that window.  A panel of more than :data:`MAX_POINTS` samples in the
    window is drawn as the min–max envelope of its samples in
    ``MAX_POINTS/2`` equal time bins (a long switching run would alias as
    lines); a signal constant to round-off (its range within
    :data:`FLAT` of its magnitude) is drawn flat, its value in the label."""
    plt = pyplot()
    panels = [list(entry) if isinstance(entry, (list, tuple)) else [entry]
              for entry in (signals or default_signals(trajectory))]
    own = axes is None  # (a figure of its own: legends outside the panels, in its constrained layout)
    if own:
        fig, axes = plt.subplots(len(panels), 1, sharex=True, figsize=(9, 1.9 * len(panels) + 0.8), squeeze=False,
                                 layout="constrained")
        axes = axes[:, 0]
    else:
        axes = np.atleast_1d(axes)
        fig = axes[0].figure
    t = np.asarray(trajectory.t)
    if t_range is not None:
        low, high = (float(v) for v in t_range)
        if not low < high:
            raise ValueError(f"t_range must be (start, end) with start < end, got {t_range!r}")
        inside = (t >= low) & (t <= high)
    else:
        low, high = (float(t[0]), float(t[-1])) if len(t) else (0.0, 1.0)
        inside = np.ones(len(t), dtype=bool)
    drawn = _densified(trajectory, low, high, int(np.count_nonzero(inside)))
    if drawn is not trajectory:
        t = np.asarray(drawn.t)
        inside = (t >= low) & (t <= high)
    spans = [(max(a, low), min(b, high), m) for a, b, m in _intervals(trajectory) if b >= low and a <= high]
    colors = mode_colors([m for *_, m in spans] or trajectory.modes, trajectory.model)
    spans = _shading(spans, low, high, MAX_POINTS // 2)
    factor, time_name = time_unit(high - low)
    instants = [i for i in trajectory.events if low <= i.t <= high]
    cycle = plt.rcParams["axes.prop_cycle"].by_key().get("color", ["C0"])
    unit, label = _units(trajectory)
    for ax, names in zip(axes, panels):
        flat = {}  # name → its value, for a signal constant to round-off
        for k, name in enumerate(names):
            color = "black" if len(names) == 1 else cycle[k % len(cycle)]
            constant = _draw_signal(ax, t[inside], np.asarray(drawn.signal(name))[inside], name, color)
            if constant is not None:
                flat[name] = constant
        _shade(ax, spans, colors)
        if len(instants) <= max_instants:
            for instant in instants:
                ax.axvline(instant.t, color="0.35", ls=_INSTANT_STYLES[_instant_kind(instant)][0], lw=0.8)
        if len(flat) == len(names):  # round-off is not a signal: a flat line around its value
            value = next(iter(flat.values()))
            pad = 0.5 * abs(value) if value else 1.0
            ax.set_ylim(value - pad, value + pad)
        shown = [plain(f"{label(name)} (constant: {flat[name]:.6g})" if name in flat else label(name))
                 for name in names]
        if len(names) == 1:
            ax.set_ylabel(shown[0], fontsize=8 if len(shown[0]) > 18 else None)
        else:
            ax.legend(shown, fontsize=7, **(dict(loc="upper left", bbox_to_anchor=(1.01, 1.0)) if own
                                            else dict(loc="upper right")))
            common = {unit(name) for name in names}
            if len(common) == 1 and None not in common:  # one unit for the panel: on its axis
                ax.set_ylabel(plain(f"[{common.pop()}]"))
        ax.grid(alpha=0.25)
        ax.set_xlim(low, high)
        ax.xaxis.set_major_formatter(_time_formatter(factor))
    axes[-1].set_xlabel(f"t [{time_name}]")
    _mode_legend(fig, axes[0], colors, instants, max_instants, own, len(panels[0]) > 1)
    name = trajectory.model.name if trajectory.model is not None else getattr(trajectory, "model_name", "run")
    count = len(trajectory.events)
    axes[0].set_title(plain(title or f"{name}: {count} instant{'' if count == 1 else 's'}"))
    if not own:
        fig.tight_layout()
    return fig


def _densified(trajectory, low, high, rows):
    """The trajectory as drawn over ``[low, high]``: with :data:`DENSE_SAMPLES` interpolated times added
    (:meth:`Trajectory.dense`) when its window holds fewer than ``MAX_POINTS/2`` rows (a run's solver steps:
    a sine stepped 20 times a period would be drawn as chords), else as it is.  Not when the run kept no
    instants: a jump between two rows could not be told from the flow."""
    if rows >= MAX_POINTS // 2 or not getattr(trajectory, "instants_kept", False) or trajectory.model is None:
        return trajectory
    return trajectory.dense(DENSE_SAMPLES, (low, high))


def _shade(ax, spans, colors):
    """The mode intervals ``spans`` shaded over the panel's height: one collection of rectangles per mode
    (thousands of ``axvspan`` patches took seconds to make and to draw)."""
    from matplotlib.collections import PolyCollection

    by_mode: dict = {}
    for t0, t1, mode in spans:
        by_mode.setdefault(mode, []).append(((t0, 0.0), (t0, 1.0), (t1, 1.0), (t1, 0.0)))
    for mode, rectangles in by_mode.items():
        ax.add_collection(PolyCollection(rectangles, transform=ax.get_xaxis_transform(), facecolor=colors[mode],
                                         alpha=0.18, lw=0, zorder=0), autolim=False)


def _time_formatter(factor: float):
    """Tick labels of times [s] in the unit ``factor`` makes of them (no offset: a 10 µs window reads
    0 … 10, not 1e-5 + …)."""
    from matplotlib.ticker import FuncFormatter

    return FuncFormatter(lambda value, position: f"{value * factor:.6g}")


def _mode_legend(fig, ax, colors, instants, max_instants, own, panel_legend):
    """The modes' colours and the instants' line styles (only those drawn): beside the panels in a figure
    of its own, else in the first panel."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [Patch(color=c, alpha=0.35, label=plain(m.describe())) for m, c in colors.items()]
    drawn = {_instant_kind(i) for i in instants} if len(instants) <= max_instants else set()
    handles += [Line2D([], [], color="0.35", ls=style, lw=0.8, label=label)
                for kind, (style, label) in _INSTANT_STYLES.items() if kind in drawn]  # only what occurred
    if own:
        fig.legend(handles=handles, fontsize=7, loc="outside right upper")
        return
    if panel_legend:  # (that panel has its signals' legend)
        ax.add_artist(ax.get_legend())
    ax.legend(handles=handles, fontsize=7, loc="best")


def phase_portrait(trajectory, x: str, y: str, ax=None, label=None, color=None):
    """``y`` against ``x``, each mode in its colour (or all in ``color``, to
    compare runs on one axis), jumps dotted; a run of few rows drawn dense
    (:func:`_densified`).  Returns the axis."""
    plt = pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(5, 4))
    if len(trajectory.t):
        trajectory = _densified(trajectory, float(trajectory.t[0]), float(trajectory.t[-1]), len(trajectory.t))
    xs, ys = trajectory.signal(x), trajectory.signal(y)
    spans = _intervals(trajectory)
    colors = mode_colors([m for *_, m in spans], trajectory.model)
    for t0, t1, mode in spans:
        mask = (trajectory.t >= t0) & (trajectory.t <= t1) & np.array([m == mode for m in trajectory.modes])
        ax.plot(xs[mask], ys[mask], color=color or colors[mode], lw=1.4)
    for k in trajectory.event_index:
        ax.plot(xs[k - 1 : k + 1], ys[k - 1 : k + 1], ":", color=color or "0.3", lw=1)
    _, label = _units(trajectory)
    ax.set_xlabel(label(x))
    ax.set_ylabel(label(y))
    if label:
        ax.plot([], [], color=color or "black", label=label)
        ax.legend(fontsize=8)
    ax.grid(alpha=0.25)
    return ax


def mode_graph(trajectory, ax=None):
    """The traversed modes as a directed graph (networkx), drawn; returns ``(graph, ax)``.

    Nodes are modes (with the kinds they were passed as), edges the steps
    taken at instants, labelled with their count."""
    import networkx as nx

    plt = pyplot()
    graph = nx.DiGraph()
    counts: Counter = Counter()
    kinds: dict = {}
    for instant in trajectory.events:
        for a, b in zip(instant.steps, instant.steps[1:]):
            counts[(a.mode.describe(), b.mode.describe())] += 1
        for step in instant.steps:
            kinds.setdefault(step.mode.describe(), set()).add(step.kind)
    for mode in trajectory.modes:
        kinds.setdefault(mode.describe(), set()).add("continuous")
    for label, ks in kinds.items():
        graph.add_node(label, kinds=sorted(ks))
    for (a, b), n in counts.items():
        graph.add_edge(a, b, count=n)
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4.5))
    pos = nx.circular_layout(graph) if len(graph) > 2 else nx.spring_layout(graph, seed=1)
    node_colors = ["#f4b6b6" if kinds[n] == {"mythical"} else "#b6d7f4" for n in graph]
    nx.draw_networkx(graph, pos, ax=ax, node_color=node_colors, node_size=1400, font_size=7, arrows=True,
                     connectionstyle="arc3,rad=0.12", labels={n: n.replace(", ", ",\n") for n in graph})
    nx.draw_networkx_edge_labels(graph, pos, edge_labels={e: graph.edges[e]["count"] for e in graph.edges},
                                 ax=ax, font_size=7)
    ax.set_axis_off()
    ax.set_title("modes traversed (red: only ever mythical)", fontsize=9)
    return graph, ax
