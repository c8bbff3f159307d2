"""Resolution of an instant: ideal diodes at rest and the guards an engineer writes first."""

import math

import pytest
import sympy as sp

from bondgraph import BondGraph, One, R, Se, Zero, t
from switching import Automaton, HybridModel
from switching.errors import DivergenceOfTimeError

W = 2 * math.pi * 50


def half_wave(turn_on: str, turn_off: str) -> HybridModel:
    """A source ``Vm sin(w t)`` feeding a resistor through an ideal diode
    (a controlled 1-junction): the diode starts off at v_D = 0, i_D = 0."""
    g = BondGraph("half_wave")
    node, diode = g.add(Zero("n")), g.add(One("D", controlled=True))
    g.connect(Se("Vs", sp.Symbol("Vm") * sp.sin(sp.Symbol("w") * t)), diode, name="source")
    g.connect(diode, node, name="diode_out")
    g.connect(node, R("Rload", "Rload"))
    automaton = Automaton("D", {"off": {"D": False}, "on": {"D": True}}, "off")
    automaton.add_transition("off", "on", turn_on, "a posteriori")
    automaton.add_transition("on", "off", turn_off, "a posteriori")
    return HybridModel(g, [automaton], {"Vm": 10.0, "w": W, "Rload": 1e3},
                       signals={"v_D": "e_source - e_diode_out", "i_D": "f_source"}, name="half_wave")


def test_a_real_loop_is_not_called_a_tie():
    # off → on when v_D >= −1 holds with room to spare, on → off at a tie (i_D = 0): no cycle of ties
    # (tests/switching/rules/test_edge_ties.py has those), a divergence with the usual advice too
    with pytest.raises(DivergenceOfTimeError) as info:
        half_wave("v_D >= -1", "i_D <= 0").simulate(0.03, "RK45")
    assert "so this is no cycle of ties" in str(info.value)
    assert "Make the guards leave only one mode consistent" in str(info.value)


def test_strict_diode_guards_leave_the_diode_at_rest_and_flow_turns_it_on():
    run = half_wave("v_D > 0", "i_D < 0").simulate(0.03, "RK45", rtol=1e-10, atol=1e-14)
    labels = [[s.mode.label for s in e.steps] for e in run.events]
    assert labels[0] == ["off", "on"] and run.events[0].t < 1e-12   # v_D = Vm sin(w t) > 0 at once
    assert labels[1] == ["on", "off"]
    assert run.events[1].t == pytest.approx(math.pi / W, rel=1e-9)  # the current Vm sin(w t)/R crosses 0
    assert labels[2] == ["off", "on"]
    assert run.events[2].t == pytest.approx(2 * math.pi / W, rel=1e-9)
