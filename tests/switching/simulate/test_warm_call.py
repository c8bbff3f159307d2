"""A warm compiled call records a kernel call's samples and instants at once (issue 46): the same run,
to the bit, as recording them one by one (switching/simulate/recorder.py: Recorder.block,
compiled_flow.py, library/kernel_rows.py, driver.py: HybridRun.instants_pass, zeno.py:
ZenoWatch.quiet, preflight.py)."""

from __future__ import annotations

import math
import pickle
import random

import numpy as np
import pytest

from models import boost_converter, bouncing_ball
from switching.errors import NonFiniteStateError, SimulationError, ZenoError
from switching.simulate.driver import HybridRun
from switching.simulate.zeno import ZenoWatch
from switching_models import relay_graph


def observed(trajectory) -> dict:
    """Everything a run gives, bytes for arrays (so that -0.0 and 0.0, NaN, … are told apart)."""
    return dict(
        t=trajectory.t.tobytes(), x=trajectory.x.tobytes(), shape=trajectory.x.shape,
        modes=[m.describe() for m in trajectory.modes], event_index=list(trajectory.event_index),
        events=[(e.t, type(e.t), e.x_before.tobytes(), e.x_after.tobytes(), e.mode_before, e.mode_after)
                for e in trajectory.events],
        stats={k: v for k, v in trajectory.stats.items() if "wall" not in k}, stopped=trajectory.stopped,
        sampling=trajectory.sampling, time_in_modes=list(trajectory.time_in_modes().items()),
        dtypes=(trajectory.t.dtype, trajectory.x.dtype, trajectory.x.flags.c_contiguous))


def outcome(run):
    """``observed`` of the run's trajectory, or of the error's (with its type and message)."""
    try:
        return observed(run())
    except SimulationError as exc:
        return type(exc), str(exc), observed(exc.trajectory)


def one_by_one(monkeypatch):
    """Every kernel call's instants taken one at a time (the recording before block)."""
    monkeypatch.setattr(HybridRun, "instants_pass", lambda self, times, count: False)


BALL, BOOST = bouncing_ball.build(), boost_converter.build()
RUNS = {
    "steps": lambda: BALL.simulate(4.02, "RK45-jit", rtol=1e-8),
    "events": lambda: BALL.simulate(4.02, "RK45-jit", rtol=1e-8, output="events"),
    "times": lambda: BALL.simulate(4.02, "RK45-jit", rtol=1e-8, t_eval=np.linspace(0.0, 4.02, 77)),
    "samples": lambda: BALL.simulate(4.02, "RK45-jit", rtol=1e-8, samples=50),
    "no instants kept": lambda: BALL.simulate(4.02, "RK45-jit", rtol=1e-8, keep_instants=False),
    "zeno stop": lambda: BALL.simulate(5.0, "RK45-jit", rtol=1e-8, on_zeno="stop"),
    "zeno raise": lambda: BALL.simulate(5.0, "RK45-jit", rtol=1e-8),
    "max events": lambda: BALL.simulate(4.02, "RK45-jit", rtol=1e-8, max_events=7),
    "max steps": lambda: BALL.simulate(4.02, "RK45-jit", rtol=1e-8, max_steps=30),
    "fixed step, buffers refilled": lambda: BALL.simulate(3.0, "rk4-jit", dt=2e-4),
    "rodas": lambda: BALL.simulate(3.0, "rodas-jit", rtol=1e-6),
    "auto": lambda: BOOST.simulate(1e-3, "auto", rtol=1e-6),
    "boost, instants in Python too": lambda: BOOST.simulate(2e-2, "RK45-jit", rtol=1e-6),
    "boost, many events": lambda: BOOST.simulate(0.1, "RK45-jit", rtol=1e-6, output="events"),
    "boost, many samples": lambda: BOOST.simulate(0.03, "RK45-jit", rtol=1e-6, samples=300),
}


@pytest.mark.parametrize("name", list(RUNS))
def test_a_call_recorded_at_once_is_the_call_recorded_one_by_one(name, monkeypatch):
    """Times, states, modes, instants, their rows, stats, the time in each mode and the errors: identical
    whether a kernel call's output is recorded at once or sample by sample and instant by instant."""
    outcome(RUNS[name])  # (warm: a first run meets the modes the kernel has not compiled yet in Python)
    at_once = outcome(RUNS[name])
    with monkeypatch.context() as patch:
        one_by_one(patch)
        single = outcome(RUNS[name])
    assert at_once == single


def test_a_warm_call_records_its_kernel_calls_at_once(monkeypatch):
    """The bouncing ball's 20 instants pass the run's checks at once: no instant goes through
    after_event (the call's instants are not taken one by one)."""
    taken = []
    original = HybridRun.after_event
    monkeypatch.setattr(HybridRun, "after_event", lambda self, instant: taken.append(instant) or original(
        self, instant))
    RUNS["steps"]()
    taken.clear()
    run = RUNS["steps"]()
    assert len(run.events) == 20 and taken == []
    RUNS["zeno stop"]()
    assert taken  # (gaps shrinking below zeno_min_gap: the Zeno watch sees them one by one)


def test_the_sampled_rows_of_a_mixed_record_are_those_of_one_by_one(monkeypatch):
    """A run whose instants the kernel leaves to Python now and then (the boost converter's) records
    rows one at a time between its kernel calls' blocks; the rows a sampling picks, and the positions of
    the instants among them, are the same (Recorder.rows, which the sensitivities read)."""
    def rows():
        from switching.model.source_periods import step_bound
        from switching.simulate.driver import option_defaults
        from switching.simulate.run_options import checked_options

        options = checked_options(BOOST, 2e-2, "RK45-jit", {**option_defaults(), "rtol": 1e-6, "samples": 200,
                                                            "max_step": step_bound(BOOST)})  # (as simulate)
        run = HybridRun(BOOST, options)
        assert run.execute(all_rows=True).stats["instants resolved in Python"] >= 1
        assert run.recorder.n_rows == len(run.recorder.t)
        return run.recorder.rows(complete=True), run.recorder.rows(complete=False)

    rows()
    at_once = rows()
    one_by_one(monkeypatch)
    assert rows() == at_once


def test_a_trajectory_recorded_at_once_pickles_and_keeps_its_own_arrays():
    """The rows and the instants' states are the trajectory's own: changing one changes no other."""
    run = RUNS["steps"]()
    before = run.x.copy()
    run.events[0].x_before[:] = 7.0
    np.testing.assert_array_equal(run.x, before)
    assert run.events[1].x_before[0] != 7.0
    again = pickle.loads(pickle.dumps(run))
    np.testing.assert_array_equal(again.x, run.x)
    assert [e.t for e in again.events] == [e.t for e in run.events]


def test_a_kernel_calls_instants_are_made_records_when_first_read():
    """A warm call leaves its kernel calls' instants unmade until ``events`` is first read; then they are
    records equal to those of a run recorded one by one, the same records in ``take``, ``dense`` and on
    every later read; a pickled trajectory carries the records, each with its own states; ``events`` may be
    set (as the periodic orbits do)."""
    RUNS["steps"]()
    run = RUNS["steps"]()
    assert "events" not in vars(run)
    assert run.instant_count == 20 and "events" not in vars(run)  # (the count is the run's statistics)
    taken = run.take(range(len(run.t)))
    events = run.events
    assert run.events is events and taken.events is events and run.dense(50).events is events
    assert [type(e).__name__ for e in events] == ["CompiledInstant"] * 20
    assert run.event_times.tolist() == [e.t for e in events]
    again = pickle.loads(pickle.dumps(RUNS["steps"]()))  # (pickled unread)
    assert [(e.t, e.x_before.tobytes(), e.x_after.tobytes(), e.mode_before, e.mode_after) for e in again.events] \
        == [(e.t, e.x_before.tobytes(), e.x_after.tobytes(), e.mode_before, e.mode_after) for e in events]
    alone = pickle.loads(pickle.dumps(events[3]))
    assert alone.x_after.tobytes() == events[3].x_after.tobytes() and alone.t == events[3].t
    run.events = events[:2]
    assert len(run.events) == 2 and len(pickle.loads(pickle.dumps(run)).events) == 2
    unread = RUNS["steps"]()
    copied = unread.take(range(len(unread.t)))
    copied.events = copied.events[:1]  # (set on a copy of a run whose records were made for it)
    assert len(pickle.loads(pickle.dumps(copied)).events) == 1 and len(unread.events) == 20
    assert not hasattr(run, "no_such_attribute")


def test_a_mode_is_one_object_in_runs_and_pickles_without_its_hash():
    """The modes a run passes are the model's one object per mode (a run holds no copies of them); a mode
    pickles without the hash it keeps (strings hash otherwise in another process)."""
    first, second = RUNS["steps"](), RUNS["steps"]()
    by_label = {}
    for mode in first.modes + second.modes + [e.mode_after for e in first.events + second.events]:
        assert by_label.setdefault(mode.label, mode) is mode
    assert BALL.mode(first.modes[-1].label) is first.modes[-1]
    mode = first.modes[-1]
    hash(mode)
    again = pickle.loads(pickle.dumps(mode))
    assert "_hash" not in vars(again) and again == mode and hash(again) == hash(mode)


def test_zeno_watch_quiet_is_add_one_by_one():
    """ZenoWatch.quiet(times) says True only where add() of each time finds nothing, and then holds
    what add() would; False changes nothing.  Random sequences: bouncing (geometric gaps), steady,
    gaps at round-off, and the first time alone."""
    rng = random.Random(46)
    answers = set()
    for trial in range(400):
        window, min_gap = rng.choice([2, 3, 8]), rng.choice([0.0, 1e-9, 1e-3, 0.2])
        t, times = rng.choice([rng.uniform(0, 5), rng.uniform(1e7, 1e9)]), []  # (round-off above 1e-9 at 1e8)
        gap, ratio = rng.uniform(1e-6, 1.0), rng.choice([0.5, 0.8, 0.99, 1.0, 1.3])
        for _ in range(rng.randrange(0, 25)):
            times.append(t)
            t += gap if rng.random() > 0.05 else rng.choice([0.0, math.ulp(t), 1e-17])
            gap *= ratio
        split = rng.randrange(0, len(times) + 1)
        quick, slow = ZenoWatch(window, 10.0, min_gap), ZenoWatch(window, 10.0, min_gap)
        for time in times[:split]:
            assert quick.add(time) == slow.add(time)
        kept = list(quick.times)
        answer = quick.quiet(times[split:])
        answers.add(answer)
        if answer:
            assert all(slow.add(time) is None for time in times[split:]), trial
            assert quick.times == slow.times
        else:
            assert quick.times == kept
    assert answers == {True, False}


def test_instants_beyond_max_events_are_taken_one_by_one():
    """A call whose instants would pass max_events is checked instant by instant: the run stops at the
    one that passes it, as before."""
    with pytest.raises(SimulationError, match="more than 7 events") as info:
        RUNS["max events"]()
    assert info.value.trajectory.stats["instants"] == 8


def test_a_zeno_sequence_in_a_kernel_call_raises_where_it_did():
    with pytest.raises(ZenoError) as info:
        RUNS["zeno raise"]()
    assert info.value.accumulation_time == pytest.approx(4.0637127, rel=1e-7)


def relay(guard_up, parameters):
    from switching import Automaton, HybridModel

    automaton = Automaton("relay", {"charge": {"a": True, "b": False}, "discharge": {"a": False, "b": True}},
                          "charge")
    automaton.add_transition("charge", "discharge", guard_up)
    automaton.add_transition("discharge", "charge", "v <= v_lo")
    values = dict(R1=1.0, R2=0.5, C=1.0, V=1.0, v_hi=0.8, v_lo=0.3)
    values.update(parameters)
    return HybridModel(relay_graph(), [automaton], values, signals={"v": "q_C/C"})


@pytest.mark.parametrize("method", ["RK45", "RK45-jit"])
def test_a_guard_not_finite_where_a_compiled_run_starts_is_named(method):
    """The start's guard sides are evaluated once (preflight.nonfinite_sides_at_start): a side that is
    not finite still stops a compiled run at once, named as the Python path names it."""
    model = relay("v/k >= v_hi", {"k": 0.0})
    with pytest.raises(NonFiniteStateError) as info:
        model.simulate(1.0, method)
    message = str(info.value)
    assert "'v/k >= v_hi'" in message and "automaton 'relay'" in message and "k = 0" in message
    assert info.value.t == 0.0


def test_the_tolerances_of_a_loop_of_runs_are_kept_and_follow_what_they_are_made_of():
    """state_tolerances returns the array it made last for the same states and parameters its slopes
    read (a mass, not a restitution), so the kernel's record keeps it; any other value, a new array
    with the values a fresh computation gives."""
    from switching.simulate import state_tolerances as module

    ball = bouncing_ball.build()
    values = {s.name: v for s, v in ball.parameter_values.items()}
    x = ball.initial_state()
    first = module.state_tolerances(ball, x)
    assert module.state_tolerances(ball, x.copy()) is first
    ball.set_parameter_values({**values, "e": 0.7})  # (the momentum's slope 1/m does not read e)
    assert module.state_tolerances(ball, x) is first
    ball.set_parameter_values({**values, "m": 2.0})
    heavier = module.state_tolerances(ball, x)
    momentum = [state.name for state in ball.states].index("p")
    assert heavier is not first and heavier[momentum] == 2 * first[momentum]  # (1e-9 N·s per kg)
    module._KEPT.clear()
    np.testing.assert_array_equal(module.state_tolerances(ball, x), heavier)
    assert module.state_tolerances(ball, x, 1e-6) is module.state_tolerances(ball, x, 1e-6)
    np.testing.assert_array_equal(module.state_tolerances(ball, x, 1e-6), np.full(2, 1e-6))


def test_a_loop_of_runs_keeps_its_options_and_the_kernel_record(monkeypatch):
    """Warm calls with the same options hand the kernel the same tolerances: the run's options and the
    compiled model's record are not rebuilt call after call."""
    ball = bouncing_ball.build()
    seen = []
    original = HybridRun.__init__

    def spy(self, model, options, *args, **kwargs):
        original(self, model, options, *args, **kwargs)
        seen.append(self.options)

    ball.simulate(4.02, "RK45-jit", rtol=1e-8)
    record = ball.compiled_model().record
    monkeypatch.setattr(HybridRun, "__init__", spy)
    for _ in range(3):
        ball.simulate(4.02, "RK45-jit", rtol=1e-8)
    assert seen[0] is seen[1] is seen[2]
    assert ball.compiled_model().record is record


def test_the_start_guard_check_is_kept_only_for_the_very_same_arguments():
    """The start's side check remembers sides that were all finite by everything they read
    (preflight._sides_key): the same model with a parameter, an initial state or a start time that
    makes a side non-finite is still stopped at once, after warm runs that passed."""
    model = relay("v/k >= v_hi", {"k": 1.0})
    values = {s.name: v for s, v in model.parameter_values.items()}
    for _ in range(2):
        model.simulate(1.0, "RK45-jit")
    model.set_parameter_values({**values, "k": 0.0})
    with pytest.raises(NonFiniteStateError, match="k = 0"):
        model.simulate(1.0, "RK45-jit")
    model.set_parameter_values(values)
    model.simulate(1.0, "RK45-jit", rtol=1e-7)  # (a tolerance study: the same start)
    inverse = relay("1/v <= 1/v_hi", {})  # (not finite where v = 0)
    for _ in range(2):
        inverse.simulate(1.0, "RK45-jit", x0=[0.5])
    with pytest.raises(NonFiniteStateError, match="'1/v <= 1/v_hi'"):
        inverse.simulate(1.0, "RK45-jit", x0=[0.0])
