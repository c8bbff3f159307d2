"""The boost converter against circuit theory: the conversion ratio in
continuous conduction (ideal and with a lossy inductor), the discontinuous
conduction ratio, exact PWM edges and exact current slopes."""

import math

import numpy as np
import pytest

from bondgraph.errors import UnknownParameterError
from models import boost_converter

OPTIONS = {"rtol": 1e-9, "atol": 1e-12}


def setup(**overrides):
    p = {**boost_converter.DEFAULTS, **overrides}
    T = 1 / p["f_sw"]
    options = {**OPTIONS, "max_step": 0.1 * min(p["D"], 1 - p["D"]) * T}
    return boost_converter.build(**overrides), p, T, options


def window_average(model, t_end, T, periods, options, *names):
    """Averages (trapezoid on a fine grid) and peak-to-peak ripples of signals
    over the last ``periods`` switching periods."""
    t0 = t_end - periods * T
    grid = np.linspace(t0, t_end, periods * 4000 + 1)
    trajectory = model.simulate(t_end, "RK45", t_eval=grid, **options)
    inside = trajectory.t >= t0
    t = trajectory.t[inside]
    out = {}
    for name in names:
        s = trajectory.signal(name)[inside]
        out[name] = (np.trapezoid(s, t) / (t[-1] - t[0]), s.max() - s.min())
    return out


def pwm_edges(trajectory, switch_on):
    """Instants at which the switch closes (switch_on=True) or opens."""
    target, source = ("on", "off") if switch_on else ("off", "on")
    return [e for e in trajectory.events
            if e.mode_before.state_of("pwm") == source and e.mode_after.state_of("pwm") == target]


@pytest.mark.parametrize("D", [0.5, 0.4])
def test_continuous_conduction_ratio_is_one_over_one_minus_d(D):
    Vin, R_load = boost_converter.DEFAULTS["Vin"], boost_converter.DEFAULTS["R_load"]
    V = Vin / (1 - D)
    model, p, T, options = setup(D=D, v_C0=V, i_L0=V / R_load / (1 - D))
    t_end = 300 * T
    averages = window_average(model, t_end, T, 5, options, "v_C", "i_L", "i_D")
    v_mean, v_ripple = averages["v_C"]
    # the mean output sits on Vin/(1 - D) within the ripple (a small fraction of it, in fact)
    assert abs(v_mean - V) < 0.25 * v_ripple, (v_mean, V, v_ripple)
    assert 0 < v_ripple < 0.05 * V
    # charge balance of C: the diode delivers the load current on average;
    # power balance of the lossless converter: Vin·<i_L> = <v_C²>/R ≈ V²/R
    assert averages["i_D"][0] == pytest.approx(v_mean / R_load, rel=1e-3)
    assert averages["i_L"][0] == pytest.approx(V**2 / R_load / Vin, rel=2e-3)


def test_continuous_conduction_with_inductor_resistance():
    """V/Vin = 1/(1 - D) · 1/(1 + R_L/((1 - D)² R_load)) (averaged model with losses)."""
    D, R_L = 0.5, 0.5
    p = boost_converter.DEFAULTS
    V = p["Vin"] / (1 - D) / (1 + R_L / ((1 - D) ** 2 * p["R_load"]))
    model, p, T, options = setup(D=D, R_L=R_L, v_C0=V, i_L0=V / p["R_load"] / (1 - D))
    averages = window_average(model, 150 * T, T, 5, options, "v_C")
    v_mean, v_ripple = averages["v_C"]
    assert abs(v_mean - V) < 0.25 * v_ripple, (v_mean, V, v_ripple)
    assert abs(v_mean - p["Vin"] / (1 - D)) > 3 * v_ripple  # the loss is clearly seen


def assert_edges_exact(times, exact, model, D, f_sw):
    """PWM edges at their exact times up to the round-off of the carrier's
    phase 2π·f_sw·t (a few units in the last place of t) and the comparison
    band rtol·max(|carrier|, |D|) = rtol·D crossed at the carrier's slope
    2·f_sw — a constant 2.5e-18 s for D = 0.5, not growing with t."""
    times, exact = np.asarray(times), np.asarray(exact)
    assert len(times) == len(exact)
    bound = 4 * np.spacing(exact) + model.tolerance.rtol * D / (2 * f_sw)
    error = np.abs(times - exact)
    worst = int(np.argmax(error / bound))
    assert np.all(error <= bound), (f"edge {worst} at {times[worst]!r} is {error[worst]:.3g} s from {exact[worst]!r} "
                                    f"({error[worst] / np.spacing(exact[worst]):.0f} ulps)")


def test_continuous_conduction_edges_and_slopes_are_exact():
    D = 0.5
    model, p, T, options = setup(D=D, v_C0=24.0, i_L0=2.4)
    trajectory = model.simulate(20.25 * T, "RK45", **options)
    assert set(trajectory.mode_labels) == {"pwm=on, diode=off", "pwm=off, diode=on"}  # never both off: continuous conduction
    closing, opening = pwm_edges(trajectory, True), pwm_edges(trajectory, False)
    # exact to round-off (see test_pwm_edges_stay_exact_over_two_thousand_periods)
    assert_edges_exact([e.t for e in closing], T * np.arange(1, 21), model, D, p["f_sw"])
    assert_edges_exact([e.t for e in opening], T * (np.arange(20) + D), model, D, p["f_sw"])
    for e in closing:  # the diode, shorted by the switch, is turned off through a mythical mode
        assert [m.label for m in e.modes] == ["off|on", "on|on", "on|off"]
        assert e.kinds == ["start", "mythical", "continuous"]
        np.testing.assert_array_equal(e.x_before, e.x_after)  # no state jumps
    for e in opening:  # the inductor current commutates to the diode
        assert [m.label for m in e.modes] == ["on|off", "off|off", "off|on"]
        np.testing.assert_array_equal(e.x_before, e.x_after)
    # switch on, R_L = 0: di_L/dt = Vin/L exactly, so the on-interval adds Vin·D·T/L
    i_close = np.array([e.x_after[0] for e in closing[:-1]]) / p["L"]
    i_open = np.array([e.x_after[0] for e in opening[1:]]) / p["L"]
    np.testing.assert_allclose(i_open - i_close, p["Vin"] * D * T / p["L"], rtol=1e-7)
    # the diode only ever conducts forward and blocks reverse voltage
    assert trajectory.signal("i_D").min() >= -1e-12
    assert trajectory.signal("v_D").max() <= 1e-12


def test_pwm_edges_stay_exact_over_two_thousand_periods():
    """A PWM edge is where the carrier crosses D, to the round-off of k·T
    itself, however many periods came before.  The carrier's round-off scale
    grows with its phase (≈ 12·f_sw·t): were it to widen the comparison band
    (rtol·R), the edges would lag 6·rtol·t — 1.2e-13 s, ~4000 ulps, at
    t = 0.2 s (switching.library.compiled.comparison_triples)."""
    D, periods = 0.3, 2000
    V = boost_converter.DEFAULTS["Vin"] / (1 - D)
    model, p, T, _ = setup(D=D, v_C0=V, i_L0=V / boost_converter.DEFAULTS["R_load"] / (1 - D))
    trajectory = model.simulate(periods * T, "RK45", max_step=min(D, 1 - D) * T, output="events")
    closing, opening = pwm_edges(trajectory, True), pwm_edges(trajectory, False)
    assert len(opening) == periods and len(closing) in (periods - 1, periods)  # the last may fall past t_end
    assert_edges_exact([e.t for e in closing], np.arange(1, len(closing) + 1) / p["f_sw"], model, D, p["f_sw"])
    assert_edges_exact([e.t for e in opening], (np.arange(periods) + D) / p["f_sw"], model, D, p["f_sw"])


@pytest.mark.parametrize("D", [0.5, 0.3])
def test_discontinuous_conduction_ratio(D):
    """Light load: M = (1 + sqrt(1 + 4 D²/K))/2 with K = 2 L f_sw / R_load < D (1 - D)²."""
    R_load, C = 500.0, 20e-6
    p = boost_converter.DEFAULTS
    K = 2 * p["L"] * p["f_sw"] / R_load
    assert K < D * (1 - D) ** 2  # the formula's condition for discontinuous conduction
    V = p["Vin"] * (1 + math.sqrt(1 + 4 * D**2 / K)) / 2
    model, p, T, options = setup(D=D, R_load=R_load, C=C, v_C0=0.95 * V, i_L0=0.0)
    t_end = 250 * T
    averages = window_average(model, t_end, T, 5, options, "v_C")
    v_mean, v_ripple = averages["v_C"]
    assert abs(v_mean - V) < 0.25 * v_ripple, (v_mean, V, v_ripple)
    assert abs(v_mean - p["Vin"] / (1 - D)) > 10 * v_ripple  # far from the continuous-conduction ratio


def test_discontinuous_conduction_visits_the_mode_with_both_off():
    D = 0.5
    model, p, T, options = setup(D=D, R_load=500.0, C=20e-6, v_C0=36.0)
    trajectory = model.simulate(30.25 * T, "RK45", **options)
    labels = np.array(trajectory.mode_labels)
    assert {"pwm=on, diode=off", "pwm=off, diode=on", "pwm=off, diode=off"} <= set(labels)
    both_off = labels == "pwm=off, diode=off"
    # there the inductor is dependent: no current, and the switch node sits at Vin
    np.testing.assert_allclose(trajectory.signal("i_L")[both_off], 0.0, atol=1e-12)
    np.testing.assert_allclose(trajectory.signal("v_sw")[both_off], p["Vin"], rtol=1e-12)
    # every period starts from zero current, so the peak current is Vin·D·T/L exactly
    closing, opening = pwm_edges(trajectory, True), pwm_edges(trajectory, False)
    for e in closing:
        assert e.modes[0].label == "off|off" and e.x_before[0] == 0.0
    np.testing.assert_allclose([e.x_after[0] / p["L"] for e in opening], p["Vin"] * D * T / p["L"], rtol=1e-7)
    # the diode turns off when the current reaches zero, once per period
    diode_off = [e for e in trajectory.events if e.mode_after.label == "off|off"]
    assert len(diode_off) == len(opening)
    for e in diode_off:
        assert abs(e.x_before[0]) / p["L"] < 1e-12
        assert (e.t % T) / T > D  # after the switch opened, within the same period
    # the inductor's flux is released over each diode interval: volt-seconds balance
    # Vin·D·T = (<v_C> - Vin)·t_diode, so t_diode ≈ D·T·Vin/(v_C - Vin)
    for open_edge, off in zip(opening[-5:], diode_off[-5:]):
        t_diode = off.t - open_edge.t
        v_out = 0.5 * (open_edge.x_after[1] + off.x_before[1]) / p["C"]
        assert t_diode == pytest.approx(D * T * p["Vin"] / (v_out - p["Vin"]), rel=0.02)


def test_default_run_starts_up_and_every_signal_evaluates():
    trajectory = boost_converter.build().simulate(**boost_converter.RUN)
    for name in boost_converter.SIGNALS:
        assert np.all(np.isfinite(trajectory.signal(name)))
    v_C = trajectory.signal("v_C")
    assert v_C[0] == pytest.approx(12.0)
    assert v_C.max() > 24.0  # the start-up overshoots the steady state 24 V
    np.testing.assert_allclose(trajectory.signal("v_in"), 12.0)
    carrier = trajectory.signal("carrier")
    assert carrier.min() >= 0.0 and carrier.max() <= 1.0


def test_unknown_parameter_is_an_error():
    with pytest.raises(UnknownParameterError):
        boost_converter.build(duty=0.3)
