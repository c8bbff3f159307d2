"""Derivation island by island (``bondgraph.islands``) gives the whole graph's derivation.

A configuration splits at its off junctions into islands, each derived once
for every configuration that holds it.  The merged causality and equations
must be *the very ones* a derivation of the whole graph gives: the same
causal strokes, the same dependent states in the same order, and each
expression identical (structurally equal, so the generated code and its
numbers do not change; structural equality implies ``simplify(a − b) == 0``).
The whole graph's derivation is :func:`assign_causality` and
:func:`derive_equations` called on it directly.
"""

from __future__ import annotations

import itertools
import random
from pathlib import Path

import pytest
import sympy as sp

import models
from bondgraph import BondGraph, C, I, One, R, Se, Sf, Zero
from bondgraph.causality import assign_causality
from bondgraph.equations import derive_equations
from bondgraph.errors import CausalityConflictError, HybridBondGraphError
from bondgraph.islands import IslandCells, islands
from models import ball_chain, boost_converter, bouncing_ball, colliding_balls, diode_circuit, falling_rod
from models import parallel_capacitors, two_tanks
from switching.files.modelfile import load_model

import switching_models as sm
import test_law_switches as law_switch_models

EXAMPLES = Path(models.__file__).parent / "examples"


def _hybrid_models():
    yield "ball chain N=6", ball_chain.build(N=6, e=1.0)
    for module in (boost_converter, bouncing_ball, colliding_balls, diode_circuit, falling_rod,
                   parallel_capacitors, two_tanks):
        yield module.__name__, module.build()
    yield "ball row", sm.ball_row([1.0, 2.0, 3.0, 1.5], 0.8)
    yield "diode (tests)", sm.diode_circuit()
    yield "independent switches", sm.independent_switches(6)
    yield "rc relay", sm.rc_relay()
    for path in sorted(EXAMPLES.glob("*.toml")):
        yield path.name, load_model(path)
    yield "friction law switch", law_switch_models.sign_block(c=0.2, F=1.0)
    yield "stick/slip automaton", law_switch_models.automaton_block(c=0.2)
    yield pytest.param("rod, Newton-Coulomb impacts", falling_rod.build(impact_law="newton-coulomb"),
                       marks=pytest.mark.slow)


def configurations(graph, limit=48, seed=3):
    names = graph.controlled_junctions
    if 2 ** len(names) <= limit:
        combos = itertools.product((False, True), repeat=len(names))
    else:
        rng = random.Random(seed)
        combos = [tuple(rng.random() < p for _ in names) for p in (0.2, 0.5, 0.8) for _ in range(limit // 3)]
    return [dict(zip(names, combo)) for combo in combos]


def assert_same_expressions(a: dict, b: dict, what: str):
    assert list(a) == list(b), what
    for key in a:
        assert a[key] == b[key], f"{what}[{key}]: {a[key]} != {b[key]}"


def assert_same_derivation(graph, config):
    """The island path of ``graph`` equals the whole graph's derivation in ``config``."""
    try:
        whole_causality = assign_causality(graph, config)
        whole = derive_equations(graph, config, whole_causality)
    except Exception as error:  # the island path must fail alike
        with pytest.raises(type(error)) as raised:
            graph.equations(config, open_ports=False)
        assert str(raised.value) == str(error)
        return False
    merged = graph.equations(config, open_ports=False)
    causality = merged.causality
    assert causality.configuration == whole_causality.configuration
    assert causality.effort_by == whole_causality.effort_by
    assert causality.dead == whole_causality.dead
    assert causality.independent == whole_causality.independent
    assert causality.dependent == whole_causality.dependent
    assert causality.algebraic_loops == whole_causality.algebraic_loops
    for table in ("relations", "rates", "constraints", "rate_symbols"):
        assert getattr(causality.relations, table) == getattr(whole_causality.relations, table), table
    assert merged.configuration == whole.configuration
    assert (merged.states, merged.independent, merged.dependent) == (whole.states, whole.independent, whole.dependent)
    for table in ("rate_symbols", "constraints", "implicit_rates", "rates", "efforts", "flows", "input_rates",
                  "port_inputs", "port_outputs"):
        assert_same_expressions(getattr(merged, table), getattr(whole, table), table)
    assert merged._dependent_rates == whole._dependent_rates
    return True


@pytest.mark.parametrize("name, model", list(_hybrid_models()), ids=lambda v: v if isinstance(v, str) else "")
def test_island_derivation_is_the_whole_graphs(name, model):
    graph = model.derivation_graph
    derived = 0
    split = 0
    for config in configurations(graph):
        split += len(islands(graph, graph.configuration(config))) > 1
        derived += assert_same_derivation(graph, graph.configuration(config))
    assert derived > 0
    if graph.controlled_junctions:
        assert split > 0, "no configuration of this model split into islands: the test checks nothing new"


@pytest.mark.parametrize("model, law, limit", [
    (ball_chain.build(N=5, e=1.0), "conservation", 48),
    pytest.param(falling_rod.build(), "conservation", 48, marks=pytest.mark.slow),
    (falling_rod.build(impact_law="newton-coulomb"), "impulse balance", 4),  # (a whole rod derivation: ~0.5 s)
], ids=["chain", "rod", "rod impulse balance"])
def test_jump_map_over_islands_is_the_whole_graphs(model, law, limit):
    graph = model.derivation_graph
    from bondgraph.jump import derive_jump_map

    for config in configurations(graph, limit):
        config = graph.configuration(config)
        whole = derive_jump_map(graph, derive_equations(graph, config, assign_causality(graph, config)), law)
        merged = graph.jump_map(config, law)
        assert merged.dependent == whole.dependent and merged.participating == whole.participating
        if whole.expressions is None:
            assert merged.expressions is None
        else:
            assert_same_expressions(merged.expressions, whole.expressions, "jump")


def test_a_configuration_that_switches_one_contact_derives_only_the_islands_next_to_it():
    graph = ball_chain.build(N=12, e=1.0).derivation_graph
    contacts = graph.controlled_junctions
    free = {c: False for c in contacts}
    graph.equations(free, open_ports=False)
    derived = {k for k in graph.derived.entries if k[0] == "island equations"}
    assert len(derived) == len(islands(graph, graph.configuration(free)))
    one_on = dict(free, **{contacts[5]: True})
    graph.equations(one_on, open_ports=False)
    new = {k for k in graph.derived.entries if k[0] == "island equations"} - derived
    assert len(new) == 1  # the two balls the contact joins: one island, derived anew
    assert len(islands(graph, graph.configuration(one_on))) == len(derived) - 1


def _walked_islands(graph, config):
    """The islands by a walk of every element and bond (the definition): union-find over the bonds,
    joined by every element but an off controlled junction and by the couplings."""
    from bondgraph.elements import Junction
    from bondgraph.islands import element_couplings

    couplings = element_couplings(graph)
    group = {b: {b} for b in graph.bonds}
    for name, el in graph.elements.items():
        bonds = graph._bonds_of[name]
        joined = [] if isinstance(el, Junction) and el.controlled and not config[name] else bonds
        for b in [*joined, *((bonds[:1] + couplings.get(name, [])) if bonds and name in couplings else [])]:
            if group[b] is not group[bonds[0]]:
                merged = group[bonds[0]] | group[b]
                for m in merged:
                    group[m] = merged
    order = list(graph.bonds)
    found = []
    for members in sorted({id(g): g for g in group.values()}.values(), key=lambda g: min(map(order.index, g))):
        bonds = tuple(b for b in order if b in members)
        names = tuple(n for n in graph.elements if any(b in members for b in graph._bonds_of[n]))
        switched = tuple((n, config[n]) for n in names if n in graph.controlled_junctions)
        found.append((bonds, names, (bonds, switched)))
    return found


@pytest.mark.parametrize("name, model", list(_hybrid_models())[:8])
def test_islands_from_the_cells_are_those_of_a_walk_of_the_whole_graph(name, model):
    graph = model.derivation_graph
    cells = IslandCells(graph)
    for config in configurations(graph, limit=16):
        config = graph.configuration(config)
        got = [(i.bonds, i.elements, i.key) for i in cells.islands(config)]
        assert got == _walked_islands(graph, config), config


def test_an_island_met_again_is_the_same_object():
    """A configuration joins the cells across its on junctions; an island it shares with an earlier one
    is the Island built then (the memo of its causality and equations hashes the same key)."""
    graph = ball_chain.build(N=12, e=1.0).derivation_graph
    cells = IslandCells(graph)
    contacts = graph.controlled_junctions
    free = {c: False for c in contacts}
    first = cells.islands(free)
    second = cells.islands(dict(free, **{contacts[5]: True}))
    assert len(second) == len(first) - 1
    assert sum(any(a is b for b in first) for a in second) == len(second) - 1  # all but the joined one
    assert len(cells.known) == len(first) + 1


def test_an_element_that_reads_another_islands_state_joins_it():
    """A source modulated by a mass's momentum, behind an off junction: one island, not two."""
    g = BondGraph("coupled")
    left, right, gate = g.add(One("left")), g.add(One("right")), g.add(Zero("gate", controlled=True))
    g.connect(left, I("m1", "m1", state="p1"))
    g.connect(Se("push", -sp.Symbol("k") * sp.Symbol("p2")), left)
    g.connect(left, gate)
    g.connect(gate, right)
    g.connect(right, I("m2", "m2", state="p2"))
    g.connect(right, R("r", "r"))
    assert len(islands(g, {"gate": False})) == 1
    assert assert_same_derivation(g, {"gate": False})
    p1, p2 = g.state("p1"), g.state("p2")
    rates = g.equations({"gate": False}).rates
    assert sp.simplify(rates[p1] - (-sp.Symbol("k") * p2)) == 0
    assert sp.simplify(rates[p2] - (-sp.Symbol("r") * p2 / sp.Symbol("m2"))) == 0


def conflicting_graph():
    """Two flow sources on a controlled 1-junction (a conflict when it is on),
    and a damped mass behind an off 0-junction (another island)."""
    g = BondGraph("conflict")
    j, k, m = g.add(One("j", controlled=True)), g.add(Zero("k", controlled=True)), g.add(One("m"))
    g.connect(Sf("s1", "F1"), j)
    g.connect(Sf("s2", "F2"), j)
    g.connect(j, k)
    g.connect(k, m)
    g.connect(m, I("mass", "M"))
    g.connect(m, R("damper", "b"))
    g.connect(C("spring", "K"), m)
    return g


def test_a_conflict_inside_an_island_is_reported_as_for_the_whole_graph():
    g = conflicting_graph()
    config = {"j": True, "k": False}
    assert len(islands(g, config)) == 2
    with pytest.raises(CausalityConflictError) as whole:
        assign_causality(g, config)
    with pytest.raises(CausalityConflictError) as merged:
        g.causality(config)
    assert str(merged.value) == str(whole.value)
    assert "j" in str(merged.value)


def test_open_ports_are_merged_from_their_islands():
    g = BondGraph("ported")
    a, b, gate = g.add(One("a")), g.add(One("b")), g.add(Zero("gate", controlled=True))
    g.connect(a, I("m1", "m1", state="p1"))
    g.connect(a, gate)
    g.connect(gate, b)
    g.connect(b, C("c2", "c2", state="q2"))
    g.port("A", a)
    g.port("B", b)
    for config in ({"gate": False}, {"gate": True}):
        whole_graph = g.open_view()
        whole = derive_equations(whole_graph, config, assign_causality(whole_graph, config))
        merged = g.equations(config)
        assert list(merged.port_inputs) == list(whole.port_inputs) == ["A", "B"]
        assert_same_expressions(merged.port_inputs, whole.port_inputs, "port_inputs")
        assert_same_expressions(merged.port_outputs, whole.port_outputs, "port_outputs")
        assert_same_expressions(merged.rates, whole.rates, "rates")


def random_graph(seed: int) -> BondGraph:
    """A small random bond graph: 0- and 1-junctions (half of them controlled,
    some joined directly, so that off junctions meet: dead bonds, bonds
    between an off 0 and an off 1), with storage, resistors, sources and a
    modulated transformer hung on them."""
    rng = random.Random(seed)
    g = BondGraph(f"random{seed}")
    junctions = []
    for k in range(rng.randint(3, 7)):
        kind = Zero if rng.random() < 0.5 else One
        junctions.append(g.add(kind(f"j{k}", controlled=rng.random() < 0.5)).name)
    for k in range(1, len(junctions)):  # a tree, and maybe a loop
        g.connect(junctions[rng.randrange(k)], junctions[k])
    if rng.random() < 0.3:
        a, b = rng.sample(junctions, 2)
        g.connect(a, b)
    made = 0
    for j in junctions:
        for _ in range(rng.randint(0, 2)):
            made += 1
            pick = rng.random()
            if pick < 0.3:
                g.connect(j, I(f"I{made}", f"m{made}"))
            elif pick < 0.55:
                g.connect(j, C(f"C{made}", f"c{made}"))
            elif pick < 0.75:
                g.connect(j, R(f"R{made}", f"r{made}"))
            elif pick < 0.87:
                g.connect(Se(f"Se{made}", f"E{made}"), j)
            else:
                g.connect(Sf(f"Sf{made}", f"F{made}"), j)
    if rng.random() < 0.4:  # a transformer modulated by a state elsewhere
        from bondgraph import TF

        states = g.states
        if states:
            tf = g.add(TF("tf", sp.Symbol("n") + sp.Symbol("a") * states[0] ** 2))
            g.connect(rng.choice(junctions), tf)
            g.connect(tf, I("Itf", "mtf"))
    for j in junctions:  # every junction needs a bond
        if not g._bonds_of[j]:
            g.connect(j, R(f"Rj{j}", f"rj{j}"))
    return g


@pytest.mark.parametrize("seed", range(60))
def test_random_graphs_derive_island_by_island_as_whole(seed):
    """Over 60 random graphs, about a third of the configurations derive and
    two thirds are causality conflicts: both must come out as for the whole graph."""
    g = random_graph(seed)
    g.validate()
    for config in configurations(g, limit=16):
        assert_same_derivation(g, g.configuration(config))


@pytest.mark.parametrize("name, model", list(_hybrid_models())[:8])
def test_the_states_impulses_reach_are_the_same_with_the_rates_symbols_kept(name, model):
    """A jump map reads which implicit rates hold a dependent rate off symbols kept with the graph's
    derivations (the configurations share most rates): the same states as asking each rate."""
    from bondgraph.jump import _reached_by_impulses

    graph = model.derivation_graph
    for config in configurations(graph, limit=8):
        try:
            eq = graph.equations(config, open_ports=False)
        except HybridBondGraphError:
            continue
        kept = _reached_by_impulses(eq, graph)
        assert kept == _reached_by_impulses(eq) == _reached_by_impulses(eq, graph)
        assert kept == {x for x, rate in eq.implicit_rates.items()
                        if any(rate.has(eq.rate_symbols[d]) for d in eq.dependent)}


def test_a_merge_swapped_from_the_configuration_before_is_a_merge_from_scratch():
    """Issue 46: the next configuration's merge swaps the islands that changed into the previous merge's
    dictionaries; it must give the entries, in the order, that merging every island gives."""
    from bondgraph import island_merge

    graph = ball_chain.build(N=30, e=1.0).derivation_graph
    contacts = graph.controlled_junctions
    rng = random.Random(7)
    config = {c: False for c in contacts}
    previous = swapped = 0
    for _ in range(25):
        # (one to three contacts switched, far apart at times: a window holding islands of both)
        config = dict(config, **{rng.choice(contacts): rng.random() < 0.6 for _ in range(rng.randint(1, 3))})
        normal = graph.configuration(config)
        parts = graph.derived.islands(graph, normal, "closed")
        causality_parts = [graph.derived.island_causality(graph, island, "closed") for island in parts]
        equation_parts = [graph.derived.island_equations(graph, island, "closed") for island in parts]
        fresh_causality = island_merge.merge_causality(graph, normal, causality_parts)
        fresh = island_merge.merge_equations(graph, normal, fresh_causality, equation_parts)
        if previous:
            causality = island_merge.merge_causality(graph, normal, causality_parts, previous[0])
            merged = island_merge.merge_equations(graph, normal, causality, equation_parts, previous[1])
            swapped += island_merge._swap(previous[1], equation_parts) is not None
            assert (causality.independent, causality.dependent) == (fresh_causality.independent,
                                                                    fresh_causality.dependent)
            for table in ("constraints", "rates", "input_rates", "port_inputs", "port_outputs"):
                assert_same_expressions(getattr(merged, table), getattr(fresh, table), table)
            assert merged._dependent_rates == fresh._dependent_rates  # (a substitution: its order is not read)
        else:
            merged, causality = fresh, fresh_causality
        previous = (causality, merged)
    assert swapped == 24
