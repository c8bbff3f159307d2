"""A sweep keeps what finished whatever one parameter set's build does (issue 34, item 5).

A build that raises, or returns something that is not a model, fails its own
parameter set — serially as on Dask — naming the build and the set; a closed
Dask client is refused up front, naming its state.
"""

import pytest

from models import bouncing_ball
from switching import simulate_many
from switching.sweep.batch import BuildError
from bondgraph.errors import HybridBondGraphError

BALL = {"rtol": 1e-8}


def fragile_build(e=0.8):
    """The bouncing ball, except for e = 0.5 (a bug in the user's build) and e = 0.6 (a build that forgot to return)."""
    if e == 0.5:
        raise ZeroDivisionError("the user's build divided by zero")
    if e == 0.6:
        return None
    return bouncing_ball.build(e=e)


def _check(results):
    assert [r.status for r in results] == ["ok", "failed", "failed", "ok"]
    raised, nothing = results[1], results[2]
    assert raised.error_type == "BuildError" and "fragile_build(**{'e': 0.5}) raised ZeroDivisionError" in raised.error
    assert nothing.error_type == "BuildError" and "returned NoneType, not a HybridModel" in nothing.error
    assert results[0].t[-1] == pytest.approx(1.0) and results[3].t[-1] == pytest.approx(1.0)


def test_a_serial_sweep_keeps_every_run_whose_build_worked():
    sets = [{"e": 0.8}, {"e": 0.5}, {"e": 0.6}, {"e": 0.9}]
    _check(simulate_many(fragile_build, sets, 1.0, "RK45", client="serial", **BALL))


def test_a_build_error_is_of_the_hierarchy_and_keeps_its_cause():
    from switching.sweep.batch import shared_model

    with pytest.raises(BuildError) as raised:
        with shared_model(fragile_build, {"e": 0.5}):
            pass
    assert isinstance(raised.value, HybridBondGraphError)
    assert isinstance(raised.value.__cause__, ZeroDivisionError)
    assert raised.value.name == "fragile_build" and raised.value.value == {"e": 0.5}


def test_on_dask_each_set_gets_its_own_result_and_a_closed_client_is_refused():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        with distributed.Client(cluster, set_as_default=False) as client:
            sets = [{"e": 0.8}, {"e": 0.5}, {"e": 0.6}, {"e": 0.9}]
            _check(simulate_many(fragile_build, sets, 1.0, "RK45", client=client, batch_size=4, **BALL))
        assert client.status == "closed"
        with pytest.raises(HybridBondGraphError, match="the Dask client given is closed"):
            simulate_many(fragile_build, sets, 1.0, "RK45", client=client, **BALL)
