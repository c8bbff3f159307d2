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
