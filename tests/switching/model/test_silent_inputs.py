"""Inputs that used to change results silently are refused by name (issue 33).

Texts read as booleans (``bool('off')`` is true), functions sympy knows only by
name, names with control characters: each is an error of the toolkit's
hierarchy naming the culprit, before anything runs.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from bondgraph import C, One, R, Zero
from bondgraph.errors import HybridBondGraphError, InvalidGraphError
from codegen.source import UnprintableExpressionError
from switching import Automaton, HybridModel
from switching.errors import ModelDefinitionError
from test_generated_code_safety import rc_relay


@pytest.mark.parametrize("value", ["off", "false", "on", "true", "", 0, 1, None, 1.0, [True]])
def test_junction_settings_are_booleans(value):
    with pytest.raises(ModelDefinitionError, match=r"automaton 'relay': state 'off' sets junction 'relay' to .*"
                                                   r"give True \(on\) or False \(off\)"):
        Automaton("relay", {"on": {"relay": True}, "off": {"relay": value}}, "on")


def test_numpy_booleans_are_booleans():
    automaton = Automaton("relay", {"on": {"relay": np.True_}, "off": {"relay": np.False_}}, "on")
    assert automaton.states == {"on": {"relay": True}, "off": {"relay": False}}
    assert all(type(v) is bool for setting in automaton.states.values() for v in setting.values())


@pytest.mark.parametrize("setting", [["relay"], "relay", {1: True}])
def test_a_state_maps_junction_names(setting):
    with pytest.raises(ModelDefinitionError, match="state 'off'"):
        Automaton("relay", {"on": {"relay": True}, "off": setting}, "on")


def _relay_with(guard=None, signals=None):
    model = rc_relay()
    automaton = Automaton("relay", {"on": {"relay": True}, "off": {"relay": False}}, "on")
    automaton.add_transition("on", "off", guard if guard is not None else "v >= v_hi")
    automaton.add_transition("off", "on", "v <= v_lo")
    return HybridModel(model.graph, [automaton], {s.name: v for s, v in model.parameter_values.items()},
                       signals=signals or {"v": sp.Symbol("q_C") / sp.Symbol("C")})


def test_a_guard_with_a_function_known_only_by_name_is_refused_by_name():
    foo = sp.Function("foo")
    with pytest.raises(ModelDefinitionError, match="the guard of relay: on → off uses the function.*'foo'"):
        _relay_with(guard=foo(sp.Symbol("q_C")) > 0)


def test_a_signal_with_a_function_known_only_by_name_is_refused_by_name():
    bar = sp.Function("bar")
    with pytest.raises(ModelDefinitionError, match="signal 'w' uses the function.*'bar'"):
        _relay_with(signals={"v": sp.Symbol("q_C") / sp.Symbol("C"), "w": bar(sp.Symbol("q_C"))})


def test_a_law_with_a_function_known_only_by_name_fails_with_the_toolkits_error():
    from bondgraph import BondGraph

    g = BondGraph("law")
    node = g.add(Zero("node"))
    g.connect(node, C("C", effort_law=lambda q: sp.Function("foo")(q)))  # (integral causality: no inversion)
    g.connect(node, R("R", "R"))
    model = HybridModel(g, [], {"R": 1.0})
    with pytest.raises(HybridBondGraphError) as raised:
        model.simulate(1.0)
    assert isinstance(raised.value, UnprintableExpressionError)
    assert "foo(q_C) has no numerical definition: foo is a function sympy knows only by name" in str(raised.value)


@pytest.mark.parametrize("name", ["C\n", "C\r\nx", "C\x00", "C\t", "C\u2028"])
def test_element_names_with_control_characters_are_refused(name):
    with pytest.raises(InvalidGraphError, match="invalid C name"):
        C(name, "C")
    with pytest.raises(InvalidGraphError):
        One(name)
