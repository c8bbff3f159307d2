"""Plots are produced with the expected structure for a known run."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402

from models import bouncing_ball, falling_rod  # noqa: E402
from switching.simulate.plotting import draw_bond_graph, mode_graph, phase_portrait, plot_trajectory  # noqa: E402


@pytest.fixture(scope="module")
def ball_run():
    return bouncing_ball.build().simulate(2.5, "RK45", rtol=1e-9)


def test_trajectory_plot_has_one_axis_per_signal_and_shades_each_flow(ball_run, tmp_path):
    fig = plot_trajectory(ball_run, ["y", "v"])
    assert len(fig.axes) == 2
    # 5 flight intervals between 4 bounces: five shaded spans per axis (pinnacles have no duration)
    assert shaded_spans(fig.axes[0]) == 5
    # one vertical line per instant, solid (each bounce is a pinnacle)
    vlines = [ln for ln in fig.axes[0].lines if len(set(ln.get_xdata())) == 1]
    assert len(vlines) == 4 and all(ln.get_linestyle() == "-" for ln in vlines)
    path = tmp_path / "ball.png"
    fig.savefig(path)
    assert path.stat().st_size > 10_000


def test_mythical_only_instants_are_dashed_and_phase_portrait_draws_jumps():
    run = falling_rod.build(mu=0.002).simulate(0.4, "RK45", rtol=1e-9, atol=1e-12)
    fig = plot_trajectory(run, ["theta"])
    vlines = [ln for ln in fig.axes[0].lines if len(set(ln.get_xdata())) == 1]
    assert [ln.get_linestyle() for ln in vlines] == ["--"]  # the impact passed only a mythical mode
    ax = phase_portrait(run, "theta", "tip_vy")
    dotted = [ln for ln in ax.lines if ln.get_linestyle() == ":"]
    assert len(dotted) == 1 and np.isclose(dotted[0].get_ydata()[1], 0.0, atol=1e-12)


def test_mode_graph_and_bond_graph_drawing(ball_run):
    graph, _ = mode_graph(ball_run)
    assert set(graph.nodes) == {"contact=flight", "contact=impact"}
    assert graph.edges["contact=flight", "contact=impact"]["count"] == 4
    assert graph.edges["contact=impact", "contact=flight"]["count"] == 4
    model = falling_rod.build()
    ax = draw_bond_graph(model.graph, model.configuration_of(model.mode("contact|stuck")))
    labels = {t.get_gid(): t.get_text() for t in ax.texts}
    assert labels["element:rod/I_J"] == "I: rod/I_J"
    assert labels["element:cx"] == r"$\mathbf{0}_{\mathrm{cx}}^{\mathrm{on}}$"  # 0-junction cx, switched on


def shaded_spans(ax) -> int:
    """The mode intervals shaded on ``ax``: the rectangles of its collections drawn over the panel's height."""
    return sum(len(c.get_paths()) for c in ax.collections if isinstance(c, PolyCollection)
               and c.get_transform() == ax.get_xaxis_transform())


def legend_entries(fig):
    """The modes' legend: beside the panels in a figure of its own."""
    (legend,) = fig.legends
    return [text.get_text() for text in legend.get_texts()]


def test_the_legend_lists_only_the_instants_that_occurred(ball_run):
    assert legend_entries(plot_trajectory(ball_run, ["y"]))[-1] == "instant with pinnacles"
    rod = falling_rod.build(mu=0.002).simulate(0.5, "RK45")  # the stuck mode passed as mythical: no pinnacle
    entries = legend_entries(plot_trajectory(rod, ["theta"]))
    assert "instant through mythical modes" in entries and "instant with pinnacles" not in entries


def test_the_command_line_draws_jumps_upright(tmp_path, monkeypatch):
    """``hbg run --plot`` plots the sampled rows plus each instant's before/after pair, so that a jump is
    a vertical segment at its instant (not a slant to the next sample)."""
    from models import cli

    drawn = []
    monkeypatch.setattr("switching.simulate.plotting.plot_trajectory",
                        lambda trajectory, signals: drawn.append(trajectory) or plot_trajectory(trajectory, signals))
    assert cli.main(["run", "falling-rod", "--set", "mu=0.002", "--signals", "tip_vx", "--plot",
                     str(tmp_path / "rod.png")]) == 0
    (shown,) = drawn
    (instant,) = shown.events
    at = np.flatnonzero(shown.t == instant.t)
    assert len(at) == 2 and shown.signal("tip_vx")[at[0]] != shown.signal("tip_vx")[at[1]]


def test_a_trajectory_plots_itself(ball_run):
    fig = ball_run.plot(["y", "v"], title="ball")
    assert [ax.get_ylabel() for ax in fig.axes] == ["y [m]", "v [m/s]"] and fig.axes[0].get_title() == "ball"
    # default: the declared signals, then the states none of them renames (issue 29: the rod drew 12 panels)
    assert [ax.get_ylabel() for ax in ball_run.plot().axes] == ["v [m/s]", "p [N·s]", "y [m]"]


def test_mode_colours_stay_with_their_modes_whatever_the_run_met_first():
    """Issue 29: the colours swapped between near-identical runs (they followed the order of first appearance)."""
    from switching.simulate.plotting import mode_colors

    model = falling_rod.build()
    modes = [model.mode("free|stuck"), model.mode("contact|stuck"), model.mode("contact|slide_pos")]
    assert mode_colors(modes, model) == mode_colors(list(reversed(modes)), model)
    assert len(set(mode_colors(modes, model).values())) == 3


def test_signals_share_a_panel_a_window_is_drawn_and_round_off_is_drawn_flat(ball_run):
    fig = plot_trajectory(ball_run, [["y", "v"], "p"], t_range=(0.5, 1.5))
    assert len(fig.axes) == 2 and fig.axes[0].get_xlim() == (0.5, 1.5)
    from matplotlib.legend import Legend

    legends = [a for a in fig.axes[0].artists if isinstance(a, Legend)] + [fig.axes[0].get_legend()]
    assert [[t.get_text() for t in legend.get_texts()] for legend in legends][0] == ["y [m]", "v [m/s]"]  # then modes
    drawn = [line for line in fig.axes[1].lines if len(set(line.get_xdata())) > 1]
    assert drawn and drawn[0].get_xdata().min() >= 0.5 and drawn[0].get_xdata().max() <= 1.5
    from models import ball_chain

    chain = ball_chain.build(N=3, distance=0.5).simulate(0.2, "RK45")  # ball 3 at rest all along: v3 = 0
    fig = plot_trajectory(chain, ["v3"])
    assert fig.axes[0].get_ylabel() == "v3 [m/s] (constant: 0)" and fig.axes[0].get_ylim() == (-1.0, 1.0)


def test_a_long_switching_run_is_drawn_as_an_envelope_not_aliased_lines():
    from models import boost_converter
    from switching.simulate import plotting

    run = boost_converter.build().simulate(0.004, "RK45", rtol=1e-6, samples=20_000)
    assert len(run.t) > plotting.MAX_POINTS
    fig = plot_trajectory(run, ["i_L"])
    envelopes = fig.axes[0].collections
    assert envelopes and not [line for line in fig.axes[0].lines if len(line.get_xdata()) > plotting.MAX_POINTS]
    low, high = plotting._envelope(np.asarray(run.t), run.signal("i_L"), plotting.MAX_POINTS // 2)[1:]
    assert low.min() == pytest.approx(run.signal("i_L").min()) and high.max() == pytest.approx(run.signal("i_L").max())


def test_a_run_of_thousands_of_mode_intervals_is_shaded_per_column_in_one_collection_per_mode():
    """The ideal buck over 2000 periods (4000 intervals): at most one rectangle per column of the shading's
    bins, in one collection per mode (12 000 ``axvspan`` patches took 12 s to make and 6 s to draw)."""
    from models.netlists import ideal_buck
    from switching.simulate import plotting

    run = ideal_buck().build().simulate(0.02, "auto")
    assert len(plotting._intervals(run)) > plotting.MAX_SPANS
    fig = plot_trajectory(run, ["v_out"])
    shading = [c for c in fig.axes[0].collections if isinstance(c, PolyCollection)
               and c.get_transform() == fig.axes[0].get_xaxis_transform()]
    assert len(shading) <= 3 and 0 < shaded_spans(fig.axes[0]) <= plotting.MAX_POINTS // 2
    assert fig.axes[0].get_xlabel() == "t [ms]"


@pytest.mark.parametrize("t_end, unit, last", [(1e-5, "µs", "10"), (2e-3, "ms", "2"), (2.5, "s", "2.5")])
def test_the_time_axis_is_in_engineering_units_without_an_offset(t_end, unit, last):
    run = bouncing_ball.build().simulate(t_end, "RK45")
    fig = plot_trajectory(run, ["y"])
    ax = fig.axes[0]
    fig.canvas.draw()
    assert ax.get_xlabel() == f"t [{unit}]"
    labels = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
    assert labels[0] == "0" and labels[-1] == last and not ax.xaxis.get_offset_text().get_text()


def test_units_and_names_with_a_dollar_are_drawn_as_text():
    """A unit ``$\\frac{a}$`` made the whole plot fail (mathtext), and ``--plot`` said nothing after its colon."""
    import sympy as sp

    from bondgraph import I, One, Se
    from bondgraph import BondGraph
    from switching import HybridModel

    g = BondGraph("fall")
    v = g.add(One("v"))
    g.connect(Se("push", sp.Symbol("F")), v)
    g.connect(v, I("mass", "m", state="p"))
    model = HybridModel(g, [], {"F": 1.0, "m": 2.0}, signals={"v": "p/m"}, name="fall",
                        units={"p": "$\\frac{a}$", "v": "$/s"})
    fig = plot_trajectory(model.simulate(1.0, "RK45"), ["p", "v"])
    fig.canvas.draw()
    assert [ax.get_ylabel() for ax in fig.axes] == ["p [\\$\\frac{a}\\$]", "v [\\$/s]"]
