"""Requests of the orbit API that cannot be met, refused with the toolkit's errors and what to do
(issue 45, item 4).

The relay (models/examples/relay.toml, one state q_C): charging towards ``v∞ = V R_load/(R + R_load)``
= 9.52 V with ``τ_on = C R R_load/(R + R_load)``, discharging with ``τ_off = C R_load``, opening at
``v_hi``, closing at ``v_lo``: the autonomous period ``τ_on ln((v∞ − v_lo)/(v∞ − v_hi)) + τ_off
ln(v_hi/v_lo)`` (as in test_orbits.py).  With ``v_hi = 12 V > v∞`` the relay never opens: the charge
comes to rest at ``C v∞`` and the section ``relay: on → off`` is never crossed.

The current-mode converter with its output held (``load="source"``) from ``i_L = 0``: the current
never reaches ``i_ref`` in one period, the switch stays on, and ``p_L(T) = p_L(0) + Vin T``: a piece of
the period map of slope exactly 1, ``M − I = 0``.
"""

from __future__ import annotations

import numpy as np
import pytest

import models
from models import current_mode_converter
from switching import (ContinuationError, OptionError, OrbitArgumentError, OrbitConvergenceError, OrbitError,
                       UnknownOptionError, continue_orbit, periodic_orbit)

V, R, C, R_LOAD, V_HI, V_LO = 10.0, 1.0, 1e-3, 20.0, 8.0, 6.0
V_INF = V * R_LOAD / (R + R_LOAD)
PERIOD = C * R * R_LOAD / (R + R_LOAD) * np.log((V_INF - V_LO) / (V_INF - V_HI)) + C * R_LOAD * np.log(V_HI / V_LO)
SECTION = "relay: on -> off"


def relay(**values):
    model = models.load("models/examples/relay.toml")
    if values:
        model.set_parameter_values({**{s.name: v for s, v in model.parameter_values.items()}, **values})
    return model


@pytest.fixture(scope="module")
def relay_model():
    return relay()


@pytest.mark.parametrize("method", ["RK45-jit", "auto"])
def test_a_compiled_method_runs_as_its_python_equivalent(relay_model, method):
    orbit = periodic_orbit(relay_model, section=SECTION, period=0.01, method=method)
    assert orbit.period == pytest.approx(PERIOD, rel=1e-8) and orbit.x0 == pytest.approx([C * V_HI], rel=1e-9)
    assert orbit.error <= 1e-8


def test_a_slope_one_piece_of_the_map_stops_at_once():
    model = current_mode_converter.build(load="source", f_sw=1e4)
    with pytest.raises(OrbitConvergenceError, match="singular") as info:
        periodic_orbit(model, period=1e-4, x0=[0.0], max_step=2e-6)
    error = info.value
    assert error.iterate == 0 and len(error.history) == 1  # not 20 identical steps
    assert "p_L: +1" in str(error) and "stays on" in str(error)


def test_a_section_never_crossed_says_so():
    with pytest.raises(OrbitConvergenceError) as info:
        periodic_orbit(relay(v_hi=12.0), section=SECTION, period=0.01)
    text = str(info.value)
    assert "never crosses the section relay: on → off" in text and "comes to rest" in text
    rest = float(text.split("at x = q_C = ")[1].split()[0])
    assert rest == pytest.approx(C * V_INF, rel=1e-8) and "stability limit" not in text


@pytest.mark.parametrize("arguments, argument, words", [
    (dict(section=("relay", "on")), "section", "three names"),
    (dict(section=5), "section", "'automaton: source -> target'"),
    (dict(section=SECTION, period="0.01"), "period", "is text, not a number"),
    (dict(period=-1e-3), "period", "is at most 0"),
    (dict(section=SECTION, period=0.01, max_iterations=-1), "max_iterations", "an integer of at least 0"),
    (dict(section=SECTION, period=0.01, max_iterations=2.5), "max_iterations", "is not an integer"),
    (dict(section=SECTION, period=0.01, crossings=0), "crossings", "at least 1"),
    (dict(section=SECTION, period=0.01, tol=0.0), "tol", "a positive number"),
    (dict(section=SECTION, period=0.01, rtol=True), "rtol", "is not a number"),
    (dict(section=SECTION, period=0.01, x0=[1.0, 2.0]), "x0", "1 finite number(s), one per state (q_C)"),
    (dict(section=SECTION, period=0.01, method="RK99"), "method", "choose one of"),
    (dict(section=SECTION, period=0.01, warmup=-2), "warmup", "at least 0"),
    (dict(section=SECTION, period=0.01, criterion="step"), "criterion", "'error'"),
    (dict(section=SECTION, period=0.01, mode=5), "mode", "a label such as 'on|off'"),
])
def test_bad_orbit_arguments_name_the_argument_the_value_and_what_to_give(relay_model, arguments, argument, words):
    with pytest.raises(OrbitArgumentError) as info:
        periodic_orbit(relay_model, **arguments)
    error = info.value
    assert error.argument == argument and isinstance(error, ValueError) and isinstance(error, OrbitError)
    assert str(error).startswith(f"periodic_orbit: {argument}") or f"section={arguments.get('section')!r}" in str(error)
    assert words in str(error)


@pytest.mark.parametrize("values, options, words", [
    ("abc", {}, "values='abc'"),
    ([[7.5, 8.0], [8.5]], {}, "a flat list of numbers"),
    ([7.5, 8.0], dict(parameter_tol=0), "parameter_tol=0 is below 8.88178e-16"),
    ([7.5, 8.0], dict(locate="yes"), "locate='yes'; give True or False"),
    ([7.5, 8.0], dict(signals=[3]), "signals=[3]: give a name or a list of names"),
])
def test_bad_continuation_arguments_are_refused_before_any_orbit(relay_model, values, options, words):
    with pytest.raises(ContinuationError) as info:
        continue_orbit(relay_model, "v_hi", values, section=SECTION, period=0.01, **options)
    assert words in str(info.value) and info.value.result is None


def test_an_orbit_argument_given_to_a_continuation_is_refused_as_such(relay_model):
    # not "no orbit at v_hi = 7.5": the request itself is wrong
    with pytest.raises(OrbitArgumentError, match="max_iterations=-1"):
        continue_orbit(relay_model, "v_hi", [7.5, 8.0], section=SECTION, period=0.01, max_iterations=-1)
    with pytest.raises(OrbitArgumentError, match="continue_orbit: x0='abc' is not a state"):
        continue_orbit(relay_model, "v_hi", [7.5, 8.0], section=SECTION, period=0.01, x0="abc")
    with pytest.raises(OptionError, match="max_step must be a positive number"):
        continue_orbit(relay_model, "v_hi", [7.5, 8.0], section=SECTION, period=0.01, max_step=-1.0)


def test_an_option_of_the_runs_is_refused_by_simulate_not_blamed_on_the_guess(relay_model):
    with pytest.raises(UnknownOptionError, match="did you mean 'max_step'") as info:
        periodic_orbit(relay_model, section=SECTION, period=0.01, max_stpe=1e-3)
    assert "initial guess" not in str(info.value)


def test_small_signal_inputs_each_once(relay_model):
    orbit = periodic_orbit(relay_model, section=SECTION, period=0.01)
    with pytest.raises(OrbitArgumentError, match="inputs=\\['V', 'V'\\] names 'V' more than once"):
        orbit.small_signal(inputs=["V", "V"])
    with pytest.raises(OrbitArgumentError, match="give a name or a list of names"):
        orbit.small_signal(inputs=[1.5])
    assert orbit.small_signal(inputs=["V"]).B.shape == (1, 1)
