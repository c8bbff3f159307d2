"""Netlists built with models.circuits.Circuit against exact answers."""

import math
import time

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import simpson
from scipy.optimize import brentq

from bondgraph.errors import (CausalityConflictError, DuplicateNameError, FloatingPartError, HybridBondGraphError,
                              InvalidGraphError, MissingParameterError, ParameterValueError, UnknownNameError)
from models import diode_circuit
from models.circuits import PWM, Circuit, Input
from switching import load_model
from switching.errors import GuardSyntaxError

RUN = dict(rtol=1e-10, atol=1e-14)


def rc_circuit():
    rc = Circuit("rc")
    rc.V("V1", "in", "0", 10.0)
    rc.R("R1", "in", "out", 1e3)
    rc.C("C1", "out", "0", 1e-6)
    return rc


def test_rc_charging_follows_the_exponential():
    model = rc_circuit().build()
    times = np.array([1e-4, 5e-4, 1e-3, 2e-3, 5e-3])
    run = model.simulate(5e-3, "RK45", t_eval=times, **RUN)
    tau = 1e3 * 1e-6
    assert set(times) <= set(run.t)
    exact = 10.0 * (1 - np.exp(-run.t / tau))
    np.testing.assert_allclose(run.signal("v_C1"), exact, rtol=1e-7)
    np.testing.assert_allclose(run.signal("v_out"), exact, rtol=1e-7)
    np.testing.assert_allclose(run.signal("i_R1"), (10.0 - exact) / 1e3, rtol=1e-6)
    np.testing.assert_allclose(run.signal("i_V1"), -run.signal("i_R1"), rtol=1e-12)  # n+ → n− through it
    np.testing.assert_allclose(run.signal("v_R1"), 10.0 - exact, rtol=1e-6)


def test_parameters_override_the_numbers_and_name_them_after_the_components():
    model = rc_circuit().build(parameters={"R1": 2e3}, name="slow_rc")
    assert model.name == "slow_rc"
    run = model.simulate(2e-3, "RK45", t_eval=[2e-3], **RUN)
    assert run.signal("v_C1")[-1] == pytest.approx(10.0 * (1 - math.exp(-1.0)), rel=1e-7)


def test_component_with_its_first_terminal_at_ground_keeps_the_sign_convention():
    c = Circuit("reversed")
    c.V("V1", "0", "a", 5.0)          # v(0) − v(a) = 5: node a at −5 V
    c.R("R1", "0", "a", 10.0)         # v_R1 = v(0) − v(a) = 5 V, i_R1 = 0.5 A from ground to a
    c.R("R2", "a", "b", 1.0)
    c.C("C1", "0", "b", 1e-3, v0=5.0)         # at rest: v(b) = v(a)
    run = c.build().simulate(1e-3, "RK45", **RUN)
    assert run.signal("v_a")[-1] == pytest.approx(-5.0)
    assert run.signal("v_R1")[-1] == pytest.approx(5.0)
    assert run.signal("i_R1")[-1] == pytest.approx(0.5)
    assert run.signal("v_C1")[-1] == pytest.approx(5.0)
    assert run.signal("v_b")[-1] == pytest.approx(-5.0)
    assert run.signal("i_V1")[-1] == pytest.approx(-0.5)  # R1 carries 0.5 A from 0 to a: back a → 0 in V1


def rectifier(V=10.0, w=2 * math.pi * 50, R=1e3, C=100e-6):
    c = Circuit("rectifier")
    c.V("Vs", "in", "0", "Vm*sin(w*t)")
    c.diode("D1", "in", "out")
    c.C("C1", "out", "0", C)
    c.R("Rload", "out", "0", R)
    return c.build(parameters={"Vm": V, "w": w})


def test_half_wave_rectifier_turns_off_at_tan_wt_equal_minus_wRC_and_on_where_the_decay_meets_the_source():
    V, w, R, C = 10.0, 2 * math.pi * 50, 1e3, 100e-6
    run = rectifier(V, w, R, C).simulate(0.03, "RK45", **RUN)
    labels = [[s.mode.label for s in e.steps] for e in run.events]
    assert labels[0] == ["blocking", "conducting"] and run.events[0].t < 1e-12   # starts conducting at once
    t_off = (math.pi - math.atan(w * R * C)) / w                      # tan(w t) = −wRC, second quadrant
    assert labels[1] == ["conducting", "blocking"]
    assert run.events[1].t == pytest.approx(t_off, rel=1e-6)
    t_on = brentq(lambda t: V * math.sin(w * t) - V * math.sin(w * t_off) * math.exp(-(t - t_off) / (R * C)),
                  2 * math.pi / w, 2.5 * math.pi / w, xtol=1e-15)
    assert labels[2] == ["blocking", "conducting"]
    assert run.events[2].t == pytest.approx(t_on, rel=1e-6)
    off = (run.t > t_off * (1 + 1e-6)) & (run.t < t_on * (1 - 1e-6))
    np.testing.assert_allclose(run.signal("v_C1")[off],
                               V * math.sin(w * t_off) * np.exp(-(run.t[off] - t_off) / (R * C)), rtol=1e-7)
    assert np.all(run.signal("i_D1")[off] == 0)
    on = (run.t > t_on * (1 + 1e-6)) & (run.t < run.events[3].t * (1 - 1e-6))
    np.testing.assert_allclose(run.signal("v_out")[on], V * np.sin(w * run.t[on]), rtol=1e-7)


def freewheel_circuit():
    c = Circuit("freewheel")
    c.V("V", "s", "0", 10.0)
    c.switch("S", "s", "n", closed_when="t < t_open")
    c.R("R", "n", "m", 1.0)
    c.L("L", "m", "0", 0.1)
    c.diode("D", "0", "n", v_f=0.7)
    return c


def test_switched_inductor_freewheels_through_the_diode_as_the_papers_circuit():
    times = np.linspace(0.0, 1.0, 101)
    run = freewheel_circuit().build(parameters={"t_open": 0.5}).simulate(1.0, "RK45", t_eval=times, **RUN)
    reference = diode_circuit.build().simulate(1.0, "RK45", t_eval=times, **RUN)
    assert [(s.mode.label, s.kind) for s in run.events[0].steps] == [
        ("closed|blocking", "start"), ("open|blocking", "mythical"), ("open|conducting", "continuous")]
    np.testing.assert_allclose(run.event_times, reference.event_times, rtol=1e-9)
    for name in ("i_L", "v_L", "i_D", "v_D"):
        np.testing.assert_allclose(run.signal(name), reference.signal(name), rtol=1e-7, atol=1e-9)
    V, R, L, V_f = 10.0, 1.0, 0.1, 0.7
    i_open = V / R * (1 - math.exp(-0.5 * R / L))
    assert run.event_times[1] == pytest.approx(0.5 + L / R * math.log(1 + R * i_open / V_f), rel=1e-8)


def test_the_built_model_round_trips_through_a_model_file(tmp_path):
    model = freewheel_circuit().build(parameters={"t_open": 0.5})
    path = tmp_path / "freewheel.toml"
    model.save(path)
    loaded = load_model(path)
    times = np.linspace(0.0, 1.0, 51)
    first = model.simulate(1.0, "RK45", t_eval=times, **RUN)
    second = loaded.simulate(1.0, "RK45", t_eval=times, **RUN)
    np.testing.assert_array_equal(first.event_times, second.event_times)
    np.testing.assert_allclose(second.signal("i_L"), first.signal("i_L"), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(second.signal("v_n"), first.signal("v_n"), rtol=1e-12, atol=1e-15)


def test_pwm_switch_edges_fall_on_the_schedule():
    c = Circuit("buck")
    c.V("Vin", "in", "0", 12.0)
    c.switch("S", "in", "sw", closed_when=PWM(period=1e-4, duty=0.3))
    c.diode("D", "0", "sw", r_on=1e-3)   # with an ideal diode, closing S would short the source
    c.L("L", "sw", "out", 1e-3)
    c.C("C", "out", "0", 1e-4)
    c.R("Rl", "out", "0", 10.0)
    run = c.build().simulate(1e-3, "RK45", rtol=1e-8, atol=1e-12, max_step=2e-5)
    edges = np.sort(np.concatenate([np.arange(1, 11) * 1e-4, np.arange(0, 10) * 1e-4 + 3e-5]))
    np.testing.assert_allclose(run.event_times, edges, rtol=1e-9)
    assert [s.mode.label for s in run.events[0].steps][-1] == "open|conducting"   # the diode takes the current


def test_buck_converter_in_continuous_conduction_meets_its_mean_output_and_ripple_closed_forms():
    """Periodic steady state of an ideal buck (switch S by PWM, freewheeling diode D with r_on):

    * the inductor's mean voltage over a period is zero, so the mean output equals the switch node's
      mean: Vin·D − r_on·(1 − D)·I (the diode's drop while it carries the load current I = Vout/R);
    * while S is closed the current rises at (Vin − Vout)/L for D·T: ΔI = (Vin − Vout)·D/(L·f);
    * the capacitor takes the triangle's ripple: ΔV = ΔI/(8·C·f)."""
    Vin, D, f, L, C, R, r_on, periods = 12.0, 0.4, 1e4, 1e-3, 1e-4, 10.0, 1e-3, 40
    T, Vout = 1 / f, Vin * D
    dI = (Vin - Vout) * D / (L * f)
    dV = dI / (8 * C * f)
    c = Circuit("buck")
    c.V("Vin", "in", "0", Vin)
    c.switch("S", "in", "sw", closed_when=PWM(period=T, duty=D))
    c.diode("D", "0", "sw", r_on=r_on)
    c.L("L", "sw", "out", L, i0=Vout / R - dI / 2)     # start on the averaged steady state, at the valley
    c.C("C", "out", "0", C, v0=Vout)
    c.R("Rl", "out", "0", R)
    last = np.linspace((periods - 1) * T, periods * T, 201)   # the edges k·T and (k + D)·T are samples
    run = c.build().simulate(periods * T, "RK45", t_eval=last, rtol=1e-8, atol=1e-12)
    t, index = np.unique(run.t, return_index=True)            # one sample per time
    v, i = run.signal("v_C")[index], run.signal("i_L")[index]
    last_period = run.events[-3:-1]                           # S closes at (periods − 1)·T, opens D·T later
    assert [e.steps[-1].mode.label for e in last_period] == ["closed|blocking", "open|conducting"]
    np.testing.assert_allclose([e.t for e in last_period], [(periods - 1) * T, (periods - 1 + D) * T], rtol=1e-12)
    assert np.min(i) > 0                                                      # continuous conduction
    mean = simpson(v, x=t) / T
    assert abs(mean - Vout) < dV / 2                                          # within the ripple band
    # the start's mismatch with the periodic orbit is of the ripple's order and decays as exp(−t/(2RC))
    assert mean == pytest.approx(Vout - r_on * (1 - D) * Vout / R, abs=dV * math.exp(-periods * T / (2 * R * C)))
    # ΔI assumes v_out constant: it moves by ΔV, so the slope (Vin − v_out)/L is off by ΔV/(Vin − Vout) at most
    assert np.ptp(i) == pytest.approx(dI, rel=dV / (Vin - Vout))
    assert np.argmax(i) == round(200 * D) and np.argmin(i) in (0, 200)          # peak as S opens, valleys as it closes
    assert np.ptp(v) == pytest.approx(dV, rel=0.01)                            # the triangle's charge ΔI·T/8


def test_relay_with_hysteresis_switches_at_its_two_thresholds():
    c = Circuit("relay")
    c.V("V", "s", "0", 10.0)
    c.switch("K", "s", "x", closed_when="v_out < v_lo", open_when="v_out > v_hi")
    c.R("R", "x", "out", 1.0)
    c.C("C", "out", "0", 1e-3)
    c.R("Rl", "out", "0", 20.0)
    run = c.build(parameters={"v_lo": 6.0, "v_hi": 8.0}).simulate(0.03, "RK45", **RUN)
    v_th, tau_on, tau_off = 10.0 * 20 / 21, 1e-3 * 20 / 21, 20 * 1e-3    # Thevenin seen by C; load alone
    t = run.event_times
    assert t[0] == 0.0 and [s.mode.label for s in run.events[0].steps][-1] == "closed"  # v_out = 0 < 6 at start
    assert t[1] == pytest.approx(tau_on * math.log(v_th / (v_th - 8.0)), rel=1e-7)
    assert t[2] - t[1] == pytest.approx(tau_off * math.log(8.0 / 6.0), rel=1e-7)
    assert t[3] - t[2] == pytest.approx(tau_on * math.log((v_th - 6.0) / (v_th - 8.0)), rel=1e-7)


def test_transformer_scales_voltage_and_current():
    c = Circuit("tf")
    c.V("Vs", "p", "0", Input("u"))
    c.transformer("T1", "p", "0", "s", "0", 2.0)
    c.R("RL", "s", "0", 5.0)
    run = c.build(inputs={"u": lambda t: 10.0}).simulate(1e-3, "RK45", **RUN)
    assert run.signal("v_s")[-1] == pytest.approx(5.0)
    assert run.signal("i_RL")[-1] == pytest.approx(1.0)
    assert run.signal("i_T1_p")[-1] == pytest.approx(0.5)
    assert run.signal("i_T1_s")[-1] == pytest.approx(1.0)


def test_dc_machine_speed_rises_with_its_mechanical_time_constant():
    V, Ra, k, J, b = 12.0, 2.0, 0.1, 1e-3, 1e-3
    c = Circuit("motor")
    c.V("Va", "a", "0", V)
    c.R("Ra", "a", "b", Ra)
    c.dc_machine("M", "b", "0", "w", "0", k)
    c.L("J", "w", "m", J)            # inertia: the shaft's speed is the secondary loop's current
    c.R("friction", "m", "0", b)
    run = c.build().simulate(0.2, "RK45", **RUN)
    speed, tau = k * V / (Ra * b + k * k), J / (b + k * k / Ra)
    np.testing.assert_allclose(run.signal("i_J"), speed * (1 - np.exp(-run.t / tau)), rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(run.signal("v_M_p"), k * run.signal("i_M_s"), rtol=1e-12)   # back-emf k·ω


def test_nonlinear_law_keeps_its_meaning_with_the_first_terminal_at_ground():
    for n1, n2, sign in (("a", "0", 1), ("0", "a", -1)):
        c = Circuit("cubic")
        c.C("C1", "a", "0", 1.0, v0=2.0)
        c.R("Rn", n1, n2, flow_law=lambda v: 0.5 * v**3)   # i = v³/2 across n1 → n2
        run = c.build().simulate(1.0, "RK45", **RUN)
        v = 1 / np.sqrt(0.25 + run.t)                         # dv/dt = −v³/2 from v = 2
        np.testing.assert_allclose(run.signal("v_C1"), v, rtol=1e-7)
        np.testing.assert_allclose(run.signal("i_Rn"), sign * 0.5 * v**3, rtol=1e-7)


@pytest.mark.timeout(60)
def test_the_readme_diode_law_in_numbers_builds_simulates_and_settles_on_the_newton_solution():
    """Issue 28: ``R("D", flow_law=lambda e: Is*(sp.exp(e/VT) - 1))`` with Is, VT = 1e-12, 0.025 A, V.

    Fed by V through R with a capacitor across it (the source alone in series with the law would be a
    static algebraic loop, its solution a Lambert W, with no state to integrate), the capacitor's voltage
    settles where its current vanishes: V = R·i + VT·ln(1 + i/Is), the diode's current solved here by
    Newton's method.  The fast time constant is C times the diode's small-signal resistance VT/i ≈ 6 Ω:
    stiff, so Radau; 10 ms is over a thousand time constants, what is left is the integration's rtol."""
    import sympy as sp

    Is, VT, V, R = 1e-12, 0.025, 5.0, 1e3
    start = time.perf_counter()
    c = Circuit("shockley")
    c.V("V1", "a", "0", V)
    c.R("R1", "a", "k", R)
    c.C("C1", "k", "0", 1e-6)
    c.R("D", "k", "0", flow_law=lambda e: Is * (sp.exp(e / VT) - 1))
    run = c.build().simulate(0.01, "Radau", **RUN)
    assert time.perf_counter() - start < 30                      # it took minutes inside sympy.solve once
    i = (V - 0.6) / R                                            # Newton on g(i) = R·i + VT·ln(1 + i/Is) − V
    for _ in range(50):
        i -= (R * i + VT * math.log1p(i / Is) - V) / (R + VT / (Is + i))
    assert abs(R * i + VT * math.log1p(i / Is) - V) < 1e-12
    assert run.signal("i_D")[-1] == pytest.approx(i, rel=1e-9)
    assert run.signal("v_D")[-1] == pytest.approx(V - R * i, rel=1e-9)
    assert run.signal("i_R1")[-1] == pytest.approx(i, rel=1e-9)


def test_initial_values_are_the_laws_outputs():
    c = Circuit("initial")
    c.C("C1", "a", "0", effort_law=lambda q: q**3 + q, v0=10.0)   # v = q³ + q: q = 2
    c.R("R1", "a", "0", 1.0)
    c.C("C2", "0", "b", 2.0, v0=3.0)                               # reversed: q_C2 = −2·3
    c.R("R2", "b", "0", 1.0)
    c.L("L1", "b", "c", "Lx", i0=2.0)
    c.R("R3", "c", "0", 1.0)
    model = c.build(parameters={"Lx": 0.5})
    assert dict(zip(model.state_names, model.initial_state())) == pytest.approx(
        {"q_C1": 2.0, "q_C2": -6.0, "p_L1": 1.0})
    run = model.simulate(1e-9, "RK45", **RUN)
    assert run.signal("v_C1")[0] == pytest.approx(10.0) and run.signal("v_C2")[0] == pytest.approx(3.0)
    assert run.signal("i_L1")[0] == pytest.approx(2.0)
    with pytest.raises(MissingParameterError, match="Lx"):
        c.build()


def test_the_graph_is_drawn_and_names_follow_the_components():
    import matplotlib

    matplotlib.use("Agg")
    from bondgraph import draw_bond_graph

    model = freewheel_circuit().build(parameters={"t_open": 0.5})
    assert {"node_s", "node_n", "node_m", "S", "D", "branch_R"} <= set(model.graph.elements)
    assert {a.name for a in model.automata} == {"S", "D"}
    assert draw_bond_graph(model.graph, {"S": True, "D": False}) is not None   # all on shorts the source


def test_unknown_node_is_named_with_a_suggestion():
    c = rc_circuit()
    c.R("R2", "otu", "0", 1.0)
    with pytest.raises(UnknownNameError, match=r"node 'otu' of 'R2'.*did you mean 'out'"):
        c.build()


def test_component_names_are_unique_checked_identifiers():
    c = rc_circuit()
    with pytest.raises(DuplicateNameError, match="'R1' is already defined"):
        c.R("R1", "out", "0", 1.0)
    with pytest.raises(InvalidGraphError, match="invalid component name"):
        c.R("R 2", "out", "0", 1.0)
    with pytest.raises(InvalidGraphError, match="invalid node name"):
        c.R("R2", "out; x", "0", 1.0)
    with pytest.raises(InvalidGraphError, match="shorted"):
        c.R("R2", "out", "out", 1.0)


def test_capacitor_loop_names_its_members():
    c = Circuit("parallel")
    c.V("V1", "a", "0", 1.0)
    c.C("C1", "a", "0", 1.0)
    with pytest.raises(InvalidGraphError, match="C1, V1 form a loop of capacitors"):
        c.build()


def test_inductor_cutset_names_its_members():
    c = Circuit("series_l")
    c.V("V1", "a", "0", 1.0)
    c.L("L1", "a", "b", 1.0)
    c.L("L2", "b", "c", 1.0)
    c.R("R1", "c", "0", 1.0)
    with pytest.raises(InvalidGraphError, match="L1, L2 form a cutset"):
        c.build()


def test_floating_node_is_refused():
    c = rc_circuit()
    c.R("R2", "x", "y", 1.0)
    c.R("R3", "y", "x", 1.0)
    with pytest.raises(InvalidGraphError, match="no path to ground"):
        c.build()


def test_source_text_is_parsed_not_run():
    c = Circuit("hostile")
    c.V("V1", "a", "0", '__import__("os").getcwd()')
    c.R("R1", "a", "0", 1.0)
    with pytest.raises(GuardSyntaxError, match="source 'V1' is not an expression of t"):
        c.build()


def test_errors_are_the_toolkits():
    with pytest.raises(HybridBondGraphError):
        Circuit("c").build()


def bridge(load_capacitance=None, **build):
    """A full-wave bridge: the source drives node a against ground; D1 a→p,
    D2 0→p, D3 n→a, D4 n→0; the load (and its filter capacitor) between p and n."""
    c = Circuit("bridge")
    c.V("Vs", "a", "0", "Vm*sin(w*t)")
    c.diode("D1", "a", "p")
    c.diode("D2", "0", "p")
    c.diode("D3", "n", "a")
    c.diode("D4", "n", "0")
    if load_capacitance is not None:
        c.C("C1", "p", "n", load_capacitance)
    c.R("Rload", "p", "n", 100.0)
    return c.build(parameters={"Vm": 10.0, "w": 2 * math.pi * 50}, **build)


def test_a_bridge_whose_load_floats_while_every_diode_blocks_builds_and_runs_in_the_limit_of_vanishing_leaks():
    """All four diodes blocking leave the load's nodes floating; their potentials are the limit of
    vanishing leaks across the diodes (DESIGN.md §6b): each blocking diode takes half of what the
    network puts across the bridge, v_D1 = (v_s − v_C)/2."""
    model = bridge(100e-6)
    me = model.mode_equations(model.mode({"D1": "off", "D2": "off", "D3": "off", "D4": "off"}))
    v_s, q, C = sp.Symbol("Vm") * sp.sin(sp.Symbol("w") * sp.Symbol("t")), sp.Symbol("q_C1"), sp.Symbol("C1")
    v_D1 = me.finite(me.to_raw(model.signal_expression("v_D1")))
    v_D2 = me.finite(me.to_raw(model.signal_expression("v_D2")))
    assert sp.simplify(v_D1 - (v_s - q / C) / 2) == 0
    assert sp.simplify(v_D2 - (-v_s - q / C) / 2) == 0
    assert sp.simplify(me.f[q] + q / (C * sp.Symbol("Rload"))) == 0  # the load discharges on its own


def test_floating_modes_lists_every_mode_that_floats():
    from models.circuits import floating_modes

    model = bridge(allow_floating=True)
    assert [mode.describe() for mode, _ in floating_modes(model)] == [
        "D1=blocking, D2=blocking, D3=blocking, D4=blocking"]
    assert floating_modes(bridge(gmin=1e-12)) == []


def test_voltage_sources_paralleled_by_a_switch_are_still_over_determined():
    c = Circuit("parallel_sources")
    c.V("V1", "a", "0", 5.0)
    c.switch("S", "a", "b", closed_when="t >= 0")
    c.V("V2", "b", "0", 6.0)
    c.R("R1", "b", "0", 10.0)
    with pytest.raises(CausalityConflictError) as info:
        c.build().simulate(1e-3, "RK45")
    assert not isinstance(info.value, FloatingPartError)
    assert "over-determine" in str(info.value) and "'V1'" in str(info.value) and "S: on" in str(info.value)
    # and in the circuit's words: the mode, the loop's components and nodes, the fix
    words = str(info.value).split("In circuit words: ")[1]
    assert words.startswith("in mode S=closed, the voltage sources V1, V2 and the conducting S close a loop")
    assert "'a'" in words and "'b'" in words and "ground" in words and "r_on" in words


def test_a_source_shorted_by_a_closed_switch_and_a_conducting_diode_is_said_in_circuit_words():
    from models.circuit_words import conflict_loop
    from models.netlist import Part

    parts = (Part("V", "V1", ("in", "0")), Part("S", "S1", ("in", "sw")), Part("D", "D1", ("0", "sw"), {"r_on": None}),
             Part("L", "L1", ("sw", "out")))
    words = conflict_loop(parts, {"S1": True, "D1": True})
    assert "mode S1=closed, D1=conducting, the voltage source V1 and the conducting " in words
    assert {"S1", "D1"} <= set(words.split(" close a loop")[0].split("conducting ")[-1].split(", "))
    assert conflict_loop(parts, {"S1": True, "D1": False}) == ""  # no loop: nothing to say
    with_r_on = parts[:2] + (Part("D", "D1", ("0", "sw"), {"r_on": 0.01}),) + parts[3:]
    assert conflict_loop(with_r_on, {"S1": True, "D1": True}) == ""  # the diode's resistance breaks it


def ideal_buck(scale=1.0, duty=0.4, period=1e-5):
    """A buck converter with an ideal switch and an ideal freewheeling diode into a constant-voltage load:
    every slope of the inductor current is a constant (voltages in V·scale, currents in A·scale)."""
    c = Circuit("buck")
    c.V("V1", "in", "0", 12.0 * scale)
    c.switch("S1", "in", "sw", PWM(period, duty))
    c.diode("D1", "0", "sw")
    c.L("L1", "sw", "out", 100e-6, i0=1.0 * scale)
    c.V("Vo", "out", "0", 4.8 * scale)
    return c.build()


@pytest.mark.parametrize("method", ["RK45", "auto"])
def test_an_ideal_buck_passes_the_shorted_source_as_mythical_and_turns_the_diode_off(method):
    """Closing the switch while the freewheeling diode conducts would short the source: the mode
    S1=closed, D1=conducting is passed as mythical, its diode current driven backwards as the limit of a
    vanishing resistance (an impulse), so D1 turns off; the current rises by (V − Vo)·D·T/L and falls
    by Vo·(1 − D)·T/L, exactly."""
    V, Vo, L, D, T = 12.0, 4.8, 100e-6, 0.4, 1e-5
    run = ideal_buck().simulate(10 * T, method, max_step=T / 20, rtol=1e-10)
    closing = [e for e in run.events if e.steps[0].mode.states == ("open", "conducting")]
    assert len(closing) >= 9
    for event in closing:
        assert [(s.mode.describe(), s.kind) for s in event.steps] == [
            ("S1=open, D1=conducting", "start"), ("S1=closed, D1=conducting", "mythical"),
            ("S1=closed, D1=blocking", "continuous")]
        (turn_off,) = event.steps[1].fired
        # i_D1 → −V/(2ε): the source shorted through the two vanishing resistances of S1 and D1
        assert turn_off.automaton == "D1" and turn_off.comparisons[0].left.impulse == pytest.approx(-V / 2)
    np.testing.assert_allclose([e.t for e in closing], [k * T for k in range(1, len(closing) + 1)], rtol=1e-12)
    rise, fall = (V - Vo) * D * T / L, Vo * (1 - D) * T / L
    assert rise == pytest.approx(fall)  # the load's voltage is the average: a periodic current from the start
    i_L = run.signal("i_L1")
    closings = np.isin(run.t, [e.t for e in closing])
    openings = np.isin(run.t, run.event_times) & ~closings
    np.testing.assert_allclose(i_L[closings], 1.0, rtol=1e-9)          # the current's minimum, each period
    np.testing.assert_allclose(i_L[openings], 1.0 + rise, rtol=1e-9)   # its maximum


def test_an_ideal_bucks_conflicting_mode_is_derived_once_not_at_every_closing(monkeypatch):
    """Each PWM closing meets the conflicting mode S1=closed, D1=conducting; its derivation's error is kept and
    raised again (it was derived anew every period: half of a warm run's time)."""
    import switching.library.mode_library as library

    calls = []
    real = library.ModeEquations

    def counting(model, mode):
        calls.append(mode.describe())
        return real(model, mode)

    monkeypatch.setattr(library, "ModeEquations", counting)
    T = 1e-5
    model = ideal_buck()
    run = model.simulate(10 * T, "RK45", max_step=T / 20, rtol=1e-10)
    closings = [e for e in run.events if any(s.kind == "mythical" for s in e.steps)]
    assert len(closings) >= 9 and calls.count("S1=closed, D1=conducting") == 1


def test_an_ideal_buck_in_other_units_has_the_same_instants_and_modes():
    runs = [ideal_buck(scale).simulate(5e-5, "RK45", max_step=5e-7, rtol=1e-10) for scale in (1.0, 1e-3, 1e3)]
    for other in runs[1:]:
        assert [[s.mode for s in e.steps] for e in other.events] == [[s.mode for s in e.steps] for e in runs[0].events]
        np.testing.assert_allclose(other.event_times, runs[0].event_times, rtol=1e-12)


def test_a_conflict_no_guard_settles_names_its_instant_and_mode():
    c = Circuit("parallel_sources")  # closing the switch ties two sources of different voltages: no automaton
    c.V("V1", "a", "0", 5.0)           # can leave that mode, so the run stops there, saying when and where
    c.R("R0", "a", "0", 10.0)
    c.switch("S", "a", "b", closed_when="t >= 1e-4")
    c.V("V2", "b", "0", 6.0)
    c.R("R1", "b", "0", 10.0)
    with pytest.raises(CausalityConflictError) as info:
        c.build().simulate(1e-3, "RK45")
    assert str(info.value).startswith("at t = 0.0001, mode S=closed: ") and "'V1'" in str(info.value)
    run = info.value.trajectory                                 # the run up to the instant is kept
    assert run.t[0] == 0.0 and run.t[-1] == pytest.approx(1e-4, rel=1e-12)
    assert run.signal("v_b")[-1] == pytest.approx(6.0, rel=1e-12)


@pytest.mark.parametrize("gmin", [None, 1e-12])
def test_capacitor_filtered_bridge_switches_at_the_exact_instants_and_no_others(gmin):
    """Without gmin the blocking diodes' voltages are the limit of vanishing leaks (DESIGN.md §6b); with it,
    the leaks' own.  Where two diodes turn on at one instant in the exact solution (|v_s| meets v_C), the
    limit may pass them at two instants within 1e-12 of it: each pair counts as one."""
    V, w, R, C = 10.0, 2 * math.pi * 50, 100.0, 100e-6
    run = bridge(C, gmin=gmin).simulate(0.05, "RK45", **RUN)
    events = [e for k, e in enumerate(run.events)
              if k + 1 == len(run.events) or run.events[k + 1].t - e.t > 1e-12 * max(e.t, 1e-300)]
    half = math.pi / w
    t_off = (math.pi - math.atan(w * R * C)) / w          # tan(w t) = −wRC: the charging current reaches 0

    def decay(t):
        return V * math.sin(w * t_off) * math.exp(-(t - t_off) / (R * C))

    t_on = brentq(lambda t: -V * math.sin(w * t) - decay(t), half, 1.5 * half, xtol=1e-15)   # |v_s| meets v_C
    exact = [0.0]
    for k in range(5):
        exact += [t_off + k * half, t_on + k * half]
    exact = [t for t in exact if t < 0.05]
    assert len(events) == len(exact)                          # the leak adds no instant
    assert events[0].t < 1e-12
    np.testing.assert_allclose([e.t for e in events[1:]], exact[1:], rtol=1e-9 if gmin is None else 1e-7)
    ends = [e.steps[-1].mode.label for e in events]
    cycle = ["conducting|blocking|blocking|conducting", "blocking|blocking|blocking|blocking",
             "blocking|conducting|conducting|blocking", "blocking|blocking|blocking|blocking"]
    assert ends == cycle * 2 + ends[8:]
    blocking = (run.t > t_off * (1 + 1e-6)) & (run.t < t_on * (1 - 1e-6))
    np.testing.assert_allclose(run.signal("v_C1")[blocking], [decay(t) for t in run.t[blocking]], rtol=1e-7)
    conducting = (run.t > t_on * (1 + 1e-6)) & (run.t < (t_off + half) * (1 - 1e-6))
    np.testing.assert_allclose(run.signal("v_C1")[conducting], V * np.abs(np.sin(w * run.t[conducting])), rtol=1e-7)
    if gmin is not None:  # the leaks carry gmin·v: picoamperes against the load's 0.1 A
        assert np.max(np.abs(run.signal("i_D1_gmin"))) < 2 * V * 1e-12
    # no charge sharing: a diode turns on where |v_s| has come up to v_C, so the capacitor's voltage (and its
    # energy) is continuous through every instant: a step ΔV onto the source would lose C·ΔV²/2 (C₁C₂ΔV²/(2(C₁ + C₂))
    # with C₂ → ∞), here ΔV is what v_D may pass before the guard holds, a band of round-off's order (~1e-12·|v|)
    for event in run.events[1:]:
        (at,) = np.nonzero(run.t == event.t)
        assert len(at) == 2 and run.signal("v_C1")[at[1]] == pytest.approx(run.signal("v_C1")[at[0]], rel=1e-10)


@pytest.mark.parametrize("gmin", [None, 1e-12])
def test_resistive_bridge_commutates_at_the_zero_crossings(gmin):
    V, w = 10.0, 2 * math.pi * 50
    model = bridge(gmin=gmin)
    if gmin is not None:
        assert {s.name: v for s, v in model.parameter_values.items()}["gmin"] == 1e-12
    run = model.simulate(0.03, "RK45", **RUN)
    assert [e.steps[-1].mode.label for e in run.events] == [
        "conducting|blocking|blocking|conducting", "blocking|conducting|conducting|blocking",
        "conducting|blocking|blocking|conducting"]
    np.testing.assert_allclose([e.t for e in run.events[1:]], [math.pi / w, 2 * math.pi / w], rtol=1e-9)
    np.testing.assert_allclose(run.signal("v_Rload"), V * np.abs(np.sin(w * run.t)), rtol=1e-7, atol=1e-9)


def test_gmin_takes_a_parameter_name_and_refuses_what_is_no_conductance():
    c = Circuit("half")
    c.V("Vs", "in", "0", 5.0)
    c.diode("D1", "in", "out")
    c.R("Rload", "out", "0", 1e3)
    model = c.build(gmin="g_leak", parameters={"g_leak": 1e-9})
    assert {s.name: v for s, v in model.parameter_values.items()}["g_leak"] == 1e-9 and "D1_gmin" in model.graph.elements
    for bad in (-1e-12, 0.0, float("nan"), True, [1e-12]):
        with pytest.raises(ParameterValueError, match="gmin"):
            c.build(gmin=bad)
    c.R("D1_gmin", "out", "0", 1.0)
    with pytest.raises(DuplicateNameError, match="D1_gmin"):
        c.build(gmin=1e-12)


def test_closed_switches_in_parallel_share_the_current_as_vanishing_resistances_would():
    """Two ideal switches closed in parallel leave the current circulating between them free; as the limit
    of equal vanishing resistances (DESIGN.md §6b) each carries half of the branch's current."""
    c = Circuit("parallel_switches")
    c.V("V1", "a", "0", 5.0)
    c.R("R1", "a", "b", 1.0)
    c.switch("S1", "b", "c", closed_when="t >= 0")
    c.switch("S2", "b", "c", closed_when="t >= 0")
    c.R("R2", "c", "0", 10.0)
    run = c.build().simulate(1e-3, "RK45")
    np.testing.assert_allclose(run.signal("i_S1"), 5.0 / 11.0 / 2, rtol=1e-12)
    np.testing.assert_allclose(run.signal("i_S2"), 5.0 / 11.0 / 2, rtol=1e-12)


def test_a_built_model_records_the_netlist_and_arguments_it_was_built_from():
    from models.netlists import ideal_buck

    circuit = ideal_buck()
    model = circuit.build({"R1": 10.0}, gmin=1e-9)
    circuit.R("R9", "out", "0", 1.0)  # a later addition does not change what the model was built from
    assert model.built_from.netlist.components == ("V1", "S1", "D1", "L1", "C1", "R1")
    assert model.built_from.parameters == {"R1": 10.0}
    assert model.built_from.options == {"gmin": 1e-9, "allow_floating": False}
    assert model.built_from.inputs == ()
