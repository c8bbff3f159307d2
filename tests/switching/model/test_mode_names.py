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
