"""The step bound from the sources' sinusoids (switching/model/source_periods.py)."""

import math

import pytest

from models.circuits import PWM, Circuit


def rectifier(law=True):
    import sympy as sp

    c = Circuit("half")
    c.V("Vs", "s", "0", "10*sin(2*pi*50*t)")
    if law:
        c.R("D1", "s", "p", flow_law=lambda v: 1e-12 * (sp.exp(v / 0.025864186384551874) - 1))
    else:
        c.diode("D1", "s", "p")
    c.C("C1", "p", "0", 100e-6)
    c.R("RL", "p", "0", 1e3)
    return c.build()


def test_a_sinusoidal_source_and_a_pwm_switch_bound_the_step():
    from switching.model.source_periods import PERIOD_FRACTION, source_periods, step_bound

    model = rectifier()
    assert source_periods(model) == [pytest.approx(0.02, rel=1e-15)]
    assert step_bound(model) == pytest.approx(0.02 / PERIOD_FRACTION, rel=1e-15)
    buck = Circuit("buck")
    buck.V("V1", "in", "0", 12.0)
    buck.switch("S1", "in", "x", closed_when=PWM(1e-5, 0.3))
    buck.diode("D1", "0", "x")
    buck.L("L1", "x", "out", 1e-4)
    buck.C("C1", "out", "0", 1e-5)
    buck.R("R1", "out", "0", 5.0)
    # half its shortest window (0.3 of 10 µs): a step spanning a whole window would pass it unseen
    assert step_bound(buck.build()) == pytest.approx(0.5 * 0.3 * 1e-5, rel=1e-12)
    assert step_bound(rectifier(law=False)) == pytest.approx(0.02 / PERIOD_FRACTION, rel=1e-15)
    plain = Circuit("rc")
    plain.V("V1", "a", "0", 1.0)
    plain.R("R1", "a", "b", 1.0)
    plain.C("C1", "b", "0", 1.0)
    assert step_bound(plain.build()) == math.inf


def test_an_exponential_diode_rectifier_does_not_step_over_its_conduction_pulses():
    """Without a bound RK45 grew its step through the blocking phase to 27 ms and passed over whole
    conduction pulses: 6.64 V after 0.1 s.  ngspice (IS = 1e-12, N = 1, 27 °C) gives 8.10840 V; the
    toolkit at tight tolerances 8.1084012 (tests/models/test_spice.py compares them where ngspice is
    installed)."""
    model = rectifier()
    for method in ("RK45", "Radau"):
        run = model.simulate(0.1, method)
        assert run.signal("v_p")[-1] == pytest.approx(8.1084012, rel=1e-4)
        assert max(run.t[1:] - run.t[:-1]) <= 0.02 / 16 * (1 + 1e-12)


def test_a_clock_only_guards_read_bounds_the_step():
    """The boost converter's PWM carrier ``acos(cos(2π·f_sw·t − π·D))/π`` is read only by its guards:
    without a bound RK45 stepped 200 µs over its 50 µs windows and read 74.7 V for 24 V.  Its period
    bounds the step, and the default run is the run with a step bound given."""
    from models import boost_converter
    from switching.model.source_periods import PERIOD_FRACTION, guard_periods, step_bound

    model = boost_converter.build()
    f_sw = 10e3
    assert guard_periods(model) == [pytest.approx(1 / f_sw, rel=1e-12)] * 2  # (the two guards)
    assert step_bound(model) == pytest.approx(1 / f_sw / PERIOD_FRACTION, rel=1e-12)
    default = model.simulate(0.02)
    bounded = model.simulate(0.02, max_step=1e-5)
    assert len(default.events) == len(bounded.events) == 400  # two PWM edges a period
    window = dict(periods=10, period=1 / f_sw)
    assert default.measure("v_C", "mean", **window) == pytest.approx(bounded.measure("v_C", "mean", **window),
                                                                     rel=1e-6)


def test_the_periods_are_derived_once_and_follow_the_values():
    """A warm run evaluates the rates only, once per value of the parameters they read (a parameter
    study moving another parameter pays nothing); the periods are those of the expression's own
    substitution, to the bit."""
    import sympy as sp

    from bondgraph.symbols import t
    from models import boost_converter
    from switching.model import source_periods as sp_module

    model = boost_converter.build()
    model.simulate(1e-4, "RK45")  # (the run bounds its step with them)
    values = {symbol: value for symbol, value in model.parameter_values.items()}
    expected = []
    for expression in sp_module._timed_guards(model):  # the direct computation
        for function in expression.atoms(sp.sin, sp.cos, sp.tan):
            rate = sp.diff(function.args[0], t)
            number = float(abs(rate.xreplace({s: sp.Float(v) for s, v in values.items()})))
            expected.append(2 * math.pi / number)
    assert sp_module.guard_periods(model) == expected
    before = sp_module._period.cache_info()
    names = {s.name: v for s, v in values.items()}
    for load in (10.0, 20.0, 30.0):  # a sweep of the load: the carrier's rate reads f_sw only
        model.set_parameter_values({**names, "R_load": load})
        assert sp_module.guard_periods(model) == expected
    after = sp_module._period.cache_info()
    assert after.misses == before.misses and after.hits > before.hits
    model.set_parameter_values({**names, "f_sw": 20e3})
    assert sp_module.guard_periods(model) == [pytest.approx(1 / 20e3, rel=1e-12)] * 2
