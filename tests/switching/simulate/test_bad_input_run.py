"""Bad input to models and runs (issue 20, API side): every bad value is named
up front, every failure of a run is an error of the hierarchy carrying what was
computed, and every error of the hierarchy survives pickling.

The command line's side is in ``test_bad_input_cli.py``, guard text in
``test_bad_input_text.py``."""

from __future__ import annotations

import importlib
import inspect
import math
import pickle
import warnings

import numpy as np
import pytest
import sympy as sp

from bondgraph.errors import (
    HybridBondGraphError,
    MissingParameterError,
    ParameterValueError,
    PhysicalRangeWarning,
    UnknownParameterError,
)
from models import boost_converter, bouncing_ball, diode_circuit
from switching import Automaton, HybridModel, simulate_many
from switching.errors import (ComplexValueError, NonFiniteStateError, SimulationError, SimulationInterrupted,
                              UnknownOptionError)

from switching_models import rc_relay, relay_graph

pytestmark = pytest.mark.timeout(60)  # a bad input must never hang a run (pytest-timeout)


def relay(guard_up="v >= v_hi", parameters=None, **kwargs):
    automaton = Automaton("relay", {"charge": {"a": True, "b": False}, "discharge": {"a": False, "b": True}},
                          "charge")
    automaton.add_transition("charge", "discharge", guard_up)
    automaton.add_transition("discharge", "charge", "v <= v_lo")
    values = dict(R1=1.0, R2=0.5, C=1.0, V=1.0, v_hi=0.8, v_lo=0.3)
    values.update(parameters or {})
    return HybridModel(relay_graph(), [automaton], values, signals={"v": "q_C/C"}, **kwargs)


# ----------------------------------------------------------------- times and options


@pytest.mark.parametrize("t_end", [math.inf, -math.inf, math.nan])
def test_a_run_needs_a_finite_end(t_end):
    model = bouncing_ball.build()
    with pytest.raises(SimulationError, match="t_end must be a finite number"):
        model.simulate(t_end, "RK45")


@pytest.mark.parametrize("option, value", [("rtol", math.nan), ("atol", math.inf), ("max_step", 0.0),
                                           ("first_step", math.nan), ("t0", math.inf)])
def test_non_finite_options_are_named(option, value):
    with pytest.raises(SimulationError, match=option):
        bouncing_ball.build().simulate(1.0, "RK45", **{option: value})


@pytest.mark.parametrize("t_eval, culprit", [([0.0, 0.5, 3.0], "3.0"), ([-1.0, 0.5], "-1.0"),
                                             ([0.5, math.nan], "nan")])
def test_sample_times_outside_the_run_are_named(t_eval, culprit):
    with pytest.raises(SimulationError, match=rf"t_eval\[\d\] = {culprit}.*outside the run"):
        bouncing_ball.build().simulate(2.0, "RK45", t_eval=t_eval)


def test_sample_times_in_any_order_give_a_monotonic_trajectory():
    trajectory = bouncing_ball.build().simulate(2.0, "RK45", t_eval=[1.5, 0.25, 1.0, 2.0, 0.0])
    assert np.all(np.diff(trajectory.t) >= 0)
    for tau in (0.0, 0.25, 1.0, 1.5, 2.0):
        assert tau in trajectory.t


@pytest.mark.parametrize("x0", [[math.nan, 0.0], [0.0, math.inf], [1.0]])
def test_a_bad_initial_state_is_named(x0):
    with pytest.raises(SimulationError, match="x0"):
        bouncing_ball.build().simulate(1.0, "RK45", x0=x0)


def test_a_non_finite_initial_value_is_named():
    automaton = Automaton("relay", {"charge": {"a": True, "b": False}, "discharge": {"a": False, "b": True}},
                          "charge")
    automaton.add_transition("charge", "discharge", "q_C >= 1")
    with pytest.raises(ParameterValueError, match="q_C") as info:
        HybridModel(relay_graph(), [automaton], dict(R1=1, R2=1, C=1, V=1), initial_state={"q_C": math.nan})
    assert info.value.name == "q_C"


# ----------------------------------------------------------------- parameter values


@pytest.mark.parametrize("name, value", [("e", math.nan), ("e", "1e400"), ("g", math.inf), ("m", -math.inf)])
def test_non_finite_model_parameters_are_refused_by_name(name, value):
    with pytest.raises(ParameterValueError, match=f"'{name}'") as info:
        bouncing_ball.build(**{name: value})
    assert info.value.name == name


@pytest.mark.parametrize("value", [math.nan, math.inf])
def test_non_finite_parameters_of_a_hybrid_model_are_refused_by_name(value):
    with pytest.raises(ParameterValueError, match="'R2'.*finite") as info:
        relay(parameters={"R2": value})
    assert info.value.name == "R2"
    assert isinstance(info.value, ValueError)


def test_an_infinite_parameter_is_accepted_where_the_model_allows_it():
    model = relay(parameters={"v_lo": -math.inf}, allow_infinite={"v_lo"})  # never switches back
    trajectory = model.simulate(3.0, "RK45", rtol=1e-9, atol=1e-12)
    assert [e.mode_after.label for e in trajectory.events] == ["discharge"]
    with pytest.raises(ParameterValueError, match="allow_infinite"):
        relay(parameters={"v_lo": -math.inf})


@pytest.mark.parametrize("build, setting, culprit", [
    (boost_converter.build, {"L": 0.0}, "L = 0"),
    (boost_converter.build, {"C": 0.0}, "C = 0"),
    (diode_circuit.build, {"L": 0.0}, "L = 0"),
])
def test_a_zero_storage_parameter_is_named_at_once(build, setting, culprit):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicalRangeWarning)
        model = build(**setting)
    with pytest.raises(NonFiniteStateError) as info:
        model.simulate(1e-3, "RK45")
    message = str(info.value)
    assert "non-finite" in message and culprit in message
    assert message.index(culprit) < message.index("Check")
    trajectory = info.value.trajectory
    assert trajectory is not None and len(trajectory.t) >= 1 and trajectory.t[-1] == info.value.t


@pytest.mark.parametrize("method", ["RK45-jit", "rk4-jit"])
def test_a_zero_storage_parameter_is_named_at_once_by_the_compiled_methods(method):
    """The kernel tells the non-finite rates itself (no evaluation in Python before it); its failure
    names them as the Python path does."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicalRangeWarning)
        model = diode_circuit.build(L=0.0)
    with pytest.raises(NonFiniteStateError) as info:
        model.simulate(1e-3, method, **({"dt": 1e-4} if method == "rk4-jit" else {}))
    message = str(info.value)
    assert message.startswith("non-finite values where a flow starts, at t = 0 s") and "L = 0" in message
    assert info.value.t == 0.0 and info.value.trajectory.t[-1] == 0.0


@pytest.mark.parametrize("method", ["RK45-jit", "rodas-jit", "rk4-jit"])
def test_rates_that_leave_the_reals_mid_run_stop_a_compiled_run_at_once(method):
    """A capacitor e = sqrt(q) drained by a current source through a resistor: q reaches 0 at
    t* = 2 − 2 ln 2 (dq/dt = −1 − sqrt(q), from q = 1), and a step past it meets sqrt of a negative
    charge.  The compiled methods stop there with NonFiniteStateError (their step control never
    loops on a NaN error), and the Python methods name the law (ComplexValueError)."""
    from bondgraph import C, R, BondGraph, Sf
    from bondgraph import Zero as Node

    g = BondGraph("drain")
    j = g.add(Node("j"))
    g.connect(Sf("I", -1.0), j)
    g.connect(j, C("C", effort_law=lambda q: sp.sqrt(q)))
    g.connect(j, R("R", 1.0))
    model = HybridModel(g, [], {}, initial_state={"q_C": 1.0})
    with pytest.raises(NonFiniteStateError) as info:
        model.simulate(3.0, method, **({"dt": 1e-3} if method == "rk4-jit" else {}))
    t_star = 2 - 2 * math.log(2)
    assert abs(info.value.t - t_star) < 0.01 and "left its domain" in str(info.value)
    with pytest.raises(ComplexValueError) as info:
        model.simulate(3.0, "RK45")
    assert abs(info.value.t - t_star) < 0.01


def test_a_guard_that_is_not_finite_at_the_start_is_named():
    model = relay("v/k >= v_hi", parameters={"k": 0.0})
    with pytest.raises(NonFiniteStateError) as info:
        model.simulate(1.0, "RK45")
    message = str(info.value)
    assert "'v/k >= v_hi'" in message and "automaton 'relay'" in message and "k = 0" in message


@pytest.mark.parametrize("build, setting, name", [
    (bouncing_ball.build, {"e": 1.2}, "e"),
    (bouncing_ball.build, {"m": -1.0}, "m"),
    (diode_circuit.build, {"R": -1.0}, "R"),
    (boost_converter.build, {"D": 1.0}, "D"),
])
def test_values_outside_the_physical_range_are_warned_about(build, setting, name):
    with pytest.warns(PhysicalRangeWarning, match=f"{name} = .* outside the physical range"):
        build(**setting)


def test_defaults_of_every_shipped_model_are_in_range():
    import models

    with warnings.catch_warnings():
        warnings.simplefilter("error", PhysicalRangeWarning)
        for name in models.MODELS:
            models.load(name).build()


def test_a_mistyped_signal_in_a_guard_is_told_from_a_missing_parameter():
    with pytest.raises(MissingParameterError) as info:
        relay("vv >= v_hi")
    message = str(info.value)
    assert info.value.missing == ("vv",)
    assert "'vv >= v_hi'" in message and "automaton 'relay'" in message and "did you mean 'v'" in message


def test_a_parameter_of_a_law_without_a_value_is_not_called_a_typo():
    automaton = Automaton("relay", {"charge": {"a": True, "b": False}, "discharge": {"a": False, "b": True}},
                          "charge")
    with pytest.raises(MissingParameterError) as info:
        HybridModel(relay_graph(), [automaton], dict(R1=1, C=1, V=1))
    assert info.value.missing == ("R2",) and "mistyped" not in str(info.value)


def test_a_value_for_an_unused_name_offers_the_closest_parameter():
    with pytest.raises(UnknownParameterError) as info:
        relay(parameters={"v_hii": 0.9})
    message = str(info.value)
    assert "no law, guard, signal or jump" in message and "did you mean 'v_hi'" in message


# ----------------------------------------------------------------- runs that fail keep their work


def test_an_interrupted_run_returns_what_it_computed():
    model = rc_relay()

    def progress(t):
        if t > 2.0:
            raise KeyboardInterrupt

    with pytest.raises(SimulationInterrupted) as info:
        model.simulate(10.0, "RK45", rtol=1e-8, max_step=0.1, progress=progress)
    error = info.value
    assert isinstance(error, KeyboardInterrupt) and isinstance(error, HybridBondGraphError)
    trajectory = error.trajectory
    assert 1.9 < trajectory.t[-1] <= 2.0 + 0.2 and error.t == trajectory.t[-1]  # the last step recorded
    assert np.all(np.diff(trajectory.t) >= 0)
    assert len(trajectory.events) >= 1  # the charge → discharge switch at t ≈ 1.6 is kept
    assert "interrupted at t =" in str(error)


def test_summaries_are_right_without_kept_instants():
    model = rc_relay()
    kept = model.simulate(6.0, "RK45", rtol=1e-9, atol=1e-12)
    sparse = model.simulate(6.0, "RK45", rtol=1e-9, atol=1e-12, t_eval=[0.0, 3.0, 6.0], keep_instants=False)
    assert sparse.instant_count == len(kept.events) >= 3
    assert f"{len(kept.events)} instants" in sparse.summary()
    exact = kept.time_in_modes()
    counted = sparse.time_in_modes()
    assert set(counted) == set(exact)
    for mode, spent in exact.items():
        assert counted[mode] == pytest.approx(spent, rel=1e-9, abs=1e-12)
    assert sum(counted.values()) == pytest.approx(6.0, rel=1e-12)


# ----------------------------------------------------------------- pickling


def _hierarchy():
    for module in ("bondgraph.errors", "switching.errors", "bondgraph.jump", "codegen.jit"):
        importlib.import_module(module)
    seen, todo = [], [HybridBondGraphError]
    while todo:
        cls = todo.pop()
        seen.append(cls)
        todo.extend(cls.__subclasses__())
    return seen


def _instance(cls):
    """An instance of ``cls`` built through its own ``__init__`` with plain arguments."""
    arguments = []
    for parameter in list(inspect.signature(cls.__init__).parameters.values())[1:]:
        if parameter.kind in (parameter.VAR_POSITIONAL, parameter.VAR_KEYWORD) or parameter.default is not parameter.empty:
            continue
        name = parameter.name
        arguments.append(["a", "b"] if name in ("missing", "unknown", "known", "elements") else f"{name} text")
    return cls(*arguments)


def test_the_hierarchy_is_found_whole():
    names = {cls.__name__ for cls in _hierarchy()}
    assert {"UnknownParameterError", "MissingParameterError", "GuardSyntaxError", "DivergenceOfTimeError",
            "ZenoError", "StiffnessError", "SimulationInterrupted", "ParameterValueError"} <= names


@pytest.mark.parametrize("cls", _hierarchy(), ids=lambda cls: cls.__name__)
def test_every_error_of_the_hierarchy_pickles(cls):
    error = _instance(cls)
    error.extra = 42
    copy = pickle.loads(pickle.dumps(error))
    assert type(copy) is cls
    assert str(copy) == str(error)
    assert copy.args == error.args
    assert vars(copy) == vars(error)


def test_a_failed_run_pickles_with_its_trajectory():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicalRangeWarning)
        model = boost_converter.build(L=0.0)
    with pytest.raises(NonFiniteStateError) as info:
        model.simulate(1e-3, "RK45")
    copy = pickle.loads(pickle.dumps(info.value))
    assert np.array_equal(copy.trajectory.t, info.value.trajectory.t)
    assert copy.trajectory.state_names == info.value.trajectory.state_names
    assert copy.trajectory.model is None and copy.mode == info.value.mode
    with pytest.raises(HybridBondGraphError, match="without its model"):
        copy.trajectory.signal("i_L")


def test_a_bad_parameter_set_fails_one_run_of_a_sweep_not_the_sweep():
    results = simulate_many(bouncing_ball.build, [{"e": 0.5}, {"v_res": 1.0}, {"e": math.nan}], 1.0, "RK45",
                            workers=2)
    assert [r.ok for r in results] == [True, False, False]
    assert "v_res" in results[1].error and "did you mean 'v_rest'" in results[1].error
    assert "'e'" in results[2].error and "finite" in results[2].error
    assert results[0].t[-1] == pytest.approx(1.0)


def test_a_failing_input_function_keeps_the_run_and_chains_its_error():
    g = relay_graph()
    u = g.input("u")
    automaton = Automaton("relay", {"charge": {"a": True, "b": False}, "discharge": {"a": False, "b": True}},
                          "charge")
    automaton.add_transition("charge", "discharge", "q_C >= 10")

    def supply(t):
        if t > 0.5:
            raise RuntimeError("the supply's data ends at 0.5 s")
        return 1.0

    model = HybridModel(g, [automaton], dict(R1=1, R2=1, C=1, V=1), signals={"w": u * 2}, inputs={"u": supply})
    with pytest.raises(SimulationError, match="RuntimeError: the supply's data ends") as info:
        model.simulate(2.0, "RK45", max_step=0.05)
    assert isinstance(info.value.__cause__, RuntimeError)
    trajectory = info.value.trajectory
    assert 0.4 < trajectory.t[-1] <= 0.5 and np.all(np.diff(trajectory.t) >= 0)


def test_a_misspelt_simulate_option_is_named_with_the_closest_ones_before_anything_runs():
    model = bouncing_ball.build()
    with pytest.raises(UnknownOptionError, match=r"unknown option 'rtoll'; did you mean 'rtol'") as info:
        model.simulate(1.0, "RK45", rtoll=1e-6)
    assert isinstance(info.value, TypeError) and "keep_instants" in str(info.value)
    assert model.derivation_count == 0  # refused before any mode was derived
    with pytest.raises(UnknownOptionError, match=r"simulate_many: unknown option 'max_stpe'; did you mean 'max_step'"):
        simulate_many(bouncing_ball.build, [{"e": 0.8}], 1.0, client="serial", max_stpe=0.1)
