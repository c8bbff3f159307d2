"""Units and descriptions of a model's names (issue 29: units on every axis, kept by ``hbg save``)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import pytest

import models
from bondgraph import BondGraph, C, One, R, Se
from bondgraph.errors import UnknownNameError
from models.circuits import Circuit
from models.mechanics import Mechanism
from switching import HybridModel
from switching.errors import ModelDefinitionError
from switching.files.errors import ModelFileError
from switching.files.modelfile import dumps_model, loads_model
from switching.simulate.plotting import phase_portrait, plot_trajectory


def _rc(**options):
    g = BondGraph("rc")
    loop = g.add(One("loop"))
    g.connect(Se("V", "V"), loop)
    g.connect(loop, R("R", "R"))
    g.connect(loop, C("C", "C"))
    return HybridModel(g, [], {"V": 1.0, "R": 1.0, "C": 1.0}, signals={"v": "q_C/C", "q": "q_C"}, **options)


def test_a_unit_is_shown_on_one_line_and_kept_as_given():
    model = _rc(units={"v": "k\nV"})
    assert model.annotations.unit("v") == "k\nV" and model.annotations.label("v") == "v [k V]"
    assert dict(loads_model(dumps_model(model)).annotations.units) == {"v": "k\nV"}


def test_units_label_names_and_a_signal_that_is_a_state_takes_its_unit():
    model = _rc(units={"q_C": "C", "v": "V", "R": "Ω"}, descriptions={"R": "the resistor"})
    notes = model.annotations
    assert notes.label("v") == "v [V]" and notes.label("R") == "R [Ω]" and notes.unit("V") is None
    assert notes.unit("q") == "C"  # q = q_C
    assert notes.label("t_unknown") == "t_unknown" and notes.descriptions["R"] == "the resistor"


@pytest.mark.parametrize("units, error, words", [
    ({"vv": "V"}, UnknownNameError, "did you mean 'v'"),
    ({"v": ""}, ModelDefinitionError, "non-empty"),
    ({"v": " "}, ModelDefinitionError, "non-empty"),
    ({"v": 3}, ModelDefinitionError, "text"),
])
def test_bad_units_are_refused_naming_the_name(units, error, words):
    with pytest.raises(error) as info:
        _rc(units=units)
    assert words in str(info.value)


def test_every_shipped_model_gives_the_unit_of_its_states_and_signals():
    for name in models.MODELS:
        module = models.load(name)
        model = module.build()
        missing = [n for n in list(module.SIGNALS) + list(model.state_names) if model.annotations.unit(n) is None]
        assert not missing, f"{name}: no unit for {missing}"
        parameters = [s.name for s in model.parameter_symbols]
        assert all(model.annotations.unit(p) for p in parameters), name


@pytest.mark.parametrize("name", models.MODELS)
def test_a_model_file_keeps_units_and_descriptions(name):
    original = models.load(name).build()
    loaded = loads_model(dumps_model(original))
    assert dict(loaded.annotations.units) == dict(original.annotations.units)
    assert dict(loaded.annotations.descriptions) == dict(original.annotations.descriptions)
    assert original.annotations.descriptions, name


def test_a_units_table_in_a_model_file_is_checked_at_its_line():
    text = dumps_model(_rc(units={"v": "V"}))
    assert '[units]\nv = "V"' in text
    with pytest.raises(ModelFileError) as info:
        loads_model(text.replace('v = "V"', 'v = 3'))
    assert "unit" in str(info.value) and ":" in str(info.value)
    with pytest.raises(ModelFileError) as info:
        loads_model(text.replace('v = "V"', 'vv = "V"'))
    assert "vv" in str(info.value)


def test_plots_show_units_on_their_axes():
    rod = models.load("falling_rod").build()
    trajectory = rod.simulate(0.3, "RK45")
    fig = plot_trajectory(trajectory, ["theta", ["tip_vx", "tip_vy"], "normal_force"])
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["theta [rad]", "[m/s]", "normal_force [N]"]
    legend = [text.get_text() for text in fig.axes[1].get_legend().get_texts()]
    assert [entry.split(" (constant")[0] for entry in legend] == ["tip_vx [m/s]", "tip_vy [m/s]"]
    ax = phase_portrait(trajectory, "theta", "omega")
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("theta [rad]", "omega [rad/s]")
    mixed = plot_trajectory(trajectory, [["theta", "tip_vx"]])
    assert mixed.axes[0].get_ylabel() == ""  # two units in one panel: each in the legend only


def test_builders_name_the_units_of_what_they_name():
    rc = Circuit("rc")
    rc.V("V1", "in", "0", 5.0)
    rc.R("R1", "in", "out", 1e3)
    rc.C("C1", "out", "0", 1e-6)
    units = rc.build().annotations.units
    assert (units["v_out"], units["i_R1"], units["q_C1"]) == ("V", "A", "C")
    for kind, position, force in (("translational", "m", "N"), ("rotational", "rad", "N·m")):
        machine = Mechanism("m", kind=kind)
        machine.mass("M", "a", 2.0) if kind == "translational" else machine.inertia("M", "a", 2.0)
        machine.spring("K", "a", "0", 10.0)
        machine.position("a", 0.1)
        units = machine.build().annotations.units
        first = "x" if kind == "translational" else "theta"
        assert units[f"{first}_a"] == position and units["F_K" if kind == "translational" else "T_K"] == force
