"""Bad text never hangs the guard parser (issue 20).

Exponent towers, deep nesting, very long text, division by zero and numbers
that are not finite in double precision are refused at once, before sympy
computes anything, with a GuardSyntaxError (a ValueError) that names the
culprit, says what to do and puts its caret under the culprit; ordinary
guards parse as before.

Every call runs in a forked child process with a time limit: neither a signal
nor a watching thread can stop a computation stuck inside one C call (a
big-integer power in gmpy holds the interpreter), a child process can be
killed whatever it does.
"""

import multiprocessing
import sys

import pytest
import sympy as sp

from switching import Automaton, GuardSyntaxError, HybridModel, parse_condition, parse_expression
from switching.language.parsing import MAX_MINMAX_ARGUMENTS, MAX_NESTING, MAX_NUMBER_LENGTH, MAX_TOKENS
from switching_models import rc_graph

SECONDS = 5.0
x, y, r, a, v = sp.symbols("x y r a v")


def bounded(function, *args, seconds=SECONDS):
    """``function(*args)`` in a forked child: its result, or its exception
    raised here; the test fails if it takes longer than ``seconds``."""
    context = multiprocessing.get_context("fork")
    receive, send = context.Pipe(duplex=False)

    def child():
        try:
            outcome = ("returned", function(*args))
        except BaseException as error:  # noqa: BLE001 - everything goes back to the parent
            # tracebacks stay here: once distributed is imported (tblib), errors pickle with them,
            # and the traceback of a deeply nested parse is too deep to pickle
            chained = error
            while chained is not None:
                chained.__traceback__ = None
                chained = chained.__cause__ or chained.__context__
            outcome = ("raised", error)
        try:
            send.send(outcome)
        except Exception as error:  # noqa: BLE001
            send.send(("raised", AssertionError(f"the outcome {outcome!r} does not pickle: {error!r}")))

    process = context.Process(target=child, daemon=True)
    process.start()
    send.close()
    try:
        if not receive.poll(seconds):
            process.kill()
            pytest.fail(f"{getattr(function, '__name__', function)} took more than {seconds} s on {args!r:.200}")
        kind, payload = receive.recv()
    finally:
        process.join(timeout=10)
        receive.close()
    if kind == "raised":
        raise payload
    return payload


def refused(function, text, culprit, *words, at=None):
    """``function(text)`` raises a GuardSyntaxError whose message contains
    ``words`` and whose caret lies inside ``culprit`` (its first occurrence in
    ``text``, or the one starting at ``at``)."""
    with pytest.raises(GuardSyntaxError) as info:
        bounded(function, text)
    error = info.value
    assert isinstance(error, ValueError)
    message = str(error)
    for word in words:
        assert word in message, (word, message)
    start = text.index(culprit) if at is None else at
    assert text[start : start + len(culprit)] == culprit
    assert start <= error.position < start + len(culprit), (error.position, start, culprit)
    assert error.text == text
    assert message.splitlines()[-1] == "    " + " " * error.position + "^"
    return error


def same(derived, expected) -> bool:
    return sp.simplify(derived - expected) == 0


# -- the reproductions of issue 20


def test_exponent_tower_is_refused_at_once():
    error = refused(parse_condition, "v >= 9**9**9**9", "9**9**9**9", "'9**9**9'", "not a finite number")
    assert error.position == 8  # 9**(9**9), the first power beyond the largest double
    refused(parse_expression, "9**9**9**9", "9**9**9**9", "'9**9**9'", "not a finite number")
    refused(parse_expression, "2**-(9**9**9)", "9**9**9", "not a finite number")


def model_with_guard(guard):
    automaton = Automaton("switch", {"open": {"sw": False}, "closed": {"sw": True}}, "open")
    automaton.add_transition("open", "closed", guard)
    return HybridModel(rc_graph(), [automaton], {"V0": 1, "R": 1, "C": 1})


def test_exponent_tower_in_a_model_guard_is_refused_at_once():
    refused(model_with_guard, "q_C >= 9**9**9**9", "9**9**9**9", "'9**9**9'", "not a finite number")


def test_a_model_guard_within_the_limits_still_builds():
    def guard_of(text):
        model = model_with_guard(text)
        ((_, _, condition, _),) = model.guards_from(model.mode("open"))
        return condition

    condition = bounded(guard_of, "q_C >= 2**-3")
    assert isinstance(condition, sp.Ge) and condition.rhs == sp.Rational(1, 8)


def test_150_nested_parentheses_are_a_guard_syntax_error_not_a_recursion_error():
    text = "(" * 150 + "x" + ")" * 150 + " > 0"
    refused(parse_condition, text, "(", f"nesting deeper than {MAX_NESTING} levels", "split", at=MAX_NESTING)


def test_nesting_at_the_limit_parses():
    text = "(" * MAX_NESTING + "x" + ")" * MAX_NESTING + " > 0"
    assert bounded(parse_condition, text) == sp.Gt(x, 0)


def test_nesting_just_beyond_the_limit_is_refused():
    depth = MAX_NESTING + 1
    text = "(" * depth + "x" + ")" * depth + " > 0"
    error = refused(parse_condition, text, "(", f"nesting deeper than {MAX_NESTING} levels", at=MAX_NESTING)
    assert f"position {MAX_NESTING}" in str(error)


@pytest.mark.parametrize(
    "text, at",
    [
        ("-" * 150 + "x > 0", MAX_NESTING),  # prefix signs: the 101st '-'
        ("not " * 150 + "x > 0", 4 * MAX_NESTING),
        ("sin(" * 150 + "x" + ")" * 150 + " > 0", 4 * MAX_NESTING),  # function calls
        ("2**" * 150 + "2 > x", 3 * MAX_NESTING + 1),  # exponents: the 101st '**', before any power is computed
        ("-(" * 75 + "x" + ")" * 75 + " > 0", MAX_NESTING),  # a sign and a parenthesis: two levels a step
    ],
)
def test_every_kind_of_nesting_counts(text, at):
    refused(parse_condition, text, text[at], f"nesting deeper than {MAX_NESTING} levels", at=at)


def test_deep_nesting_parses_from_a_deep_python_stack():
    """The parser makes room on Python's stack for MAX_NESTING levels whatever
    the depth of its caller, and gives the recursion limit back."""
    text = "(" * MAX_NESTING + "x" + ")" * MAX_NESTING + " > 0"

    def stack_depth():
        frame, depth = sys._getframe(), 0
        while frame is not None:
            frame, depth = frame.f_back, depth + 1
        return depth

    def at_depth(n):
        if n > 0:
            return at_depth(n - 1)
        return parse_condition(text), sys.getrecursionlimit()

    def deep():
        limit = sys.getrecursionlimit()
        return at_depth(limit - stack_depth() - 30), limit  # 30 frames to spare when the parse starts

    (condition, limit_after), limit_before = bounded(deep)
    assert condition == sp.Gt(x, 0)
    assert limit_after == limit_before


def test_long_text_is_refused():
    terms = MAX_TOKENS // 2 + 1  # 'x1 + x2 + …': one token more than the limit
    text = " + ".join(f"x{i}" for i in range(terms))
    excess = text.rindex(f"x{terms - 1}")  # token number MAX_TOKENS (from 0)
    error = refused(parse_expression, text, text[excess:], f"longer than {MAX_TOKENS} tokens", "split", at=excess)
    assert error.position == excess


def test_long_hierarchical_name_is_refused_at_once():
    text = "a/" * 5000 + "b"  # split into 'a' / 'a' / … / 'a/b': 10 000 tokens
    with pytest.raises(GuardSyntaxError, match=f"longer than {MAX_TOKENS} tokens"):
        bounded(parse_expression, text, {"a/b": sp.Symbol("a/b")})


def test_text_at_the_token_limit_parses():
    text = "-x" + "+1" * ((MAX_TOKENS - 2) // 2)  # exactly MAX_TOKENS tokens
    assert same(bounded(parse_expression, text), (MAX_TOKENS - 2) // 2 - x)


def test_division_by_a_literal_zero():
    error = refused(parse_condition, "x > 1/0", "0", "division by zero", "'1/0'", at=6)
    assert "zoo" not in str(error)


@pytest.mark.parametrize(
    "text, culprit, words",
    [
        ("x > y/(2-2)", "(2-2)", ["division by zero", "'(2-2)'"]),
        ("x > y/0.0", "0.0", ["division by zero"]),
        ("x > 0**-1", "0**-1", ["negative power", "division by zero"]),
        ("x > log(0)", "log(0)", ["'log(0)' is not a finite number"]),
        ("x > tan(pi/2)", "tan(pi/2)", ["'tan(pi/2)' is not a finite number", "zoo"]),
        ("x > atan2(0, 0)", "atan2(0, 0)", ["not a finite number", "NaN"]),
    ],
)
def test_other_divisions_by_zero_and_undefined_values(text, culprit, words):
    refused(parse_condition, text, culprit, *words)


def test_float_literal_that_overflows():
    refused(parse_condition, "v >= 1e400", "1e400", "'1e400' is not a finite number")


@pytest.mark.parametrize(
    "text, culprit",
    [
        ("v >= -1e400", "1e400"),
        ("v >= 1e300*1e300", "1e300*1e300"),
        ("v >= 10**400", "10**400"),
        ("v >= exp(1000)", "exp(1000)"),
        ("v >= 1.7e308 + 1e308", "1.7e308 + 1e308"),
    ],
)
def test_numbers_beyond_the_largest_double(text, culprit):
    refused(parse_condition, text, culprit, f"'{culprit}' is not a finite number")


@pytest.mark.parametrize(
    "text, culprit", [("v >= 1e-400", "1e-400"), ("v >= 2**-2000", "2**-2000"), ("v >= 1e-200*1e-200", "1e-200*1e-200")]
)
def test_nonzero_numbers_that_round_to_zero(text, culprit):
    refused(parse_condition, text, culprit, f"'{culprit}' underflows to 0")


def test_huge_integer_literal():
    digits = "1" + "7" * 5000
    error = refused(parse_condition, f"v >= {digits}", digits, "not a finite number", "(5001 characters)")
    assert error.position == 5


def test_long_number_literal_within_range():
    digits = "1" + "0" * MAX_NUMBER_LENGTH  # 1e100, written out
    refused(parse_condition, f"v >= {digits}", digits, f"longer than {MAX_NUMBER_LENGTH} characters", "1.5e300")


@pytest.mark.parametrize(
    "text, culprit", [("x**(9**9) > 0", "(9**9)"), ("x**1e300 > 0", "1e300"), ("(x + 1)**-5000 > 0", "-5000")]
)
def test_huge_exponent_of_a_quantity(text, culprit):
    refused(parse_condition, text, culprit, "beyond ±1000", "rescale")


def test_exact_fractions_that_would_grow_without_bound():
    refused(parse_condition, "x > (1 + 1/10**30)**(10**6)", "(1 + 1/10**30)**(10**6)", "exact fraction", "decimal")
    text = "x > " + " + ".join(f"1/{10**29 + 2 * i + 1}" for i in range(60))
    refused(parse_condition, text, text[4:], "exact fraction", "decimals")


def test_min_max_take_a_bounded_number_of_values():
    many = ", ".join(f"x{i}" for i in range(MAX_MINMAX_ARGUMENTS + 1))
    refused(parse_condition, f"max({many}) > 0", "max", f"at most {MAX_MINMAX_ARGUMENTS}")
    refused(parse_condition, "min(min(a, b, c, d, e), f, g, h, i) > 0", "min", f"at most {MAX_MINMAX_ARGUMENTS}", at=0)
    assert bounded(parse_expression, "max(a, b, c)") == sp.Max(a, *sp.symbols("b c"))


# -- what stays as it was


def test_ordinary_guards_parse_to_the_same_sympy():
    circle = bounded(parse_condition, "x**2 + y**2 <= r**2")
    assert isinstance(circle, sp.Le) and same(circle.lhs, x**2 + y**2) and same(circle.rhs, r**2)
    assert same(bounded(parse_expression, "a^2"), a**2)
    assert same(bounded(parse_expression, "2**-3"), sp.Rational(1, 8))
    tiny = bounded(parse_condition, "v >= 1e-300")
    assert isinstance(tiny, sp.Ge) and tiny.lhs == v and same(tiny.rhs, sp.Float("1e-300"))
    deep = bounded(parse_condition, "(" * 99 + "x + 1" + ")" * 99 + " > 0")
    assert isinstance(deep, sp.Gt) and same(deep.lhs, x + 1) and deep.rhs == 0


def test_numbers_near_the_limits_still_parse():
    assert same(bounded(parse_expression, "2**1000"), sp.Integer(2) ** 1000)
    assert same(bounded(parse_expression, "2**-1074"), sp.Rational(1, 2**1074))  # the smallest double
    assert same(bounded(parse_expression, "1.7e308 - x"), sp.Float("1.7e308") - x)
    assert same(bounded(parse_expression, "x**1000 + x**-1000"), x**1000 + x**-1000)
    assert same(bounded(parse_expression, "(-1)**(9**9)"), -1)
    assert same(bounded(parse_expression, "exp(700)*x"), sp.exp(700) * x)
    assert same(bounded(parse_expression, "log(x, 10)"), sp.log(x) / sp.log(10))
