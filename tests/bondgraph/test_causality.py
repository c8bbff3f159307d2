"""Causality assignment: invariants on several graphs, dependent storage, conflicts."""

import itertools

import pytest

from bondgraph import (
    TF,
    BondGraph,
    C,
    CausalityConflictError,
    FloatingPartError,
    I,
    One,
    R,
    Se,
    Sf,
    Zero,
    causality_violations,
)
from bondgraph.floating import determination
from models.graphs import GRAPHS, msd_chain, parallel_capacitors, pivoting_rod, switched_rl


def all_configurations(graph):
    names = graph.controlled_junctions
    for values in itertools.product((True, False), repeat=len(names)):
        yield dict(zip(names, values))


@pytest.mark.parametrize("name", sorted(GRAPHS))
def test_invariants_hold_on_every_shipped_graph_and_configuration(name):
    graph = GRAPHS[name]()
    for config in all_configurations(graph):
        causality = graph.causality(config)
        assert causality_violations(graph, causality) == []
        # every active bond has exactly one stroke, at one of its ends
        for bond_name, bond in graph.bonds.items():
            if bond_name in causality.dead:
                continue
            stroke = causality.stroke_at(graph, bond_name)
            assert stroke in (bond.tail, bond.head)
            assert stroke != causality.effort_by[bond_name]
        # storage split: every storage state is either independent or dependent
        storage_states = {el.state for el in graph.storage}
        assert storage_states == (set(causality.independent) | set(causality.dependent)) - set(graph.displacements)
        assert not set(causality.independent) & set(causality.dependent)


def test_violations_are_detected_on_a_corrupted_assignment():
    """The invariant checker itself must fail on a wrong assignment."""
    graph = GRAPHS["series_rlc"]()
    causality = graph.causality()
    bad = dict(causality.effort_by)
    bad["V"] = "i"  # the junction imposing the source's effort
    corrupted = type(causality)(**{**causality.__dict__, "effort_by": bad})
    problems = causality_violations(graph, corrupted)
    assert any("Se 'V'" in p for p in problems) and any("1-junction 'i'" in p for p in problems)


def test_storage_in_integral_causality_when_possible():
    graph = msd_chain(10)
    causality = graph.causality()
    assert causality.dependent == () and len(causality.independent) == 20


def test_pivoting_rod_keeps_the_rotation_independent():
    causality = pivoting_rod().causality()
    names = {s.name for s in causality.dependent}
    assert names == {"rod/p_x", "rod/p_y"}


def test_closed_switch_makes_a_capacitor_dependent_open_does_not():
    graph = parallel_capacitors()
    assert [s.name for s in graph.causality({"switch": True}).dependent] == ["q_C2"]
    assert graph.causality({"switch": False}).dependent == ()


def test_off_junctions_impose_their_zero_on_every_bond():
    graph = switched_rl()
    causality = graph.causality({"switch": False})
    for bond in graph.bonds_of("switch"):
        # an off 1-junction imposes flow, so the effort comes from the other end
        assert causality.effort_by[bond.name] == bond.other("switch")


def test_bond_between_two_off_junctions_of_one_kind_is_dead():
    g = BondGraph("two_switches")
    a, b = g.add(One("a", controlled=True)), g.add(One("b", controlled=True))
    g.connect(Se("V", "V"), a)
    g.connect(a, b)
    g.connect(b, R("R", "R"))
    causality = g.causality({"a": False, "b": False})
    assert causality.dead == {"a__b"}
    eq = g.equations({"a": False, "b": False})
    assert eq.effort("a__b") == 0 and eq.flow("a__b") == 0
    assert g.causality({"a": True, "b": False}).dead == frozenset()


def test_tf_passes_and_gy_flips_causality():
    for two_port_kind in ("TF", "GY"):
        g = GRAPHS["dc_motor"]() if two_port_kind == "GY" else None
        if g is None:
            g = BondGraph("tf")
            a, b = g.add(One("a")), g.add(One("b"))
            g.connect(Se("F", "F"), a)
            g.connect(a, I("m1", "m1"))
            g.connect(a, TF("lever", "n"))
            g.connect("lever", b)
            g.connect(b, C("k", "k"))
        assert causality_violations(g, g.causality()) == []


def test_two_effort_sources_in_parallel_conflict_names_them():
    g = BondGraph("parallel_sources")
    n = g.add(Zero("n"))
    g.connect(Se("V1", "V1"), n)
    g.connect(Se("V2", "V2"), n)
    g.connect(n, R("R", "R"))
    with pytest.raises(CausalityConflictError) as info:
        g.causality()
    message = str(info.value)
    assert "'V1'" in message and "'V2'" in message and "'n'" in message
    assert {"V1", "V2", "n"} <= set(info.value.elements)


def test_two_flow_sources_in_series_conflict_names_them():
    g = BondGraph("series_sources")
    j = g.add(One("j"))
    g.connect(Sf("I1", "I1"), j)
    g.connect(Sf("I2", "I2"), j)
    g.connect(j, C("C", "C"))
    with pytest.raises(CausalityConflictError) as info:
        g.causality()
    assert "'I1'" in str(info.value) and "'I2'" in str(info.value) and "'j'" in str(info.value)


def test_flow_sources_alone_on_a_zero_junction_conflict():
    g = BondGraph("flows_only")
    n = g.add(Zero("n"))
    g.connect(Sf("I1", "I1"), n)
    g.connect(n, Sf("I2", "I2"))
    with pytest.raises(CausalityConflictError) as info:
        g.causality()
    assert "'n'" in str(info.value) and "'I1'" in str(info.value)


def test_effort_source_on_switched_off_zero_junction_conflicts_in_that_configuration_only():
    g = BondGraph("grounded_source")
    n = g.add(Zero("n", controlled=True))
    g.connect(Se("V", "V"), n)
    g.connect(n, R("R", "R"))
    assert causality_violations(g, g.causality({"n": True})) == []
    with pytest.raises(CausalityConflictError) as info:
        g.causality({"n": False})
    assert "'V'" in str(info.value) and "n: off" in str(info.value)


def floating_pair(switched_on=False):
    """Nodes p and n joined by a resistor, each tied to the driven node a only
    through a controlled 1-junction (an ideal diode): with both off, p and n float."""
    g = BondGraph("floating_pair")
    a, p, n = g.add(Zero("a")), g.add(Zero("p")), g.add(Zero("n"))
    g.connect(Se("V", "V"), a)
    g.connect(a, R("Rs", "Rs"))
    d1, d2 = g.add(One("D1", controlled=True)), g.add(One("D2", controlled=True))
    g.connect(a, d1)
    g.connect(d1, p)
    g.connect(n, d2)
    g.connect(d2, a)
    load = g.add(One("load"))
    g.connect(p, load)
    g.connect(load, n)
    g.connect(load, R("RL", "RL"))
    return g


def test_floating_junctions_are_called_under_determined_and_named():
    g = floating_pair()
    assert causality_violations(g, g.causality({"D1": True, "D2": True})) == []
    with pytest.raises(FloatingPartError) as info:
        g.causality({"D1": False, "D2": False})
    message = str(info.value)
    assert "under-determined, not over-determined" in message and "Sources (or switched-off" not in message
    assert set(info.value.elements) == {"p", "n"}
    assert set(info.value.cut) == {"D1", "D2"}
    assert "D1: off, D2: off" in message and "float" in message
    assert info.value.kind == "effort"
    assert isinstance(info.value, CausalityConflictError)  # code catching conflicts still catches it


def test_sources_that_meet_are_still_over_determined_not_floating():
    g = BondGraph("parallel_sources")
    n = g.add(Zero("n"))
    g.connect(Se("V1", "V1"), n)
    g.connect(Se("V2", "V2"), n)
    g.connect(n, R("R", "R"))
    with pytest.raises(CausalityConflictError) as info:
        g.causality()
    assert not isinstance(info.value, FloatingPartError)
    assert "over-determine" in str(info.value)


def test_determination_separates_the_two_failures():
    over, efforts, flows = determination(floating_pair(), {"D1": False, "D2": False})
    assert over == () and flows == ()
    assert {"D1__p", "p__load", "load__n", "n__D2"} <= set(efforts)
    g = BondGraph("series_sources")          # I1 and I2 in series: I1 = I2 is required, an over-determination
    j = g.add(One("j"))
    g.connect(Sf("I1", "I1"), j)
    g.connect(Sf("I2", "I2"), j)
    g.connect(j, C("C", "C"))
    over, efforts, flows = determination(g, {})
    assert set(over) == {"I1", "I2"}
