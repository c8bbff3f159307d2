"""Open ports: a graph with declared ports, derived on its own, leaves each
port's effort or flow free (an input) and gives the other as an output
(BondGraphTools-style cases, against hand-derived equations)."""

import math

import pytest
import sympy as sp

from bondgraph import (
    C,
    I,
    BondGraph,
    DuplicateNameError,
    InvalidGraphError,
    One,
    R,
    Se,
    Sf,
    UnknownNameError,
    Zero,
)
from models.components import rlc_cell

q, Rs, Cs = sp.symbols("q_C R C")
e_A, f_A = sp.symbols("e_A f_A")


def same(a, b) -> bool:
    return sp.simplify(sp.sympify(a) - sp.sympify(b)) == 0


def parallel_rc() -> BondGraph:
    """R‖C: a 0-junction with R and C, port A on the junction."""
    g = BondGraph("rc_parallel")
    j = g.add(Zero("j"))
    g.connect(j, R("R", "R"))
    g.connect(j, C("C", "C"))
    g.port("A", j)
    return g


def series_rc() -> BondGraph:
    """A series resistor: a 1-junction with R and C, port A on the junction."""
    g = BondGraph("rc_series")
    j = g.add(One("j"))
    g.connect(j, R("R", "R"))
    g.connect(j, C("C", "C"))
    g.port("A", j)
    return g


def test_parallel_rc_port_flow_is_input():
    g = parallel_rc()
    eq = g.equations()
    assert eq.port_inputs == {"A": f_A}
    assert same(eq.rate(q), -q / (Rs * Cs) + f_A)
    symbol, output = eq.port_outputs["A"]
    assert symbol == e_A and same(output, q / Cs)
    assert same(eq.effort("A"), q / Cs) and eq.flow("A") == f_A


def test_parallel_rc_flow_fixed_by_user_gives_the_same():
    eq = parallel_rc().equations(port_causality={"A": "flow"})
    assert eq.port_inputs == {"A": f_A}
    assert same(eq.rate(q), -q / (Rs * Cs) + f_A)


def test_parallel_rc_effort_imposed_fixes_the_capacitor():
    # e_A imposed on a C in parallel fixes its charge: q = C e_A (derivative causality), and the
    # port's flow takes the input's derivative: f_A = e_A/R + C de_A/dt (issue 19, item 2)
    g = parallel_rc()
    assert g.causality(port_causality={"A": "effort"}).dependent == (q,)
    eq = g.equations(port_causality={"A": "effort"})
    de_A = eq.input_rates[e_A]
    assert de_A == sp.Symbol("de_A/dt")
    assert same(eq.constraints[q], Cs * e_A) and same(eq.rate(q), Cs * de_A)
    symbol, output = eq.port_outputs["A"]
    assert symbol == f_A and same(eq.resolve(output), e_A / Rs + Cs * de_A)


def test_series_resistor_port_effort_imposed():
    eq = series_rc().equations(port_causality={"A": "effort"})
    assert eq.port_inputs == {"A": e_A}
    assert same(eq.rate(q), (e_A - q / Cs) / Rs)
    symbol, output = eq.port_outputs["A"]
    assert symbol == f_A and same(output, (e_A - q / Cs) / Rs)


def test_series_resistor_default_follows_the_rest():
    # R keeps resistance causality, C integral: the junction's flow comes in at the port
    eq = series_rc().equations()
    assert eq.port_inputs == {"A": f_A}
    assert same(eq.rate(q), f_A)
    assert same(eq.port_outputs["A"][1], Rs * f_A + q / Cs)


def test_user_graph_is_not_changed_and_ports_can_be_closed():
    g = parallel_rc()
    before = (dict(g.elements), dict(g.bonds), dict(g.inputs), g.version)
    g.equations()
    g.equations(port_causality={"A": "flow"})
    assert (dict(g.elements), dict(g.bonds), dict(g.inputs), g.version) == before
    closed = g.equations(open_ports=False)
    assert same(closed.rate(q), -q / (Rs * Cs)) and closed.port_inputs == {}
    g.validate()


def test_bad_port_causality():
    g = parallel_rc()
    with pytest.raises(UnknownNameError):
        g.equations(port_causality={"B": "effort"})
    with pytest.raises(InvalidGraphError):
        g.equations(port_causality={"A": "voltage"})


def test_port_name_clashing_with_a_bond_is_reported():
    g = BondGraph("clash")
    j = g.add(Zero("j"))
    g.connect(j, C("A", "C"))
    g.port("A", j)
    with pytest.raises(DuplicateNameError, match="open_ports=False"):
        g.equations()
    assert g.equations(open_ports=False).rates


def test_port_inputs_enter_the_state_space_matrices():
    A, B, Cm, D = parallel_rc().equations().state_space(outputs=["e_A"])
    assert same(A[0, 0], -1 / (Rs * Cs))
    assert B.shape == (1, 1) and same(B[0, 0], 1)
    assert same(Cm[0, 0], 1 / Cs) and D[0, 0] == 0


def test_composition_through_ports_is_unchanged():
    # the R‖C placed as a sub-model and driven through its port by a flow source
    parent = BondGraph("driven")
    inst = parent.add_submodel(parallel_rc(), "rc")
    parent.connect(Sf("I", "I0"), inst.port("A"))
    assert parent.ports == {}
    eq = parent.equations()
    qi, Ri, Ci, I0 = sp.symbols("q_rc/C rc/R rc/C I0")
    assert same(eq.rate(qi), -qi / (Ri * Ci) + I0)
    assert eq.port_inputs == {} and eq.port_outputs == {}
    # the same as the open sub-model with its port input replaced by the source
    open_rate = parallel_rc().equations().rate(q).xreplace({f_A: I0, q: qi, Rs: Ri, Cs: Ci})
    assert same(eq.rate(qi), open_rate)


def test_rlc_ladder_composition_matches_the_flat_circuit():
    # reference: test_graph.test_submodel_instances_get_hierarchical_names (one cell)
    g = BondGraph("ladder")
    inst = g.add_submodel(rlc_cell(), "cell")
    g.connect(Se("V", "V0"), inst.port("in"))
    eq = g.equations()
    flat = BondGraph("flat")
    series, node = flat.add(One("series")), flat.add(Zero("node"))
    flat.connect(Se("V", "V0"), series)
    flat.connect(series, R("R", "cell/R"))
    flat.connect(series, I("L", "cell/L", state="p_cell/L"))
    flat.connect(series, node)
    flat.connect(node, C("C", "cell/C", state="q_cell/C"))
    ref = flat.equations()
    for x in ref.states:
        assert same(eq.rate(x), ref.rate(x))
    # the open cell on its own: the series current's effort comes in through port "in",
    # port "out" (the node) is open as well
    cell = rlc_cell().equations(port_causality={"in": "effort"})
    assert cell.port_inputs == {"in": sp.Symbol("e_in"), "out": sp.Symbol("f_out")}
    p, L, Cc, Rr = sp.symbols("p_L L C R")
    qc = sp.Symbol("q_C")
    assert same(cell.rate(p), sp.Symbol("e_in") - Rr * p / L - qc / Cc)
    assert same(cell.rate(qc), p / L + sp.Symbol("f_out"))


def test_a_hybrid_model_keeps_its_declared_ports_closed():
    """A hybrid model simulates its graph as a whole: a declared port (for
    composing the graph elsewhere) is not an input of its modes."""
    from switching import Automaton, HybridModel

    g = BondGraph("rc_with_port")
    n = g.add(Zero("n"))
    sw = g.add(One("sw", controlled=True))
    g.connect(Se("V", "V"), sw)
    g.connect(sw, R("R", "R"))
    g.connect(sw, n)
    g.connect(n, C("C", "C"))
    g.port("A", n)
    switch = Automaton("switch", {"open": {"sw": False}, "closed": {"sw": True}}, "closed")
    model = HybridModel(g, [switch], {"V": 1.0, "R": 1.0, "C": 1.0})
    rates = model.mode_equations(model.initial_mode).f
    q = g.state("q_C")
    assert sp.simplify(rates[q] - (sp.Symbol("V") - q / sp.Symbol("C")) / sp.Symbol("R")) == 0
    trajectory = model.simulate(1.0, "RK45", rtol=1e-10, atol=1e-12)
    assert trajectory.x[-1][0] == pytest.approx(1.0 - math.exp(-1.0), rel=1e-8)
