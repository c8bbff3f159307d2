"""Guard sides of a large mode in blocks of automata (issue 15).

A mode of more than ``2·SIDE_BLOCK_AUTOMATA`` automata prints its guard
comparisons as one function per block of ``SIDE_BLOCK_AUTOMATA`` automata,
named by a hash of its text and shared by every mode holding it; ``sides``
calls the blocks in turn.  The numbers must be those of the one-function
form to the last bit, on the Python path, on numpy's math, vectorized, from
the disk cache and in a standalone export (where ``out`` may be a list).
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import switching.library.compiled as compiled
from codegen.cache import SourceCache
from codegen.runtime import Hyper
from codegen.source import module_namespace
from models import ball_chain

N = 40  # 39 contact automata: three blocks


@pytest.fixture(scope="module")
def chain():
    model = ball_chain.build(N=N, e=1.0)
    model.simulate(0.4, "RK45", rtol=1e-9)
    return model


def one_function_module(model, mode, monkeypatch):
    """The mode's module with the guard sides as one function, as smaller modes have them."""
    monkeypatch.setattr(compiled, "SIDE_BLOCK_AUTOMATA", 10 ** 6)
    source, _ = compiled.mode_source_and_meta(model, model.mode_equations(mode))
    monkeypatch.undo()
    assert "def _sides_" not in source
    namespace = module_namespace()
    exec(compile(source, "<one function>", "exec"), namespace)
    return namespace


def random_states(model, count, seed=5):
    rng = np.random.default_rng(seed)
    return [rng.normal(size=len(model.states)) * 10.0 ** rng.integers(-3, 4) for _ in range(count)]


def test_a_large_mode_calls_blocks_of_sixteen_automata(chain):
    cm = chain.compiled_mode(list(chain.visited_modes)[-1])
    calls = [line for line in cm._chunks["sides"][1].splitlines() if line.startswith("    _sides_")]
    assert len(calls) == 3  # automata 1–16, 17–32, 33–39
    assert calls[0].endswith("(x, t, p, u, out[0:%d])" % int(calls[1].split("out[")[1].split(":")[0]))
    small = ball_chain.build(N=8, e=1.0)
    assert "def _sides_" not in small.compiled_mode(small.initial_mode).source


def test_blocks_give_the_numbers_of_one_function(chain, monkeypatch):
    p, u = chain.parameter_array, chain.input_values(0.0)
    for mode in chain.visited_modes:
        cm = chain.compiled_mode(mode)
        flat = one_function_module(chain, mode, monkeypatch)
        for x in random_states(chain, 4):
            blocked = cm._sides(x, 0.3, p, u, np.empty(cm.n_sides))
            assert np.array_equal(blocked, flat["sides"](x, 0.3, p, u, np.empty(cm.n_sides)), equal_nan=True)
            xdot = [Hyper(float(k % 3), float(k)) for k in range(len(x))]
            raw, raw_flat = cm._sides_raw(x, 0.3, p, u, xdot), flat["sides_raw"](x, 0.3, p, u, xdot)
            assert [(h.impulse, h.finite) if isinstance(h, Hyper) else h for h in raw] == \
                   [(h.impulse, h.finite) if isinstance(h, Hyper) else h for h in raw_flat]


def test_blocks_run_on_numpy_math_and_vectorized(chain):
    cm = chain.compiled_mode(list(chain.visited_modes)[5])
    p, u = chain.parameter_array, chain.input_values(0.0)
    xs = random_states(chain, 6)
    namespace = module_namespace(vectorized=True)
    exec(compile(cm.source, "<vectorized>", "exec"), namespace)
    many = np.empty((cm.n_sides, len(xs)))
    namespace["sides"](np.array(xs).T, np.full(len(xs), 0.3), p, u, many)
    for j, x in enumerate(xs):
        one = cm._sides(x, 0.3, p, u, np.empty(cm.n_sides))
        assert np.array_equal(many[:, j], one)
        assert np.array_equal(cm.on_numpy("sides")(x, np.float64(0.3), p, u, np.empty(cm.n_sides)), one)


def test_a_new_mode_prints_only_the_blocks_it_changes(tmp_path):
    model = ball_chain.build(N=N, e=1.0)
    model.cache = SourceCache(tmp_path)  # empty: every mode is generated here
    contacts = [a.name for a in model.automata]
    model.compiled_mode(model.initial_mode)._sides  # noqa: B018 - compiles the blocks
    def side_blocks():
        return [key for key in model.library.side_block_sources if key[0] in ("sides", "sides_raw")]

    printed, functions = len(side_blocks()), len(model.library.side_block_functions)
    assert functions == 3
    states = dict(zip(contacts, model.initial_mode.states))
    states[contacts[20]] = "collide"
    cm = model.compiled_mode(model.mode(states))
    cm._sides  # noqa: B018
    assert len(side_blocks()) == printed + 2  # one block of finite sides, one of raw sides
    assert len(model.library.side_block_functions) == functions + 1  # the two other blocks are the initial mode's


def test_a_second_process_reads_the_blocks_from_the_cache(chain, tmp_path):
    first = ball_chain.build(N=N, e=1.0)
    first.cache = SourceCache(tmp_path)
    first.simulate(0.4, "RK45", rtol=1e-9)
    again = ball_chain.build(N=N, e=1.0)
    again.cache = SourceCache(tmp_path)
    p, u = again.parameter_array, again.input_values(0.0)
    for mode in first.visited_modes:
        loaded = again.compiled_mode(mode)
        assert again.derivation_count == 0  # nothing derived: the blocks came with the source
        x = random_states(again, 1)[0]
        assert np.array_equal(loaded._sides(x, 0.1, p, u, np.empty(loaded.n_sides)),
                              first.compiled_mode(mode)._sides(x, 0.1, p, u, np.empty(loaded.n_sides)))
    trajectory = again.simulate(0.4, "RK45", rtol=1e-9)
    assert again.derivation_count == 0 and trajectory.t[-1] == pytest.approx(0.4)


def test_an_export_of_large_modes_fills_a_list(chain, tmp_path):
    labels = chain.export_module(tmp_path / "chain_modes.py")
    text = (tmp_path / "chain_modes.py").read_text()
    raw_blocks = [line for line in text.splitlines() if line.startswith("def _sides_raw_")]
    assert len(raw_blocks) == len(set(raw_blocks))  # each shared block written once
    assert "def _sides_" not in text.replace("def _sides_raw_", "")  # finite sides written out: lists work
    assert "def _rates_" not in text  # and the rates
    mode = chain.mode(labels[-1])
    cm = chain.compiled_mode(mode)
    x = random_states(chain, 1)[0]
    expected = cm._sides(x, 0.2, chain.parameter_array, chain.input_values(0.0), np.empty(cm.n_sides))
    check = textwrap.dedent(
        f"""
        import json, sys
        sys.modules["sympy"] = None
        sys.modules["numpy"] = None
        sys.path.insert(0, sys.argv[1])
        import chain_modes as m
        functions = m.MODES[{labels[-1]!r}]
        out = [0.0] * {cm.n_sides}
        functions["sides"]({[float(v) for v in x]!r}, 0.2, m.PARAMETER_VALUES, [], out)
        raw = functions["sides_raw"]({[float(v) for v in x]!r}, 0.2, m.PARAMETER_VALUES, [],
                                     [m.Hyper(0.0, 0.0)] * {len(x)})
        rates = [0.0] * {len(x)}
        functions["rates"]({[float(v) for v in x]!r}, 0.2, m.PARAMETER_VALUES, [], rates)
        print(json.dumps([out, len(raw), rates]))
        """
    )
    out = subprocess.run([sys.executable, "-c", check, str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    values, count, rates = json.loads(out.stdout)
    assert np.array_equal(np.array(values), expected)
    assert np.array_equal(np.array(rates), cm.rates(x, 0.2))
    assert count == 2 * cm.n_relations


@pytest.mark.parametrize("moved", [1, 5, 30])
def test_a_jump_that_leaves_most_states_copies_them_in_one_slice(moved):
    """``copy_of``: outputs equal to their entry of ``x`` are written by ``out[:] = x``
    from ``COPY_MIN`` of them on; the numbers are those of one line per output."""
    import sympy as sp

    from codegen.source import COPY_MIN, Argument, FunctionSpec, function_source

    n = 40
    x = sp.symbols(f"x0:{n}")
    k = sp.Symbol("k")
    outputs = tuple((x[i] + k * x[(i + 1) % n]) / (1 + k) if i < moved else x[i] for i in range(n))
    arguments = (Argument("x", x, doc="states"), Argument("t", (sp.Symbol("t"),), scalar=True),
                 Argument("p", (k,), doc="parameters"), Argument("u", (), doc="inputs"))
    copying = function_source(FunctionSpec("jump", arguments, outputs, "g", copy_of="x"))
    plain = function_source(FunctionSpec("jump", arguments, outputs, "g"))
    assert ("out[:] = x" in copying) == (n - moved >= COPY_MIN)
    writes = [line for line in copying.splitlines() if line.startswith("    out[") and " = " in line]
    assert len(writes) == (moved + 1 if n - moved >= COPY_MIN else n)
    functions = []
    for text in (copying, plain):
        namespace = module_namespace()
        exec(compile(text, "<jump>", "exec"), namespace)
        functions.append(namespace["jump"])
    values = np.random.default_rng(1).normal(size=n)
    for out in (np.empty(n), [0.0] * n):
        a = functions[0](values, 0.0, [0.3], [], out)
        assert np.array_equal(np.asarray(a, dtype=float), functions[1](values, 0.0, [0.3], [], np.empty(n)))
    aliased = values.copy()  # out may be x itself
    functions[0](aliased, 0.0, [0.3], [], aliased)
    assert np.array_equal(aliased, functions[1](values, 0.0, [0.3], [], np.empty(n)))


@pytest.mark.parametrize("blocked", [True, False])
def test_the_parts_of_a_module_assembled_are_those_read_off_its_text(chain, blocked, monkeypatch):
    """A mode generated now hands its CompiledMode the parts it was assembled from (the text is
    not searched for them): the very parts, first lines included, that a module from the disk
    cache is read into."""
    if not blocked:
        monkeypatch.setattr(compiled, "SIDE_BLOCK_AUTOMATA", 10 ** 6)
    for mode in list(chain.visited_modes)[:3]:
        source, meta, chunks = compiled.mode_module(chain, chain.mode_equations(mode))
        calls = chunks.pop("CALLS")  # (and the blocks each caller calls: those its text names)
        assert chunks == compiled._function_chunks(source)
        assert calls == {name: compiled.called_blocks(chunks[name][1]) for name in ("rates", "sides", "sides_raw")}
        assert bool(compiled.called_blocks(chunks["sides"][1])) == blocked  # (the blocks are stored apart)
        given, read = compiled.CompiledMode(chain, mode, source, meta, {**chunks, "CALLS": calls}), \
            compiled.CompiledMode(chain, mode, source)
        assert (given._chunks, given._blocks) == (read._chunks, read._blocks)
