"""One way to write a mode (issue 29, item 1): every output shows
``automaton=state`` pairs (``"contact=free, friction=stuck"``), and every
input accepts what the outputs show, as well as the states joined by ``|``."""

import csv
import re

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from bondgraph.errors import UnknownNameError  # noqa: E402
from models import cli, falling_rod  # noqa: E402


@pytest.fixture(scope="module")
def rod():
    return falling_rod.build()


@pytest.mark.parametrize("text", ["contact=contact, friction=stuck", "contact=contact|friction=stuck",
                                  " friction = stuck ,contact=contact ", "contact|stuck"])
def test_every_spelling_names_the_same_mode(rod, text):
    assert rod.mode(text) == rod.mode({"contact": "contact", "friction": "stuck"})


def test_automata_not_named_keep_their_initial_state(rod):
    assert rod.mode("friction=slide_pos").describe() == "contact=free, friction=slide_pos"


@pytest.mark.parametrize("text, message", [
    ("contakt=contact", r"no automaton named 'contakt' \(did you mean 'contact'\?\)"),
    ("contact=contact, contact=free", "names automaton 'contact' twice"),
    ("contact=, friction=stuck", "'contact=' is not automaton=state"),
    ("contact=flying", "automaton 'contact' has no state 'flying'"),
])
def test_a_mode_written_wrong_is_named(rod, text, message):
    with pytest.raises(UnknownNameError, match=message):
        rod.mode(text)


def test_outputs_show_modes_as_inputs_take_them(rod, tmp_path):
    run = rod.simulate(0.5, "RK45")
    path = tmp_path / "rod.csv"
    run.to_csv(path)
    with open(path, newline="") as f:
        written = {row["mode"] for row in csv.DictReader(f)}
    run.to_npz(tmp_path / "rod.npz")
    stored = set(np.load(tmp_path / "rod.npz")["modes"])
    shown = {m.describe() for m in run.modes}
    assert written == stored == set(run.mode_labels) == shown and len(shown) >= 2
    assert all(rod.mode(text).describe() == text for text in shown)


def test_every_mode_of_a_run_summary_is_accepted_by_modes_and_draw(capsys, tmp_path):
    assert cli.main(["run", "falling-rod", "--t-end", "0.5"]) == 0
    summary = capsys.readouterr().out
    names = re.findall(r"^  ((?:\w+=\w+, )*\w+=\w+)\s", summary, re.M)
    assert len(names) >= 2, summary
    for name in names:
        assert cli.main(["modes", "falling-rod", "--mode", name]) == 0, capsys.readouterr().err
        assert f"mode {name}" in capsys.readouterr().out
    assert cli.main(["draw", "falling-rod", "--mode", names[-1], "-o", str(tmp_path / "rod.svg")]) == 0


def _relay_with_aliases(**aliases):
    from bondgraph import C, BondGraph, One, R, Se
    from switching import Automaton, HybridModel

    g = BondGraph("relay")
    sw = g.add(One("sw", controlled=True))
    g.connect(Se("V", "V0"), sw)
    g.connect(sw, R("R", "R"))
    g.connect(sw, C("C", "C"))
    relay = Automaton("relay", {"closed": {"sw": True}, "open": {"sw": False}}, "closed", aliases=aliases)
    relay.add_transition("closed", "open", "q_C >= 0.5*C*V0")
    return HybridModel(g, [relay], {"V0": 1.0, "R": 1.0, "C": 1e-3})


def test_an_automatons_aliases_read_as_its_states_and_are_never_shown():
    """Issue 44: a renamed state keeps its old name readable (``on`` for ``closed``) wherever a mode is
    written as input — text, mapping, tuple, a signal taken in another mode — and the mode shows the
    state's own name."""
    from switching import InMode

    model = _relay_with_aliases(on="closed", off="open")
    assert model.mode("relay=off").describe() == "relay=open"
    assert model.mode({"relay": "on"}) == model.mode(("closed",)) == model.mode("on")
    assert model.automata[0].state_named("off") == "open"
    with pytest.raises(UnknownNameError, match=r"no state 'shut'.*\['closed', 'open'\] \(also read: on as closed"):
        model.mode("relay=shut")
    cross = type(model)(model.graph, model.automata, {"V0": 1.0, "R": 1.0, "C": 1e-3},
                        signals={"i_open": InMode("f_R", relay="off")})
    assert cross.cross_signals["i_open"][1] == {"relay": "open"}


@pytest.mark.parametrize("aliases, message", [
    ({"open": "closed"}, "alias 'open' is the name of a state"),
    ({"on": "shut"}, "alias 'on' names unknown state 'shut'"),
    ({"1on": "closed"}, "invalid alias"),
])
def test_an_alias_must_be_another_name_of_a_state(aliases, message):
    from bondgraph.errors import HybridBondGraphError

    with pytest.raises(HybridBondGraphError, match=message):
        _relay_with_aliases(**aliases)
