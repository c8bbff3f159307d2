"""Bond graph drawings as textbooks draw them (bondgraph.drawing): the
geometry of every mark is checked against the graph and its causality."""

import matplotlib

matplotlib.use("Agg")

import itertools  # noqa: E402

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import models  # noqa: E402
from bondgraph import C, BondGraph, I, One, R, Se, Zero  # noqa: E402
from models import cli  # noqa: E402
from bondgraph.drawing import _segment_meets_box, draw_bond_graph, element_label, layout_bond_graph  # noqa: E402
from switching.simulate.plotting import draw_bond_graph as draw_from_plotting  # noqa: E402
from checkout import ROOT

#: every shipped model, and the large variants
CASES = [(name, {}) for name in models.MODELS] + [
    ("ball_chain", {"N": 50}),
    ("ball_chain", {"N": 4, "compliant": True, "b": 1.0}),
]
IDS = [name + "".join(f"-{k}{v}" for k, v in params.items()) for name, params in CASES]


def bridge():
    """A junction structure with a loop (a Wheatstone bridge): one bond cannot follow the tree."""
    g = BondGraph("bridge")
    top, left, right, bottom = (g.add(Zero(n)) for n in ("top", "left", "right", "bottom"))
    g.connect(g.add(Se("V", 1.0)), g.add(One("src")))
    g.connect("src", top)
    g.connect(bottom, "src")
    arms = ((top, left, "R1"), (top, right, "R2"), (left, bottom, "R3"), (right, bottom, "R4"), (left, right, "R5"))
    for a, b, r in arms:
        j = g.add(One(f"j_{r}"))
        g.connect(a, j)
        g.connect(j, b)
        g.connect(j, g.add(R(r, 1.0)))
    g.connect(left, g.add(C("Cl", 1.0)))
    g.connect(right, g.add(I("Lr", 1.0)))
    return g


def branched(depth):
    """A binary tree of junctions ``depth`` deep, each with a storage element and a resistor."""
    g = BondGraph("branched")
    root = g.add(One("j"))
    g.connect(g.add(Se("S", 1.0)), root)

    def grow(parent, name, d):
        for k in (0, 1) if d else ():
            n = f"{name}{k}"
            j = g.add((Zero if d % 2 else One)(n))
            g.connect(parent, j)
            g.connect(j, g.add((C if d % 2 else I)(f"s{n}", 1.0)))
            g.connect(j, g.add(R(f"r{n}", 1.0)))
            grow(j, n, d - 1)

    grow(root, "j", depth)
    return g


class Drawn:
    """A drawing's marks in display coordinates, by gid."""

    def __init__(self, graph, config=None, ax=None, **options):
        self.graph = graph
        self.ax = draw_bond_graph(graph, config, ax, **options)
        self.fig = self.ax.figure
        self.fig.draw_without_rendering()
        self.causality = graph.causality(config, open_ports=False)
        to_px = self.ax.transData.transform
        self.labels, self.boxes = {}, {}
        for t in self.ax.texts:
            gid = t.get_gid() or ""
            if gid.startswith("element:") or gid == "legend":
                self.labels[gid] = t
                self.boxes[gid] = t.get_bbox_patch().get_window_extent()
        self.lines = {}
        for line in self.ax.lines:
            gid = line.get_gid() or ""
            self.lines.setdefault(gid, []).append(line)
        self.points = {gid: to_px(lines[0].get_xydata()) for gid, lines in self.lines.items() if len(lines) == 1}

    def centre(self, element):
        box = self.boxes[f"element:{element}"]
        return np.array([(box.x0 + box.x1) / 2, (box.y0 + box.y1) / 2])

    def close(self):
        plt.close(self.fig)


@pytest.fixture(params=CASES, ids=IDS)
def drawn(request):
    name, params = request.param
    model = models.load(name).build(**params)
    d = Drawn(model.graph, model.configuration_of(model.initial_mode))
    yield d
    d.close()


def _overlap(a, b, tol=0.5):
    return a.x0 < b.x1 - tol and b.x0 < a.x1 - tol and a.y0 < b.y1 - tol and b.y0 < a.y1 - tol


def _segment_hits_box(p, q, box, shrink=1.5):
    """Does the segment p–q pass through the box (shrunk by ``shrink`` pixels)?"""
    x0, x1, y0, y1 = box.x0 + shrink, box.x1 - shrink, box.y0 + shrink, box.y1 - shrink
    if x0 >= x1 or y0 >= y1:
        return False
    return _segment_meets_box(p, q, (x0, x1, y0, y1))


# ------------------------------------------------------------------ labels


def test_every_element_has_one_label_and_no_two_labels_overlap(drawn):
    names = sorted(g[len("element:"):] for g in drawn.labels if g.startswith("element:"))
    assert names == sorted(drawn.graph.elements)
    assert "legend" in drawn.labels
    for (ga, a), (gb, b) in itertools.combinations(drawn.boxes.items(), 2):
        assert not _overlap(a, b), f"{ga} overlaps {gb}"


def test_labels_stay_inside_the_figure(drawn):
    frame = drawn.fig.bbox
    for gid, box in drawn.boxes.items():
        assert frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0 and box.y1 <= frame.y1, gid


def test_no_bond_is_drawn_through_a_label_other_than_its_ends(drawn):
    for bond in drawn.graph.bonds.values():
        check_bond_avoids_labels(drawn, bond)


def check_bond_avoids_labels(drawn, bond):
    way = drawn.points[f"bond:{bond.name}"]
    for p, q in zip(way, way[1:]):
        for gid, box in drawn.boxes.items():
            if gid in (f"element:{bond.tail}", f"element:{bond.head}"):
                continue
            assert not _segment_hits_box(p, q, box), f"bond {bond.name} crosses {gid}"


def _plain_graphs():
    from models.graphs import GRAPHS

    return [(name, fn) for name, fn in GRAPHS.items()]


@pytest.mark.parametrize("name, build", _plain_graphs(), ids=[n for n, _ in _plain_graphs()])
def test_plain_graphs_and_model_files_draw_clear_too(name, build):
    graphs = [build()]
    if name == "series_rlc":  # once: the model files written by hand
        graphs += [models.load(str(path)).graph for path in sorted(models.EXAMPLES.glob("*.toml"))]
    for graph in graphs:
        d = Drawn(graph)
        try:
            for (ga, a), (gb, b) in itertools.combinations(d.boxes.items(), 2):
                assert not _overlap(a, b), f"{graph.name}: {ga} overlaps {gb}"
            for bond in graph.bonds.values():
                check_bond_avoids_labels(d, bond)
                assert len(d.lines[f"stroke:{bond.name}"]) == 1
        finally:
            d.close()


# ------------------------------------------------------------ half-arrows


def test_each_bond_has_one_half_arrow_at_the_end_power_flows_to(drawn):
    check_half_arrows(drawn)


def check_half_arrows(drawn):
    for bond in drawn.graph.bonds.values():
        assert len(drawn.lines[f"arrow:{bond.name}"]) == 1 and len(drawn.lines[f"bond:{bond.name}"]) == 1
        way = drawn.points[f"bond:{bond.name}"]
        start, end = way[-2], way[-1]  # the last leg
        tip, barb = drawn.points[f"arrow:{bond.name}"]
        head, tail = drawn.centre(bond.head), drawn.centre(bond.tail)
        # the tip is the bond's end nearer the head's label
        assert np.allclose(tip, end, atol=0.5), bond.name
        assert np.linalg.norm(end - head) < np.linalg.norm(end - tail), bond.name
        # one barb, back along the bond and to its left (⇀), not across it
        d = (end - start) / np.linalg.norm(end - start)
        back = barb - tip
        assert np.dot(back, d) < 0, bond.name
        assert d[0] * back[1] - d[1] * back[0] > 0, bond.name


# --------------------------------------------------------- causal strokes


def test_each_bond_has_one_causal_stroke_across_the_end_that_receives_the_effort(drawn):
    check_strokes(drawn)


def check_strokes(drawn):
    causality = drawn.causality
    for bond in drawn.graph.bonds.values():
        strokes = drawn.lines.get(f"stroke:{bond.name}", [])
        if bond.name in causality.dead:
            assert strokes == [], bond.name
            continue
        assert len(strokes) == 1, bond.name
        receiver = bond.tail if causality.effort_by[bond.name] == bond.head else bond.head
        way = drawn.points[f"bond:{bond.name}"]
        leg = way[-2:] if receiver == bond.head else way[:2][::-1]  # the leg at the receiving end, towards it
        at = leg[1]
        a, b = drawn.points[f"stroke:{bond.name}"]
        assert np.allclose((a + b) / 2, at, atol=0.5), bond.name  # centred on the bond's end
        d = (leg[1] - leg[0]) / np.linalg.norm(leg[1] - leg[0])
        s = (b - a) / np.linalg.norm(b - a)
        assert abs(np.dot(d, s)) < 1e-6, bond.name  # across the bond
        assert strokes[0].get_linewidth() > 1.8 * drawn.lines[f"bond:{bond.name}"][0].get_linewidth()  # bold


def _configurations():
    """Every configuration of the shipped models with at most three controlled junctions."""
    out = []
    for name in models.MODELS:
        graph = models.load(name).build().graph
        names = graph.controlled_junctions
        if 0 < len(names) <= 3:
            out += [(name, dict(zip(names, values))) for values in itertools.product((True, False), repeat=len(names))]
    return out


@pytest.mark.parametrize("name, config", _configurations(),
                         ids=[f"{n}-" + "".join("1" if v else "0" for v in c.values()) for n, c in _configurations()])
def test_every_configuration_is_drawn_with_its_own_strokes(name, config):
    from bondgraph.errors import CausalityConflictError

    graph = models.load(name).build().graph
    try:
        graph.causality(config, open_ports=False)
    except CausalityConflictError as conflict:  # a configuration no automaton reaches: drawing it says why
        with pytest.raises(CausalityConflictError) as raised:
            draw_bond_graph(graph, config)
        assert str(raised.value) == str(conflict)
        return
    d = Drawn(graph, config)
    try:
        check_half_arrows(d)
        check_strokes(d)
        for junction, on in config.items():
            assert ("on" if on else "off") in d.labels[f"element:{junction}"].get_text()
    finally:
        d.close()


def test_strokes_follow_the_textbook_rules_in_a_known_case():
    """Bouncing ball in flight, by hand: the source imposes effort on the
    junction (stroke at 1_v); the mass is in integral causality (it receives
    the effort); the off 0-junction imposes zero effort on both its bonds."""
    model = models.load("bouncing_ball").build()
    d = Drawn(model.graph, model.configuration_of(model.mode("flight")))
    try:
        expected = {"gravity": "v", "ball": "ball", "v__floor": "v", "ground": "ground"}
        for bond, receiver in expected.items():
            a, b = d.points[f"stroke:{bond}"]
            way = d.points[f"bond:{bond}"]
            near = min((way[0], way[-1]), key=lambda p: np.linalg.norm(p - d.centre(receiver)))
            assert np.allclose((a + b) / 2, near, atol=0.5), bond
    finally:
        d.close()


# ------------------------------------------------------------------ layout


def test_layout_follows_the_junction_structure():
    boost = models.load("boost_converter").build().graph
    cells = layout_bond_graph(boost).cells
    # the main chain on one row, power flowing left to right; the source at its start
    chain = ["iL", "A", "D", "B"]
    assert len({cells[n][1] for n in chain}) == 1
    assert [cells[n][0] for n in chain] == sorted(cells[n][0] for n in chain)
    assert cells["Vin"] == (cells["iL"][0] - 1, cells["iL"][1])
    # the switch branch hangs below or above the switch node, in its column
    assert cells["S"][0] == cells["A"][0] and cells["S"][1] != cells["A"][1]
    # storage above its junction, resistors below it
    assert cells["L"] == (cells["iL"][0], cells["iL"][1] - 1)
    assert cells["R_L"] == (cells["iL"][0], cells["iL"][1] + 1)


@pytest.mark.parametrize("name, params", CASES, ids=IDS)
def test_one_ports_sit_next_to_their_junction_and_cells_are_unique(name, params):
    graph = models.load(name).build(**params).graph
    layout = layout_bond_graph(graph)
    assert len(set(layout.cells.values())) == len(graph.elements)
    assert not set(layout.reserved) & set(layout.cells.values())
    assert layout.chords == ()  # every shipped junction structure is a tree: all bonds routed
    for bond in graph.bonds.values():
        (c0, r0), (c1, r1) = layout.cells[bond.tail], layout.cells[bond.head]
        ends = [graph.elements[bond.tail].kind, graph.elements[bond.head].kind]
        if any(k not in ("0", "1", "TF", "GY") for k in ends):
            assert max(abs(c0 - c1), abs(r0 - r1)) == 1, bond.name


def test_a_long_chain_is_folded_and_a_loop_is_drawn_as_a_chord():
    chain = models.load("ball_chain").build(N=50).graph
    cells = layout_bond_graph(chain).cells
    rows = {cells[f"v{k}"][1] for k in range(1, 51)}
    assert 4 <= len(rows) <= 12  # folded into bands, not one row 99 junctions long
    g = bridge()
    layout = layout_bond_graph(g)
    assert len(layout.chords) >= 1
    d = Drawn(g)
    try:
        for (ga, a), (gb, b) in itertools.combinations(d.boxes.items(), 2):
            assert not _overlap(a, b), f"{ga} overlaps {gb}"
        assert all(len(d.lines[f"stroke:{b}"]) == 1 for b in g.bonds)
        assert set(layout.paths) == set(layout.chords)  # each loop-closing bond found a way round
        for bond in g.bonds.values():
            check_bond_avoids_labels(d, bond)
    finally:
        d.close()


def test_the_layout_is_the_same_in_every_process():
    """No set order (string hashes differ from process to process) leaks into the layout."""
    import subprocess
    import sys

    code = ("import sys; sys.path[:0] = ['tests', 'tests/bondgraph']; from test_drawing import branched; "
            "from bondgraph.drawing import layout_bond_graph; import models; "
            "print(sorted(layout_bond_graph(branched(4)).cells.items()), "
            "sorted(layout_bond_graph(models.load('falling_rod').build().graph).cells.items()))")
    root = ROOT
    outputs = {subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=root, timeout=120,
                              env={**__import__("os").environ, "PYTHONHASHSEED": seed, "MPLBACKEND": "Agg"}).stdout
               for seed in ("1", "2", "3")}
    assert len(outputs) == 1 and "rod/omega" in outputs.pop()


def test_a_crowded_branched_graph_still_draws_without_overlapping_labels():
    """188 elements, junctions of five bonds in a tree that fills the grid:
    a few one-ports find no free place next to their junction (their bond is
    then long and may pass a label), but no two labels overlap and every
    mark is where it belongs."""
    g = branched(5)
    d = Drawn(g)
    try:
        boxes = list(d.boxes.items())
        for (ga, a), (gb, b) in itertools.combinations(boxes, 2):
            assert not _overlap(a, b), f"{ga} overlaps {gb}"
        check_half_arrows(d)
        check_strokes(d)
    finally:
        d.close()
    d = Drawn(branched(3))  # less crowded: every bond clear of the labels
    try:
        for bond in d.graph.bonds.values():
            check_bond_avoids_labels(d, bond)
    finally:
        d.close()


# ------------------------------------------------------ controlled junctions


def test_a_switched_off_junction_and_its_bonds_are_drawn_differently():
    model = models.load("diode_circuit").build()
    graph = model.graph
    on = Drawn(graph, graph.configuration(sw=False, D=True))  # switch open, diode conducting
    off = Drawn(graph, graph.configuration(sw=False, D=False))  # nothing conducts: L dependent
    try:
        lab_on, lab_off = on.labels["element:D"], off.labels["element:D"]
        assert "on" in lab_on.get_text() and "off" in lab_off.get_text()
        box_on, box_off = lab_on.get_bbox_patch(), lab_off.get_bbox_patch()
        assert box_on.get_linestyle() == "-" and box_off.get_linestyle() == "--"
        assert matplotlib.colors.to_hex(lab_off.get_color()) != matplotlib.colors.to_hex(lab_on.get_color())
        for bond in ("diode", "drop"):  # the bonds of D
            assert on.lines[f"bond:{bond}"][0].get_linestyle() == "-"
            assert off.lines[f"bond:{bond}"][0].get_linestyle() == "--"
        for bond in ("n__loop", "L", "R"):  # bonds away from the switches are drawn alike
            assert off.lines[f"bond:{bond}"][0].get_linestyle() == "-"
        # an uncontrolled junction has no box edge; a controlled one always has one
        assert on.labels["element:n"].get_bbox_patch().get_edgecolor()[3] == 0
        assert box_on.get_edgecolor()[3] > 0
    finally:
        on.close()
        off.close()


def freewheel():
    """A switch S1 and a freewheeling diode D1 (models.circuits), built."""
    from models.circuits import Circuit

    c = Circuit("freewheel")
    c.V("V", "s", "0", 10.0)
    c.switch("S1", "s", "n", closed_when="t < 0.5")
    c.R("R", "n", "m", 1.0)
    c.L("L", "m", "0", 0.1)
    c.diode("D1", "0", "n", v_f=0.7)
    return c.build()


def _mark(text) -> str:
    """The superscript of a junction's label: its state as drawn."""
    return text.rsplit("^{\\mathrm{", 1)[1].rstrip("}$")


def test_controlled_junctions_are_marked_with_the_words_the_mode_says():
    """Issue 44: a switch is drawn closed or open, a diode conducting or blocking, a clutch engaged or
    disengaged — what the run says — not on/off; an off junction is still grey and dashed."""
    from models.mechanics import Mechanism

    model = freewheel()
    mode = model.mode("S1=open, D1=on")  # an old name of the diode's state reads
    d = Drawn(model.graph, model.configuration_of(mode), words=model.mode_space.junction_words(mode))
    try:
        assert _mark(d.labels["element:S1"].get_text()) == "open"
        assert _mark(d.labels["element:D1"].get_text()) == "conducting"
        assert d.labels["element:S1"].get_bbox_patch().get_linestyle() == "--"
        assert d.ax.get_title() == "freewheel: S1 open, D1 conducting"
    finally:
        d.close()
    drive = Mechanism("drive", "rotational")
    drive.inertia("J1", "a", 1.0, omega0=1.0)
    drive.clutch("K", "a", "b", engaged_when="t >= 0.5")
    drive.inertia("J2", "b", 1.0)
    model = drive.build()
    for mode, word in ((model.initial_mode, "disengaged"), (model.mode("K=engaged"), "engaged")):
        d = Drawn(model.graph, model.configuration_of(mode), words=model.mode_space.junction_words(mode))
        try:
            assert _mark(d.labels["element:K"].get_text()) == word
        finally:
            d.close()


def test_a_junction_whose_automaton_says_more_than_on_or_off_is_drawn_on_or_off():
    """A ball's contact=impact and contact=rest both hold the floor on: the floor is drawn on/off."""
    model = models.load("bouncing_ball").build()
    mode = model.mode("contact=rest")
    assert model.mode_space.junction_words(mode) == {}
    d = Drawn(model.graph, model.configuration_of(mode), words=model.mode_space.junction_words(mode))
    try:
        assert _mark(d.labels["element:floor"].get_text()) == "on"
    finally:
        d.close()


def test_hbg_draw_marks_the_junctions_with_the_words_of_the_mode(tmp_path, capsys, monkeypatch):
    """``hbg draw FILE --mode ...`` of a saved circuit: the labels say open and conducting (the mode
    given in the old words, ``D1=on``, reads)."""
    import bondgraph.drawing as drawing

    path = tmp_path / "freewheel.toml"
    freewheel().save(path)
    real, seen = drawing.draw_bond_graph, {}

    def drawing_seen(*args, **kwargs):
        ax = real(*args, **kwargs)
        seen.update({t.get_gid(): t.get_text() for t in ax.texts}, title=ax.get_title())
        return ax

    monkeypatch.setattr(drawing, "draw_bond_graph", drawing_seen)
    status = cli.main(["draw", str(path), "--mode", "S1=open, D1=on", "-o", str(tmp_path / "freewheel.png")])
    assert status == 0, capsys.readouterr().err
    assert _mark(seen["element:S1"]) == "open" and _mark(seen["element:D1"]) == "conducting"
    assert seen["title"] == "freewheel in mode S1=open, D1=conducting"


def test_a_bond_between_two_off_junctions_of_one_kind_is_dead():
    model = models.load("falling_rod").build()
    graph = model.graph
    d = Drawn(graph, graph.configuration(cy=False, cx=False, stick=False))
    try:
        assert "cx__stick" in d.causality.dead
        assert "stroke:cx__stick" not in d.lines
        assert d.lines["bond:cx__stick"][0].get_linestyle() == ":"
    finally:
        d.close()


def test_without_a_configuration_controlled_junctions_are_boxed_but_not_marked_on_or_off():
    model = models.load("two_tanks").build()
    assert "on" not in element_label(model.graph.elements["V"])
    assert element_label(model.graph.elements["V"], False).endswith("^{\\mathrm{off}}$")
    d = Drawn(model.graph)
    try:
        assert d.labels["element:V"].get_bbox_patch().get_edgecolor()[3] > 0
        assert d.ax.get_title() == "two_tanks"
    finally:
        d.close()


def test_labels_are_written_as_textbooks_write_them():
    rod = models.load("falling_rod").build().graph
    assert element_label(rod.elements["rod/I_J"]) == "I: rod/I_J"
    params = rod.parameters
    assert element_label(rod.elements["rod/lever_x"], parameters=params) == "MTF: rod/lever_x"  # by theta
    assert element_label(rod.elements["coulomb"], parameters=params) == "MSe: coulomb"  # by the normal force
    assert element_label(rod.elements["rod/gravity"], parameters=params) == "Se: rod/gravity"  # m g: parameters
    motor = __import__("models.graphs", fromlist=["dc_motor"]).dc_motor()
    gyrator = next(el for el in motor.elements.values() if el.kind == "GY")
    assert element_label(gyrator, parameters=motor.parameters) == f"GY: {gyrator.name}"  # a constant K
    assert element_label(rod.elements["rod/tip_x"]) == r"$\mathbf{0}_{\mathrm{rod/tip\_x}}$"


# ------------------------------------------------------------ axes and files


def test_a_small_given_axis_gets_the_drawing_scaled_into_it():
    fig, (ax, other) = plt.subplots(1, 2, figsize=(6, 3))
    model = models.load("falling_rod").build()
    try:
        assert draw_from_plotting(model.graph, None, ax) is ax
        fig.draw_without_rendering()
        frame = ax.get_window_extent()
        boxes = [t.get_bbox_patch().get_window_extent() for t in ax.texts if t.get_bbox_patch() is not None]
        for box in boxes:
            assert frame.x0 - 1 <= box.x0 and box.x1 <= frame.x1 + 1
        for a, b in itertools.combinations(boxes, 2):
            assert not _overlap(a, b)
        assert max(t.get_fontsize() for t in ax.texts) < 10  # shrunk to fit
    finally:
        plt.close(fig)


@pytest.mark.parametrize("suffix", ["png", "svg"])
def test_hbg_draw_writes_png_and_svg(tmp_path, capsys, suffix):
    target = tmp_path / f"rod.{suffix}"
    status = cli.main(["draw", "falling-rod", "--mode", "contact|stuck", "-o", str(target)])
    out = capsys.readouterr()
    assert status == 0, out.err
    assert f"wrote {target}" in out.out
    data = target.read_bytes()
    if suffix == "png":
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    else:
        text = data.decode()
        assert "<svg" in text and 'id="element:rod/I_J"' in text and 'id="stroke:normal"' in text


def test_hbg_draw_no_legend_and_a_model_file(tmp_path, capsys):
    target = tmp_path / "relay.svg"
    status = cli.main(["draw", str(models.EXAMPLES / "relay.toml"), "--no-legend", "-o", str(target)])
    assert status == 0, capsys.readouterr().err
    text = target.read_text()
    assert 'id="element:relay"' in text and 'id="legend"' not in text


def test_hbg_draw_rejects_an_unknown_format_before_drawing(tmp_path, capsys):
    status = cli.main(["draw", "falling-rod", "-o", str(tmp_path / "rod.xyz")])
    assert status == 2 and "cannot write 'xyz'" in capsys.readouterr().err
