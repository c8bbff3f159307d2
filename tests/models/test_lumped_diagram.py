"""Mechanisms' lumped diagrams (models/lumped_diagram.py): one symbol (or block) per component, labelled;
connectivity read off the drawing; clutches and stops drawn in a mode's states; SVG output; the CLI."""

import random
from xml.etree import ElementTree

import pytest
from drawing_checks import check_connectivity, check_no_overlap, svg_texts
from schemdraw import elements as elm

from models.cli import main
from models.lumped_diagram import Clutch, Stop
from models.mechanics import Mechanism


def two_masses():
    m = Mechanism("two_masses")
    m.mass("m1", "a", 1.0)
    m.spring("k1", "0", "a", 100.0)
    m.damper("b1", "0", "a", 0.5)
    m.spring("k2", "a", "b", 50.0)
    m.mass("m2", "b", 2.0)
    m.force("F", "b", "sin(t)")
    m.stop("wall", "b", upper=0.1, e=0.5)
    return m


def drivetrain():
    """The notebook's drivetrain: a motor, a clutch, a backlash, three inertias and a drag to the frame."""
    drive = Mechanism("drivetrain", "rotational")
    drive.motor("M", "m", 0.1, V=12.0, R=2.0)
    drive.inertia("J1", "m", 1e-3)
    drive.clutch("K", "m", "s", engaged_when="t >= 0.1")
    drive.inertia("J2", "s", 4e-3)
    drive.backlash("B", "s", "l", 0.05, e=0.5)
    drive.inertia("J3", "l", 5e-3)
    drive.damper("drag", "l", "0", 2e-4)
    return drive


def gearbox():
    box = Mechanism("gearbox", "rotational")
    box.inertia("J_m", "m", 2.0, omega0=8.0)
    box.gear("G", "m", "out", 4.0)
    box.stop("end", "out", upper=1.0, e=0.5)
    return box


def shaker():
    """Masses in a chain between the frame at both ends, a prescribed motion, a brake and a speed loop."""
    m = Mechanism("shaker")
    for k in range(4):
        m.mass(f"m{k}", f"n{k}", 1.0)
        m.spring(f"k{k}", "0" if k == 0 else f"n{k - 1}", f"n{k}", 10.0)
    m.spring("k_end", "n3", "0", 5.0)
    m.velocity("drive", "n0", "0.1*sin(t)")
    m.clutch("brake", "n2", "0", "t >= 1", T_max=2.0)
    m.pi("PI1", "v_n3", 0.0, kp=1.0, ki=1.0)
    m.force("push", "n3", "PI1")
    return m


MECHANISMS = {"two_masses": two_masses, "drivetrain": drivetrain, "gearbox": gearbox, "shaker": shaker}


def blocks(drawn, mechanism):
    return [drawn.elements[p.name][0] for p in mechanism._parts.values() if p.kind == "M"]


@pytest.mark.parametrize("name", MECHANISMS)
def test_each_component_is_drawn_once_labelled_with_its_name_and_the_parts_join_the_nodes_they_join(name):
    mechanism = MECHANISMS[name]()
    drawn = mechanism.draw()
    parts = [p for p in mechanism._parts.values() if p.kind != "PI"]
    assert sorted(drawn.elements) == sorted(p.name for p in parts)
    assert all(len(drawn.elements[p.name]) == 1 for p in parts)
    assert all(type(drawn.elements[p.name][0]) is elm.Rect for p in parts if p.kind == "M")  # a mass: its block
    texts = svg_texts(drawn.svg())
    assert all(part.name in texts for part in mechanism._parts.values())
    check_connectivity(drawn, mechanism, blocks(drawn, mechanism))
    check_no_overlap(drawn)


def test_a_drivetrain_is_drawn_on_one_line_from_the_wall():
    drawn = drivetrain().draw()
    assert drawn.layout.tracks == {"0": 0, "l": 1, "s": 2, "m": 3}
    assert len(drawn.layout.slots) == 1


@pytest.mark.parametrize("seed", range(8))
def test_random_mechanisms_draw_with_their_connectivity(seed):
    rng = random.Random(seed)
    m = Mechanism(f"random_{seed}")
    nodes = ["0"] + [f"n{k}" for k in range(rng.randint(2, 6))]
    for k, n in enumerate(nodes[1:], 1):
        m.mass(f"m{k}", n, 1.0)
        m.spring(f"k{k}", rng.choice(nodes[:k]), n, 1.0)
    for k in range(rng.randint(1, 5)):
        a, b = rng.sample(nodes, 2)
        rng.choice([lambda: m.damper(f"b{k}", a, b, 1.0), lambda: m.clutch(f"c{k}", a, b, "t > 1")])()
    m.force("F", nodes[-1], 1.0)
    drawn = m.draw()
    check_connectivity(drawn, m, blocks(drawn, m))
    check_no_overlap(drawn)


def test_a_clutch_and_a_backlash_are_drawn_in_the_modes_states():
    model = drivetrain().build()
    netlist = model.built_from.netlist
    apart = netlist.draw()
    together = netlist.draw(model.mode("K=engaged, B=upper"))
    assert apart.states == {"K": "disengaged", "B": "free"}
    assert together.states == {"K": "engaged", "B": "upper"}
    assert isinstance(apart.elements["K"][0], Clutch) and not apart.elements["K"][0].engaged
    assert together.elements["K"][0].engaged and together.elements["B"][0].in_contact
    assert not apart.elements["B"][0].in_contact
    assert "K engaged" in svg_texts(together.svg())


def test_a_stop_in_contact_is_drawn_touching():
    drop = Mechanism("drop")
    drop.mass("m1", "a", 2.0, x0=1.0)
    drop.force("gravity", "a", -2.0 * 9.81)
    drop.stop("floor", "a", lower=0.0, e=0.5)
    assert not drop.draw().elements["floor"][0].in_contact
    stop = drop.draw("floor=lower").elements["floor"][0]
    assert isinstance(stop, Stop) and stop.in_contact
    with pytest.raises(KeyError, match="'upper'.*free, lower_impact, lower"):
        drop.draw("floor=upper")


def test_a_mechanism_shows_as_svg_in_notebooks_and_hbg_draw_writes_its_diagram(tmp_path, capsys, monkeypatch):
    mechanism = two_masses()
    svg = mechanism._repr_svg_()
    assert ElementTree.fromstring(svg).tag.endswith("svg")
    assert all(name in svg_texts(svg) for name in mechanism.components)
    model = drivetrain().build()  # as a model file of the mechanism would give it
    monkeypatch.setattr("models.cli.draw.build_model", lambda args: (None, model))
    assert main(["draw", "drivetrain", "--mode", "K=engaged, B=free", "-o", str(tmp_path / "drive.svg")]) == 0
    diagram = tmp_path / "drive-schematic.svg"
    assert "K engaged" in svg_texts(diagram.read_text())
    assert "lumped diagram of mechanism 'drivetrain'" in capsys.readouterr().out
