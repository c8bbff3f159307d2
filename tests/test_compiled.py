"""The compiled (numba) flow kernels give the Python methods' results."""

import numpy as np
import pytest

pytest.importorskip("numba")

from models import bouncing_ball, falling_rod  # noqa: E402
from switching import SimulationError  # noqa: E402

BOUNCES = np.array([0.451523640986, 1.173961466563, 1.751911727025, 2.214271935394])


@pytest.fixture(scope="module")
def ball():
    return bouncing_ball.build()


def test_fixed_step_kernels_reproduce_the_python_steps_exactly(ball):
    for method, jit in (("rk4", "rk4-jit"), ("euler", "euler-jit")):
        python = ball.simulate(2.5, method, dt=0.01)
        compiled = ball.simulate(2.5, jit, dt=0.01)
        assert len(python.t) == len(compiled.t)
        np.testing.assert_array_equal(compiled.event_times, python.event_times)
        np.testing.assert_allclose(compiled.x, python.x, rtol=0, atol=1e-13)


def test_rk45_kernel_takes_scipys_steps(ball):
    python = ball.simulate(2.5, "RK45", rtol=1e-6)
    compiled = ball.simulate(2.5, "RK45-jit", rtol=1e-6)
    assert python.stats["steps"] == compiled.stats["steps"] and len(python.t) == len(compiled.t)
    np.testing.assert_allclose(compiled.t, python.t, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(compiled.x, python.x, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(compiled.event_times[:4], BOUNCES, atol=1e-9)


def test_compiled_path_with_dependent_states_and_mythical_modes():
    model = falling_rod.build(mu=0.002)
    python = model.simulate(0.4, "RK45", rtol=1e-9, atol=1e-12)
    compiled = model.simulate(0.4, "RK45-jit", rtol=1e-9, atol=1e-12)
    assert [s.kind for s in compiled.events[0].steps] == ["start", "mythical", "continuous"]
    assert compiled.events[0].t == pytest.approx(python.events[0].t, abs=1e-13)
    np.testing.assert_allclose(compiled.x[-1], python.x[-1], rtol=1e-9, atol=1e-12)


def test_compiled_methods_refuse_what_they_cannot_do(ball):
    with pytest.raises(SimulationError, match="t_eval needs 'RK45'"):
        ball.simulate(1.0, "RK45-jit", t_eval=[0.5])
    with pytest.raises(SimulationError, match="fixed-step"):
        ball.simulate(1.0, "rk4-jit")


def test_zeno_is_detected_on_the_compiled_path_too():
    from switching import ZenoError

    with pytest.raises(ZenoError) as info:
        bouncing_ball.build().simulate(10.0, "RK45-jit", rtol=1e-8)
    assert info.value.accumulation_time == pytest.approx(0.451523640986 * 9, abs=1e-6)


def test_simulate_many_runs_a_sweep_on_all_cores_and_keeps_failures_apart():
    from switching import simulate_many

    sets = [{"mu": 0.002}, {"mu": 0.005}, {"mu": 0.004}, {"mu": 0.003}]
    results = simulate_many(falling_rod.build, sets, 0.3, "RK45-jit", workers=2, rtol=1e-9, atol=1e-12,
                            output="events")
    assert [r.parameters for r in results] == sets  # in order
    last = [r.instants[0][-1] for r in results]
    assert last == [("contact|slide_neg", "continuous"), ("contact|stuck", "continuous"),
                    ("contact|slide_neg", "continuous"), ("contact|slide_neg", "continuous")]
    broken = simulate_many(bouncing_ball.build, [{"e": 0.5}, {"e": 0.8}], 5.0, "RK45", workers=2)
    assert [r.ok for r in broken] == [False, False] and "Zeno" in broken[0].error
    assert len(broken[0].event_times) >= 8  # the partial run came back
