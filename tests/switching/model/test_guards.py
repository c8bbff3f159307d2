"""Guard language, impulsive comparisons and automaton/model definition errors."""

import pytest
import sympy as sp
from switching_models import ball_row, diode_circuit, rc_graph

from bondgraph import MissingParameterError, UnknownParameterError
from codegen.runtime import H, Hyper, PulseError, decide
from switching import Automaton, GuardSyntaxError, HybridModel, ModelDefinitionError, parse_condition, parse_expression

x, y, a, b = sp.symbols("x y a b")


def test_parse_precedence_and_logic():
    c = parse_condition("x + 2*y**2 <= 3 and not (a > b or x == 1)")
    expected = sp.And(sp.Le(x + 2 * y**2, 3), sp.Not(sp.Or(sp.Gt(a, b), sp.Eq(x, 1))))
    assert c == expected
    assert parse_condition("x < y && y != 2 || !(a >= 0)") == sp.Or(sp.And(x < y, sp.Ne(y, 2)), sp.Not(a >= 0))
    assert parse_expression("-x^2 + abs(y)/2 - max(a, b)") == -(x**2) + sp.Abs(y) / 2 - sp.Max(a, b)
    assert parse_expression("2.5e-3*x + .5") == sp.Float("2.5e-3") * x + sp.Float(0.5)


def test_step_and_heaviside_are_the_right_continuous_unit_step():
    """``step(x) = Heaviside(x) = H(x)`` with ``H(0) = 1``; ``Heaviside(x, h0)`` sets the value at 0
    (``Heaviside(x, 1/2)`` is sympy's ``Heaviside(x)``)."""
    t, t1, V = sp.symbols("t t1 V")
    source = parse_expression("V*step(t - t1)", {"t": t})
    assert sp.simplify(source - V * sp.Heaviside(t - t1, 1)) == 0
    assert parse_expression("Heaviside(x)") == sp.Heaviside(x, 1) == parse_expression("step(x)")
    assert parse_expression("Heaviside(x, 1/2)") == sp.Heaviside(x)
    assert source.subs({t: 2, t1: 2}) == V and source.subs({t: 1, t1: 2}) == 0  # on from t1 itself
    values = [parse_expression(text) for text in ("step(0)", "step(-1e-300)", "step(3)", "Heaviside(0, 0.25)")]
    assert values == [1, 0, 1, 0.25]
    assert parse_condition("step(t - 1) > 1/2", {"t": t}) == sp.Gt(sp.Heaviside(t - 1, 1), sp.Rational(1, 2))


def test_chained_comparison_is_a_conjunction():
    assert parse_condition("0 <= x < 1") == sp.And(sp.Le(0, x, evaluate=False), sp.Lt(x, 1))


def test_hierarchical_names_and_division():
    theta, rod_y = sp.Symbol("rod/theta"), sp.Symbol("rod/y")
    names = {"rod/theta": theta, "rod/y": rod_y}
    assert parse_expression("rod/y - l*sin(rod/theta)", names) == rod_y - sp.Symbol("l") * sp.sin(theta)
    assert parse_expression("rod/y/m", names) == rod_y / sp.Symbol("m")
    assert parse_expression("a/b") == a / b  # unknown: a division


def test_text_is_never_executed():
    # looks like code, is parsed as names or refused
    with pytest.raises(GuardSyntaxError) as info:
        parse_condition("__import__('os').system('echo hi') > 0")
    assert "unexpected character" in str(info.value) and "^" in str(info.value)
    with pytest.raises(GuardSyntaxError, match="unknown function 'eval'"):
        parse_condition("eval(x) > 0")


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("x +", "expected a number"),
        ("x > ", "expected a number"),
        ("(x > 1", "expected ')'"),
        ("x + 1", "not a condition"),
        ("(x > 1) + 2 > 0", "a condition is used where a number is expected"),
        ("sin(x, y) > 0", "wrong number of arguments"),
        ("step(x, y) > 0", "wrong number of arguments to step()"),
        ("Heaviside(x, y, a) > 0", "wrong number of arguments to Heaviside()"),
        ("step() > 0", "expected a number"),
        ("x > 1 y", "unexpected 'y'"),
        ("", "non-empty"),
    ],
)
def test_syntax_errors_point_at_the_problem(text, fragment):
    with pytest.raises(GuardSyntaxError) as info:
        parse_condition(text)
    assert fragment in str(info.value)


def test_impulsive_arithmetic_and_comparisons():
    # x carries an impulse of area -3 on top of its finite value 2
    xv, yv, av = Hyper(-3.0, 2.0), -1.0, 0.5
    value = abs(xv) - av * yv
    assert (value.impulse, value.finite) == (3.0, -2.0 + 0.5)
    big = Hyper(1.0, -100.0)
    assert decide(">", big, 1e9, 1e-11, 1e-14)  # a positive pulse beats any finite value
    assert decide("<=", Hyper(-1e-3, 5.0), 0.0, 1e-11, 1e-14)
    # equal pulses: the finite parts decide (the paper's Lemma 5.3)
    assert decide(">", Hyper(2.0, 1.0), Hyper(2.0, 0.5), 1e-11, 1e-14)
    assert not decide(">", Hyper(2.0, 0.5), Hyper(2.0, 1.0), 1e-11, 1e-14)
    with pytest.raises(PulseError, match="two Dirac pulses"):
        Hyper(1.0, 0.0) * Hyper(1.0, 0.0)
    with pytest.raises(PulseError, match="sin of a Dirac pulse"):
        H.sin(Hyper(1.0, 0.0))
    with pytest.raises(PulseError, match="denominator"):
        1.0 / Hyper(1.0, 2.0)


def test_tolerance_band_separates_le_from_lt():
    rtol, atol = 1e-9, 1e-12
    at, one = 1.0 + 1e-12, 1.0
    assert decide("<=", at, one, rtol, atol) and not decide("<", at, one, rtol, atol)
    assert decide(">=", one, at, rtol, atol) and not decide(">", one, at, rtol, atol)
    assert decide("==", at, one, rtol, atol) and not decide("!=", at, one, rtol, atol)


def switch_automaton(**kwargs):
    return Automaton("switch", {"open": {"sw": False}, "closed": {"sw": True}}, "open", **kwargs)


def test_model_definition_errors_name_the_culprit():
    g = rc_graph()
    with pytest.raises(ModelDefinitionError, match="'sw'.*driven by no automaton"):
        HybridModel(g, [], {"V0": 1, "R": 1, "C": 1})
    other = Automaton("other", {"a": {"nope": True}}, "a")
    with pytest.raises(ModelDefinitionError, match="'nope', which is not in graph"):
        HybridModel(g, [switch_automaton(), other], {"V0": 1, "R": 1, "C": 1})
    twice = Automaton("twice", {"a": {"sw": True}}, "a")
    with pytest.raises(ModelDefinitionError, match="switched by both 'switch' and 'twice'"):
        HybridModel(g, [switch_automaton(), twice], {"V0": 1, "R": 1, "C": 1})
    with pytest.raises(ModelDefinitionError, match="initial state 'shut'"):
        Automaton("s", {"open": {"sw": False}}, "shut")
    with pytest.raises(ModelDefinitionError, match="same junctions"):
        Automaton("s", {"open": {"sw": False}, "closed": {"sw2": True}}, "open")
    automaton = switch_automaton()
    with pytest.raises(ModelDefinitionError, match="unknown state 'ajar'"):
        automaton.add_transition("open", "ajar", "t > 1")
    with pytest.raises(ModelDefinitionError, match="'a priori' or 'a posteriori'"):
        automaton.add_transition("open", "closed", "t > 1", "sometimes")


def test_guard_parameters_are_required_all_at_once():
    automaton = switch_automaton()
    automaton.add_transition("open", "closed", "q_C <= q_min and t >= t_on")
    with pytest.raises(MissingParameterError) as info:
        HybridModel(rc_graph(), [automaton], {"V0": 1})
    assert info.value.missing == ("C", "R", "q_min", "t_on")
    with pytest.raises(UnknownParameterError, match="Rr"):
        HybridModel(rc_graph(), [automaton], {"V0": 1, "R": 1, "C": 1, "q_min": 0, "t_on": 0, "Rr": 2})


def test_conflicting_restitution_in_one_mode_is_refused():
    model = ball_row([1.0, 1.0, 1.0], 0.5)
    model.automata[1].restitution["collide"] = sp.Symbol("e") / 2
    with pytest.raises(ModelDefinitionError, match="different restitution"):
        model.mode_equations("collide|collide")


def test_mode_lookup_by_label_tuple_and_mapping():
    model = diode_circuit()
    assert model.mode("open|on") == model.mode(("open", "on")) == model.mode({"switch": "open", "diode": "on"})
    from bondgraph import UnknownNameError

    with pytest.raises(UnknownNameError, match="no state 'ajar'"):
        model.mode("ajar|on")
    with pytest.raises(UnknownNameError, match="2 automata"):
        model.mode("open")


def test_mode_equations_print_f_g_and_guards():
    text = diode_circuit().mode_equations("open|off").pretty()
    assert "p_L⁺ = 0" in text and "off → on when v_D >= V_th (a posteriori)" in text


def test_guards_as_sympy_relations_over_signal_symbols():
    """A guard given as a sympy condition, over a named signal's symbol, behaves
    like the same guard written as text."""
    import numpy as np

    def model_with(guard):
        automaton = switch_automaton()
        automaton.add_transition("open", "closed", guard)
        return HybridModel(rc_graph(), [automaton], {"V0": 1, "R": 1, "C": 1, "v_on": 0.5},
                           initial_state={"q_C": 0.2}, signals={"v": "q_C/C"})

    v, v_on = sp.symbols("v v_on")
    as_sympy = model_with(sp.And(sp.Le(v, v_on), sp.Symbol("t") >= 1))
    as_text = model_with("v <= v_on and t >= 1")
    for model in (as_sympy, as_text):
        assert [s.kind for s in model.resolve(np.array([0.2]), "open", 1.0).steps] == ["start", "continuous"]
        assert model.resolve(np.array([0.2]), "open", 0.5).mode_after.label == "open"
        assert model.resolve(np.array([0.9]), "open", 1.0).mode_after.label == "open"


def test_divisions_of_names_read_alike_with_and_without_the_bound_of_the_longest_name(monkeypatch):
    """A run of names divided by ``/`` is read as the longest known names, divided: the run of a few parts
    (``p2/m``) by trying every join of its parts, without looking at every known name (a scene's thousand
    texts against thousands of names); a long run within the parts of the longest known name — the same
    tokens either way."""
    import random

    from switching.language import parsing

    class Looked(dict):
        looks = 0

        def __iter__(self):
            Looked.looks += 1
            return super().__iter__()

    rng = random.Random(46)
    known = ["a/b", "a/b/c", "b/c", "c/a/b/a", "a", "d/e/f/g/h/i/j/k/l"]
    names = Looked({n: sp.Symbol(n) for n in known})
    for _ in range(300):
        text = "/".join(rng.choice("abcdefghijkl") for _ in range(rng.randint(2, 14)))
        free = parsing._tokenize(text, names)
        monkeypatch.setattr(parsing, "_PARTS_TRIED", 0)
        assert parsing._tokenize(text, names) == free, text
        monkeypatch.setattr(parsing, "_PARTS_TRIED", 8)
    Looked.looks = 0
    p1, p2, m = sp.symbols("p1 p2 m")
    assert sp.simplify(parse_expression("p2/m - p1/m", Looked(p2=p2)) - (p2 - p1) / m) == 0
    assert Looked.looks == 0
