"""The floating check of a circuit found on its netlist (models/circuit_topology.py):
the same answer as checking every mode, at the cost of a few checks."""

from __future__ import annotations

import random

import pytest

from bondgraph.errors import HybridBondGraphError
from models.circuit_topology import first_floating_mode, floating_witnesses, tie_groups, witness_modes
from models.circuits import Circuit, floating_modes
from models.netlists import bridges, ladder, parallel_switches


def random_circuit(rng: random.Random) -> Circuit:
    """A small random netlist: nodes 0, a, b, c; resistors, capacitors, inductors, sources, diodes (with
    or without r_on) and switches between random pairs."""
    c = Circuit("random")
    nodes = ["0", "a", "b", "c"]
    kinds = ["R", "R", "C", "L", "V", "I", "D", "D", "Dr", "S"]
    for k in range(rng.randint(3, 7)):
        kind = rng.choice(kinds)
        n1, n2 = rng.sample(nodes, 2)
        name = f"{kind}{k}"
        if kind == "R":
            c.R(name, n1, n2, 10.0)
        elif kind == "C":
            c.C(name, n1, n2, 1e-3)
        elif kind == "L":
            c.L(name, n1, n2, 1e-3)
        elif kind == "V":
            c.V(name, n1, n2, 5.0)
        elif kind == "I":
            c.I(name, n1, n2, 1.0)
        elif kind == "D":
            c.diode(name, n1, n2)
        elif kind == "Dr":
            c.diode(name, n1, n2, r_on=0.1)
        else:
            c.switch(name, n1, n2, "t < 1")
    return c


def compare(seed: int, count: int) -> tuple[int, int]:
    """Compare the netlist's answers with every mode's on ``count`` random circuits: every witness
    floats (it is among every mode's floating ones); some witness exists when a mode floats; the check
    the build uses (witnesses, then every mode when a conflict hid them) finds a floating mode exactly
    when one exists.  Returns (circuits that float, of those the witnesses alone found)."""
    rng = random.Random(seed)
    compared = floating = found = 0
    while compared < count:
        circuit = random_circuit(rng)
        try:
            model = circuit.build(allow_floating=True)
        except HybridBondGraphError:  # a topology the circuit refuses whatever its modes
            continue
        parts = list(circuit._parts.values())
        every = floating_modes(model)
        witnesses = floating_witnesses(parts, model)
        assert all(mode in [m for m, _ in every] for mode, _ in witnesses), (circuit._parts, witnesses)
        assert bool(witness_modes(parts, model)) or not every, (circuit._parts, every)
        assert (first_floating_mode(parts, model, floating_modes) is not None) == bool(every), circuit._parts
        compared += 1
        floating += bool(every)
        found += bool(witnesses)
    return floating, found


def test_the_netlist_finds_a_floating_mode_exactly_when_one_of_every_mode_floats():
    floating, found = compare(41, 120)
    assert floating >= 20 and found == floating  # both answers are met; no witness hidden here


@pytest.mark.slow
def test_the_netlist_finds_a_floating_mode_exactly_when_one_of_every_mode_floats_many():
    floating, found = compare(4141, 3000)
    assert floating >= 500 and found >= 0.99 * floating, (floating, found)


def test_bridges_beyond_a_thousand_modes_are_checked_and_each_floating_load_found():
    circuit = bridges(3)  # 2^12 modes: beyond what enumerating every mode checked
    model = circuit.build(allow_floating=True)
    witnesses = floating_witnesses(list(circuit._parts.values()), model)
    ((mode, error),) = witnesses  # every diode blocking (their initial states): all three loads float at once
    assert set(error.elements) == {f"node_{side}{k}" for side in "pn" for k in range(3)} and error.kind == "effort"
    assert set(mode.states) == {"blocking"}
    assert circuit.build().mode_equations(witnesses[0][0]).f  # each runs as the limit of vanishing leaks


def test_switches_in_parallel_are_a_free_loop_whatever_their_number():
    c = parallel_switches(24)
    model = c.build(allow_floating=True)
    ((mode, error),) = floating_witnesses(list(c._parts.values()), model, limit=1)
    assert error.kind == "flow" and "loop" in str(error) and len(error.elements) >= 2


def test_a_long_ladder_is_one_tie_group_with_ground():
    c = ladder(400)
    assert len(tie_groups(c._parts.values())) == 1
    model = c.build()
    assert len(model.states) == 400
