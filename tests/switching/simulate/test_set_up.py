"""A run takes the set-up of the model's last run when its options and its model are as they were
(switching/simulate/set_up.py, driver.prepared_run, HybridRun._start; issue 46): the same run, to the bit,
as a run set up afresh; anything the set-up reads that changes gives a fresh one."""

from __future__ import annotations

import copy
import gc
import weakref

import numpy as np
import pytest

from bondgraph import BondGraph, C, One, R, Se
from models import bouncing_ball
from switching import Automaton, ExpressionInput, HybridModel
from switching.errors import NonFiniteStateError, OptionTypeError
from switching.model.hybrid_model import Tolerance
from switching.model.inputs import InputValues
from switching.simulate import driver, set_up
from switching.simulate.driver import HybridRun
from switching_models import relay_graph

from test_warm_call import observed

RUN = dict(t_end=4.02, rtol=1e-8)


@pytest.fixture
def runs(monkeypatch):
    """Every HybridRun made while the test runs, in order."""
    made = []
    original = HybridRun.__init__

    def spy(self, *args, **kwargs):
        original(self, *args, **kwargs)
        made.append(self)

    monkeypatch.setattr(HybridRun, "__init__", spy)
    return made


def simulate(model, method="RK45-jit", **options):
    return model.simulate(RUN["t_end"], method, **{"rtol": RUN["rtol"], **options})


def afresh(monkeypatch, run):
    """``run()`` with its set-up made afresh (none taken)."""
    with monkeypatch.context() as patch:
        patch.setattr(driver, "kept_set_up", lambda model, key: None)
        return run()


@pytest.mark.parametrize("method", ["RK45-jit", "RK45", "rk4-jit"])
def test_a_run_with_the_last_runs_options_takes_its_set_up_and_runs_as_a_fresh_one(method, runs, monkeypatch):
    options = {"dt": 1e-3} if method == "rk4-jit" else {}
    model = bouncing_ball.build()
    simulate(model, method, **options)  # (the first run meets a mode the kernel has not compiled yet in Python)
    simulate(model, method, **options)  # (the second, with the values of the first, keeps its set-up)
    kept = [observed(simulate(model, method, **options)) for _ in range(2)]
    assert [run.kept is not None for run in runs] == [False, False, True, True]
    assert runs[2].kept is runs[3].kept and runs[2].options is runs[1].options is runs[0].options
    assert kept[0] == kept[1] == observed(afresh(monkeypatch, lambda: simulate(model, method, **options)))
    assert runs[-1].kept is None


def changes():
    """What a set-up reads, each changed on a model whose last run took a kept set-up: (name, change(model))."""
    def values(model, **changed):
        given = {symbol.name: value for symbol, value in model.parameter_values.items()}
        initial = changed.pop("initial", None)
        model.set_parameter_values({**given, **changed}, initial=initial)

    def in_place(model):
        model.parameter_array[model.parameter_symbols.index(next(s for s in model.parameter_symbols
                                                                 if s.name == "e"))] = 0.85

    return [
        ("a parameter", lambda model: values(model, e=0.85)),
        ("a parameter changed in place", in_place),
        ("the same values set again (a new array)", lambda model: values(model)),
        ("the initial state", lambda model: values(model, initial={"y0": 2.0, "v0": 0.0})),
        ("the initial state alone", lambda model: setattr(model, "initial_state", lambda: np.array([0.0, 1.5]))),
        ("the guard tolerances", lambda model: setattr(model, "tolerance", Tolerance(rtol=1e-8))),
        ("a step hint", lambda model: setattr(model, "max_step_hint", 0.01)),
        ("the inputs (new ones, alike)", lambda model: setattr(model, "input_signals", InputValues(
            model.input_signals.names, model.input_signals.functions))),
        ("the structure (a new mode space, alike)", lambda model: setattr(model, "mode_space",
                                                                          copy.copy(model.mode_space))),
    ]


@pytest.mark.parametrize("name, change", changes(), ids=[name for name, _ in changes()])
def test_a_change_to_what_the_set_up_reads_gives_a_fresh_one(name, change, runs, monkeypatch):
    model = bouncing_ball.build()
    for _ in range(3):
        simulate(model)
    assert runs[-1].kept is not None
    change(model)
    changed = observed(simulate(model))
    assert runs[-1].kept is None and runs[-1].keep_as is not None
    assert observed(simulate(model)) == observed(simulate(model)) == changed  # (kept again from here)
    assert runs[-1].kept is not None
    assert observed(afresh(monkeypatch, lambda: simulate(model))) == changed


@pytest.mark.parametrize("other", [
    {"rtol": 1e-7}, {"t0": 0.5}, {"output": "events"}, {"max_step": 0.1}, {"atol": 1e-9}, {"atol": 1},
    {"method": "RK45"}, {"t_end": 4.0}, {"rtol": np.float64(1e-8)}, {"zeno_window": 9},
])
def test_other_options_give_a_fresh_set_up(other, runs, monkeypatch):
    model = bouncing_ball.build()
    for _ in range(3):
        simulate(model)
    assert runs[-1].kept is not None
    options = dict(other)
    t_end, method = options.pop("t_end", RUN["t_end"]), options.pop("method", "RK45-jit")
    run = observed(model.simulate(t_end, method, **{"rtol": RUN["rtol"], **options}))
    assert runs[-1].kept is None
    assert run == observed(afresh(monkeypatch, lambda: model.simulate(t_end, method, **{"rtol": RUN["rtol"],
                                                                                          **options})))


def test_a_bad_option_after_a_kept_set_up_is_named_as_before():
    """The options are compared with the kept ones before they are checked: an array where a number
    belongs compares as no bool, and the run still stops with the option's own error."""
    model = bouncing_ball.build()
    for _ in range(3):
        simulate(model, atol=1e-9)
    with pytest.raises(OptionTypeError, match="atol must be a positive finite number"):
        simulate(model, atol=np.array([1e-9, 1e-9]))


@pytest.mark.parametrize("options", [
    {"x0": [0.0, 1.0]}, {"t_eval": np.linspace(0.0, 4.0, 9)}, {"samples": 20}, {"progress": lambda t: None},
    {"method": "auto"},
])
def test_runs_that_keep_nothing(options, runs):
    """A run given its own initial state, requested times or samples, a progress callback, or run by
    ``auto`` (which chooses anew each run) neither keeps nor takes a set-up."""
    model = bouncing_ball.build()
    options = dict(options)
    method = options.pop("method", "RK45-jit")
    for _ in range(2):
        simulate(model, method, **options)
    assert [(run.kept, run.keep_as) for run in runs] == [(None, None), (None, None)]


def test_a_start_whose_guard_side_is_not_finite_is_stopped_at_every_run():
    """The start's check is kept only once it passed: a model whose guard side is NaN at the start stops
    every run, and one made so by a value changed in place after runs that passed is stopped too."""
    def relay(k):
        automaton = Automaton("relay", {"charge": {"a": True, "b": False}, "discharge": {"a": False, "b": True}},
                              "charge")
        automaton.add_transition("charge", "discharge", "v/k >= v_hi")
        automaton.add_transition("discharge", "charge", "v <= v_lo")
        values = dict(R1=1.0, R2=0.5, C=1.0, V=1.0, v_hi=0.8, v_lo=0.3, k=k)
        return HybridModel(relay_graph(), [automaton], values, signals={"v": "q_C/C"})

    broken = relay(0.0)
    for _ in range(2):
        with pytest.raises(NonFiniteStateError, match="k = 0"):
            broken.simulate(1.0, "RK45-jit")
    model = relay(1.0)
    for _ in range(3):
        model.simulate(1.0, "RK45-jit")
    model.parameter_array[[s.name for s in model.parameter_symbols].index("k")] = 0.0
    with pytest.raises(NonFiniteStateError, match="left side of 'q_C/\\(C\\*k\\) >= v_hi'.* = nan"):
        model.simulate(1.0, "RK45-jit")


def test_a_model_with_inputs_checks_its_guard_sides_at_every_start(runs, monkeypatch):
    graph = BondGraph("driven")
    j = graph.add(One("j"))
    graph.connect(Se("V", graph.input("u")), j)
    graph.connect(j, R("R1", "R1"))
    graph.connect(j, C("C", "C"))
    automaton = Automaton("level", {"low": {}, "high": {}}, "low")
    automaton.add_transition("low", "high", "q_C >= 0.5")
    model = HybridModel(graph, [automaton], dict(R1=1.0, C=1.0), {"q_C": 0.0}, inputs={"u": ExpressionInput("1 + 0*t")})
    checked = []
    original = driver.nonfinite_sides_at_start
    monkeypatch.setattr(driver, "nonfinite_sides_at_start", lambda *args: checked.append(args[3]) or original(*args))
    for _ in range(3):
        model.simulate(1.0, "RK45-jit")
    assert runs[-1].kept is not None and not runs[-1].kept.start_checked and len(checked) == 3
    bouncing_ball_model = bouncing_ball.build()
    checked.clear()
    for _ in range(3):
        simulate(bouncing_ball_model)
    assert len(checked) == 2  # (the ball has no inputs: the third run takes the second's checked start)


def test_a_kept_set_up_lets_its_model_go():
    def run_and_drop():
        model = bouncing_ball.build()
        for method in ("RK45-jit", "RK45-jit", "RK45", "RK45"):  # (from the second run on, each keeps its set-up)
            simulate(model, method)
        return weakref.ref(model)

    gone = run_and_drop()
    gc.collect()
    assert gone() is None


def test_a_parameter_study_keeps_no_set_up_it_would_never_take(runs):
    """Each run of a study has new values: it notes them only, and the set-up is kept once a run has the
    values of the run before (then the next takes it)."""
    model = bouncing_ball.build()
    given = {symbol.name: value for symbol, value in model.parameter_values.items()}
    for e in (0.8, 0.81, 0.82, 0.83):
        model.set_parameter_values({**given, "e": e})
        simulate(model)
    assert set_up.kept_set_up(model, runs[-1].keep_as) is None
    simulate(model)
    assert set_up.kept_set_up(model, runs[-1].keep_as) is not None
    simulate(model)
    assert [run.kept is not None for run in runs] == [False] * 5 + [True]


def test_a_batchs_runs_neither_take_nor_keep_a_set_up(runs):
    """A batch's runs each have their own values (switching.sweep.kernel_batch: prepared_run(keep=False)),
    even one whose values are the model's own, run after a kept set-up."""
    from switching import simulate_batch

    model = bouncing_ball.build()
    for _ in range(3):
        simulate(model)
    assert runs[-1].kept is not None
    runs.clear()
    simulate_batch(model, [{"e": 0.8}, {"e": 0.8}, {"e": 0.85}], RUN["t_end"], "RK45-jit", rtol=RUN["rtol"])
    assert runs and all(run.kept is None and run.keep_as is None for run in runs)
