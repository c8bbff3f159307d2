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

__all__ = ["plot_trajectory", "phase_portrait", "mode_graph", "draw_bond_graph", "mode_colors"]


def mode_colors(modes) -> dict:
    """A stable colour per mode (in order of first appearance)."""
    plt = pyplot()
    cmap = plt.get_cmap("tab10")
    return {mode: cmap(k % 10) for k, mode in enumerate(dict.fromkeys(modes))}


def _intervals(trajectory):
    """(t_start, t_end, mode) of each flow interval (a new one after every instant)."""
    breaks = set(trajectory.event_index)
    spans = []
    start = 0
    for k in range(1, len(trajectory.t) + 1):
        if k == len(trajectory.t) or k in breaks or trajectory.modes[k] != trajectory.modes[start]:
            t0, t1 = trajectory.t[start], trajectory.t[k - 1]
            if t1 > t0:
                spans.append((t0, t1, trajectory.modes[start]))
            start = k
    return spans


#: how an instant is marked: (line style, legend entry) by what it passed
_INSTANT_STYLES = {
    "pinnacles": ("-", "instant with pinnacles"),
    "mythical": ("--", "instant through mythical modes"),
    "switch": (":", "instant (a switch, no mode passed between)"),
}


def _instant_kind(instant) -> str:
    return "pinnacles" if instant.pinnacles else "mythical" if instant.mythical else "switch"


def plot_trajectory(trajectory, signals=None, axes=None, title=None, max_instants=60):
    """One axis per signal (default: every state), mode intervals shaded,
    instants marked (when there are at most ``max_instants`` of them).
    Returns the figure."""
    plt = pyplot()
    signals = list(signals or trajectory.state_names)
    if axes is None:
        fig, axes = plt.subplots(len(signals), 1, sharex=True, figsize=(8, 1.9 * len(signals) + 0.8), squeeze=False)
        axes = axes[:, 0]
    else:
        axes = np.atleast_1d(axes)
        fig = axes[0].figure
    spans = _intervals(trajectory)
    colors = mode_colors([m for *_, m in spans] or trajectory.modes)
    for ax, name in zip(axes, signals):
        values = trajectory.signal(name)
        ax.plot(trajectory.t, values, color="black", lw=1.2)
        for t0, t1, mode in spans:
            ax.axvspan(t0, t1, color=colors[mode], alpha=0.18, lw=0)
        if len(trajectory.events) <= max_instants:
            for instant in trajectory.events:
                ax.axvline(instant.t, color="0.35", ls=_INSTANT_STYLES[_instant_kind(instant)][0], lw=0.8)
        ax.set_ylabel(name)
        ax.grid(alpha=0.25)
    axes[-1].set_xlabel("t [s]")
    from matplotlib.patches import Patch
    from matplotlib.lines import Line2D

    handles = [Patch(color=c, alpha=0.35, label=m.describe()) for m, c in colors.items()]
    drawn = {_instant_kind(i) for i in trajectory.events} if len(trajectory.events) <= max_instants else set()
    handles += [Line2D([], [], color="0.35", ls=style, lw=0.8, label=label)
                for kind, (style, label) in _INSTANT_STYLES.items() if kind in drawn]  # only what occurred
    axes[0].legend(handles=handles, fontsize=7, loc="best")
    axes[0].set_title(title or f"{trajectory.model.name}: {len(trajectory.events)} instants")
    fig.tight_layout()
    return fig


def phase_portrait(trajectory, x: str, y: str, ax=None, label=None, color=None):
    """``y`` against ``x``, each mode in its colour (or all in ``color``, to
    compare runs on one axis), jumps dotted.  Returns the axis."""
    plt = pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(5, 4))
    xs, ys = trajectory.signal(x), trajectory.signal(y)
    spans = _intervals(trajectory)
    colors = mode_colors([m for *_, m in spans])
    for t0, t1, mode in spans:
        mask = (trajectory.t >= t0) & (trajectory.t <= t1) & np.array([m == mode for m in trajectory.modes])
        ax.plot(xs[mask], ys[mask], color=color or colors[mode], lw=1.4)
    for k in trajectory.event_index:
        ax.plot(xs[k - 1 : k + 1], ys[k - 1 : k + 1], ":", color=color or "0.3", lw=1)
    ax.set_xlabel(x)
    ax.set_ylabel(y)
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
