"""A scene's mode modules (issue 46): their size grows with the number of blocks, not with the states.

Their guards' entries are in tables of a block of automata each, stored once like the blocks
(:mod:`switching.library.guard_tables`).

A mode of more than ``2·SIDE_BLOCK_AUTOMATA`` automata calls block functions for its rates (``STATE_BLOCK``
states each) and guard sides, which its module does not hold: each block is stored in the disk cache once,
under a key of its own, and compiled once for every mode that calls it.  Its functions' docstrings state the
arrays' shapes, not every entry.  The numbers are those of the one-function form to the last bit.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import switching.library.compiled as compiled
from codegen.cache import SourceCache
from codegen.source import module_namespace
from models import ball_chain
from switching.model.modes import ModeEquations
from switching.simulate.flow_rates import _reads


def functions_text(module: str) -> str:
    """A mode module without its ``META`` line."""
    return re.sub(r"^META = .*\n", "", module, flags=re.MULTILINE)


def lowest_comparison(tree) -> int:
    """The lowest comparison number in a guard tree."""
    if tree[0] == "rel":
        return tree[1]
    return min(map(lowest_comparison, tree[1] if tree[0] in ("and", "or") else (tree[1],)))


def chain_with_one_pinnacle(n, tmp_path):
    model = ball_chain.build(N=n, e=1.0)
    model.cache = SourceCache(tmp_path / f"cache{n}")
    contacts = [a.name for a in model.automata]
    states = dict(zip(contacts, model.initial_mode.states))
    states[contacts[n // 2]] = "collide"
    return model, model.mode(states)


def test_a_scene_module_grows_with_its_blocks_not_with_its_states(tmp_path):
    sizes = {}
    for n in (40, 160):
        model, mode = chain_with_one_pinnacle(n, tmp_path)
        cm = model.compiled_mode(mode)
        text = functions_text(cm.module)
        sizes[n] = len(text.encode())
        assert "    [0] = " not in text and "x[0] = p1" not in text  # no per-entry lines in the docstrings
        assert not re.search(r"^def _(rates|sides|sides_raw)_", cm.module, re.MULTILINE)  # blocks stored apart
        calls = re.findall(r"^    _rates_\w+\(x, t, p, u, out\[", cm.function_text("rates"), re.MULTILINE)
        assert len(calls) == -(-2 * n // compiled.STATE_BLOCK)  # (equal blocks are one function: all p's rates 0)
    # 120 more balls: about 16 more block calls (≈ 60 bytes each); it was ≈ 1.2 kB a ball
    assert sizes[160] - sizes[40] < 12 * 120, sizes


def test_each_block_is_stored_once_and_read_back(tmp_path):
    model, mode = chain_with_one_pinnacle(40, tmp_path)
    cache = model.cache
    first = model.compiled_mode(model.initial_mode)
    second = model.compiled_mode(mode)
    blocks = {b for cm in (first, second) for names in cm._blocks.values() for b in names}
    tables = {name for cm in (first, second) for name, _ in cm.meta["guard_blocks"]}
    assert blocks | tables == model.library.stored_blocks
    assert cache.hits["built"] == 2 + len(blocks) + len(tables)  # two modules and each block and table once
    again = ball_chain.build(N=40, e=1.0)
    again.cache = SourceCache(cache.directory)
    loaded = again.compiled_mode(mode)
    assert again.derivation_count == 0 and loaded.module == second.module
    assert loaded.guards == second.guards and loaded.n_relations == second.n_relations
    x = np.random.default_rng(3).normal(size=len(again.states))
    p, u = again.parameter_array, again.input_values(0.0)
    for name in ("rates", "sides"):
        size = loaded.n if name == "rates" else loaded.n_sides
        assert np.array_equal(getattr(loaded, "_" + name)(x, 0.1, p, u, np.empty(size)),
                              getattr(second, "_" + name)(x, 0.1, p, u, np.empty(size)))
    assert loaded.source == second.source  # the whole module: the blocks written after it


def test_a_module_whose_block_left_the_cache_is_made_again(tmp_path):
    model, mode = chain_with_one_pinnacle(40, tmp_path)
    made = model.compiled_mode(mode)
    directory = model.cache.directory
    for name in made._blocks["rates"]:
        (directory / f"{model.library._block_key(name)}.py").unlink()
    again = ball_chain.build(N=40, e=1.0)
    again.cache = SourceCache(directory)
    loaded = again.compiled_mode(mode)
    assert again.derivation_count == 1  # derived again, with its blocks
    x = np.random.default_rng(4).normal(size=len(again.states))
    p, u = again.parameter_array, again.input_values(0.0)
    assert np.array_equal(loaded._rates(x, 0.2, p, u, np.empty(loaded.n)), made._rates(x, 0.2, p, u,
                                                                                         np.empty(made.n)))


def test_a_scenes_modules_name_their_guards_in_tables_shared_by_the_modes(tmp_path):
    """A scene's module writes no guard entry: its ``META`` names the guard tables of its blocks of
    automata (:mod:`switching.library.guard_tables`), whose entries, numbered from each table's offset, are
    the mode's guards as written out in full; the whole module (``source``, as exported) writes them out."""
    import ast

    from switching.library.guard_tables import table_checked, table_entries

    model, mode = chain_with_one_pinnacle(40, tmp_path)
    for cm in (model.compiled_mode(model.initial_mode), model.compiled_mode(mode)):
        assert "'tree'" not in cm.module and cm.meta["guard_blocks"]
        assert cm.guards == compiled._mode_guards(model, model.mode_equations(cm.mode))[0]
        assert cm.n_relations == sum(compiled._count_rel(g["tree"]) for g in cm.guards) == cm.meta["comparisons"]
        offsets = [offset for _, offset in cm.meta["guard_blocks"]]
        assert offsets[0] == 0 and offsets == sorted(offsets) and len(set(offsets)) == len(offsets)
        for name, _ in cm.meta["guard_blocks"]:
            text = model.library.block_texts[name]
            assert table_checked(name, text) and not table_checked(name, text + " ")
            assert min(lowest_comparison(e["tree"]) for e in table_entries(text)[:1]) == 0
        by_table, whole_list = cm._conjunction_arrays(), compiled._conjunctions_of(model.library, cm.guards)
        assert all(np.array_equal(a, b) for a, b in zip(by_table, whole_list)) and len(by_table[0])
        whole = ast.literal_eval(compiled._function_chunks(cm.source)["META"])
        assert whole["guards"] == tuple(cm.guards) and "guard_blocks" not in whole
        assert whole["mode"] == cm.mode.states and whole["automata"] == cm.mode.automata
        assert whole["independent"] == tuple(k for k in range(cm.n) if k not in whole["dependent"])
        initial = model.initial_mode.states
        assert dict(cm.meta["changed"]) == {a: s for a, s, i in zip(cm.mode.automata, cm.mode.states, initial)
                                            if s != i}
        assert list(whole) == ["mode", "automata", "independent", "dependent", "moved", "jump", "guards", "n_states"]
    # a module of a chain of N contacts holds a call a block of contacts, not its guards' entries nor every
    # state (≈ 330 bytes a contact, which made the disk cache of a run through N modes grow as N²)
    big, pinnacle = chain_with_one_pinnacle(120, tmp_path)
    assert len(big.compiled_mode(pinnacle).module) < 40 * 120


def test_a_scenes_blocks_read_from_the_disk_cache_are_compiled_only_to_run(tmp_path, monkeypatch):
    """A second process reads a scene's module checked (compiled for the safety check), and the few
    hundred blocks it calls by their names' hashes only: a block is compiled, and checked, when it is
    first run (the guard sides' raw blocks of a chain whose guards are all decided a priori never are)."""
    import codegen.cache as cache_module

    model, mode = chain_with_one_pinnacle(40, tmp_path)
    made = model.compiled_mode(mode)
    again = ball_chain.build(N=40, e=1.0)
    again.cache = SourceCache(model.cache.directory)
    checked, compiled_now = [], []
    check = cache_module.check_source
    monkeypatch.setattr(cache_module, "check_source", lambda source, where, *a: checked.append(where) or
                        check(source, where, *a))
    execute = compiled.execute
    monkeypatch.setattr(compiled, "execute", lambda text, namespace, where, **k: compiled_now.append(where) or
                        execute(text, namespace, where, **k))
    loaded = again.compiled_mode(mode)
    assert again.derivation_count == 0 and len(checked) == 1  # the module itself
    x = np.random.default_rng(5).normal(size=len(again.states))
    assert np.array_equal(loaded.sides(x, 0.2), made.sides(x, 0.2))
    run = {where.split()[-1].rstrip(">") for where in compiled_now if where.startswith("<hbg block")}
    assert run == set(loaded._blocks["sides"]) and not run & set(loaded._blocks["sides_raw"])


def test_a_module_whose_guard_table_is_not_one_is_made_again(tmp_path):
    """A guard table in the disk cache that is not the table its name hashes (a valid cache entry of
    other text) is not read: the module is derived again, its guards those of the mode."""
    model, mode = chain_with_one_pinnacle(40, tmp_path)
    made = model.compiled_mode(mode)
    name = made.meta["guard_blocks"][1][0]
    model.cache.store(model.library._block_key(name), "RECORD = ()\n")
    again = ball_chain.build(N=40, e=1.0)
    again.cache = SourceCache(model.cache.directory)
    loaded = again.compiled_mode(mode)
    assert again.derivation_count == 1 and loaded.guards == made.guards


def test_a_guard_table_text_is_read_or_refused():
    from switching.library.guard_tables import guard_table_record, shifted_entries, table_entries

    entries = ({"automaton": "a", "tree": ("rel", 0, ">=", "x >= 0")},
               {"automaton": "b", "tree": ("and", (("rel", 1, "<", "y < 1"), ("rel", 2, ">", "y > 0")))})
    record = guard_table_record([repr(e) for e in entries])
    assert table_entries(record) == entries
    assert table_entries(guard_table_record([repr(entries[0])])) == entries[:1]
    moved = shifted_entries(entries, 5, compiled.shifted_tree)
    assert [lowest_comparison(e["tree"]) for e in moved] == [5, 6]
    assert shifted_entries(entries, 0, compiled.shifted_tree) is entries
    for text in ("RECORD = (1, 2)\n", "RECORD = (\n", "x = ()\n", "RECORD = {'tree': 1}\n", "RECORD = (f(),)\n",
                 "RECORD = ({[1]: 2},)\n"):
        with pytest.raises(ValueError, match="not a guard table"):
            table_entries(text)


@pytest.fixture(scope="module")
def chain():
    model = ball_chain.build(N=40, e=0.5)
    model.simulate(0.4, "RK45", rtol=1e-9)
    return model


def test_blocked_rates_and_jumps_give_the_numbers_of_one_function(chain, monkeypatch):
    p, u = chain.parameter_array, chain.input_values(0.0)
    rng = np.random.default_rng(8)
    for mode in chain.visited_modes:
        cm = chain.compiled_mode(mode)
        assert compiled.called_blocks(cm.function_text("rates"))
        # (the blocks each caller calls, handed over as the module is assembled: those its text names)
        assert cm._blocks == {name: compiled.called_blocks(cm.function_text(name))
                              for name in ("rates", "sides", "sides_raw")}
        monkeypatch.setattr(compiled, "SIDE_BLOCK_AUTOMATA", 10 ** 6)
        source, _ = compiled.mode_source_and_meta(chain, chain.mode_equations(mode))
        monkeypatch.undo()
        assert "def _rates_" not in source and "    [0] = " in source
        flat = module_namespace()
        exec(compile(source, "<one function>", "exec"), flat)
        for _ in range(4):
            x = rng.normal(size=cm.n) * 10.0 ** rng.integers(-3, 4)
            assert np.array_equal(cm._rates(x, 0.3, p, u, np.empty(cm.n)), flat["rates"](x, 0.3, p, u,
                                                                                          np.empty(cm.n)))
            assert np.array_equal(cm._rates(list(x), 0.3, p, u, np.empty(cm.n)), flat["rates"](x, 0.3, p, u,
                                                                                                np.empty(cm.n)))
            if cm.jump_kind == "symbolic":
                assert np.array_equal(cm._jump(x, 0.3, p, u, np.empty(cm.n)), flat["jump"](x, 0.3, p, u,
                                                                                           np.empty(cm.n)))
        # the states the rates read, through their blocks: those the one function unpacks
        unpacked = {int(k) for k in re.findall(r"^    \w+ = x\[(\d+)\]$", source.split("def rates(")[1]
                                               .split("\ndef ")[0], re.MULTILINE)}
        assert _reads(cm, "rates") == unpacked


def test_the_whole_source_runs_vectorized_with_its_blocks(chain):
    cm = chain.compiled_mode(list(chain.visited_modes)[3])
    p, u = chain.parameter_array, chain.input_values(0.0)
    xs = np.random.default_rng(2).normal(size=(5, cm.n))
    namespace = module_namespace(vectorized=True)
    exec(compile(cm.source, "<vectorized>", "exec"), namespace)
    many = np.empty((cm.n, len(xs)))
    namespace["rates"](xs.T, np.full(len(xs), 0.3), p, u, many)
    for j, x in enumerate(xs):
        assert np.array_equal(many[:, j], cm._rates(x, 0.3, p, u, np.empty(cm.n)))
    assert np.array_equal(cm.rates_at(xs, np.full(len(xs), 0.3)), many.T)


def test_the_modes_of_a_scene_hand_the_print_memo_one_argument_list(chain):
    """The print memo finds its table by the arguments tuple itself, not by a hash of every state's symbol."""
    memo = chain.library.print_memo
    modes = list(chain.visited_modes)
    compiled.mode_module(chain, chain.mode_equations(modes[0]))
    known = dict(memo._by_arguments)
    for mode in modes[1:4]:
        compiled.mode_module(chain, chain.mode_equations(mode))
    assert memo._by_arguments == known and len(known) == 2  # (the functions' list, and the raw functions')


def test_the_guards_that_may_hold_are_decided_at_once_as_one_by_one(chain):
    """``maybe_holding`` is False only where ``decide_tree`` decides False: on random sides, with ties at
    the band's edges, zeros, infinities and NaN."""
    rng = np.random.default_rng(11)
    rtol, atol = chain.tolerance.rtol, chain.tolerance.atol
    specials = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 1e-300, 1.0])
    for mode in list(chain.visited_modes)[:6]:
        cm = chain.compiled_mode(mode)
        for trial in range(30):
            sides = rng.normal(size=cm.n_sides) * 10.0 ** rng.integers(-12, 6, size=cm.n_sides)
            if trial % 3 == 0:  # right side = left side, or just beyond the band
                width = rtol * np.abs(sides[0::3]) + atol
                sides[1::3] = sides[0::3] + rng.choice([0.0, 1.0, -1.0], size=cm.n_relations) * width
            if trial % 5 == 0:
                spots = rng.integers(0, cm.n_sides, size=cm.n_sides // 4)
                sides[spots] = rng.choice(specials, size=len(spots))
            maybe = cm.maybe_holding(sides, rtol, atol)
            decided = [compiled.decide_tree(g["tree"], sides, rtol, atol) for g in cm.guards]
            assert not any(d and not m for d, m in zip(decided, maybe))
            assert list(maybe) == decided  # (every guard of the chain is a conjunction of comparisons)


def test_a_pinnacle_decides_one_by_one_only_the_guards_that_may_hold(monkeypatch):
    import switching.simulate.resolution as resolution

    model = ball_chain.build(N=40, e=1.0)
    calls = []
    decide = resolution.decide_tree
    monkeypatch.setattr(resolution, "decide_tree", lambda *a, **k: calls.append(1) or decide(*a, **k))
    model.simulate(0.2, "RK45", rtol=1e-9)
    pinnacles = len(model.library.compiled)
    assert pinnacles >= 39
    # two calls (decision and record) per fired guard, ~2 fired a pinnacle; it was 39 guards a pinnacle
    assert len(calls) < 8 * pinnacles, len(calls)


def test_a_modules_meta_is_the_repr_of_its_value_with_its_guards_kept(chain):
    """``META``'s text is assembled of the guards' kept texts: the very ``repr`` of the value."""
    for mode in list(chain.visited_modes)[:5]:
        source, meta, chunks = compiled.mode_module(chain, chain.mode_equations(mode))
        assert chunks["META"] == repr(meta)
    small = ball_chain.build(N=3, e=0.5)
    small.simulate(0.3, "RK45", rtol=1e-9)
    for mode in small.visited_modes:
        source, meta, chunks = compiled.mode_module(small, small.mode_equations(mode))
        assert chunks["META"] == repr(meta)
    kept = chain.library.guard_entries
    assert kept and all(len(found[6]) <= compiled.GUARD_OFFSETS_KEPT for found in kept.values())


def test_a_new_mode_builds_only_the_guard_entries_it_changes(tmp_path):
    model, mode = chain_with_one_pinnacle(40, tmp_path)
    model.compiled_mode(model.initial_mode)
    calls = []
    tree = model.library.guard_tree
    model.library.guard_tree = lambda *a: calls.append(a) or tree(*a)
    model.compiled_mode(mode)
    assert len(calls) == 1  # the contact that collides (its other 38 guards kept; it was 39)


def test_a_function_reading_few_of_many_states_unpacks_them_without_a_pass_over_all():
    """A block of a scene's functions reads a few of a thousand states: with the print memo, its source
    is written without walking the state vector (the argument lists' positions are kept)."""
    import sympy as sp

    from codegen.source import Argument, FunctionSpec, PrintMemo, function_source

    class Counted(tuple):
        passes = 0

        def __iter__(self):
            Counted.passes += 1
            return super().__iter__()

    x = Counted(sp.symbols("x0:1000"))
    arguments = (Argument("x", x, doc="states"), Argument("t", (sp.Symbol("t"),), scalar=True),
                 Argument("p", (), doc="parameters"), Argument("u", (), doc="inputs"))
    memo = PrintMemo()
    first = function_source(FunctionSpec("_block_", arguments, (x[3] * x[700], x[5]), "a", brief=True), memo)
    passes = Counted.passes
    second = function_source(FunctionSpec("_block_", arguments, (x[9] - x[2],), "b", brief=True), memo)
    assert Counted.passes == passes  # (it was one pass over the thousand states a function)
    assert "    x3 = x[3]\n    x5 = x[5]\n    x700 = x[700]\n" in first
    assert "    x2 = x[2]\n    x9 = x[9]\n" in second


def test_the_guard_entries_a_library_keeps_are_bounded(monkeypatch, tmp_path):
    """Where a guard's condition is a new object in every mode its entry is never met again: the library
    drops its kept entries at GUARD_ENTRIES_KEPT instead of growing by every guard of every mode."""
    from models import boost_converter

    monkeypatch.setattr(compiled, "GUARD_ENTRIES_KEPT", 2)
    model = boost_converter.build()
    model.cache = SourceCache(tmp_path / "a")  # (every mode generated here, none loaded)
    made, tree = [], model.library.guard_tree
    model.library.guard_tree = lambda *a: made.append(a) or tree(*a)
    run = model.simulate(1e-4, "RK45", rtol=1e-8)
    assert len(made) > 2 and len(model.library.guard_entries) <= 2
    monkeypatch.undo()
    fresh = boost_converter.build()
    fresh.cache = SourceCache(tmp_path / "b")
    np.testing.assert_array_equal(fresh.simulate(1e-4, "RK45", rtol=1e-8).x, run.x)


def test_a_mode_derived_after_many_others_is_the_mode_derived_alone(tmp_path):
    """What a scene's modes share (guard forms, entries and blocks of automata, island pieces, comparison
    triples, merged islands read lazily) leaves each mode as it is: a mode derived after a run of
    pinnacles has the META, guards and numbers (rates, guard sides, jump, to the bit) of the mode derived
    first in a fresh model.  (The names of the generated temporaries may differ: the print memo names
    them in the order it meets them.)"""
    model = ball_chain.build(N=40, e=1.0)
    model.cache = SourceCache(tmp_path / "warm")
    model.max_steps_per_instant = 1000
    model.simulate(1.0, "RK45", rtol=1e-9)  # (the pinnacles: every contact colliding in turn)
    assert model.derivation_count >= 40
    x = np.random.default_rng(46).normal(size=len(model.states))
    for k, mode in enumerate(model.derived_modes[::7]):
        fresh = ball_chain.build(N=40, e=1.0)
        fresh.cache = SourceCache(tmp_path / f"cold{k}")
        alone, after = fresh.compiled_mode(mode), model.compiled_mode(mode)
        assert alone.meta == after.meta, mode.describe()
        np.testing.assert_array_equal(alone.rates(x, 0.3), after.rates(x, 0.3))
        np.testing.assert_array_equal(alone.sides(x, 0.3), after.sides(x, 0.3))
        if alone.jump_kind == "symbolic":
            np.testing.assert_array_equal(alone.jump(x, 0.3), after.jump(x, 0.3))
        assert model.mode_equations(mode).guards == fresh.mode_equations(mode).guards


def test_the_modes_of_a_scene_share_the_guard_forms_of_automata_states_they_share(tmp_path):
    model, mode = chain_with_one_pinnacle(40, tmp_path)
    first, second = model.mode_equations(model.initial_mode), model.mode_equations(mode)
    changed = [k for k, (a, b) in enumerate(zip(first.guards, second.guards)) if a is not b]
    assert len(changed) == 1 and first.guards[changed[0]].automaton == second.mode.automata[20]
    assert second.guard_starts == list(range(len(second.guards) + 1))  # (one transition leaves each state)


def test_a_modes_guard_forms_made_from_the_last_modes_are_those_made_afresh():
    """Issue 46: a mode's guard forms start from those of the mode made before it, automaton by automaton;
    in any order of modes they are the forms (and the starts) made with nothing before."""
    model = ball_chain.build(N=40, e=0.5)
    automata = [a.name for a in model.automata]
    rng = np.random.default_rng(12)
    modes = [model.mode({name: rng.choice(["free", "collide"]) if rng.random() < 0.2 else "free"
                         for name in automata}) for _ in range(6)]
    for mode in modes:
        made = model.mode_equations(mode)
        model.library.last_guard_groups = None
        again = ModeEquations(model, mode)
        assert made.guards == again.guards and made.guard_starts == again.guard_starts, mode.describe()
        assert all(a is b for a, b in zip(made.guards, again.guards))  # (every group the library's, shared)


def test_the_side_blocks_known_block_by_block_are_those_of_the_spans(chain):
    for mode in list(chain.visited_modes)[:6]:
        *_, spans, _, _, side_blocks = compiled._mode_comparisons(chain, chain.mode_equations(mode), True)
        assert side_blocks and side_blocks == compiled._side_blocks(spans)


def test_an_instant_pauses_the_cyclic_collector_and_leaves_it_as_it_was(monkeypatch):
    """The modes an instant derives are one block for the cyclic garbage collector: off while it is
    resolved, on again after it if it was on (and left off if the caller had it off)."""
    import gc

    import switching.simulate.resolution as resolution
    from models import bouncing_ball
    from switching.library.collection import collection_paused

    model = bouncing_ball.build()
    seen = []
    evaluate = resolution.evaluate_guards

    def watched(*args, **kwargs):  # (between the modes' derivations)
        seen.append(gc.isenabled())
        return evaluate(*args, **kwargs)

    monkeypatch.setattr(resolution, "evaluate_guards", watched)
    was = gc.isenabled()
    try:
        for enabled in (True, False):
            (gc.enable if enabled else gc.disable)()
            model.resolve(np.array([0.0, -1.0]), model.initial_mode, 0.5)
            assert gc.isenabled() is enabled
        with collection_paused():
            with collection_paused():
                assert not gc.isenabled()
            assert not gc.isenabled()
    finally:
        (gc.enable if was else gc.disable)()
    assert seen and not any(seen)


def test_a_scene_jumps_pulse_is_the_rules_on_all_states_taken_on_the_moved_ones(tmp_path):
    """CompiledMode.pulse runs the rule (switching.rules.jumps.jump_pulse) on the states the jump moves alone
    when it keeps the others exactly: the same pulse, to the bit, as the rule on all states; else on all."""
    from switching.rules.jumps import jump_pulse

    model, mode = chain_with_one_pinnacle(40, tmp_path)
    cm = model.compiled_mode(mode)
    assert 0 < len(cm.moved) < cm.n
    tol = model.tolerance
    rng = np.random.default_rng(11)
    for trial in range(40):
        x = rng.normal(size=cm.n)
        x_plus = x.copy()
        x_plus[cm.moved] += rng.choice([0.0, 1e-17, 1e-3, -2.0], size=len(cm.moved))
        if trial % 4 == 3:
            x_plus[rng.integers(cm.n)] += 1.0  # a state the jump should keep, moved: the rule on all of them
        if trial % 5 == 4:
            x[rng.integers(cm.n)] = np.nan
            x_plus = np.where(np.isnan(x), np.nan, x_plus)
        motion = np.abs(rng.normal(size=cm.n)) * 1e-12
        expected = np.empty(cm.n)
        jump_pulse(x, x_plus, cm.moved, len(cm.moved), tol.jump_rtol, tol.jump_atol, motion, expected)
        found = cm.pulse(x, x_plus, motion)
        assert np.array_equal(found, expected, equal_nan=True), trial
    x = rng.normal(size=cm.n)
    assert np.array_equal(cm.pulse(x, x), np.zeros(cm.n))
