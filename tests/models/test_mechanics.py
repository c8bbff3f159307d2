"""Machines built with models.mechanics.Mechanism against exact answers."""

import math

import numpy as np
import pytest

from bondgraph.errors import DuplicateNameError, HybridBondGraphError, InvalidGraphError, UnknownNameError
from models.mechanics import Mechanism
from switching import ZenoError, load_model
from switching.errors import GuardSyntaxError
from switching.files.modelfile import dumps_model

RUN = dict(rtol=1e-10, atol=1e-12)
TOL = 1e-7   # relative error of the runs' values at rtol = 1e-10 (event times are located to round-off)


def around(run, t):
    """The indices of the samples just before and just after the instant at ``t``."""
    (at,) = np.nonzero(run.t == t)
    return at[0], at[-1]


def energy(run, inertias):
    return sum(0.5 * J * run.signal(f"omega_{name}") ** 2 for name, J in inertias.items())


def test_spring_mass_damper_follows_its_closed_form():
    m, k, b, x0 = 1.0, 4.0, 0.4, 0.1
    smd = Mechanism("smd")
    smd.mass("m1", "a", m, x0=x0)
    smd.spring("k1", "a", "0", k, q0=x0)      # relaxed at x = 0: compressed by x0 at the start
    smd.damper("c1", "0", "a", b)             # first end on the frame: v_c1 = 0 − v_a
    run = smd.build().simulate(5.0, "RK45", t_eval=np.linspace(0, 5, 51), **RUN)
    wn, zeta = math.sqrt(k / m), b / (2 * math.sqrt(k * m))
    wd = wn * math.sqrt(1 - zeta**2)
    t = run.t
    x = x0 * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    v = -x0 * wn / math.sqrt(1 - zeta**2) * np.exp(-zeta * wn * t) * np.sin(wd * t)
    np.testing.assert_allclose(run.signal("x_m1"), x, rtol=TOL, atol=1e-9)
    np.testing.assert_allclose(run.signal("v_m1"), v, rtol=TOL, atol=1e-9)
    np.testing.assert_allclose(run.signal("F_k1"), k * x, rtol=TOL, atol=1e-9)   # pushes the frame, holds a back
    np.testing.assert_allclose(run.signal("v_c1"), -v, rtol=TOL, atol=1e-9)
    np.testing.assert_allclose(run.signal("F_c1"), -b * v, rtol=TOL, atol=1e-9)


def test_spring_between_two_masses_transmits_its_compression_force():
    two = Mechanism("two")
    two.mass("m1", "a", 1.0, v0=1.0)
    two.spring("k1", "a", "b", 100.0)
    two.mass("m2", "b", 1.0)
    run = two.build().simulate(0.3, "RK45", **RUN)
    w = math.sqrt(200.0)                         # relative motion: reduced mass 1/2
    q = np.sin(w * run.t) / w                    # x_a − x_b, from v_a − v_b = cos(w t)
    np.testing.assert_allclose(run.signal("F_k1"), 100.0 * q, rtol=TOL, atol=1e-9)
    np.testing.assert_allclose(run.signal("v_m2"), 0.5 * (1 - np.cos(w * run.t)), rtol=TOL, atol=1e-9)
    np.testing.assert_allclose(run.signal("x_m1") - run.signal("x_m2"), q, rtol=TOL, atol=1e-9)


def dropped(e, v_th=0.0, m=2.0, h=1.0, g=9.81):
    drop = Mechanism("drop")
    drop.mass("m1", "a", m, x0=h)
    drop.force("gravity", "a", -m * g)
    drop.stop("floor", "a", lower=0.0, e=e, v_th=v_th)
    return drop.build()


def test_mass_hits_a_stop_and_rebounds_at_minus_e_v():
    e, h, g = 0.5, 1.0, 9.81
    run = dropped(e).simulate(1.3, "RK45", **RUN)
    t1 = math.sqrt(2 * h / g)
    exact, t, v = [], t1, g * t1
    for _ in range(len(run.events)):
        exact.append(t)
        v *= e
        t += 2 * v / g
    assert len(exact) >= 4
    np.testing.assert_allclose(run.event_times, exact, rtol=1e-9)
    assert [(s.mode.label, s.kind) for s in run.events[0].steps] == [
        ("free", "start"), ("lower_impact", "pinnacle"), ("free", "continuous")]
    # samples strictly between the run's own first two instants (both samples at an instant excluded)
    first = (run.t > run.event_times[0]) & (run.t < run.event_times[1])  # v = e·g·t1 − g (t − t1)
    np.testing.assert_allclose(run.signal("v_m1")[first], e * g * t1 - g * (run.t[first] - t1), rtol=TOL, atol=1e-9)
    with pytest.raises(ZenoError) as info:       # e < 1 and no resting speed: the bounces accumulate
        dropped(e).simulate(2.0, "RK45", **RUN)
    assert info.value.accumulation_time == pytest.approx(t1 * (1 + e) / (1 - e), rel=1e-6)


def test_a_slow_landing_stays_in_contact_carrying_the_weight():
    m, g = 2.0, 9.81
    run = dropped(0.5, v_th=0.1, m=m).simulate(2.0, "RK45", **RUN)
    assert [s.mode.label for s in run.events[-1].steps] == ["free", "lower"]
    assert run.events[-1].t < math.sqrt(2 / g) * 3      # before the accumulation point
    end = run.t > run.events[-1].t
    assert np.all(run.signal("v_m1")[end] == 0)
    np.testing.assert_allclose(run.signal("x_m1")[end], 0.0, atol=1e-12)
    np.testing.assert_allclose(run.signal("F_floor")[end], -m * g, rtol=1e-12)   # a pushes the frame down


def test_a_pressed_contact_lets_go_when_the_force_turns():
    press = Mechanism("press")
    press.mass("m1", "a", 1.0)
    press.force("push", "a", "2*cos(t)")
    press.stop("wall", "a", upper=0.0)          # starts touching the wall: e = 0, it stays
    run = press.build().simulate(3.0, "RK45", **RUN)
    labels = [[s.mode.label for s in e.steps] for e in run.events]
    assert labels[-1] == ["upper", "free"]
    assert run.events[-1].t == pytest.approx(math.pi / 2, rel=1e-9)   # the push turns to a pull
    assert [s.mode.label for s in run.events[0].steps] == ["free", "upper_impact", "upper"]   # at once
    held = np.arange(len(run.t)) >= around(run, run.events[0].t)[1]
    held &= run.t < math.pi / 2 * (1 - 1e-9)
    np.testing.assert_allclose(run.signal("F_wall")[held], 2 * np.cos(run.t[held]), rtol=1e-9, atol=1e-12)
    free = run.t > math.pi / 2
    t = run.t[free]
    np.testing.assert_allclose(run.signal("v_m1")[free], 2 * (np.sin(t) - 1), rtol=TOL, atol=1e-9)
    np.testing.assert_allclose(run.signal("x_m1")[free], 2 * (-np.cos(t) - (t - math.pi / 2)), rtol=TOL, atol=1e-9)


def test_gear_divides_the_speed_and_multiplies_the_torque():
    T, J1, J2, n = 2.0, 1.0, 16.0, 4.0
    gears = Mechanism("gears", "rotational")
    gears.torque("Tin", "a", T)
    gears.inertia("J1", "a", J1)
    gears.gear("G", "a", "b", n)
    gears.inertia("J2", "b", J2)
    run = gears.build().simulate(1.0, "RK45", **RUN)
    J = J1 + J2 / n**2                            # the load's inertia seen from the input
    np.testing.assert_allclose(run.signal("omega_J1"), T / J * run.t, rtol=TOL, atol=1e-12)
    np.testing.assert_allclose(run.signal("omega_J2"), run.signal("omega_J1") / n, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(run.signal("T_G_out"), n * run.signal("T_G_in"), rtol=1e-12)
    assert run.signal("T_G_out")[-1] == pytest.approx(J2 * T / (n * J), rel=1e-9)
    assert run.signal("theta_b")[-1] == pytest.approx(run.signal("theta_a")[-1] / n, rel=1e-9)


def test_motor_reaches_the_no_load_speed_V_over_k():
    V, k, Ra, J = 12.0, 0.1, 2.0, 1e-3
    drive = Mechanism("drive", "rotational")
    drive.motor("M", "s", k, V=V, R=Ra)
    drive.inertia("J1", "s", J)
    run = drive.build().simulate(1.0, "RK45", **RUN)
    tau = J * Ra / k**2
    speed = V / k * (1 - np.exp(-run.t / tau))
    np.testing.assert_allclose(run.signal("omega_J1"), speed, rtol=TOL, atol=1e-9)
    np.testing.assert_allclose(run.signal("i_M"), (V - k * speed) / Ra, rtol=TOL, atol=1e-9)
    np.testing.assert_allclose(run.signal("T_M"), k * run.signal("i_M"), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(run.signal("emf_M"), k * run.signal("omega_M"), rtol=1e-12, atol=1e-15)
    inductive = Mechanism("inductive", "rotational")
    inductive.motor("M", "s", "k", V="V", R=Ra, L=1e-3)
    inductive.inertia("J1", "s", J)
    model = inductive.build(parameters={"k": k, "V": V})
    assert "p_M_L" in model.state_names
    assert model.simulate(6.0, "RK45", **RUN).signal("omega_J1")[-1] == pytest.approx(V / k, rel=1e-7)   # 30 τ


def drivetrain(e=0.5, T_max=None):
    """Flywheel J1 → clutch C1 (engages at t = 0.5 s) → J2 → backlash B1 (±δ) → load J3."""
    d = Mechanism("drivetrain", "rotational")
    d.inertia("J1", "a", 2.0, omega0=10.0)
    d.clutch("C1", "a", "b", engaged_when="t >= 0.5", T_max=T_max)
    d.inertia("J2", "b", 3.0)
    d.backlash("B1", "b", "c", 0.1, e=e)
    d.inertia("J3", "c", 1.0)
    return d.build()


def test_drivetrain_clutch_conserves_momentum_and_loses_the_closed_form_energy_then_backlash_impacts():
    J1, J2, J3, w0, delta, e, t_on = 2.0, 3.0, 1.0, 10.0, 0.1, 0.5, 0.5
    run = drivetrain(e).simulate(3.0, "RK45", **RUN)
    J = {"J1": J1, "J2": J2, "J3": J3}
    momentum = J1 * run.signal("omega_J1") + J2 * run.signal("omega_J2") + J3 * run.signal("omega_J3")
    np.testing.assert_allclose(momentum, J1 * w0, rtol=1e-9)     # across the engagement and every impact
    assert run.events[0].t == pytest.approx(t_on, rel=1e-12) and [s.mode.label for s in run.events[0].steps] == [
        "disengaged|free", "engaged|free"]
    before, after = around(run, run.events[0].t)
    w12 = J1 * w0 / (J1 + J2)
    assert run.signal("omega_J2")[after] == pytest.approx(w12, rel=1e-12)
    E = energy(run, J)
    assert E[before] - E[after] == pytest.approx(J1 * J2 / (J1 + J2) * w0**2 / 2, rel=1e-9)
    # backlash: J1 + J2 (locked) against J3 at rest, centred in the play; impacts alternate ends
    Ja, w_rel, t, exact = J1 + J2, w12, t_on + delta / w12, []
    while t < 3.0:
        exact.append(t)
        w_rel *= e
        t += 2 * delta / w_rel
    np.testing.assert_allclose(run.event_times[1:], exact, rtol=1e-9)
    ends = [e_.steps[1].mode.label for e_ in run.events[1:]]
    assert ends == ["engaged|upper_impact", "engaged|lower_impact"] * 2 + ends[4:]
    before, after = around(run, run.events[1].t)               # the first impact: −e·w12 relative after it
    assert run.signal("omega_J2")[before] - run.signal("omega_J3")[before] == pytest.approx(w12, rel=1e-9)
    assert run.signal("omega_J2")[after] - run.signal("omega_J3")[after] == pytest.approx(-e * w12, rel=1e-9)
    lost = Ja * J3 / (Ja + J3) * (1 - e**2) * w12**2 / 2
    assert E[before] - E[after] == pytest.approx(lost, rel=1e-9)
    assert np.all(np.abs(run.signal("theta_B1")) <= delta * (1 + 1e-9))


def test_plastic_backlash_takes_up_the_play_and_stays_closed():
    run = drivetrain(e=0.0).simulate(1.0, "RK45", **RUN)
    w = 2.0 * 10.0 / 6.0                                         # all three at J1·w0/(J1+J2+J3)
    assert [s.mode.label for s in run.events[-1].steps] == ["engaged|free", "engaged|upper_impact", "engaged|upper"]
    assert run.events[-1].t == pytest.approx(0.5 + 0.1 / 4.0, rel=1e-9)
    for name in ("omega_J1", "omega_J2", "omega_J3"):
        assert run.signal(name)[-1] == pytest.approx(w, rel=1e-9)
    assert run.signal("theta_B1")[-1] == pytest.approx(0.1, rel=1e-9)


def test_friction_clutch_slips_with_T_max_then_sticks_losing_the_same_energy():
    J1, J2, w0, T_max, t_on = 2.0, 3.0, 10.0, 5.0, 0.5
    d = Mechanism("friction", "rotational")
    d.inertia("J1", "a", J1, omega0=w0)
    d.clutch("C1", "a", "b", engaged_when="t >= t_on", T_max="T_c")
    d.inertia("J2", "b", J2)
    model = d.build(parameters={"t_on": t_on, "T_c": T_max})
    run = model.simulate(4.0, "RK45", **RUN)
    t_stick = t_on + w0 / (T_max * (1 / J1 + 1 / J2))
    np.testing.assert_allclose(run.event_times, [t_on, t_stick], rtol=1e-9)
    assert run.events[1].steps[-1].mode.label == "engaged|stuck"   # the law's sliding (Filippov) mode
    # issue 44: the run says stuck and slipping, and the law's generic names still read
    summary = run.summary()
    assert "C1=engaged, C1_law=slipping_pos" in summary and "C1=engaged, C1_law=stuck" in summary
    assert "sliding" not in summary and "positive" not in summary
    assert model.mode("C1=engaged, C1_law=sliding").describe() == "C1=engaged, C1_law=stuck"
    slipping = (run.t > t_on) & (run.t < t_stick * (1 - 1e-9))
    np.testing.assert_allclose(run.signal("T_C1")[slipping], T_max, rtol=1e-9)
    np.testing.assert_allclose(run.signal("omega_J2")[slipping], T_max / J2 * (run.t[slipping] - t_on), rtol=TOL)
    w = J1 * w0 / (J1 + J2)
    assert run.signal("omega_J1")[-1] == pytest.approx(w, rel=1e-9)
    assert run.signal("omega_J2")[-1] == pytest.approx(w, rel=1e-9)
    E = energy(run, {"J1": J1, "J2": J2})
    assert E[0] - E[-1] == pytest.approx(J1 * J2 / (J1 + J2) * w0**2 / 2, rel=1e-8)
    assert np.all(run.signal("T_C1")[run.t < t_on * (1 - 1e-9)] == 0)


def test_clutch_engages_on_a_speed_threshold_of_a_motor_driven_shaft():
    V, k, Ra, J1, J2, w_on = 12.0, 0.1, 2.0, 1e-3, 3e-3, 60.0
    d = Mechanism("threshold", "rotational")
    d.motor("M", "a", k, V=V, R=Ra)
    d.inertia("J1", "a", J1)
    d.clutch("C1", "a", "b", engaged_when="omega_J1 >= w_on", disengaged_when="t < 0")
    d.inertia("J2", "b", J2)
    run = d.build(parameters={"w_on": w_on}).simulate(0.5, "RK45", **RUN)
    tau = J1 * Ra / k**2
    t_on = -tau * math.log(1 - w_on * k / V)
    assert run.events[0].t == pytest.approx(t_on, rel=1e-9)
    before, after = around(run, run.events[0].t)
    assert run.signal("omega_J1")[before] == pytest.approx(w_on, rel=1e-9)
    assert run.signal("omega_J2")[after] == pytest.approx(J1 * w_on / (J1 + J2), rel=1e-9)
    tau2 = (J1 + J2) * Ra / k**2                                # then both speed up to V/k together
    late = run.t > t_on
    exact = V / k - (V / k - J1 * w_on / (J1 + J2)) * np.exp(-(run.t[late] - t_on) / tau2)
    np.testing.assert_allclose(run.signal("omega_J2")[late], exact, rtol=TOL)


def test_the_built_machine_round_trips_through_a_model_file_and_draws(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from bondgraph import draw_bond_graph

    model = drivetrain(e=0.5, T_max=20.0)
    assert {a.name for a in model.automata} >= {"C1", "B1"}
    assert {"node_a", "node_b", "node_c", "B1", "J1"} <= set(model.graph.elements)
    path = tmp_path / "drivetrain.toml"
    path.write_text(dumps_model(model))
    loaded = load_model(path)
    times = np.linspace(0.0, 2.0, 41)
    first = model.simulate(2.0, "RK45", t_eval=times, **RUN)
    second = loaded.simulate(2.0, "RK45", t_eval=times, **RUN)
    np.testing.assert_array_equal(first.event_times, second.event_times)
    assert len(first.events) >= 4
    for name in ("omega_J3", "theta_B1", "T_C1"):
        np.testing.assert_allclose(second.signal(name), first.signal(name), rtol=1e-12, atol=1e-15)
    assert draw_bond_graph(model.graph, {"B1": True}) is not None


def test_errors_name_the_component_and_say_what_to_do():
    m = Mechanism("m")
    m.mass("m1", "a", 1.0)
    with pytest.raises(DuplicateNameError, match="'m1' is already defined"):
        m.spring("m1", "a", "0", 1.0)
    with pytest.raises(InvalidGraphError, match="already carries the mass 'm1'.*add them"):
        m.mass("m2", "a", 1.0)
    with pytest.raises(InvalidGraphError, match="'m3' is on the frame"):
        m.mass("m3", "0", 1.0)
    with pytest.raises(InvalidGraphError, match="both ends on node 'a'"):
        m.damper("c1", "a", "a", 1.0)
    with pytest.raises(InvalidGraphError, match="gear 'G'.*frame"):
        m.gear("G", "a", "0", 2.0)
    with pytest.raises(InvalidGraphError, match="invalid component name"):
        m.spring("k 1", "a", "0", 1.0)
    with pytest.raises(InvalidGraphError, match="upper=.*lower="):
        m.stop("s1", "a")
    with pytest.raises(InvalidGraphError, match="kind must be"):
        Mechanism("x", "rotary")
    with pytest.raises(InvalidGraphError, match="engaged_when must be a condition as text"):
        m.clutch("C1", "a", "b", engaged_when=True)
    massless = Mechanism("massless")
    massless.mass("m1", "a", 1.0)
    massless.spring("k1", "a", "b", 1.0)
    massless.stop("s1", "b", upper=1.0)
    with pytest.raises(InvalidGraphError, match="'s1' acts on node\\(s\\) 'b' without a mass"):
        massless.build()
    clash = Mechanism("clash")
    clash.mass("a", "a", 1.0)
    with pytest.raises(DuplicateNameError, match="node 'a' has the name of a component"):
        clash.build()
    stray = Mechanism("stray")
    stray.mass("m1", "a", 1.0)
    stray.position("b", 1.0)
    with pytest.raises(UnknownNameError, match="node 'b'"):
        stray.build()
    hostile = Mechanism("hostile")
    hostile.mass("m1", "a", 1.0)
    hostile.force("F1", "a", '__import__("os").getcwd()')
    with pytest.raises(GuardSyntaxError, match="'F1' is not an expression of t"):
        hostile.build()
    with pytest.raises(HybridBondGraphError):
        Mechanism("empty").build()
    parallel = Mechanism("parallel", "rotational")
    parallel.inertia("J1", "a", 2.0, omega0=10.0)
    parallel.clutch("C1", "a", "b", engaged_when="t >= 0.5")
    parallel.clutch("C2", "a", "b", engaged_when="t >= 0.5")
    parallel.inertia("J2", "b", 3.0)
    # two clutches in parallel engaging at once: the torque between them is free, and the vanishing
    # compliances divide it equally (DESIGN.md §6b); the inertias lock at the speed that keeps their
    # momentum, 2·10/(2 + 3) = 4 rad/s (this mode used to stop the run with a FloatingPartError)
    run = parallel.build().simulate(1.0, "RK45")
    assert [e.mode_after.describe() for e in run.events] == ["C1=engaged, C2=engaged"]
    assert [run.signal(name)[-1] for name in ("omega_J1", "omega_J2")] == pytest.approx([4.0, 4.0], rel=1e-12)
    assert run.signal("T_C1")[-1] == pytest.approx(run.signal("T_C2")[-1], abs=1e-12)


@pytest.mark.parametrize("ends", [("a", "0"), ("0", "a")])
def test_coulomb_friction_damper_stops_the_block_and_holds_it(ends):
    import sympy

    m, mu_N, v0, push = 2.0, 3.0, 1.5, 1.0          # the push stays below the friction: the block stays put
    block = Mechanism("block")
    block.mass("m1", "a", m, v0=v0)
    block.force("push", "a", push)
    block.damper("friction", *ends, effort_law=lambda v: mu_N * sympy.sign(v))
    run = block.build().simulate(3.0, "RK45", **RUN)
    t_stop = v0 / ((mu_N - push) / m)
    assert run.event_times[-1] == pytest.approx(t_stop, rel=1e-9)
    sliding = run.t < t_stop * (1 - 1e-9)
    np.testing.assert_allclose(run.signal("v_m1")[sliding], v0 - (mu_N - push) / m * run.t[sliding], rtol=TOL)
    sign = 1 if ends[0] == "a" else -1                     # F from the first end to the second
    np.testing.assert_allclose(run.signal("F_friction")[sliding], sign * mu_N, rtol=1e-9)
    stuck = run.t > t_stop * (1 + 1e-9)
    np.testing.assert_allclose(run.signal("v_m1")[stuck], 0.0, atol=1e-12)
    np.testing.assert_allclose(run.signal("F_friction")[stuck], sign * push, rtol=1e-9)   # static: the push


def test_a_prescribed_speed_winds_up_a_torsion_spring():
    W, k, J = 3.0, 400.0, 1.0
    d = Mechanism("wind_up", "rotational")
    d.velocity("drive", "a", "W")
    d.spring("shaft", "a", "b", k)
    d.inertia("J1", "b", J)
    run = d.build(parameters={"W": W}).simulate(1.0, "RK45", **RUN)
    w = math.sqrt(k / J)
    np.testing.assert_allclose(run.signal("theta_J1"), W * run.t - W / w * np.sin(w * run.t), rtol=TOL, atol=1e-9)
    np.testing.assert_allclose(run.signal("T_shaft"), k * W / w * np.sin(w * run.t), rtol=TOL, atol=1e-8)
    np.testing.assert_allclose(run.signal("T_drive"), run.signal("T_shaft"), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(run.signal("omega_a"), W, rtol=1e-12)


def test_a_mass_between_two_elastic_stops_bounces_with_the_closed_form_period():
    box = Mechanism("box")
    box.mass("m1", "a", 1.0, v0=2.0)
    box.stop("walls", "a", upper=0.5, lower=-0.5, e="e_w")
    run = box.build(parameters={"e_w": 1.0}).simulate(2.2, "RK45", **RUN)
    np.testing.assert_allclose(run.event_times, [0.25, 0.75, 1.25, 1.75], rtol=1e-9)
    assert [e.steps[1].mode.label for e in run.events] == ["upper_impact", "lower_impact"] * 2
    assert run.signal("v_m1")[-1] == pytest.approx(2.0, rel=1e-12)
    assert run.signal("x_m1")[-1] == pytest.approx(-0.5 + 2.0 * (2.2 - 1.75), rel=1e-7)   # from the lower wall
