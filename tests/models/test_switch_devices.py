"""MOSFETs and IGBTs with their body diodes, half-bridge legs with dead time (models.circuits)."""

import numpy as np
import pytest

from bondgraph.errors import ParameterValueError
from models.circuits import PWM, Circuit

T, D, DEAD, V, VF = 1e-5, 0.4, 2e-7, 12.0, 0.7


def synchronous_buck(dead=DEAD, v_f=VF):
    c = Circuit("sync_buck")
    c.V("V1", "in", "0", V)
    c.half_bridge("Q", "in", "0", "sw", T, D, dead, diode_v_f=v_f)
    c.L("L1", "sw", "out", 100e-6, i0=2.0)
    c.C("C1", "out", "0", 100e-6, v0=4.8)
    c.R("R1", "out", "0", 2.4)
    return c.build()


@pytest.mark.parametrize("method", ["auto", "RK45"])
def test_a_half_bridge_leg_commutes_through_the_body_diode_during_its_dead_time(method):
    """The low side closed over [0, (1 − D)T − t_d), the high side over [(1 − D)T, T − t_d): in each dead
    time the inductor's current (positive here) flows through the low side's body diode, so the switching
    node sits at −v_f, then at V while the high side conducts and at 0 while the low side does; its
    mean is V·(D − t_d/T) − v_f·2t_d/T.  Each high-side closing shorts the source through the
    conducting body diode: passed as mythical, the diode turned off by the impulse.  The edges are
    located on the schedule in every period (a step spanning a whole window used to pass it unseen)."""
    model = synchronous_buck()
    run = model.simulate(5 * T, method, rtol=1e-10, t_eval=np.linspace(0, 5 * T, 20001))
    edges = np.array([e.t for e in run.events if e.t > 0])
    expected = np.sort(np.concatenate([k * T + np.array([(1 - D) * T - DEAD, (1 - D) * T, T - DEAD, T])
                                       for k in range(5)]))
    np.testing.assert_allclose(edges, expected, rtol=0, atol=1e-12 * T * 10)
    phase = (run.t / T) % 1.0
    v, margin = run.signal("v_sw"), 1e-3
    windows = {0.0: (margin, 1 - D - DEAD / T - margin), -VF: (1 - D - DEAD / T + margin, 1 - D - margin),
               V: (1 - D + margin, 1 - DEAD / T - margin)}
    for level, (low, high) in windows.items():
        inside = (phase > low) & (phase < high)
        assert inside.sum() > 100
        np.testing.assert_allclose(v[inside], level, rtol=0, atol=1e-9)
    assert run.signal("i_L1").min() > 0
    closings = [e for e in run.events if e.mode_after.describe().startswith("Q_H=closed")]
    assert closings and all(any(step.kind == "mythical" for step in e.steps) for e in closings)


def test_a_mosfet_is_a_switch_with_its_body_diode_and_its_resistance():
    """A MOSFET closed on a resistor: v_DS = R_DS(on)·i; opened, the load's inductor drives its current
    through the body diode (source to drain) at −v_f."""
    c = Circuit("mos")
    c.V("V1", "in", "0", 10.0)
    c.mosfet("Q1", "in", "x", "t < 1e-3", r_on=0.1, diode_v_f=0.6)
    c.L("L1", "x", "y", 1e-3)
    c.R("R1", "y", "0", 9.9)
    c.diode("Dfw", "0", "x")  # the freewheeling path when the channel opens
    run = c.build().simulate(2e-3, "RK45", rtol=1e-10)
    before = run.t < 1e-3 - 1e-6
    np.testing.assert_allclose(run.signal("v_Q1")[before], 0.1 * run.signal("i_Q1")[before], rtol=1e-9, atol=1e-12)
    assert {"Q1", "Q1_D"} <= {a.name for a in run.model.automata}


def test_a_half_bridge_without_room_for_its_dead_time_is_refused():
    c = Circuit("leg")
    with pytest.raises(ParameterValueError, match="dead time"):
        c.half_bridge("Q", "in", "0", "sw", T, 0.01, 2e-7)


def test_a_flyback_converter_magnetises_its_transformer_while_on_and_delivers_while_off():
    """A flyback drawn as engineers draw it: an ideal transformer (turns ratio n) with its magnetising
    inductance across the primary, the switch below it, the secondary reversed into a diode.  While the
    switch is closed the primary sees the input (v_Lm = V, the diode blocks at −V/n); while it is open
    the magnetising current flows out of the secondary through the diode, so v_Lm = −n·v_out and the
    diode carries i_Lm/n — in every period, whatever the output's transient."""
    n, V = 2.0, 12.0
    c = Circuit("flyback")
    c.V("Vin", "in", "0", V)
    c.L("Lm", "in", "d", 100e-6, i0=1.0)
    c.transformer("T1", "in", "d", "0", "s", n)
    c.switch("S1", "d", "0", PWM(T, D))
    c.diode("D1", "s", "out")
    c.C("C1", "out", "0", 100e-6, v0=4.0)
    c.R("RL", "out", "0", 10.0)
    run = c.build().simulate(5 * T, "auto", rtol=1e-10, t_eval=np.linspace(0, 5 * T, 5001))
    phase = (run.t / T) % 1.0
    on, off = (phase > 1e-3) & (phase < D - 1e-3), (phase > D + 1e-3) & (phase < 1 - 1e-3)
    v_lm, v_out, i_lm, i_d = (run.signal(s) for s in ("v_Lm", "v_out", "i_Lm", "i_D1"))
    np.testing.assert_allclose(v_lm[on], V, rtol=1e-12)
    np.testing.assert_allclose(v_lm[off], -n * v_out[off], rtol=1e-9)
    np.testing.assert_allclose(i_d[off], n * i_lm[off], rtol=1e-9)
    np.testing.assert_allclose(i_d[on], 0.0, atol=1e-12)
    assert i_lm.min() > 0  # continuous conduction
