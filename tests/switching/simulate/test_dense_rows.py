"""Dense rows between a run's steps (cubic Hermite per flow interval) and the plots drawn from them."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from models import bouncing_ball  # noqa: E402
from models.circuits import Circuit  # noqa: E402


@pytest.fixture(scope="module")
def ball():
    model = bouncing_ball.build()
    return model, model.simulate(2.5)


def test_dense_flights_of_a_ball_are_its_parabolas(ball):
    """A cubic Hermite interpolant is exact on a parabola: every added row lies on the flight through the
    run's own instant before it, ``y = y_k + v_k·τ − g·τ²/2``, to round-off."""
    model, run = ball
    dense = run.dense()
    assert len(dense.t) > len(run.t) + 1500
    values = {symbol.name: value for symbol, value in model.parameter_values.items()}
    g, m = values["g"], values["m"]
    starts = [(run.t[0], run.x[0])] + [(e.t, e.x_after) for e in run.events]
    p, y = (dense.state_names.index(name) for name in ("p", "y"))
    for k, (t_k, x_k) in enumerate(starts):
        end = run.events[k].t if k < len(run.events) else run.t[-1]
        inside = (dense.t > t_k) & (dense.t < end)
        tau = dense.t[inside] - t_k
        assert inside.sum() > 100
        np.testing.assert_allclose(dense.x[inside, y], x_k[y] + x_k[p] / m * tau - g * tau**2 / 2, atol=1e-12)
        np.testing.assert_allclose(dense.x[inside, p], x_k[p] - m * g * tau, atol=1e-12)


def test_dense_rows_keep_every_row_and_instant(ball):
    _, run = ball
    dense = run.dense()
    assert [dense.t[k] for k in dense.event_index] == [run.t[k] for k in run.event_index]
    for k in dense.event_index:  # each instant's pair stays adjacent: nothing is drawn across a jump
        assert dense.t[k - 1] == dense.t[k] and dense.x[k - 1, 0] != dense.x[k, 0]
    original = {(float(t), tuple(x)) for t, x in zip(run.t, run.x)}
    assert original <= {(float(t), tuple(x)) for t, x in zip(dense.t, dense.x)}
    assert dense.sampling == "dense" and np.all(np.diff(dense.t) >= 0)


def test_an_interval_holding_an_instant_is_not_interpolated():
    """Rows at requested times hold no instant rows: an interval with a bounce inside keeps its two rows
    only (the parabola on one side is not the other's)."""
    model = bouncing_ball.build()
    run = model.simulate(2.5, t_eval=np.linspace(0.0, 2.5, 11))
    dense = run.dense()
    bounces = run.event_times
    for a, b in zip(run.t[:-1], run.t[1:]):
        added = (dense.t > a) & (dense.t < b)
        holds = np.any((bounces > a) & (bounces < b))
        assert (added.sum() == 0) == holds


def lc_error(dt: float) -> float:
    """The largest error of the dense rows of an undamped LC circuit (ω = 1 rad/s) stepped by RK4 at
    ``dt``, against ``v = cos t``."""
    c = Circuit("lc")
    c.C("C1", "a", 0, 1.0, v0=1.0)
    c.L("L1", "a", 0, 1.0)
    run = c.build().simulate(2 * np.pi, "RK4", dt=dt)
    dense = run.dense(4000)
    return float(np.max(np.abs(dense.signal("v_C1") - np.cos(dense.t))))


def test_the_dense_rows_converge_at_fourth_order():
    steps = np.array([0.2, 0.1, 0.05])
    errors = np.array([lc_error(dt) for dt in steps])
    slope = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert 3.7 < slope < 4.3, (errors, slope)


def test_a_run_that_kept_no_instants_is_drawn_as_its_rows():
    run = bouncing_ball.build().simulate(2.5, keep_instants=False)
    fig = run.plot(["y"])
    assert len(fig.axes[0].lines[0].get_xdata()) == len(run.t)


def test_the_default_plot_of_a_sine_driven_rectifier_draws_its_peaks():
    """``model.simulate(...)`` keeps solver steps (68 here); its plot draws the curve they followed: the
    capacitor, tied to a 325 V sine while the diode conducts, reaches 325 V in the plot, not only the
    highest step's value."""
    c = Circuit("rectifier")
    c.V("V1", "a", 0, "325*sin(2*pi*50*t)")
    c.diode("D1", "a", "b")
    c.R("R1", "b", 0, 100.0)
    c.C("C1", "b", 0, 1e-4)
    run = c.build().simulate(0.06)
    assert run.sampling == "steps" and run.signal("v_b").max() < 325 * (1 - 1e-4)  # (the steps miss the peak)
    fig = run.plot(["v_b", "v_a"])
    for ax in fig.axes[:2]:
        drawn = ax.lines[0].get_ydata()
        assert len(drawn) > 2000 and drawn.max() > 325 * (1 - 2e-5)
    assert len(fig.axes[0].lines[0].get_xdata()) > 2000


def test_the_flow_of_many_rows_at_once_is_the_flow_of_each():
    from models import boost_converter

    model = boost_converter.build()
    run = model.simulate(1e-3)
    for mode in set(run.modes):
        rows = np.array([k for k, m in enumerate(run.modes) if m == mode])
        compiled = model.compiled_mode(mode)
        each = np.array([compiled.rates(run.x[k].copy(), run.t[k]) for k in rows])
        np.testing.assert_array_equal(compiled.rates_at(run.x[rows], run.t[rows]), each)
