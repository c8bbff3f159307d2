"""The keywords of ``simulate`` become small frozen groups (issue 27 item
5): each keyword is carried by exactly one group, with the value given (the
checked arrays for ``x0`` and ``t_eval``), after the same checks and errors
as before; the groups' values reach the integrators."""

from __future__ import annotations

import dataclasses
import inspect

import numpy as np
import pytest

from models import bouncing_ball
from switching.errors import OptionTypeError, OptionValueError
from switching.simulate import driver
from switching.simulate.methods import METHOD_CLASSES, RK4Method, RK45Method, register
from switching.simulate.option_groups import (GROUPS, Events, Limits, Output, RunOptions, Start, Stepping, group_of,
                                              keyword_names)
from switching.simulate.run_options import checked_options

pytestmark = pytest.mark.timeout(60)


def keywords(**given):
    return {**driver.option_defaults(), **given}


def test_every_keyword_of_simulate_is_carried_by_exactly_one_group():
    taken = [name for name, p in inspect.signature(driver.simulate).parameters.items()
             if p.kind is inspect.Parameter.KEYWORD_ONLY]
    names = keyword_names()
    assert sorted(names) == sorted(taken) and len(set(names)) == len(names)
    assert set(driver.option_defaults()) == set(names)
    assert group_of("rtol") is Stepping and group_of("dt") is Stepping and group_of("max_steps") is Limits
    assert group_of("t_eval") is Output and group_of("on_zeno") is Events and group_of("mode") is Start
    with pytest.raises(KeyError):
        group_of("rtoll")


def test_the_groups_carry_the_values_given_and_the_checked_arrays():
    ball = bouncing_ball.build()
    rtol = np.float32(1e-5)  # passed on as given: the integrators see the caller's value
    progress = print
    options = checked_options(ball, 2.0, "RK45", keywords(rtol=rtol, atol=1e-8, t_eval=[1.5, 0.5], x0=[1, 0],
                                                          max_steps=1000, max_events=7, on_zeno="stop",
                                                          progress=progress, zeno_min_gap=0.0))
    assert isinstance(options, RunOptions) and options.method == "RK45" and options.t_end == 2.0
    assert options.stepping.rtol is rtol and options.stepping.atol == 1e-8 and options.stepping.dt is None
    assert options.stepping.integrator_options() == dict(dt=None, rtol=rtol, atol=1e-8, max_step=np.inf,
                                                         first_step=None, stiffness_check=True)
    np.testing.assert_array_equal(options.output.t_eval, [0.5, 1.5])  # sorted
    assert options.output.recorded == "events" and options.output.progress is progress
    assert options.start.x0.dtype == float and list(options.start.x0) == [1.0, 0.0] and options.start.t0 == 0.0
    assert options.limits == Limits(max_steps=1000, max_events=7)
    assert options.events == Events(event_samples=3, on_zeno="stop", zeno_window=8, zeno_min_gap=0.0)
    for group in (options.start, options.stepping, options.events, options.limits, options.output):
        assert type(group) in GROUPS
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(group, dataclasses.fields(group)[0].name, None)


def test_grouping_raises_the_checks_errors_before_anything_is_built():
    ball = bouncing_ball.build()
    with pytest.raises(OptionValueError, match="rtol must be a positive finite number"):
        checked_options(ball, 1.0, "RK45", keywords(rtol=-1.0))
    with pytest.raises(OptionTypeError, match="keep_instants must be True or False"):
        checked_options(ball, 1.0, "RK45", keywords(keep_instants="yes"))
    with pytest.raises(OptionValueError, match="is fixed-step: give a positive step dt"):
        checked_options(ball, 1.0, "rk4", keywords())
    assert ball.derivation_count == 0
    assert Output("steps", None, True, None).recorded == "steps"


@pytest.fixture
def spy():
    """Methods registered for one test whose integrators record the options they were built with."""
    built = []

    def recording(base):
        class Spy(base):
            name = "spy-" + base.name

            @classmethod
            def stepper(cls, fun, t0, y0, t_bound, **options):
                built.append(options)
                return base.stepper(fun, t0, y0, t_bound, **options)

        return register(Spy)

    classes = [recording(RK4Method), recording(RK45Method)]
    yield built
    for cls in classes:
        del METHOD_CLASSES[cls.name]


def test_the_step_options_reach_the_integrator_of_every_flow(spy):
    ball = bouncing_ball.build()
    run = ball.simulate(1.5, "spy-rk4", dt=0.01, stiffness_check=False)
    assert len(spy) == len(run.events) + 1 >= 2  # one integrator per flow
    assert all(o["dt"] == 0.01 and o["stiffness_check"] is False and o["autonomous"] for o in spy)
    spy.clear()
    ball.simulate(1.5, "spy-RK45", rtol=1e-7, atol=1e-10, max_step=0.05, first_step=1e-4)
    assert spy and all((o["rtol"], o["max_step"], o["first_step"]) == (1e-7, 0.05, 1e-4) for o in spy)
    assert all(np.all(np.asarray(o["atol"]) == 1e-10) for o in spy)  # (each state's: all the one given)
    np.testing.assert_array_equal(  # the same results as the method it wraps
        ball.simulate(1.5, "spy-RK45", rtol=1e-7).x, ball.simulate(1.5, "RK45", rtol=1e-7).x)


def test_from_keywords_puts_every_keyword_in_its_own_field():
    from switching.simulate.option_groups import GROUPS, RunOptions, group_of, keyword_names

    values = {name: object() for name in keyword_names()}  # a distinct value per keyword
    options = RunOptions.from_keywords("RK45", 1.0, values)
    groups = {type(getattr(options, attribute)): getattr(options, attribute)
              for attribute in ("start", "stepping", "events", "limits", "output")}
    assert set(groups) == set(GROUPS)
    for name, value in values.items():
        assert getattr(groups[group_of(name)], name) is value, name


def test_options_given_again_are_checked_once_and_told_apart_by_type():
    """A loop of runs with the same options gets the same frozen groups (checked
    once); an equal value of another type is another set of options (the run
    sees the value given, and True is still refused where 1 is taken); options
    with x0, t_eval or samples are checked each time."""
    ball = bouncing_ball.build()
    first = checked_options(ball, 1.0, "RK45", keywords(rtol=1e-4, output="events"))
    assert checked_options(ball, 1.0, "RK45", keywords(rtol=1e-4, output="events")) is first
    other = checked_options(ball, 1.0, "RK45", keywords(rtol=np.float64(1e-4), output="events"))
    assert other is not first and type(other.stepping.rtol) is np.float64 and type(first.stepping.rtol) is float
    assert checked_options(ball, 1, "RK45", keywords(rtol=1e-4, output="events")) is not first
    checked_options(ball, 1.0, "RK45", keywords(max_events=1))
    with pytest.raises(OptionTypeError, match="True and False are not numbers"):
        checked_options(ball, 1.0, "RK45", keywords(max_events=True))
    with_start = checked_options(ball, 1.0, "RK45", keywords(x0=[1.0, 0.0]))
    assert checked_options(ball, 1.0, "RK45", keywords(x0=[1.0, 0.0])) is not with_start
    with pytest.raises(OptionValueError):
        checked_options(ball, 1.0, "RK45", keywords(x0=[1.0, 0.0, 3.0]))


def test_runs_in_a_loop_with_kept_options_give_the_results_of_fresh_ones():
    ball = bouncing_ball.build()
    runs = [ball.simulate(2.0, "RK45", rtol=1e-7, output="events") for _ in range(3)]
    for run in runs[1:]:
        np.testing.assert_array_equal(run.t, runs[0].t)
        np.testing.assert_array_equal(run.x, runs[0].x)
