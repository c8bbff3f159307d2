"""A step's result reused for an expression of the same shape (bondgraph.shape_memo): the renamed result is the
one the step gives the expression itself, term for term; other shapes, kinds of symbol and assumptions are apart."""

import sympy as sp

from bondgraph.equations import tidy
from bondgraph.shape_memo import NotKept, ShapeMemo


def _contact_jump(k):
    """The velocity of ball k after an elastic contact with ball k + 1 (masses and velocities named by k)."""
    m1, m2 = sp.symbols(f"m{k} m{k + 1}", positive=True)
    v1, v2 = sp.symbols(f"ball{k}_v ball{k + 1}_v")
    e = sp.Symbol("e", positive=True)
    return (m1 * v1 + m2 * v2 - e * m2 * (v1 - v2)) / (m1 + m2) + v1 / (1 + m2 / m1)


def _counted(how):
    """``(calls, step)``: ``how`` as a step that lists the expressions it is called with."""
    calls = []

    def step(expr):
        calls.append(expr)
        return how(expr)

    return calls, step


def test_a_shape_met_again_takes_the_step_once_and_gives_its_own_result_term_for_term():
    calls, step = _counted(sp.cancel)
    memo = ShapeMemo()
    for k in (1, 2, 3, 5, 7):  # the names keep their order: m1 < m2 < ball1_v … as m7 < m8 < ball7_v …
        expected = sp.cancel(_contact_jump(k))
        found = memo(step, _contact_jump(k))
        assert found == expected and sp.srepr(found) == sp.srepr(expected)
        assert sp.simplify(found - _contact_jump(k)) == 0
    assert len(calls) == 1 and memo.hits == 4


def test_a_renaming_that_changes_the_names_order_is_another_shape():
    memo = ShapeMemo()
    calls, step = _counted(sp.cancel)
    memo(step, _contact_jump(8))
    found = memo(step, _contact_jump(9))  # m9 < m10 by number, not by name ("m10" < "m9")
    assert len(calls) == 2
    assert sp.srepr(found) == sp.srepr(sp.cancel(_contact_jump(9)))


def test_assumptions_other_kinds_of_symbol_and_two_symbols_of_one_name_are_apart():
    memo = ShapeMemo()
    calls, step = _counted(sp.simplify)
    x, y = sp.symbols("x y")
    px, py = sp.symbols("x y", positive=True)
    assert memo(step, sp.sqrt(x**2) + y) == sp.simplify(sp.sqrt(x**2) + y)
    assert memo(step, sp.sqrt(px**2) + py) == px + py  # not the first's result: positive symbols are another shape
    assert len(calls) == 2
    d = sp.Dummy("d")
    memo(step, d + x)
    memo(step, d + x)
    assert len(calls) == 4  # a Dummy: not memoised
    memo(step, x + px)
    memo(step, x + px)
    assert len(calls) == 6  # two symbols named x


def test_the_memo_keeps_at_most_its_size():
    memo = ShapeMemo(size=3)
    x = sp.Symbol("x")
    for power in range(1, 8):
        memo(sp.expand, (x + 1) ** power)
    assert len(memo.entries) == 3


def test_tidy_gives_the_shape_memos_result_of_a_contact_jump_as_its_own():
    for k in (11, 12, 13):
        direct = sp.cancel(_contact_jump(k))
        assert sp.srepr(tidy(_contact_jump(k))) == sp.srepr(direct)


def test_a_result_the_step_says_not_to_keep_is_returned_and_the_next_of_its_shape_runs_the_step_again():
    """A step whose budget ran out (NotKept) leaves the expression as it stands, for this one only."""
    memo = ShapeMemo()
    calls = []

    def step(expr):
        calls.append(expr)
        if len(calls) == 1:
            raise NotKept(expr)
        return sp.cancel(expr)

    first = _contact_jump(1)
    assert memo(step, first) is first and not memo.entries
    assert sp.srepr(memo(step, _contact_jump(2))) == sp.srepr(sp.cancel(_contact_jump(2)))
    memo(step, _contact_jump(3))
    assert len(calls) == 2 and memo.hits == 1


def test_tidy_past_its_budget_keeps_the_expression_and_keeps_nothing_for_its_shape(monkeypatch):
    from bondgraph import budget, equations

    def over(step, how, expr):
        raise budget.OverBudget(step, 0.0)

    memo = ShapeMemo()
    monkeypatch.setattr(equations, "_TIDIED", memo)
    monkeypatch.setattr(budget, "run", over)
    expr = _contact_jump(21)
    assert tidy(expr) is expr and not memo.entries
    monkeypatch.undo()
    monkeypatch.setattr(equations, "_TIDIED", memo)
    assert sp.srepr(tidy(_contact_jump(22))) == sp.srepr(sp.cancel(_contact_jump(22)))
    assert len(memo.entries) == 1
