"""Building graphs: validation errors, names, parameters, composition."""

import pytest
import sympy as sp

from bondgraph import (
    GY,
    TF,
    BondGraph,
    C,
    DuplicateNameError,
    NameCollisionError,
    HybridBondGraphError,
    I,
    InvalidGraphError,
    MissingParameterError,
    One,
    R,
    Se,
    Sf,
    UnknownNameError,
    UnknownParameterError,
    Zero,
)
from models.components import msd_cell, rigid_planar_body, rlc_cell
from models.graphs import series_rlc


def test_every_error_derives_from_the_one_base():
    for cls in (InvalidGraphError, DuplicateNameError, UnknownNameError, MissingParameterError, UnknownParameterError):
        assert issubclass(cls, HybridBondGraphError)


def test_dangling_element_is_named():
    g = series_rlc()
    g.add(C("C_loose", "C2"))
    with pytest.raises(InvalidGraphError) as info:
        g.equations()
    assert "'C_loose'" in str(info.value) and "dangling" in str(info.value)
    assert info.value.elements == ("C_loose",)


def test_junction_with_no_bonds_is_named():
    g = series_rlc()
    g.add(Zero("lonely"))
    with pytest.raises(InvalidGraphError) as info:
        g.validate()
    assert "junction" in str(info.value) and "'lonely'" in str(info.value)


def test_over_connected_one_port_is_named():
    g = BondGraph("over")
    a, b = g.add(One("a")), g.add(One("b"))
    cap = g.add(C("C", "C"))
    g.connect(a, cap)
    g.connect(b, cap)
    with pytest.raises(InvalidGraphError) as info:
        g.validate()
    assert "'C'" in str(info.value) and "2 bonds" in str(info.value)


@pytest.mark.parametrize("kind", [TF, GY])
def test_two_port_needs_exactly_two_bonds(kind):
    g = BondGraph("tp")
    a = g.add(One("a"))
    tp = g.add(kind("X", "n"))
    g.connect(a, tp)
    with pytest.raises(InvalidGraphError) as info:
        g.validate()
    assert "'X'" in str(info.value) and "exactly 2 bonds" in str(info.value)
    g.connect(tp, One("b"))
    g.connect(tp, One("c"))
    with pytest.raises(InvalidGraphError) as info:
        g.validate()
    assert "has 3" in str(info.value)


def test_two_port_bonds_must_pass_power_through():
    g = BondGraph("tp")
    a, b = g.add(One("a")), g.add(One("b"))
    g.connect(a, TF("X", "n"))
    g.connect(b, "X")
    with pytest.raises(InvalidGraphError) as info:
        g.validate()
    assert "'X'" in str(info.value) and "both in" in str(info.value)


def test_unknown_names_are_reported_with_suggestions():
    g = series_rlc()
    with pytest.raises(UnknownNameError) as info:
        g.connect("i", "Cx")
    assert "'Cx'" in str(info.value) and "did you mean" in str(info.value)
    with pytest.raises(UnknownNameError):
        g.element("nope")
    with pytest.raises(UnknownNameError) as info:
        g.state("q_X")
    assert "q_C" in str(info.value)  # lists the real states


def test_duplicate_element_names_are_rejected():
    g = series_rlc()
    with pytest.raises(DuplicateNameError) as info:
        g.add(R("R", "R9"))
    assert "'R'" in str(info.value)


def test_symbol_name_clash_between_state_and_bond_variable():
    g = BondGraph("clash")
    j = g.add(One("j"))
    g.connect(Se("V", "V"), j)
    g.connect(j, R("R", "R"))
    g.connect(j, C("C", "C", state="e_R"))  # a state named like the resistor's effort
    with pytest.raises(NameCollisionError) as info:
        g.validate()
    message = str(info.value)
    assert info.value.name == "e_R" and "the state of C 'C'" in message and "the effort of bond 'R'" in message
    assert "rename" in message  # it says how to fix it


def test_a_source_may_be_modulated_by_a_state():
    g = BondGraph("feedback")
    j = g.add(One("j"))
    g.connect(j, C("C", "C"))
    g.connect(j, R("R", "R"))
    g.connect(Se("V", -2 * sp.Symbol("q_C")), j)  # the state symbol itself: a controlled source
    eq = g.equations()
    q, C_, R_ = sp.symbols("q_C C R")
    assert sp.simplify(eq.rate(q) - (-2 * q - q / C_) / R_) == 0


def test_text_formulas_are_never_parsed():
    with pytest.raises(InvalidGraphError) as info:
        R("R", "R0*__import__('os')")
    assert "not parsed" in str(info.value)
    with pytest.raises(InvalidGraphError):
        Se("V", sp.Symbol("a") > 1)
    with pytest.raises(InvalidGraphError):
        C("bad name!", "C")


def test_missing_parameters_are_listed_all_at_once():
    g = series_rlc()
    assert {s.name for s in g.parameters} == {"V0", "R", "L", "C"}
    with pytest.raises(MissingParameterError) as info:
        g.check_parameters({"R": 1.0})
    assert info.value.missing == ("C", "L", "V0")
    assert all(name in str(info.value) for name in ("C", "L", "V0"))
    with pytest.raises(UnknownParameterError) as info:
        g.check_parameters({"R": 1, "L": 1, "C": 1, "V0": 1, "Rx": 2})
    assert "Rx" in str(info.value)
    values = g.check_parameters({"R": 1, "L": 2, "C": 3, sp.Symbol("V0"): 4})
    assert values[sp.Symbol("L")] == 2.0


def test_bad_configuration_names():
    g = series_rlc()
    with pytest.raises(UnknownNameError):
        g.equations({"switch": False})
    with pytest.raises(InvalidGraphError) as info:
        g.equations({"i": False})
    assert "not a controlled junction" in str(info.value)


def test_bond_direction_and_names():
    g = series_rlc()
    bond = g.bond("R")
    assert (bond.tail, bond.head) == ("i", "R")
    assert bond.sign_at("R") == 1 and bond.sign_at("i") == -1
    assert g.effort("R") == sp.Symbol("e_R") and g.flow(g.element("L")) == sp.Symbol("f_L")


def test_element_orientation_only_flips_the_state_sign():
    """A capacitor drawn with its bond pointing out of it is the same circuit
    with the charge measured the other way round: q → −q."""

    def build(reverse):
        g = BondGraph("rc")
        j = g.add(One("j"))
        g.connect(Se("V", "V"), j)
        g.connect(j, R("R", "R"))
        if reverse:
            g.connect(C("C", "C"), j)
        else:
            g.connect(j, C("C", "C"))
        return g.equations()

    forward, backward = build(False), build(True)
    q = sp.Symbol("q_C")
    assert sp.simplify(forward.rate(q) + backward.rate(q).xreplace({q: -q})) == 0


def test_flow_source_pushes_its_value_out_whatever_the_bond_direction():
    for reverse in (False, True):
        g = BondGraph("charging")
        n = g.add(Zero("n"))
        if reverse:
            g.connect(n, Sf("I", "I0"))
        else:
            g.connect(Sf("I", "I0"), n)
        g.connect(n, C("C", "C"))
        assert g.equations().rate("q_C") == sp.Symbol("I0")


def test_displacement_integrates_a_bond_flow():
    g = BondGraph("mass")
    v = g.add(One("v"))
    g.connect(Se("F", "F"), v)
    g.connect(v, I("m", "m"))
    x = g.displacement("x", of=v)
    y = g.displacement("y", of="m")  # of a one-port: the flow into it
    eq = g.equations()
    p, m = sp.symbols("p_m m")
    assert eq.states == (p, x, y)
    assert eq.rate(x) == p / m and eq.rate(y) == p / m
    with pytest.raises(DuplicateNameError):
        g.displacement("x", of=v)


def _mass_graph(mass_bond_into_mass: bool, mass_bond_name=None):
    """A force on a mass through a 1-junction ``v``; the mass's bond is drawn
    ``v → m`` or ``m → v`` (named after the mass by default, like connect())."""
    g = BondGraph("mass")
    v = g.add(One("v"))
    g.connect(Se("F", "F"), v)
    mass = I("m", "m")
    bond = g.connect(v, mass, name=mass_bond_name) if mass_bond_into_mass else g.connect(mass, v, name=mass_bond_name)
    return g, v, mass, bond


def _rate(g, state):
    return g.equations().rate(state)


@pytest.mark.parametrize("into_mass", [True, False], ids=["v->m", "m->v"])
def test_displacement_of_an_element_is_the_flow_into_it_whichever_way_its_bond_is_drawn(into_mass):
    """Issue 12 item 6: ``of="m"`` names both the mass and (by connect()'s
    default naming) its bond; the element wins, so the rate is +p/m both ways."""
    p, m = sp.symbols("p_m m")
    g, v, mass, bond = _mass_graph(into_mass)
    assert bond.name == "m" and "m" in g.elements
    x = g.displacement("x", of="m")
    y = g.displacement("y", of=mass)  # the element object: the same
    z = g.displacement("z", of="m", sign=-1)
    assert sp.simplify(_rate(g, x) - p / m) == 0
    assert sp.simplify(_rate(g, y) - p / m) == 0
    assert sp.simplify(_rate(g, z) + p / m) == 0


@pytest.mark.parametrize("into_mass", [True, False], ids=["v->m", "m->v"])
def test_displacement_of_a_bond_is_its_flow_in_the_drawn_direction(into_mass):
    p, m = sp.symbols("p_m m")
    expected = p / m if into_mass else -p / m
    # a bond object, whose name is also the element's: the bond's direction counts
    g, _, _, bond = _mass_graph(into_mass)
    x = g.displacement("x", of=bond)
    assert sp.simplify(_rate(g, x) - expected) == 0
    # a bond named apart from every element: by object and by name alike
    g, _, _, bond = _mass_graph(into_mass, mass_bond_name="link")
    x = g.displacement("x", of=bond)
    y = g.displacement("y", of="link")
    z = g.displacement("z", of="m")  # the element: still the flow into it
    assert sp.simplify(_rate(g, x) - expected) == 0
    assert sp.simplify(_rate(g, y) - expected) == 0
    assert sp.simplify(_rate(g, z) - p / m) == 0


@pytest.mark.parametrize("into_mass", [True, False], ids=["v->m", "m->v"])
def test_displacement_of_a_one_junction_is_its_common_flow_as_drawn(into_mass):
    """The docstring's rule: the flow variable all the junction's bonds share,
    into the elements its bonds point to (so −p/m when the mass's bond is
    drawn into the junction)."""
    p, m = sp.symbols("p_m m")
    g, v, _, _ = _mass_graph(into_mass)
    x = g.displacement("x", of=v)
    y = g.displacement("y", of="v")
    expected = p / m if into_mass else -p / m
    assert sp.simplify(_rate(g, x) - expected) == 0
    assert sp.simplify(_rate(g, y) - expected) == 0


def test_displacement_of_a_capacitor_is_the_flow_into_it_and_bad_references_are_named():
    g = BondGraph("charging")
    n = g.add(Zero("n"))
    g.connect(Sf("I", "I0"), n)
    g.connect(C("C", "C"), n)  # drawn out of the capacitor
    q = g.displacement("Q", of="C")
    eq = g.equations()
    assert sp.simplify(eq.rate(q) - eq.rate(g.state("q_C"))) == 0
    assert sp.simplify(eq.rate(q) - sp.Symbol("I0")) == 0
    with pytest.raises(InvalidGraphError) as info:
        g.displacement("bad", of=n)  # a 0-junction has no single flow
    assert "'n'" in str(info.value)
    with pytest.raises(UnknownNameError):
        g.displacement("bad", of="nowhere")
    with pytest.raises(UnknownNameError):
        g.displacement("bad", of=I("stranger", "m"))
    assert "stranger" not in g.elements


def test_submodel_instances_get_hierarchical_names():
    g = BondGraph("ladder")
    cell = rlc_cell()
    previous = g.add(Se("V", "V0"))
    instances = []
    for i in range(3):
        inst = g.add_submodel(cell, f"cell{i}")
        g.connect(previous, inst.port("in"))
        previous = inst.port("out")
        instances.append(inst)
    assert "cell2/C" in g.elements and inst["C"] == "cell2/C"
    assert inst.state("p_L") == sp.Symbol("p_cell2/L")
    assert inst.parameter("R") == sp.Symbol("cell2/R")
    assert {s.name for s in g.parameters} == {"V0"} | {f"cell{i}/{p}" for i in range(3) for p in "RLC"}
    with pytest.raises(UnknownNameError):
        inst.port("nope")


def test_submodel_share_and_bind():
    g = BondGraph("two_cells")
    first = g.add_submodel(msd_cell(), "a", share=["m"], bind={"k": 100.0, "c": "c_common"})
    second = g.add_submodel(msd_cell(), "b", share=["m"], bind={"c": "c_common"})
    g.connect(Sf("wall", 0), first.port("in"))
    g.connect(first.port("mass"), second.port("in"))
    names = {s.name for s in g.parameters}
    assert names == {"m", "c_common", "b/k"}
    eq = g.equations()
    q_a = sp.Symbol("q_a/k")
    assert 100.0 * q_a in sp.Add.make_args(sp.expand(eq.rate("p_a/m")))
    with pytest.raises(UnknownParameterError):
        g.add_submodel(msd_cell(), "c", share=["mass"])
    with pytest.raises(DuplicateNameError):
        g.add_submodel(msd_cell(), "a")


def test_submodels_nest():
    inner = rigid_planar_body()
    middle = BondGraph("pinned")
    rod = middle.add_submodel(inner, "body", share=["g"])
    middle.connect(rod.port("tip_x"), Sf("pin_x", 0))
    middle.connect(rod.port("tip_y"), Sf("pin_y", 0))
    outer = BondGraph("scene")
    outer.add_submodel(middle, "left", share=["g"])
    outer.add_submodel(middle, "right", share=["g"])
    assert "right/body/I_J" in outer.elements
    assert sp.Symbol("left/body/theta") in outer.states
    assert {s.name for s in outer.parameters} == {"g"} | {f"{side}/body/{p}" for side in ("left", "right") for p in "mJl"}
    eq = outer.equations()
    assert {s.name for s in eq.dependent} == {f"{side}/body/p_{c}" for side in ("left", "right") for c in "xy"}


def test_modulated_source_can_use_another_bonds_variable():
    """A friction-like force proportional to a normal force elsewhere in the graph."""
    g = BondGraph("modulated")
    vx, vy = g.add(One("vx")), g.add(One("vy"))
    g.connect(vx, I("mx", "m"))
    g.connect(vy, I("my", "m"))
    g.connect(Se("push", "N"), vy)
    mu = sp.Symbol("mu")
    g.connect(Se("friction", -mu * g.effort("push")), vx)
    eq = g.equations()
    assert eq.rate("p_mx") == -mu * sp.Symbol("N")
