"""A kernel call's Python side (switching.library.jit_model.CompiledModel.run): what it keeps between calls."""

import numpy as np

from models import bouncing_ball


def _ball():
    model = bouncing_ball.build()
    model.simulate(2.5, "RK45", rtol=1e-6, output="events")  # visit both modes: the record covers them
    return model, model.compiled_model()


def _events(compiled, model, atol):
    result = compiled.run(2, model.initial_mode, model.initial_state(), 0.0, 2.5, dt=None, rtol=1e-6, atol=atol,
                          max_step=np.inf, first_step=None, samples=3, save=False)
    arrays = result.arrays()
    return result.steps, arrays.t_events.copy(), arrays.x_after.copy()


def test_a_number_as_atol_is_made_an_array_once_and_records_handed_out_keep_theirs():
    model, compiled = _ball()
    first = _events(compiled, model, 1e-9)
    record = compiled.record
    again = _events(compiled, model, 1e-9)
    assert compiled.record is record  # the same number: the record and its array as they were
    other = _events(compiled, model, 1e-7)
    assert compiled.record.atol is not record.atol
    assert np.all(record.atol == 1e-9) and np.all(compiled.record.atol == 1e-7)
    assert other[0] < first[0]
    last = _events(compiled, model, 1e-9)
    for a, b, c in zip(first, again, last):
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(a, c)


def test_the_kernel_inputs_of_a_call_are_those_it_runs_with():
    model, compiled = _ball()
    arguments = dict(kind=2, mode=model.initial_mode, x=model.initial_state(), t=0.0, t_end=2.5, dt=None, rtol=1e-6,
                     atol=1e-8, max_step=np.inf, first_step=None, samples=3, save=False)
    record, ints, floats, x, te = compiled.call_arrays(**arguments)
    assert np.all(record.atol == 1e-8) and ints[4] == 0 and ints[3] == model.max_steps_per_instant
    kept = record.atol.copy()
    compiled.run(**{**arguments, "atol": 1e-6})
    np.testing.assert_array_equal(record.atol, kept)  # a record handed out is never written


_LOAD_ONLY = """
import json, sys
sys.path.insert(0, {root!r})
import numba
from numba.core import base
imported = {{name for name in sys.modules if name.startswith("numba")}}
calls = []
refresh = base.BaseContext.refresh
base.BaseContext.refresh = lambda self: (calls.append(1), refresh(self))[1]
from models import bouncing_ball
model = bouncing_ball.build()
trajectory = model.simulate(2.5, "RK45-jit", rtol=1e-6, output="events")
print(json.dumps([len(calls), [float(t) for t in trajectory.event_times],
                  sorted(name for name in sys.modules if name.startswith("numba") and name not in imported)]))
"""


def _second_process(tmp_path) -> tuple:
    """``(numba's context refreshes, the event times, the numba modules imported beyond numba's own import)``
    of the ball's first ``RK45-jit`` run in a new process, the kernel and the modes' functions cached; and the
    event times of the same run in this process."""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    model = bouncing_ball.build()
    events = model.simulate(2.5, "RK45-jit", rtol=1e-6, output="events").event_times  # the kernel cached now
    root = str(Path(__file__).resolve().parents[3])
    environment = {**os.environ, "HBG_CACHE_DIR": str(tmp_path)}
    script = _LOAD_ONLY.format(root=root)
    subprocess.run([sys.executable, "-c", script], env=environment, capture_output=True, text=True, check=True)
    done = subprocess.run([sys.executable, "-c", script], env=environment, capture_output=True, text=True, check=True)
    refreshes, times, modules = json.loads(done.stdout)
    return refreshes, times, modules, [float(t) for t in events]


def test_a_new_process_loads_the_cached_kernel_without_numbas_compilation_set_up(tmp_path):
    """numba's first use refreshes its contexts (its registries of implementations: 0.2–0.3 s) before it loads
    machine code from its disk cache; the kernel's loads skip that (codegen.numba_internals.load_cached), and
    numba refreshes them itself before it compiles anything.  Nor does the load import numba's implementation
    modules (``numba.np.arrayobj``, ``numba.np.arraymath``, ``numba.cpython.numbers`` and the twenty-odd they
    import, ~0.1 s): the kernel keeps no environment of theirs (``switching.kernel.views``; no ``**`` of an
    integer, no ``np.searchsorted``, no array made in compiled code)."""
    refreshes, times, modules, events = _second_process(tmp_path)
    assert refreshes == 0
    assert times == events
    assert modules == []
