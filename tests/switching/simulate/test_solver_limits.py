"""Runs that the solvers must finish (issue 45, items 5-9): the step limit
counts the steps a run takes, and a fixed-step run of ``n·dt`` takes ``n``."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
from scipy.optimize import brentq

from bondgraph import BondGraph, C, One, R, Se, Zero
from models import boost_converter
from models.mechanics import Mechanism
from switching import Automaton, ExpressionInput, HybridModel
from switching.errors import NonFiniteStateError, SimulationError, ZenoError

from switching_models import rc_relay, rc_relay_exact, relay_graph


@pytest.mark.parametrize("method", ["euler", "rk4", "euler-jit", "rk4-jit"])
def test_a_run_of_n_fixed_steps_fits_max_steps_n(method):
    # 10 000 steps of 1e-4 from 0 sum to 0.9999999999999062: the remainder is round-off, not a 10 001st step
    trajectory = rc_relay().simulate(1.0, method, dt=1e-4, max_steps=10_000)
    assert trajectory.t[-1] == 1.0


# ----------------------------------------------------------------- messages that point the right way (item 9)


def negative_resistance(resistance=-1e-3):
    """``q' = −q/(R·C)`` with ``R < 0``: ``q = e^{t/|R·C|}``, which overflows near t = 0.71 s."""
    g = BondGraph("negative")
    n = g.add(Zero("n"))
    g.connect(n, C("C", "C"))
    g.connect(n, R("R", "R"))
    return HybridModel(g, [], dict(C=1.0, R=resistance), {"q_C": 1.0})


@pytest.mark.parametrize("method", ["RK45", "RK45-jit", "rodas-jit", "auto", "Radau", "BDF"])
def test_an_overflowing_flow_is_reported_as_unbounded_growth(method):
    with pytest.raises(NonFiniteStateError, match="grew without bound and overflowed") as info:
        negative_resistance().simulate(2.0, method)
    assert "left its domain" not in str(info.value) and "q_C = " in str(info.value)
    # the growth is e^{1000 t}: the kept run ends where q passed 1e150, t = ln(1e150)/1000 ≈ 0.345 s, or later
    assert 0.345 < info.value.t < 0.71


def test_a_start_below_a_stop_is_named_as_the_initial_state_not_zeno():
    drop = Mechanism("drop")
    drop.mass("m1", "a", 2.0, x0=-1.0)  # below the floor at 0
    drop.force("gravity", "a", -2 * 9.81)
    drop.stop("floor", "a", lower=0.0, e=0.5)
    with pytest.raises(ZenoError, match=r"(?s)events pile up at the start of the run.*x_a = -1.*Check the initial"):
        drop.build().simulate(1.0, "RK45")


@pytest.mark.parametrize("method", ["RK45", "RK45-jit", "rk4"])
def test_a_progress_callback_that_raises_names_its_own_time_and_the_kept_end(method):
    seen = []

    def progress(t):
        seen.append(t)
        if t > 0.5:
            raise RuntimeError("enough")

    options = {"dt": 1e-3} if method == "rk4" else {}
    with pytest.raises(SimulationError) as info:
        rc_relay().simulate(2.0, method, progress=progress, **options)
    error = info.value
    kept = error.trajectory.t[-1]
    assert f"called with t = {seen[-1]:.12g} s" in str(error) and f"kept up to t = {kept:.12g} s" in str(error)
    assert error.t == kept > 0.0 and isinstance(error.__cause__, RuntimeError)


def test_advice_names_a_method_simulate_accepts():
    from switching.analysis.sensitivity_run import sensitivity_method
    from switching.simulate.methods import method_names

    with pytest.raises(SimulationError, match="use 'Radau'") as info:
        sensitivity_method("rodas-jit", {})
    assert "'rodas'" not in str(info.value) and "Radau" in method_names()
    relay = Automaton("relay", {"charge": {"a": True, "b": False}, "discharge": {"a": False, "b": True}}, "charge")
    relay.add_transition("charge", "discharge", "q_C/C >= 0.8")
    relay.add_transition("discharge", "charge", "q_C/C <= 0.3")
    g = relay_graph()
    u = g.input("u")
    model = HybridModel(g, [relay], dict(R1=1.0, R2=0.5, C=1.0, V=1.0), signals={"w": u * 2},
                        inputs={"u": lambda t: 1.0})
    with pytest.raises(SimulationError, match="use 'Radau'") as info:  # a Python function as an input
        model.simulate(1.0, "rodas-jit")
    assert "'rodas'" not in str(info.value)


# ----------------------------------------------------------------- runs the implicit methods must finish (item 5)


def sqrt_capacitor():
    """V = 1 through R = 1 onto a C with ``e = √q`` from q = 0: ``q' = 1 − √q``, whose Jacobian
    ``−1/(2√q)`` is infinite at the start.  With ``u = √q``: ``t = −2u − 2·ln(1 − u)``."""
    g = BondGraph("sqrt")
    j = g.add(One("j"))
    g.connect(Se("V", "V"), j)
    g.connect(j, R("R1", "R1"))
    g.connect(j, C("K", effort_law=lambda q: sp.sqrt(q)))
    return HybridModel(g, [], dict(V=1.0, R1=1.0), {"q_K": 0.0})


def sqrt_capacitor_exact(t):
    u = brentq(lambda u: -2 * u - 2 * math.log1p(-u) - t, 0.0, 1.0 - 1e-16, xtol=1e-16, rtol=1e-15)
    return u * u


@pytest.mark.parametrize("method", ["rodas-jit", "Radau", "BDF", "auto", "RK45"])
def test_an_infinite_jacobian_at_the_start_is_stepped_over_explicitly(method):
    # rodas-jit returned q = 0 for ever (a matrix I/(γh) − J with J = −∞), Radau and BDF failed at t = 0
    run = sqrt_capacitor().simulate(1.0, method, rtol=1e-9, atol=1e-12)
    assert sqrt_capacitor_exact(1.0) == pytest.approx(0.48761, abs=1e-5)
    assert run.x[-1, 0] == pytest.approx(sqrt_capacitor_exact(1.0), rel=1e-6)


def test_rodas_takes_the_relay_with_atol_1e_300():
    # the first step was 10 ulps of t = 0 (5e-323 s): 1/(γh) infinite, the stages NaN
    run = rc_relay().simulate(2.0, "rodas-jit", atol=1e-300, rtol=1e-8)
    v, events = rc_relay_exact(2.0)
    assert run.x[-1, 0] == pytest.approx(v, rel=1e-6)
    np.testing.assert_allclose(run.event_times, events, rtol=1e-7)


def test_rodas_ends_on_a_pwm_edge_at_t_end():
    # 0.01 s is an edge of the boost converter's PWM: the flow after that instant is of length 0
    model = boost_converter.build()
    implicit = model.simulate(0.01, "rodas-jit", max_step=1e-5)
    explicit = model.simulate(0.01, "RK45-jit", max_step=1e-5)
    assert implicit.t[-1] == explicit.t[-1] == 0.01
    np.testing.assert_allclose(implicit.x[-1], explicit.x[-1], rtol=1e-4)


@pytest.mark.parametrize("mass", [1e-6, 1e-15])
@pytest.mark.parametrize("method", ["BDF", "Radau", "LSODA"])
def test_the_implicit_methods_take_a_light_rod_with_much_friction_through_its_impact(mass, method):
    from models import falling_rod

    run = falling_rod.build(m=mass, mu=10.0).simulate(0.5, method, rtol=1e-9, atol=1e-12)
    # free fall at rest until the lower end, l·sin(θ0) below the centre, meets the floor
    p = falling_rod.DEFAULTS
    impact = math.sqrt(2 * (p["y0"] - p["l"] * math.sin(p["theta0"])) / p["g"])
    assert run.t[-1] == 0.5 and run.event_times[0] == pytest.approx(impact, rel=1e-6)


def sqrt_driven_rc(resistance):
    """``√t`` across R in series with C = 1 from q = 0: ``q' = (√t − q)/R``, whose ∂f/∂t is infinite at t = 0;
    for ``τ = R·C`` small, ``q = u − τ·u′ + τ²·u″ − …`` with ``u = √t``."""
    g = BondGraph("sqrt_t")
    j = g.add(One("j"))
    u = g.input("u")
    g.connect(Se("V", u), j)
    g.connect(j, R("R1", "R1"))
    g.connect(j, C("C", "C"))
    return HybridModel(g, [], dict(R1=resistance, C=1.0), {"q_C": 0.0}, inputs={"u": ExpressionInput("sqrt(t)")})


@pytest.mark.parametrize("method", ["RK45", "RK45-jit", "rodas-jit", "auto", "Radau"])
def test_an_input_with_an_infinite_slope_at_the_start(method):
    # the input's rate 1/(2√t) raised ZeroDivisionError at t = 0 (RK45, and auto before choosing: not even an
    # error of the toolkit); rodas-jit's f_t was NaN there ("a law left its domain")
    tau = 1e-5
    run = sqrt_driven_rc(tau).simulate(1.0, method, rtol=1e-10, atol=1e-12)
    assert run.x[-1, 0] == pytest.approx(1.0 - tau / 2 - tau**2 / 4, rel=1e-8)
    if method == "auto":
        assert "rodas-jit" in run.stats["method per mode (auto)"]  # τ·T = 1e5: stiff, the implicit method
