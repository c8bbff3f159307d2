"""``HybridModel.verify`` samples only states a run can have at an event, shows
every loop it finds, and refuses a sample count that would check nothing
(issues 20 and 21; switching/analysis/verify.py's module docstring has the rules)."""

import numpy as np
import pytest
from switching_models import ball_row, rc_relay

from models import diode_circuit, falling_rod
from models.cli import main
from switching import Automaton, SimulationError
from switching.analysis.verify import ENTRY, HELD

ROD_SIGNALS = ("tip_y", "tip_vx", "tip_vy", "normal_force", "friction_force")
CONTACT_MODES = {"contact|stuck", "contact|slide_pos", "contact|slide_neg"}


def below_floor(model, values) -> bool:
    """``tip_y <= 0`` at every sample of one mode, within the band of verify's
    entry comparisons (1e-12 of the terms of ``tip_y = y − l sin θ``)."""
    l = {s.name: v for s, v in model.parameter_values.items()}["l"]
    size = np.array([abs(s.values["rod/y"]) + l for s in values["samples"]])
    return bool(np.all(values["tip_y"] <= 1e-12 * size))


def signals_at_samples(model, samples, names=ROD_SIGNALS) -> dict:
    """Mode label → {signal: array over the samples of that mode, "samples": those samples}."""
    by_mode: dict = {}
    for sample in samples:
        by_mode.setdefault(sample.mode, []).append(sample)
    out = {}
    for mode, group in by_mode.items():
        fn = model.signal_function(mode, names)
        x = np.array([s.x for s in group]).T
        t = np.array([s.t for s in group])
        values = fn(x, t, model.parameter_array, [], np.empty((len(names), len(group))))
        out[mode.label] = {**dict(zip(names, values)), "samples": group}
    return out


@pytest.fixture(scope="module", params=[{}, {"mu": 0.002}, {"mu": 5.0}], ids=["defaults", "mu=0.002", "mu=5"])
def rod(request):
    model = falling_rod.build(**request.param)
    return model, model.verify(samples=10)


def test_falling_rod_verifies_without_false_loops(rod):
    """Issue 21: ``hbg verify falling-rod`` reported two loops from states the
    rod cannot have (the tip 14 m above the floor in contact mode)."""
    model, report = rod
    assert report.ok, str(report)
    text = str(report)
    assert "no divergence of time found" in text and "loop" not in text
    assert {m.label for m in report.explored} == {"free|stuck", "free|slide_pos", "free|slide_neg", *CONTACT_MODES}
    assert report.samples == len(report.sampled) > 100
    for mode, comparison, guard in report.unsampled:  # said, not hidden
        assert f"{mode.describe()}: {comparison} (guard {guard})" in text


def test_sampled_states_lie_on_the_modes_constraints(rod):
    model, report = rod
    for sample in report.sampled:
        cm = model.compiled_mode(sample.mode)
        np.testing.assert_allclose(cm.complete(sample.x.copy(), sample.t), sample.x, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(cm.jump(sample.x, sample.t), sample.x, rtol=1e-9, atol=1e-12)
    values = signals_at_samples(model, report.sampled)
    for label in CONTACT_MODES & set(values):
        assert np.all(np.abs(values[label]["tip_vy"]) <= 1e-12), label  # the floor holds the tip's vertical velocity


def test_sampled_states_are_ones_the_mode_can_flow_through(rod):
    """Filters 2 and 3: no guard of the mode already held (a stuck tip's floor
    pushes, its friction force is within the cone), and in contact the tip is
    where contact began, at or below the floor."""
    model, report = rod
    parameters = {s.name: v for s, v in model.parameter_values.items()}
    mu, y_lift = parameters["mu"], parameters["y_lift"]
    values = signals_at_samples(model, report.sampled)
    assert CONTACT_MODES <= set(values)
    for label in CONTACT_MODES:
        v = values[label]
        assert below_floor(model, v), (label, v["tip_y"].max())
        # on the boundary (not nudged off it, where the sampled guard may just have become true), up to the
        # boundary's own tolerance (forces of some N, relative 1e-9)
        on = np.array([s.nudge == 0 for s in v["samples"]])
        assert np.all(v["normal_force"][on] >= -1e-7), (label, v["normal_force"][on].min())
        if label == "contact|stuck":
            assert np.all(np.abs(v["friction_force"][on]) <= mu * v["normal_force"][on] + 1e-7)
    for label in ("free|slide_pos", "free|slide_neg"):
        if label in values:  # in the air a sliding state lasts only up to y_lift
            on = np.array([s.nudge == 0 for s in values[label]["samples"]])
            assert np.all(values[label]["tip_y"][on] <= y_lift + 1e-12), label
    assert report.rejected[HELD] > 0 and report.rejected[ENTRY] > 0
    assert "rod/y" in report.entry_conditions["contact=contact"]
    assert "kept since it was entered" in str(report)


def test_the_rod_as_filed_has_no_loop_from_impossible_states(monkeypatch):
    """The rod as it was when the issue was filed (its slide → stuck lift-off
    guard was ``tip_y > y_lift`` alone): verify then found the loops
    contact|stuck → contact|slide_pos (tip_y 2.45 m in contact) and
    contact|slide_neg → contact|stuck; neither state can occur."""
    add = Automaton.add_transition

    def as_filed(self, source, target, guard, *args, **kwargs):
        if guard == "tip_y > y_lift and normal_force <= 0":
            guard = "tip_y > y_lift"
        return add(self, source, target, guard, *args, **kwargs)

    monkeypatch.setattr(Automaton, "add_transition", as_filed)
    model = falling_rod.build()
    assert any("tip_y > y_lift" == g.text for g in model.mode_equations("contact|slide_pos").guards)
    report = model.verify(samples=10)
    assert report.ok, str(report)
    assert report.rejected[ENTRY] > 0
    # in contact the tip's height does not change with the flow: its lift-off threshold is never crossed there
    never = {(mode.label, comparison) for mode, comparison, _ in report.constant}
    for label in ("contact|slide_pos", "contact|slide_neg"):
        assert any(m == label and "y_lift" in comparison for m, comparison in never), (label, never)
    values = signals_at_samples(model, report.sampled)
    for label in CONTACT_MODES:
        assert below_floor(model, values[label]), (label, values[label]["tip_y"].max())


def test_a_real_loop_is_shown_with_its_state_and_guard_values():
    """The diode circuit with a holding current above any current it carries:
    off → on → off at the switch's opening, a loop of the model itself."""
    model = diode_circuit.build(I_th=100)
    report = model.verify(samples=5)
    assert not report.ok
    (loop,) = report.loops
    modes, message = loop  # unpacks as before
    assert {m.label for m in modes} == {"open|off", "open|on"}
    assert loop.sample.values["p_L"] / 0.1 < 100  # the current at the sampled state is below I_th
    assert loop.sample.outcome == "divergence of time" and loop.count >= 1
    assert all(step.fired for step in loop.steps)
    text = str(report)
    assert "1 divergence-of-time loop(s):" in text and "loop 1: switch=open, diode=off → switch=open, diode=on" in text
    assert f"p_L = {loop.sample.values['p_L']:.12g}" in text
    assert "boundary of t >= t_open" in text
    for line in message.splitlines():  # every line of the resolution's message: fired guards and their values
        assert line in text
    assert "fired diode: on → off [i_D <= I_th]" in text and "fired diode: off → on [v_D >= V_th]" in text


def test_colliding_balls_without_separating_condition_still_loop():
    report = ball_row([1.0, 1.0], 0.8, separating=False).verify(samples=5)
    assert report.loops
    text = str(report)
    assert "collide" in text and "p1 = " in text and "repeats" in text


def test_cli_prints_the_loop_and_exits_1(capsys):
    assert main(["verify", "diode-circuit", "--set", "I_th=100", "--samples", "5"]) == 1
    out = capsys.readouterr().out
    assert "divergence-of-time loop" in out and "p_L = " in out and "fired diode: on → off" in out


@pytest.mark.parametrize("samples", [0, -1, 2.5, True, "3", None])
def test_sample_counts_that_check_nothing_are_refused(samples):
    """Issue 20: ``--samples 0`` passed falsely ("no divergence of time found")."""
    model = diode_circuit.build(I_th=100)
    with pytest.raises(SimulationError, match="samples must be"):
        model.verify(samples=samples)


def test_other_bad_verify_arguments_are_refused(capsys):
    model = diode_circuit.build()
    with pytest.raises(SimulationError, match="max_modes"):
        model.verify(max_modes=0)
    with pytest.raises(SimulationError, match="scale"):
        model.verify(scale=-1.0)
    assert model.verify(samples=np.int64(2)).ok  # a numpy integer is a whole number
    assert main(["verify", "diode-circuit", "--set", "I_th=100", "--samples", "0"]) == 2
    assert "samples" in capsys.readouterr().err


def test_one_sample_crosses_a_time_threshold_and_constant_comparisons_are_not_sampled():
    """A time threshold (t_open = 0.5) far below the largest parameter
    (I_th = 100) is still crossed by one sample; a comparison that cannot
    change in a mode (the diode's forward voltage −V with the switch closed)
    is listed as never crossed, not as unsampled."""
    for seed in range(5):
        report = diode_circuit.build(I_th=100).verify(samples=1, seed=seed)
        assert report.samples >= 1 and not report.unsampled, str(report)
        assert [key[1] for key in report.coverage if key[0].label == "closed|off"] == ["t >= t_open"]
        assert ("closed|off", "-V >= V_th") in {(mode.label, comparison) for mode, comparison, _ in report.constant}
        assert "never crossed by the flow of their mode" in str(report)



def test_a_boundary_the_flow_only_leaves_is_not_sampled():
    """Filter 2 follows the flow's direction: a relay charging towards 0.5 V
    never reaches its 0.8 V threshold; the states on it are reached only from
    above, where the guard already held, so none is sampled (and the
    discharge mode is never reached)."""
    report = rc_relay(V=0.5, v_hi=0.8).verify(samples=5)
    assert [m.label for m in report.explored] == ["charge"]
    assert [(m.label, comparison) for m, comparison, _ in report.unsampled] == [("charge", "q_C/C >= v_hi")]
    assert report.rejected[HELD] > 0 and report.samples == 0
    assert "charge: q_C/C >= v_hi" in str(report)
    report = rc_relay(V=1.0, v_hi=0.8).verify(samples=5)  # a source above the threshold reaches it
    assert {m.label for m in report.explored} == {"charge", "discharge"} and not report.unsampled and report.ok
