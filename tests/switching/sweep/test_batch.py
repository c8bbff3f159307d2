"""simulate_many shares one model per structure within a process: runs must
equal runs of freshly built models bit for bit, in this process
(``client="serial"``) and on Dask workers.  Its options are checked before
anything runs, and without Dask it says which extra to install."""

import sys
import warnings

import numpy as np
import pytest
from switching_models import parallel_capacitors as caps_closed_or_open

from models import bouncing_ball, falling_rod, parallel_capacitors
from bondgraph import ParameterValueError
from switching import InitialStateProjected, MissingDependencyError, simulate_many
from switching.sweep.batch import batch_size_for, shared_model

ROD = {"rtol": 1e-9, "atol": 1e-12}


def assert_same_as_fresh(build, sets, t_end, method="RK45", sweep=None, **options):
    """Every run of the sweep (``sweep``: options of simulate_many, default
    ``client="serial"``) equals ``build(**p).simulate(...)`` exactly:
    samples, states, modes, instants."""
    results = simulate_many(build, sets, t_end, method, **(sweep or {"client": "serial"}), **options)
    for p, result in zip(sets, results):
        assert result.ok, result.error
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InitialStateProjected)
            fresh = build(**p).simulate(t_end, method, **options)
        assert result.parameters == p
        assert result.modes == fresh.mode_labels
        np.testing.assert_array_equal(result.t, fresh.t)
        np.testing.assert_array_equal(result.x, fresh.x)
        np.testing.assert_array_equal(result.event_times, fresh.event_times)
        assert result.instants == [[(s.mode.describe(), s.kind) for s in e.steps] for e in fresh.events]
    return results


def test_a_sweep_shares_one_model_and_its_derived_modes():
    sets = [{"mu": 0.002}, {"mu": 0.008}, {"mu": 0.004}]
    models = []
    for p in sets:
        with shared_model(falling_rod.build, p) as model:
            models.append(model)
            np.testing.assert_array_equal(model.parameter_array, falling_rod.build(**p).parameter_array)
    assert models[0] is models[1] is models[2]
    with shared_model(falling_rod.build, {"mu": 0.003}) as outer, shared_model(falling_rod.build, {"mu": 0.004}) as inner:
        assert inner is not outer  # a model in use is not lent to a second run
        assert inner.parameter_values == falling_rod.build(mu=0.004).parameter_values
        assert outer.parameter_values == falling_rod.build(mu=0.003).parameter_values


def test_falling_rod_friction_sweep_equals_fresh_builds_bit_for_bit():
    # μ = 0.002 and 0.004 slide after the impact, 0.008 sticks: the shared model changes behaviour twice
    results = assert_same_as_fresh(falling_rod.build, [{"mu": 0.002}, {"mu": 0.008}, {"mu": 0.004}], 0.5, **ROD)
    assert [r.instants[0][-1][0] for r in results] == ["contact=contact, friction=slide_neg", "contact=contact, friction=stuck",
                                                       "contact=contact, friction=slide_neg"]


def test_arguments_that_set_the_initial_state_are_applied_to_the_shared_model():
    # θ0, y0 are build arguments, not model parameters: they reach only the initial state
    assert_same_as_fresh(falling_rod.build, [{"mu": 0.002, "theta0": 0.7}, {"mu": 0.008, "y0": 0.3}, {"mu": 0.004}],
                         0.5, **ROD)
    # the ball's mass is a parameter and sets the initial momentum m·v0
    assert_same_as_fresh(bouncing_ball.build, [{"m": 1.0, "v0": 1.0, "v_rest": 0.5},
                                               {"m": 2.0, "v0": 3.0, "v_rest": 0.5},
                                               {"m": 0.5, "v0": -1.0, "v_rest": 0.5}], 2.0, rtol=1e-8)


def test_parameters_that_change_the_structure_get_their_own_shared_model():
    # R > 0 adds a resistor (another fingerprint); C1, V1 set the initial charge C1·V1
    sets = [{"C1": 1e-3, "V1": 5.0}, {"C1": 3e-3, "V1": 2.0, "R": 10.0}, {"C1": 2e-3, "V1": 7.0},
            {"C1": 2e-3, "V1": 7.0, "R": 5.0}]
    assert_same_as_fresh(parallel_capacitors.build, sets, 0.05, rtol=1e-9, atol=1e-12)


def test_an_initial_state_projected_with_the_parameters_is_projected_anew_for_each_run():
    """Starting closed, the charges are projected onto equal voltages,
    q_i = C_i (q1 + q2)/(C1 + C2): the projection depends on C1, C2."""
    sets = [{"C1": 1e-3, "C2": 2e-3, "initial": "closed"}, {"C1": 4e-3, "C2": 1e-3, "initial": "closed"},
            {"C1": 2e-3, "C2": 2e-3, "v2": 3.0, "initial": "closed"}]
    with pytest.warns(InitialStateProjected) as record:
        results = assert_same_as_fresh(caps_closed_or_open, sets, 0.01, rtol=1e-9, atol=1e-12)
    assert sum("q_C1" in str(w.message) for w in record) >= 3  # once per run, as for fresh models
    for p, r in zip(sets, results):
        q1, q2 = r.x[0]
        assert q1 / p["C1"] == pytest.approx(q2 / p["C2"], rel=1e-14)


@pytest.mark.timeout(120)
def test_dask_workers_give_the_same_runs_as_one_process():
    pytest.importorskip("distributed")
    # R > 0 adds a resistor: two structures, each worker keeps a model of each it meets
    sets = [{"C1": 1e-3, "V1": 5.0}, {"C1": 3e-3, "V1": 2.0, "R": 10.0}, {"C1": 2e-3, "V1": 7.0},
            {"C1": 2e-3, "V1": 7.0, "R": 5.0}, {"C1": 1e-3, "V1": 3.0, "R": 5.0}]
    results = assert_same_as_fresh(parallel_capacitors.build, sets, 0.05, sweep={"workers": 2, "batch_size": 2},
                                   rtol=1e-9, atol=1e-12)
    assert all(r.wall_time > 0 for r in results)


def test_runs_travel_several_to_a_task_when_there_are_many():
    assert batch_size_for(200, 2) == 13  # 16 tasks: 8 per worker thread
    assert batch_size_for(5, 2) == 1
    assert batch_size_for(100_000, 4) == 50  # a lost worker loses at most 50 runs' work


@pytest.mark.parametrize("options, culprit", [
    ({"workers": 0}, "workers"), ({"batch_size": 2.5}, "batch_size"), ({"retries": -1}, "retries"),
    ({"workers": 2, "client": "tcp://127.0.0.1:1"}, "workers"), ({"progress": print}, "progress"),
    ({"client": 4}, "client"),
])
def test_bad_options_are_named_before_anything_runs(options, culprit):
    with pytest.raises(ParameterValueError, match=culprit) as info:
        simulate_many(bouncing_ball.build, [{"e": 0.8}], 1.0, **options)
    assert info.value.name == culprit


def test_a_parameter_set_that_is_not_a_dict_is_named():
    with pytest.raises(ParameterValueError, match="parameter set 1 is a float"):
        simulate_many(bouncing_ball.build, [{"e": 0.8}, 0.5], 1.0, client="serial")


def test_without_dask_the_error_names_the_extra_and_the_serial_path_still_runs(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed → ImportError
    with pytest.raises(MissingDependencyError, match=r"pip install '\.\[dask\]'") as info:
        simulate_many(bouncing_ball.build, [{"e": 0.8}, {"e": 0.9}], 1.0, workers=2)
    assert isinstance(info.value, ImportError) and "client='serial'" in str(info.value)
    (result,) = simulate_many(bouncing_ball.build, [{"e": 0.8}], 1.0, client="serial", rtol=1e-8)
    assert result.ok and result.t[-1] == pytest.approx(1.0)


def test_without_pandas_to_frame_names_the_extra(monkeypatch):
    from switching import to_frame

    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(MissingDependencyError, match=r"\.\[dask\]"):
        to_frame([])
