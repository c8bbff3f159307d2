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

import models
from bondgraph.errors import HybridBondGraphError, NameCollisionError
from switching import load_model

from name_scenes import (SCENES, file_renaming, file_roles, fresh_names, hierarchy_parts, pattern_names, renamed,
                         renamed_text, same_tables)

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

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


# -- every shipped model, renamed in its model file

#: the part of a shipped model's own run the comparison takes (its converters' first tens of periods)
SHIPPED_FRACTION = 0.1


def shipped_run(model, name: str):
    settings = dict(getattr(models.load(name), "RUN", {}))
    t_end = settings.pop("t_end") * SHIPPED_FRACTION
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return model.simulate(t_end, **settings)


_SHIPPED = {}


def shipped(name: str, folder):
    """(the model file's text, its table, the run of the model it holds) of the shipped model ``name``."""
    if name not in _SHIPPED:
        path = folder / f"{name}.toml"
        models.load(name).build().save(path)
        text = path.read_text()
        _SHIPPED[name] = (text, tomllib.loads(text), shipped_run(load_model(path), name))
    return _SHIPPED[name]


def check_shipped(name: str, seed: int, folder) -> str:
    """The shipped model ``name`` with one name renamed (drawn by ``seed``) to one a pattern makes of its
    other names or one its namespace holds: ``"same"`` run, or ``"refused"`` naming the name."""
    text, table, reference = shipped(name, folder)
    rng = random.Random(seed)
    parts = hierarchy_parts(text)
    roles = file_roles(table, parts)
    old = rng.choice(sorted(roles))
    namespace = reference.model.namespace
    if rng.random() < 0.5:  # a name the model has (a key of a table that has the old name breaks the file)
        pool = [n for n in namespace if namespace.owner(n).kind != "word" and re.fullmatch(r"[A-Za-z_]\w*", n)]
    else:  # a name a pattern makes of the model's other names
        pool = [n for n in pattern_names({r: r for r in roles if r != old}) if n not in set(roles) | set(namespace)
                or n in ("t", "pi")]
    new = rng.choice(sorted(set(pool) - same_tables(table, old) - parts))
    path = folder / f"{name}-{seed}.toml"
    path.write_text(renamed_text(text, file_renaming(table, old, new)))
    try:
        run = shipped_run(load_model(path), name)
    except HybridBondGraphError as error:
        message = str(error)
        assert new in message, (old, new, message)
        return "refused"
    same_run(run, reference)
    return "same"


def shipped_outcomes(seeds, folder) -> dict:
    counts = {"same": 0, "refused": 0}
    names = sorted(models.MODELS)
    for seed in seeds:
        counts[check_shipped(names[seed % len(names)], seed, folder)] += 1
    return counts


def test_every_shipped_model_renamed_to_generated_names_runs_the_same_or_is_refused_by_name(tmp_path):
    counts = shipped_outcomes(range(44), tmp_path)  # four renamings of each of the eleven models
    assert counts["same"] >= 10 and counts["refused"] >= 5, counts


@pytest.mark.slow
def test_every_shipped_model_renamed_to_generated_names_runs_the_same_or_is_refused_by_name_many(tmp_path):
    counts = shipped_outcomes(range(44, 374), tmp_path)
    assert counts["same"] >= 80 and counts["refused"] >= 40, counts
