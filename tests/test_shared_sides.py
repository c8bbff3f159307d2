"""Guard sides shared by the modes (switching.compiled.SHARED_SIDES_FROM):
a scene of many contacts computes each comparison's sides by a function of
its own, printed and compiled once per model, called by each mode's
``sides``/``sides_raw``.  The numbers must be those of one function per mode,
to the bit, in runs, in the generated functions and in an exported module."""

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import switching.compiled as compiled
from codegen.cache import SourceCache
from codegen.runtime import Hyper
from models import ball_chain

N = 14  # 13 contacts: at least SHARED_SIDES_FROM comparisons in every mode


def chain(cache=None):
    model = ball_chain.build(N=N, e=0.9)
    model.cache = SourceCache(cache)
    return model


def hyper(value):
    return value if isinstance(value, Hyper) else Hyper(0.0, float(value))


@pytest.fixture(scope="module")
def both():
    """The chain's run with shared sides, and with one function per mode."""
    assert N - 1 >= compiled.SHARED_SIDES_FROM
    shared = chain()
    run = shared.simulate(1.0, "RK45", rtol=1e-9)
    saved = compiled.SHARED_SIDES_FROM
    compiled.SHARED_SIDES_FROM = 10**9
    try:
        inline = chain()
        reference = inline.simulate(1.0, "RK45", rtol=1e-9)
    finally:
        compiled.SHARED_SIDES_FROM = saved
    return shared, run, inline, reference


def test_runs_are_the_same_to_the_bit(both):
    shared, run, inline, reference = both
    assert len(shared.visited_modes) >= 5
    assert np.array_equal(run.t, reference.t) and np.array_equal(run.x, reference.x)
    assert [m.label for m in run.modes] == [m.label for m in reference.modes]
    assert "_gs" in shared.compiled_mode(shared.initial_mode).source
    assert "_gs" not in inline.compiled_mode(inline.initial_mode).source


def test_each_comparison_is_printed_and_compiled_once_per_model(both):
    shared, *_ = both
    modes = shared.visited_modes
    calls = sum(shared.compiled_mode(m).n_relations for m in modes)
    assert len(shared._shared_side_functions) == len(shared._shared_sides)
    assert len(shared._shared_sides) < calls  # far fewer functions than comparisons met in all the modes
    # any two modes share all but the comparisons of the contacts they switch
    first, second = sorted(modes, key=lambda m: m.label)[:2]
    a, b = (set(shared.compiled_mode(m)._chunks) for m in (first, second))
    assert len(a & b) >= len(a) - 4


def test_sides_and_raw_sides_agree_with_one_function_per_mode(both):
    shared, _, inline, _ = both
    rng = np.random.default_rng(8)
    n = len(shared.states)
    for mode in shared.visited_modes:
        ours, theirs = shared.compiled_mode(mode), inline.compiled_mode(mode)
        for _ in range(5):
            x, xdot = rng.normal(size=n), rng.normal(size=n)
            assert np.array_equal(ours.sides(x, 0.2), theirs.sides(x, 0.2))
            pulses = [Hyper(float(i), float(f)) for i, f in zip(rng.normal(size=n), xdot)]
            p, u = shared.parameter_array, shared.input_values(0.2)
            raw_ours = [hyper(v) for v in ours._sides_raw(x, 0.2, p, u, pulses)]
            raw_theirs = [hyper(v) for v in theirs._sides_raw(x, 0.2, p, u, pulses)]
            assert [(h.impulse, h.finite) for h in raw_ours] == [(h.impulse, h.finite) for h in raw_theirs]


def test_a_mode_read_back_from_the_cache_reuses_the_compiled_side_functions(tmp_path):
    model = chain(tmp_path)
    model.simulate(0.5, "RK45", rtol=1e-9)
    mode = model.initial_mode
    made = model.compiled_mode(mode)
    count = len(model._shared_side_functions)
    again = compiled.CompiledMode(model, mode, made.source)
    x = model.initial_state()
    assert np.array_equal(again.sides(x, 0.1), made.sides(x, 0.1))
    assert len(model._shared_side_functions) == count  # nothing compiled again


def test_an_exported_module_keeps_each_modes_side_functions_apart(both, tmp_path):
    shared, *_ = both
    labels = shared.export_module(tmp_path / "chain_modes.py")
    x = np.linspace(-1.0, 1.0, len(shared.states))
    expected = {label: list(shared.compiled_mode(label).sides(x, 0.3)) for label in labels}
    check = textwrap.dedent(
        """
        import json, sys
        sys.path.insert(0, sys.argv[1])
        import chain_modes as m
        x = json.loads(sys.argv[2])
        out = {}
        for label, mode in m.MODES.items():
            values = mode["sides"](x, 0.3, m.PARAMETER_VALUES, [], [0.0] * int(sys.argv[3]))
            out[label] = list(values)
        print(json.dumps(out))
        """
    )
    size = max(len(v) for v in expected.values())
    done = subprocess.run([sys.executable, "-c", check, str(tmp_path), json.dumps(list(x)), str(size)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    got = json.loads(done.stdout)
    for label, values in expected.items():
        assert got[label][: len(values)] == values, label
