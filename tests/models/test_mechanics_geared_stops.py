"""Stops and backlash on a node without a mass of its own, behind a gear or lever: the impact acts on
the inertia reflected through the gear (models.mechanics, issue 44), against exact answers."""

import math

import numpy as np
import pytest

from bondgraph.errors import InvalidGraphError
from models.mechanics import Mechanism
from switching import load_model
from switching.files.modelfile import dumps_model

RUN = {"rtol": 1e-10, "atol": 1e-12}
TOL = 1e-7   # relative error of the runs' values at rtol = 1e-10


def around(run, t):
    """The indices of the samples just before and just after the instant at ``t``."""
    (at,) = np.nonzero(run.t == t)
    return at[0], at[-1]


def labels(run):
    return [[s.mode.label for s in event.steps] for event in run.events]


def geared_stop(n, J=2.0, w0=8.0, theta0=0.2, e=0.5):
    """A motor inertia J spinning at w0 through a gear of ratio n (ω_out = ω_m/n) onto end stops at ±1 rad
    of the output shaft, which starts at theta0 and has no inertia of its own."""
    d = Mechanism("geared", "rotational")
    d.inertia("J1", "m", J, omega0=w0)
    d.gear("G", "m", "out", n)
    d.position("out", theta0)
    d.stop("end", "out", upper=1.0, lower=-1.0, e=e)
    return d.build()


@pytest.mark.parametrize("n", [4.0, 0.5, -4.0])
def test_a_geared_end_stop_reverses_the_output_and_the_motor_at_minus_e(n):
    J, w0, theta0, e = 2.0, 8.0, 0.2, 0.5
    run = geared_stop(n, J, w0, theta0, e).simulate(3.0, "RK45", **RUN)
    v_out = w0 / n
    stop = math.copysign(1.0, v_out)
    t1 = (stop - theta0) / v_out                             # a free spin: the output reaches the stop
    exact, t, speed = [t1], t1, abs(v_out)
    while True:                                              # bouncing from stop to stop at e^k·|v_out|
        speed *= e
        t += 2.0 / speed
        if t >= 3.0:
            break
        exact.append(t)
    np.testing.assert_allclose(run.event_times, exact, rtol=1e-12)
    side = "upper" if stop > 0 else "lower"
    assert labels(run)[0] == ["free", f"{side}_impact", "free"]   # a pinnacle: the impact mode is real
    before, after = around(run, run.event_times[0])
    assert run.signal("omega_out")[before] == pytest.approx(v_out, rel=1e-12)
    assert run.signal("omega_out")[after] == pytest.approx(-e * v_out, rel=1e-12)
    assert run.signal("omega_J1")[before] == pytest.approx(w0, rel=1e-12)
    assert run.signal("omega_J1")[after] == pytest.approx(-e * w0, rel=1e-12)
    assert run.signal("theta_out")[before] == pytest.approx(stop, rel=1e-12)
    energy = 0.5 * J * run.signal("omega_J1") ** 2
    assert energy[after] == pytest.approx(e**2 * energy[before], rel=1e-12)
    free = (run.t > t1) & (run.t < min(exact[1:] + [3.0]) * (1 - 1e-12))
    np.testing.assert_allclose(run.signal("theta_out")[free], stop - e * v_out * (run.t[free] - t1), rtol=TOL)
    np.testing.assert_allclose(run.signal("omega_G_out"), run.signal("omega_out"), rtol=1e-12, atol=1e-14)


def driven(reflected: bool, T=6.0, J=2.0, n=4.0):
    """The same scene two ways: a motor inertia J under a torque T through a gear n onto an end stop of
    the output (e = 0.5, landing speed 0.2 rad/s), or the inertia reflected onto the output, J·n², under
    the torque n·T (T_out = n·T_in)."""
    d = Mechanism("driven", "rotational")
    if reflected:
        d.inertia("J1", "out", J * n**2, omega0=0.5)
        d.torque("T1", "out", n * T)
    else:
        d.inertia("J1", "m", J, omega0=0.5 * n)
        d.torque("T1", "m", T)
        d.gear("G", "m", "out", n)
    d.stop("end", "out", upper=1.0, e=0.5, v_th=0.2)
    return d.build()


def test_a_geared_stop_behaves_as_the_reflected_inertia_on_the_output(tmp_path):
    T, J, n = 6.0, 2.0, 4.0
    times = np.linspace(0.0, 6.0, 61)
    geared = driven(False, T, J, n).simulate(6.0, "RK45", t_eval=times, **RUN)
    direct = driven(True, T, J, n).simulate(6.0, "RK45", t_eval=times, **RUN)
    assert labels(geared) == labels(direct)
    assert labels(geared)[-1] == ["free", "upper"] and len(geared.events) >= 3   # bounces, then lands
    np.testing.assert_allclose(geared.event_times, direct.event_times, rtol=1e-12)
    a = T / (J * n)                                          # the output's acceleration n·T/(J·n²)
    v, exact = math.sqrt(0.25 + 2 * a), []                   # from 0.5 rad/s over 1 rad
    t = (v - 0.5) / a
    while v > 0.2:                                           # bounces at e·v while faster than v_th
        exact.append(t)
        v *= 0.5
        t += 2 * v / a
    exact.append(t)                                          # and lands
    np.testing.assert_allclose(geared.event_times, exact, rtol=1e-9)
    for name in ("theta_out", "omega_out", "T_end"):
        np.testing.assert_allclose(geared.signal(name), direct.signal(name), rtol=1e-9, atol=1e-12)
    resting = geared.t > geared.event_times[-1]
    np.testing.assert_allclose(geared.signal("T_end")[resting], n * T, rtol=1e-12)   # holds the reflected torque
    np.testing.assert_allclose(geared.signal("omega_J1")[resting], 0.0, atol=1e-12)
    path = tmp_path / "driven.toml"                          # the reflected velocity is text: it round-trips
    path.write_text(dumps_model(driven(False, T, J, n)))
    again = load_model(path).simulate(6.0, "RK45", t_eval=times, **RUN)
    np.testing.assert_array_equal(again.event_times, geared.event_times)


@pytest.mark.parametrize("e", [0.0, 0.5])
def test_a_backlash_behind_a_gear_conserves_the_momentum_through_the_gear(e):
    J1, J2, n, w0, delta = 2.0, 5.0, 3.0, 6.0, 0.1
    d = Mechanism("geared_play", "rotational")
    d.inertia("J1", "m", J1, omega0=w0)
    d.gear("G", "m", "out", n)
    d.backlash("B1", "out", "L", delta, e=e)
    d.inertia("J2", "L", J2)
    run = d.build().simulate(1.0, "RK45", **RUN)
    w_rel = w0 / n                                           # the output's speed; the load at rest
    t1 = delta / w_rel
    assert run.event_times[0] == pytest.approx(t1, rel=1e-12)
    Ja = J1 * n**2                                           # the motor's inertia reflected to the output
    momentum = n * J1 * run.signal("omega_J1") + J2 * run.signal("omega_J2")   # J_a·ω_out + J2·ω_L
    np.testing.assert_allclose(momentum, n * J1 * w0, rtol=1e-12)
    before, after = around(run, run.event_times[0])
    common = J1 * n * w0 / (Ja + J2)                         # the plastic impact's common speed
    relative = run.signal("omega_out") - run.signal("omega_J2")
    assert relative[after] == pytest.approx(-e * w_rel, rel=1e-12, abs=1e-14)
    assert run.signal("omega_J2")[after] == pytest.approx(common + e * Ja / (Ja + J2) * w_rel, rel=1e-12)
    assert run.signal("omega_J1")[after] == pytest.approx(n * run.signal("omega_out")[after], rel=1e-12)
    kinetic = 0.5 * J1 * run.signal("omega_J1") ** 2 + 0.5 * J2 * run.signal("omega_J2") ** 2
    lost = Ja * J2 / (Ja + J2) * (1 - e**2) * w_rel**2 / 2
    assert kinetic[before] - kinetic[after] == pytest.approx(lost, rel=1e-12)
    if e == 0.0:
        assert labels(run) == [["free", "upper_impact", "upper"]]
        assert run.signal("omega_J2")[-1] == pytest.approx(common, rel=1e-12)
        assert run.signal("omega_J1")[-1] == pytest.approx(n * common, rel=1e-12)
    else:
        t2 = t1 + 2 * delta / (e * w_rel)
        np.testing.assert_allclose(run.event_times[:2], [t1, t2], rtol=1e-12)
        assert [steps[1] for steps in labels(run)[:2]] == ["upper_impact", "lower_impact"]
    assert np.all(np.abs(run.signal("theta_B1")) <= delta * (1 + 1e-9))


def lever(scale: float):
    """A 1 kg mass pushed by 2·cos(t) N through a lever of ratio 2 onto a wall 0.1 m ahead of the
    output, which has no mass (e = 0.5, landing speed 0.1 m/s); lengths in units of 1/scale m."""
    d = Mechanism("lever")
    d.mass("m1", "a", 1.0)
    d.gear("L", "a", "out", 2.0)
    d.force("push", "a", f"{2.0 * scale}*cos(t)")
    d.stop("wall", "out", upper=0.1 * scale, e=0.5, v_th=0.1 * scale)
    return d.build()


def test_a_lever_stop_has_the_same_modes_and_instants_in_millimetres():
    metres = lever(1.0).simulate(4.0, "RK45", **RUN)
    millimetres = lever(1000.0).simulate(4.0, "RK45", rtol=1e-10, atol=1e-9)
    assert labels(metres) == labels(millimetres) == [["free", "upper_impact", "free"]] * 2 + [
        ["free", "upper"], ["upper", "free"]]                  # two bounces, a landing, let go at π/2
    np.testing.assert_allclose(millimetres.event_times, metres.event_times, rtol=1e-12)
    assert metres.event_times[0] == pytest.approx(math.acos(0.9), rel=1e-9)   # x_out = 1 − cos t
    assert metres.event_times[-1] == pytest.approx(math.pi / 2, rel=1e-9)
    before, after = around(metres, metres.event_times[0])
    assert metres.signal("v_out")[before] == pytest.approx(math.sin(math.acos(0.9)), rel=1e-9)
    assert metres.signal("v_out")[after] == pytest.approx(-0.5 * metres.signal("v_out")[before], rel=1e-12)
    assert metres.signal("v_m1")[after] == pytest.approx(2 * metres.signal("v_out")[after], rel=1e-12)
    np.testing.assert_allclose(millimetres.signal("x_out")[-1], 1000.0 * metres.signal("x_out")[-1], rtol=1e-9)


def test_a_stop_on_a_node_with_no_mass_behind_it_is_still_refused_by_name():
    springy = Mechanism("springy", "rotational")
    springy.inertia("J1", "a", 1.0)
    springy.spring("k1", "a", "b", 10.0)
    springy.gear("G", "b", "c", 2.0)                        # geared, but to a node with a spring only
    springy.stop("s1", "c", upper=1.0)
    with pytest.raises(InvalidGraphError, match="'s1' acts on node\\(s\\) 'c' without a mass.*massless node"
                                                ".*put a mass \\(inertia\\) on node 'c', or on a node it is geared"):
        springy.build()
    driven_node = Mechanism("prescribed")
    driven_node.velocity("drive", "a", 1.0)
    driven_node.gear("L", "a", "b", 2.0)
    driven_node.backlash("B1", "b", "c", 0.1)
    driven_node.mass("m2", "c", 1.0)
    with pytest.raises(InvalidGraphError, match="'B1' acts on node\\(s\\) 'b' without a mass") as info:
        driven_node.build()
    assert "'c'" not in str(info.value).split("without")[0]          # the load has its mass


def test_a_stop_on_the_input_of_a_gear_chain_acts_on_the_inertia_at_its_far_end():
    d = Mechanism("chain", "rotational")
    d.gear("G1", "a", "b", "n")                              # ω_a = n·ω_b = n²·ω_c
    d.gear("G2", "b", "c", "n")
    d.inertia("J", "c", 1.0, omega0=1.0)
    d.stop("s", "a", upper=0.9, e=1.0)
    run = d.build(parameters={"n": 3.0}).simulate(0.5, "RK45", **RUN)
    np.testing.assert_allclose(run.event_times, [0.9 / 9.0], rtol=1e-12)
    before, after = around(run, run.event_times[0])
    assert [run.signal("omega_a")[i] for i in (before, after)] == pytest.approx([9.0, -9.0], rel=1e-12)
    assert [run.signal("omega_J")[i] for i in (before, after)] == pytest.approx([1.0, -1.0], rel=1e-12)
