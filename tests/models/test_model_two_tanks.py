"""The two tanks against hydraulics: conservation of volume, valves moving
exactly at their level thresholds, closed-form filling and exchange phases."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from bondgraph.errors import UnknownParameterError
from models import two_tanks

P = two_tanks.DEFAULTS
OPTIONS = {"rtol": 1e-10, "atol": 1e-12}


def valve_events(trajectory, automaton):
    """(instant, new state) for each move of one automaton."""
    out = []
    for e in trajectory.events:
        before, after = e.mode_before.state_of(automaton), e.mode_after.state_of(automaton)
        if before != after:
            out.append((e, after))
    return out


def test_volume_is_conserved():
    """V1 + V2 changes by what the pump brings minus what the drain lets out."""
    model = two_tanks.build()
    t_end = 1000.0
    # 40001 uniform times and every instant's before/after rows (samples=): the trapezoids never straddle a jump
    trajectory = model.simulate(t_end, "RK45", samples=40001, **OPTIONS)
    t = trajectory.t
    assert len(t) == 40001 + 2 * len(trajectory.events)
    assert len(trajectory.events) > 20  # several cycles of both valves
    stored = trajectory.signal("V_total")
    inflow = trajectory.signal("Q_pump")
    outflow = trajectory.signal("Q_out")
    np.testing.assert_allclose(inflow, P["Q_in"])
    # cumulative trapezoid; the two samples of an instant have zero width, so jumps of Q_out are exact
    dt = np.diff(t)
    net = np.concatenate([[0.0], np.cumsum(0.5 * dt * ((inflow - outflow)[1:] + (inflow - outflow)[:-1]))])
    # 10 m³ pumped in 1000 s; the trapezoid rule on a 25 ms grid is good to ~2e-6 m³
    np.testing.assert_allclose(stored - stored[0], net, rtol=0, atol=1e-5)
    # and the internal flow is a pure exchange: tank 1 loses what tank 2 gains
    q_valve = trajectory.signal("Q_valve")
    v1 = trajectory.state("V1")
    lost = np.concatenate([[0.0], np.cumsum(0.5 * dt * ((inflow - q_valve)[1:] + (inflow - q_valve)[:-1]))])
    np.testing.assert_allclose(v1 - v1[0], lost, rtol=0, atol=1e-5)


def test_valves_move_exactly_at_their_thresholds():
    trajectory = two_tanks.build().simulate(1000.0, "RK45", **OPTIONS)
    transfer, drain = valve_events(trajectory, "valve"), valve_events(trajectory, "drain")
    assert len(transfer) >= 8 and len(drain) >= 8
    level = {"valve": lambda x: x[0] / P["A1"], "drain": lambda x: x[1] / P["A2"]}
    threshold = {
        ("valve", "open"): P["h1_high"], ("valve", "closed"): P["h1_low"],
        ("drain", "open"): P["h2_high"], ("drain", "closed"): P["h2_low"],
    }
    for name, moves in (("valve", transfer), ("drain", drain)):
        states = [state for _, state in moves]
        assert states == ["open", "closed"] * (len(states) // 2) + ["open"] * (len(states) % 2)  # alternate
        for instant, state in moves:
            assert level[name](instant.x_before) == pytest.approx(threshold[(name, state)], abs=1e-12)
            np.testing.assert_array_equal(instant.x_before, instant.x_after)  # a valve moving makes no jump
            assert instant.kinds == ["start", "continuous"]
    # between moves the levels stay inside the hysteresis bands (the valves never chatter)
    labels = np.array(trajectory.mode_labels)
    h1, h2 = trajectory.signal("h1"), trajectory.signal("h2")
    closed = np.char.startswith(labels, "valve=closed, ")
    assert h1[closed].max() <= P["h1_high"] + 1e-12
    assert h1[~closed & (trajectory.t > 0)].min() >= P["h1_low"] - 1e-12
    drain_closed = np.char.endswith(labels, "drain=closed")
    assert h2[drain_closed].max() <= P["h2_high"] + 1e-12
    assert h2[~drain_closed].min() >= P["h2_low"] - 1e-12


def test_tank_one_fills_linearly_until_the_valve_opens():
    model = two_tanks.build()
    times = np.linspace(0, 99, 100)
    trajectory = model.simulate(150.0, "RK45", t_eval=times, **OPTIONS)
    first = trajectory.events[0]
    t_open = P["A1"] * (P["h1_high"] - P["h1_0"]) / P["Q_in"]  # 100 s
    assert first.t == pytest.approx(t_open, abs=1e-9)
    assert first.mode_after.label == "open|closed"
    before = np.array([m.label == "closed|closed" for m in trajectory.modes])
    assert trajectory.t[before].max() < t_open
    np.testing.assert_allclose(trajectory.signal("h1")[before], P["h1_0"] + P["Q_in"] * trajectory.t[before] / P["A1"],
                               rtol=0, atol=1e-11)
    np.testing.assert_allclose(trajectory.signal("h2")[before], P["h2_0"], atol=1e-15)
    np.testing.assert_allclose(trajectory.signal("Q_valve")[before], 0.0, atol=1e-15)


def test_exchange_phase_matches_closed_form_and_the_drain_opens_on_time():
    """Valve open, drain closed: d = h1 - h2 relaxes exponentially, the total volume grows as Q t."""
    model = two_tanks.build()
    t_open = P["A1"] * (P["h1_high"] - P["h1_0"]) / P["Q_in"]
    rho_g = P["rho"] * P["g"]
    tau = P["R_v"] / (rho_g * (1 / P["A1"] + 1 / P["A2"]))
    d_inf = P["Q_in"] * tau / P["A1"]
    d0 = P["h1_high"] - P["h2_0"]
    volume0 = P["A1"] * P["h1_high"] + P["A2"] * P["h2_0"]

    def levels(t):
        s = t - t_open
        d = d_inf + (d0 - d_inf) * math.exp(-s / tau)
        h2 = (volume0 + P["Q_in"] * s - P["A1"] * d) / (P["A1"] + P["A2"])
        return h2 + d, h2

    # which threshold comes first: tank 2 reaching h2_high (drain opens) or tank 1 falling to h1_low
    t_drain = brentq(lambda t: levels(t)[1] - P["h2_high"], t_open + 1e-9, t_open + 200, xtol=1e-14)
    assert levels(t_drain)[0] > P["h1_low"]  # (for the defaults, the drain)
    times = np.linspace(t_open + 1, t_drain - 1, 50)
    trajectory = model.simulate(t_drain + 1, "RK45", t_eval=times, **OPTIONS)
    second = trajectory.events[1]
    assert [m.label for m in second.modes] == ["open|closed", "open|open"]
    assert second.t == pytest.approx(t_drain, abs=1e-8)
    inside = (trajectory.t > t_open) & (trajectory.t < t_drain)
    exact = np.array([levels(t) for t in trajectory.t[inside]])
    np.testing.assert_allclose(trajectory.signal("h1")[inside], exact[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(trajectory.signal("h2")[inside], exact[:, 1], rtol=0, atol=1e-9)
    # the valve flow is the pressure difference over the pipe resistance
    np.testing.assert_allclose(trajectory.signal("Q_valve")[inside],
                               rho_g * (exact[:, 0] - exact[:, 1]) / P["R_v"], rtol=1e-8)


def test_both_valves_open_tends_to_the_hydrostatic_steady_state():
    """Thresholds out of reach keep both valves open: Q_out = Q_in, p2 = Q_in R_out, p1 = p2 + Q_in R_v."""
    model = two_tanks.build(h1_low=-1.0, h1_high=0.0, h2_low=-1.0, h2_high=0.0, h1_0=0.2)
    trajectory = model.simulate(3000.0, "RK45", **OPTIONS)
    assert trajectory.modes[-1].label == "open|open"
    assert trajectory.signal("Q_out")[-1] == pytest.approx(P["Q_in"], rel=1e-6)
    assert trajectory.signal("p2")[-1] == pytest.approx(P["Q_in"] * P["R_out"], rel=1e-6)
    assert trajectory.signal("p1")[-1] == pytest.approx(P["Q_in"] * (P["R_out"] + P["R_v"]), rel=1e-6)
    rho_g = P["rho"] * P["g"]
    assert trajectory.signal("h1")[-1] == pytest.approx(P["Q_in"] * (P["R_out"] + P["R_v"]) / rho_g, rel=1e-6)


def test_default_run_and_signals():
    trajectory = two_tanks.build().simulate(**two_tanks.RUN)
    for name in two_tanks.SIGNALS:
        assert np.all(np.isfinite(trajectory.signal(name)))
    np.testing.assert_allclose(trajectory.signal("p1"), P["rho"] * P["g"] * trajectory.signal("h1"), rtol=1e-12)
    assert {"valve=closed, drain=closed", "valve=open, drain=closed", "valve=open, drain=open",
            "valve=closed, drain=open"} <= set(trajectory.mode_labels)


def test_unknown_parameter_is_an_error():
    with pytest.raises(UnknownParameterError):
        two_tanks.build(area=2.0)
