"""The mode library (switching.library.mode_library): what it keeps and by what key, that
the model's own methods are its, and that models share one only explicitly —
as a sweep does (switching.sweep.batch.shared_model), with the numbers of a fresh
model to the bit and no memo lost or stale."""

import numpy as np
import pytest

from models import bouncing_ball, parallel_capacitors
from switching import ModeLibrary, ModelDefinitionError
from switching.sweep.batch import shared_model
from switching.library.mode_library import definition_fingerprint

#: the library's memos of the code generator, by attribute name
MEMOS = ("print_memo", "roundoff_memo", "scale_memo", "guard_texts", "guard_trees", "side_block_sources",
         "side_block_functions", "symbols_memo")


def _size(memo) -> int:
    """Entries in a memo (the print memo: expressions printed into it)."""
    return memo.misses if hasattr(memo, "misses") else len(memo)


def _same_run(a, b) -> None:
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.event_times, b.event_times)
    assert a.mode_labels == b.mode_labels


def test_each_model_builds_its_own_library_even_for_the_same_structure():
    a, b = bouncing_ball.build(), bouncing_ball.build(e=0.5)
    assert isinstance(a.library, ModeLibrary) and a.library.model is a
    assert a.fingerprint == b.fingerprint  # one structure (the values are no part of it) ...
    assert a.library is not b.library  # ... and still two libraries: sharing is explicit
    a.mode_equations(a.initial_mode)
    assert a.library.derivation_count == 1 and b.library.derivation_count == 0 and b.derived_modes == ()


def test_the_fingerprint_hashes_the_structure_not_the_values():
    closed = parallel_capacitors.build(C1=1e-3)
    assert closed.fingerprint == definition_fingerprint(closed) == parallel_capacitors.build(C1=5e-3).fingerprint
    assert closed.fingerprint != parallel_capacitors.build(R=10.0).fingerprint  # a resistor more


def test_a_mode_is_derived_once_and_generated_once():
    model = bouncing_ball.build()
    library = model.library
    mode = model.initial_mode
    me = model.mode_equations(mode)
    assert library.mode_equations(mode.label) is me and library.equations == {mode: me}
    assert library.derivation_count == model.derivation_count == 1
    assert library.visited_modes == model.visited_modes == ()
    compiled = library.compiled_mode(mode)
    assert model.compiled_mode(mode.label) is compiled and library.compiled == {mode: compiled}
    assert model.visited_modes == (mode,) and model.mode_source(mode) == compiled.source
    assert library.derivation_count == 1  # its equations were not derived again for the code


def test_the_models_methods_are_the_librarys(tmp_path):
    from codegen.cache import SourceCache

    model = bouncing_ball.build()
    model.cache = SourceCache(tmp_path)  # the model's cache is the library's
    assert model.library.cache is model.cache and model.cache.directory == tmp_path
    trajectory = model.simulate(1.0, "RK45", rtol=1e-8)
    assert model.visited_modes == model.library.visited_modes and len(model.visited_modes) >= 2
    assert model.derived_modes == model.library.derived_modes
    x = np.array(trajectory.x[-1])
    mode = model.visited_modes[0]
    out_model, out_library = np.empty(1), np.empty(1)
    model.signal_function(mode, ["v"])(x, 0.0, model.parameter_array, [], out_model)
    model.library.signal_function(mode, ["v"])(x, 0.0, model.parameter_array, [], out_library)
    assert out_model[0] == out_library[0] == x[model.state_index[model.state("p")]] / 1.0
    labels = model.library.export_module(tmp_path / "ball.py")
    assert labels == [m.label for m in model.visited_modes] == model.export_module(tmp_path / "again.py")
    assert (tmp_path / "ball.py").read_text() == (tmp_path / "again.py").read_text()
    assert model.compiled_model("visited") is model.library.compiled_model("visited")


def test_the_code_generators_memos_fill_as_modes_are_generated():
    from codegen.cache import SourceCache

    model = bouncing_ball.build()
    library = model.library
    library.cache = SourceCache(None)  # no disk cache: the code is generated here
    library.compiled_mode(model.initial_mode)
    assert library.derivation_count == 1 and library.print_memo.misses > 0
    assert library.scale_memo and library.guard_trees and library.guard_texts and library.symbols_memo
    trees = dict(library.guard_trees)
    library.compiled_mode(model.mode("impact"))
    assert all(library.guard_trees[c] is t for c, t in trees.items())  # kept, not built again


def test_a_model_takes_another_definition_and_keeps_its_library():
    from codegen.cache import SourceCache

    model = bouncing_ball.build(e=0.8)
    model.cache = SourceCache(None)  # no disk cache: every memo is filled here
    first = model.simulate(1.2, "RK45", rtol=1e-8)
    library = model.library
    memos = {name: getattr(library, name) for name in MEMOS}
    sizes = {name: _size(memo) for name, memo in memos.items()}
    derived, visited = library.derivation_count, model.visited_modes
    assert sizes["print_memo"] > 0 and sizes["scale_memo"] > 0 and sizes["guard_trees"] > 0
    model.take_definition(bouncing_ball.build(e=0.5, y0=2.0))
    assert model.library is library and library.model is model
    assert model.parameter_values == bouncing_ball.build(e=0.5).parameter_values  # the new values ...
    again = model.simulate(1.2, "RK45", rtol=1e-8)
    assert not np.array_equal(again.x[-1], first.x[-1])  # ... are read
    _same_run(again, bouncing_ball.build(e=0.5, y0=2.0).simulate(1.2, "RK45", rtol=1e-8))  # to the bit
    assert library.derivation_count == derived and model.visited_modes == visited  # nothing derived anew
    for name in MEMOS:  # none lost, none rebuilt
        assert getattr(library, name) is memos[name]
        assert _size(getattr(library, name)) >= sizes[name]


def test_only_a_model_of_the_same_structure_can_take_the_place_of_another():
    model = parallel_capacitors.build()
    with pytest.raises(ModelDefinitionError, match="one type and fingerprint"):
        model.take_definition(parallel_capacitors.build(R=10.0))
    with pytest.raises(ModelDefinitionError, match="one type and fingerprint"):
        model.take_definition(bouncing_ball.build())
    assert model.library.model is model and model.fingerprint == parallel_capacitors.build().fingerprint
    values = dict(model.parameter_values)
    model.take_definition(model)  # its own: nothing changes
    assert model.parameter_values == values and model.library.model is model


def test_a_sweep_shares_the_library_and_each_run_equals_a_fresh_model_to_the_bit():
    runs, libraries, derived = {}, [], []
    for e in (0.8, 0.5, 0.8, 0.6):
        with shared_model(bouncing_ball.build, {"e": e}) as model:
            libraries.append(model.library)
            runs[e] = model.simulate(1.2, "RK45", rtol=1e-8)
            derived.append(model.library.derivation_count)
            assert model.parameter_values == bouncing_ball.build(e=e).parameter_values
        _same_run(runs[e], bouncing_ball.build(e=e).simulate(1.2, "RK45", rtol=1e-8))
    assert all(library is libraries[0] for library in libraries)
    assert derived[-1] == derived[0]  # the later runs derived no mode: all came from the shared library
    assert not np.array_equal(runs[0.8].x[-1], runs[0.6].x[-1])


def test_guard_comparisons_that_read_no_rate_keep_their_sides_for_every_mode():
    """A comparison's finite sides and round-off scale are the mode's own only where it reads a
    rate (ẋ = f(x) of the mode substituted); the others are kept once for every mode (a scene's
    modes share a thousand contact comparisons) and are the triples derived anew."""
    from sympy.core.relational import Relational

    from models import ball_chain, diode_circuit
    from switching.library.compiled import comparison_triples

    chain = ball_chain.build(N=6, e=1.0)
    automata = chain.initial_mode.automata
    chain_modes = [{a: "collide" if j == k else "free" for j, a in enumerate(automata)} for k in range(len(automata))]
    for model, modes in ((chain, [chain.initial_mode, *chain_modes]), (diode_circuit.build(), [None])):
        library = model.library
        for mode in modes:
            mode = model.initial_mode if mode is None else model.mode(mode)
            me = model.mode_equations(mode)
            relations = [rel for guard in me.guards for rel in guard.condition.atoms(Relational)]
            kept = comparison_triples(me, relations)
            library.triple_memo.clear()
            library.triple_by_id.clear()
            assert comparison_triples(me, relations) == kept
            assert all((rel in library.triple_memo) == (me.finite(rel.lhs) is rel.lhs and me.finite(rel.rhs)
                                                        is rel.rhs) for rel in relations)
        assert library.triple_memo or model.name.startswith("diode")


def test_the_garbage_collector_waits_while_a_mode_is_prepared_and_is_left_as_it_was():
    """Preparing a mode allocates many objects and hardly any cyclic garbage; the collections they
    would trigger walk every object of the modes before it.  The collector is off inside the outermost
    preparation and switched back on after it only if it was on (a caller's gc.disable() stands)."""
    import gc

    from models import bouncing_ball

    library = bouncing_ball.build().library
    seen = []
    assert gc.isenabled()
    try:
        with library._preparation():
            seen.append(gc.isenabled())
            with library._preparation():
                seen.append(gc.isenabled())
            seen.append(gc.isenabled())
        seen.append(gc.isenabled())
        gc.disable()
        with library._preparation():
            pass
        seen.append(gc.isenabled())
    finally:
        gc.enable()
    assert seen == [False, False, False, True, False]
