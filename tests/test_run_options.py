"""The options of a run (issue 32).

The advice after a collapsed step never names the method that failed.
"""

from __future__ import annotations

import pytest

from models import two_tanks
from switching.errors import StepSizeError

pytestmark = pytest.mark.timeout(30)


@pytest.mark.parametrize("method", ["BDF", "Radau"])
def test_the_advice_after_a_collapsed_step_never_names_the_method_that_failed(method):
    model = two_tanks.build()
    with pytest.raises(StepSizeError) as info:
        model.simulate(1e15 + 1000, method, t0=1e15, rtol=1e-8)
    message = str(info.value)
    assert message.startswith(f"{method} failed")
    advice = message.split("try method=", 1)[1].split(")")[0]
    assert f"'{method}'" not in advice and "'LSODA'" in advice
