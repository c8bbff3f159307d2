"""One namespace, as a property: a circuit or mechanism whose components,
nodes and parameters are renamed to the names the builders and the bond
graph make (``<name>_period``, ``f_<bond>``, ``q_<C>``, ``node_<n>``, ``t``,
``gmin``, …; tests/models/name_scenes.py) runs as it does with fresh names —
the same instants, modes and states — or is refused, by a
:class:`~bondgraph.errors.NameCollisionError` that names the name and both
its owners.  A seeded generator draws the renamings; the default suite
draws a few hundred, the slow set many more."""

from __future__ import annotations

import random
import re
import warnings

import numpy as np
import pytest

from bondgraph.errors import NameCollisionError

from name_scenes import SCENES, fresh_names, renamed

#: agreement of a renamed run with the fresh one: sympy orders the terms of a sum by their symbols'
#: names, so renaming may change the last bits of each step; the runs' tolerance (rtol 1e-9) bounds
#: how far that moves an instant or a state
RTOL = 1e-7


def run_of(scene: str, names: dict):
    netlist, build, run = SCENES[scene][0](names)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return netlist.build(**build).simulate(**run)


_FRESH = {}


def fresh_run(scene: str):
    if scene not in _FRESH:
        _FRESH[scene] = run_of(scene, fresh_names(scene))
    return _FRESH[scene]


def same_run(run, reference) -> None:
    """The same instants (modes passed and their kinds) and states as ``reference``, to :data:`RTOL`."""
    assert len(run.events) == len(reference.events)
    for event, expected in zip(run.events, reference.events):
        assert [(s.mode.states, s.kind) for s in event.steps] == [(s.mode.states, s.kind) for s in expected.steps]
    np.testing.assert_allclose(run.event_times, reference.event_times, rtol=RTOL, atol=0)
    scale = np.max(np.abs(reference.x), axis=0) + 1e-300
    np.testing.assert_allclose(run.x[-1] / scale, reference.x[-1] / scale, rtol=0, atol=RTOL)


def check(scene: str, seed: int, how_many: int) -> str:
    """Run ``scene`` renamed by ``seed``: ``"same"`` or ``"refused"`` (anything else fails)."""
    rng = random.Random(seed)
    namespace = fresh_run(scene).model.namespace
    made = [n for n in namespace if n not in fresh_names(scene).values() and namespace.owner(n).kind != "word"
            and re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", n)]  # not the rates d<state>/dt: no component's name
    fresh, names = renamed(scene, rng, how_many, made)
    chosen = {names[r] for r in names if names[r] != fresh[r]}
    try:
        run = run_of(scene, names)
    except NameCollisionError as error:
        message = str(error)
        assert error.name and repr(error.name) in message and len(error.owners) == 2, message
        assert all(owner in message for owner in error.owners), message
        assert "rename" in message or "give" in message, message
        # the name is one the renaming chose, or one a builder made of a chosen name
        assert any(error.name == c or re.search(rf"(^|_){re.escape(c)}($|_)", error.name) for c in chosen), \
            (error.name, chosen)
        return "refused"
    same_run(run, fresh_run(scene))
    return "same"


def outcomes(seeds, how_many_of) -> dict:
    counts = {"same": 0, "refused": 0}
    scenes = sorted(SCENES)
    for seed in seeds:
        scene = scenes[seed % len(scenes)]
        counts[check(scene, seed, how_many_of(seed))] += 1
    return counts


def test_renamed_to_generated_names_runs_the_same_or_is_refused_by_name():
    counts = outcomes(range(200), lambda seed: 1 + seed % 2)
    # both outcomes occur: names a generated pattern takes are refused, the others run the same
    assert counts["same"] >= 50 and counts["refused"] >= 30, counts


@pytest.mark.slow
def test_renamed_to_generated_names_runs_the_same_or_is_refused_by_name_many():
    counts = outcomes(range(200, 1400), lambda seed: 1 + seed % 3)
    assert counts["same"] >= 300 and counts["refused"] >= 150, counts
