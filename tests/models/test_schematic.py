"""Circuits' schematics (models/schematic.py, models/schematic_layout.py): one symbol per component,
labelled; connectivity read off the drawing; switches drawn in a mode's states; SVG output; the CLI."""

import random
from xml.etree import ElementTree

import pytest
from drawing_checks import check_connectivity, check_no_overlap, svg_texts
from schemdraw import elements as elm

from models.circuits import PWM, Circuit
from models.cli import main
from models.netlists import bridges, ideal_buck, parallel_switches
from models.schematic import ClosedSwitch
from models.spice import read

FLYBACK_SPICE = """Flyback converter, coupled inductors
Vin in 0 DC 12
Lp in d 100u
Ls 0 s2 100u
K1 Lp Ls 1
Vg g 0 PULSE(0 10 0 10n 10n 7.99u 20u)
S1 d 0 g 0 swm
D1 s2 out dfly
Cout out 0 47u
Rload out 0 20
.model swm SW(VT=5 RON=10m ROFF=1e12)
.model dfly D(IS=1e-12 N=1)
.tran 10n 1m 0 100n uic
.end
"""


def boost():
    c = Circuit("boost")
    c.V("V1", "in", "0", 5.0)
    c.L("L1", "in", "sw", 100e-6)
    c.switch("S1", "sw", "0", PWM(1e-5, 0.5))
    c.diode("D1", "sw", "out")
    c.C("C1", "out", "0", 100e-6)
    c.R("R1", "out", "0", 10.0)
    return c


def bridge():
    c = Circuit("bridge")
    c.V("Vs", "s", "0", "325*sin(2*pi*50*t)")
    c.R("Rs", "s", "a", 1.0)
    for name, anode, cathode in (("D1", "a", "p"), ("D2", "0", "p"), ("D3", "n", "a"), ("D4", "n", "0")):
        c.diode(name, anode, cathode)
    c.C("C1", "p", "n", 1e-3)
    c.R("RL", "p", "n", 100.0)
    return c


def flyback():
    """A flyback with an ideal transformer and its magnetising inductance (tests/models/test_switch_devices.py)."""
    c = Circuit("flyback")
    c.V("Vin", "in", "0", 12.0)
    c.L("Lm", "in", "d", 100e-6, i0=1.0)
    c.transformer("T1", "in", "d", "0", "s", 2.0)
    c.switch("S1", "d", "0", PWM(1e-5, 0.4))
    c.diode("D1", "s", "out")
    c.C("C1", "out", "0", 100e-6, v0=4.0)
    c.R("RL", "out", "0", 10.0)
    return c


def half_bridge_buck():
    c = Circuit("leg")
    c.V("V1", "in", "0", 12.0)
    c.half_bridge("Q", "in", "0", "sw", 1e-5, 0.4, 1e-7, diode_v_f=0.7)
    c.L("L1", "sw", "out", 100e-6, i0=2.0)
    c.C("C1", "out", "0", 100e-6)
    c.R("R1", "out", "0", 2.4)
    return c


def closed_loop_buck():
    c = Circuit("closed_loop_buck")
    c.V("Vin", "in", 0, 24.0)
    c.switch("S", "in", "sw", PWM(1e-5, "PI1"), r_on=0.05)
    c.diode("D1", 0, "sw", v_f=0.4)
    c.L("L", "sw", "out", 100e-6)
    c.C("C", "out", 0, 100e-6, v0=12.0)
    c.R("R_1A", "out", 0, 12.0)
    c.switch("S_load", "out", "x", "t >= t_step")
    c.R("R_step", "x", 0, 6.0)
    c.pi("PI1", "v_out", 12.0, kp=0.003, ki=20.0, limits=(0.0, 0.95))
    return c


def dc_motor():
    """A DC machine (a gyrator) with its shaft's inertia, friction and a load torque (a current source)."""
    c = Circuit("motor")
    c.V("Va", "a", "0", 12.0)
    c.R("Ra", "a", "b", 2.0)
    c.dc_machine("M", "b", "0", "w", "0", 0.1)
    c.L("J", "w", "m", 1e-3)
    c.R("friction", "m", "0", 1e-3)
    c.I("load", "0", "w", 0.1)
    return c


CIRCUITS = {"buck": ideal_buck, "boost": boost, "bridge": bridge, "flyback": flyback, "half_bridge": half_bridge_buck,
            "closed_loop": closed_loop_buck, "dc_motor": dc_motor, "two_bridges": lambda: bridges(2),
            "parallel_switches": lambda: parallel_switches(3), "spice_flyback": lambda: read(FLYBACK_SPICE).circuit}


@pytest.mark.parametrize("name", CIRCUITS)
def test_each_component_is_drawn_once_labelled_with_its_name_and_the_wires_connect_the_netlists_nodes(name):
    circuit = CIRCUITS[name]()
    drawn = circuit.draw()
    parts = [p for p in circuit._parts.values() if p.kind != "PI"]
    assert sorted(drawn.elements) == sorted(p.name for p in parts)
    for part in parts:  # one symbol, a two-port's two windings (or its one box)
        assert len(drawn.elements[part.name]) == (1 if part.kind not in ("T", "K") else 2)
    texts = svg_texts(drawn.svg())
    for part in circuit._parts.values():
        assert part.name in texts
    check_connectivity(drawn, circuit)
    check_no_overlap(drawn)


def test_a_controller_is_listed_under_the_schematic():
    drawn = closed_loop_buck().draw()
    assert drawn.notes == ("PI1: controller of v_out → 12",)


def test_the_buck_converter_reads_as_drawn_in_textbooks():
    """The source's node and the switch and inductor in series on the top row, the diode, the capacitor and
    the load between it and the ground rail below."""
    drawn = ideal_buck().draw()
    layout = drawn.layout
    assert {layout.tracks[n] for n in ("in", "sw", "out")} == {0} and layout.tracks["0"] == 1
    assert sorted(layout.along) == ["L1", "S1"]
    assert [slot for slot in layout.slots] == [["V1"], ["S1"], ["D1"], ["L1"], ["C1"], ["R1"]]


def test_a_circuit_whose_series_parts_cannot_all_be_chained_still_draws_right():
    """A ring of resistors (a chain cannot close a loop) with a source across each node."""
    c = Circuit("ring")
    nodes = ["a", "b", "c", "d"]
    for k, n in enumerate(nodes):
        c.R(f"R{k}", n, nodes[(k + 1) % 4], 1.0)
        c.V(f"V{k}", n, "0", float(k + 1)) if k == 0 else c.R(f"G{k}", n, "0", 1.0)
    drawn = c.draw()
    check_connectivity(drawn, c)
    check_no_overlap(drawn)


@pytest.mark.parametrize("seed", range(12))
def test_random_netlists_draw_with_the_netlists_connectivity(seed):
    """Any netlist: a random connected graph of parts among up to seven nodes and ground."""
    rng = random.Random(seed)
    c = Circuit(f"random_{seed}")
    nodes = ["0"] + [f"n{k}" for k in range(rng.randint(2, 7))]
    kinds = ["R", "C", "L", "D", "S"]
    edges = [(nodes[k], rng.choice(nodes[:k])) for k in range(1, len(nodes))]  # a spanning tree
    edges += [tuple(rng.sample(nodes, 2)) for _ in range(rng.randint(1, 6))]
    for k, (a, b) in enumerate(edges):
        kind = rng.choice(kinds)
        if k == 0:
            c.V("V0", a, b, 1.0)
        elif kind == "D":
            c.diode(f"D{k}", a, b)
        elif kind == "S":
            c.switch(f"S{k}", a, b, "t < 1")
        else:
            getattr(c, kind)(f"{kind}{k}", a, b, 1.0)
    drawn = c.draw()
    check_connectivity(drawn, c)
    check_no_overlap(drawn)


def test_a_switch_is_drawn_closed_in_a_mode_where_it_is_closed_and_open_otherwise():
    model = ideal_buck().build()
    netlist = model.built_from.netlist
    closed = netlist.draw(model.mode("S1=closed, D1=blocking"))
    opened = netlist.draw(model.mode("S1=open, D1=conducting"))
    assert isinstance(closed.elements["S1"][0], ClosedSwitch)
    assert type(opened.elements["S1"][0]) is elm.Switch
    assert closed.states == {"S1": "closed", "D1": "blocking"}
    assert opened.states == {"S1": "open", "D1": "conducting"}
    assert "S1 open" in svg_texts(opened.svg()) and "D1 conducting" in svg_texts(opened.svg())
    assert closed.elements["D1"][0].params.get("color") != opened.elements["D1"][0].params.get("color")


def test_by_default_each_switch_is_drawn_in_its_state_at_t_0():
    c = Circuit("delayed")
    c.V("V1", "in", "0", 1.0)
    c.switch("S1", "in", "a", PWM(1e-3, 0.5, delay=2e-4))  # open until its delay
    c.switch("S2", "a", "b", "t < 1e-3")  # closed at t = 0
    c.diode("D1", "b", "0", on=True)
    assert c.draw().states == {"S1": "open", "S2": "closed", "D1": "conducting"}
    assert c.draw("S1=closed, D1=off").states == {"S1": "closed", "S2": "closed", "D1": "blocking"}


def test_a_state_a_switch_has_not_or_a_component_without_states_is_refused_by_name():
    with pytest.raises(KeyError, match="'R1'"):
        ideal_buck().draw({"R1": "closed"})
    with pytest.raises(KeyError, match="'on'.*open, closed"):
        ideal_buck().draw("S1=on")


def test_a_circuit_and_its_model_show_as_svg_in_notebooks_the_model_as_its_bond_graph():
    circuit = ideal_buck()
    svg = circuit._repr_svg_()
    root = ElementTree.fromstring(svg)
    assert root.tag.endswith("svg")
    assert all(name in svg_texts(svg) for name in circuit.components)
    graph_svg = circuit.build()._repr_svg_()
    texts = svg_texts(graph_svg)
    assert ElementTree.fromstring(graph_svg).tag.endswith("svg")
    assert "L1" in texts and "S1" in texts and "closed" in texts  # the switch's junction, as its mode says


def test_hbg_draw_writes_a_circuits_schematic_beside_the_bond_graph(tmp_path, capsys):
    netlist = tmp_path / "buck.cir"
    netlist.write_text(ideal_buck().to_spice({"t_end": 1e-4, "max_step": 1e-6}))
    out = tmp_path / "buck.svg"
    assert main(["draw", str(netlist), "--mode", "S1=open, D1=conducting", "-o", str(out)]) == 0
    schematic = tmp_path / "buck-schematic.svg"
    assert out.exists() and schematic.exists()
    texts = svg_texts(schematic.read_text())
    assert "S1 open" in texts and "D1 conducting" in texts and "L1" in texts
    assert f"wrote {schematic}" in capsys.readouterr().out
    assert main(["draw", str(netlist), "-o", str(tmp_path / "b.png")]) == 0
    assert (tmp_path / "b-schematic.png").read_bytes().startswith(b"\x89PNG")  # the picture's format
    chosen = tmp_path / "elsewhere.svg"
    assert main(["draw", str(netlist), "-o", str(tmp_path / "c.svg"), "--schematic", str(chosen)]) == 0
    assert chosen.exists() and not (tmp_path / "c-schematic.svg").exists()
    assert main(["draw", str(netlist), "-o", str(tmp_path / "d.svg"), "--no-schematic"]) == 0
    assert not (tmp_path / "d-schematic.svg").exists()


def test_hbg_draw_of_a_bond_graph_model_draws_no_schematic_and_refuses_one(tmp_path, capsys):
    assert main(["draw", "diode-circuit", "-o", str(tmp_path / "d.svg")]) == 0
    assert [p.name for p in tmp_path.iterdir()] == ["d.svg"]
    assert main(["draw", "diode-circuit", "-o", str(tmp_path / "e.svg"), "--schematic", str(tmp_path / "s.svg")]) == 2
    assert "was not built from a circuit or a mechanism" in capsys.readouterr().err
