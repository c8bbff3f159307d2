"""The semantics written once (switching.rules): each rule is defined in its
rule module and nowhere else, the Python path and the kernel use that very
function, and it gives the same results called and compiled."""

import ast
import math
import random
from pathlib import Path

import pytest

from switching import rules
from switching.rules import instants
from switching.rules.maximize import GOLDEN, maximize_begin, maximize_next
from checkout import ROOT

PACKAGES = ("bondgraph", "codegen", "models", "switching")


def _rule_names():
    """Each rule's name (and its module's, e.g. ``maximize``) → the rule module's file."""
    names = {}
    for module in rules.MODULES:
        path = Path(module.__file__).resolve()
        names[module.__name__.rsplit(".", 1)[1]] = path
        for name in module.RULES:
            names[name] = path
    return names


def test_the_rule_modules_list_their_rules():
    """``RULES`` of a rule module names exactly its public functions, each
    defined there (not imported)."""
    for module in rules.MODULES:
        tree = ast.parse(Path(module.__file__).read_text())
        public = {n.name for n in tree.body if isinstance(n, ast.FunctionDef) and not n.name.startswith("_")}
        assert set(module.RULES) == public, module.__name__
        for name in module.RULES:
            assert getattr(module, name).__module__ == module.__name__


def test_no_rule_is_defined_twice():
    """No function elsewhere in the packages is named as a rule (or as its
    module), with or without leading underscores: a second copy of a rule
    would have to be fixed apart from the first."""
    names = _rule_names()
    twice = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    home = names.get(node.name.lstrip("_"))
                    if home is not None and home != path.resolve():
                        twice.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} (the rule is in "
                                     f"{home.relative_to(ROOT)})")
    assert not twice, "rules defined again:\n" + "\n".join(twice)


def test_the_kernel_compiles_the_rules_themselves():
    """Every rule is compiled by the kernel (one of its modules) from the rule's own function object."""
    pytest.importorskip("numba")
    import importlib

    from numba.core.dispatcher import Dispatcher

    from switching import kernel

    compiled = set()
    for name in kernel.MODULES:
        module = importlib.import_module(f"switching.kernel.{name}")
        compiled |= {value.py_func for value in vars(module).values() if isinstance(value, Dispatcher)}
    for module in rules.MODULES:
        for name in module.RULES:
            assert getattr(module, name) in compiled, f"{module.__name__}.{name}"


def test_the_rules_include_the_guards_comparison_and_the_stiffness_verdict():
    """The rules moved here from their copies: a copy reintroduced under one of these names (the kernel's
    ``_band``, ``_larger``, ``_fixed_stiffness``) fails test_no_rule_is_defined_twice."""
    names = _rule_names()
    for name in ("band", "larger", "pulse_decides", "pulse_holds", "finite_holds", "fixed_stiffness", "halve",
                 "parabola_peak", "peak_in_reach", "worth_refining"):
        assert name in names


def test_the_comparison_stiffness_and_bracket_rules_python_and_compiled_agree_to_the_bit():
    """The rules of codegen.decision, switching.rules.stiffness and switching.rules.bracket called and compiled:
    the same results on random, edge and non-finite arguments."""
    numba = pytest.importorskip("numba")
    from codegen import decision
    from switching.rules import bracket, stiffness

    rng = random.Random(27)
    special = [0.0, -0.0, 1.0, -1.0, 1e-300, 2.78**4, 16.0, math.inf, -math.inf, math.nan]

    def number():
        return rng.choice(special) if rng.random() < 0.3 else rng.uniform(-5, 5) * 10 ** rng.randint(-12, 3)

    cases = {decision.band: 5, decision.larger: 2, decision.pulse_decides: 2, bracket.halve: 2,
             bracket.parabola_peak: 6, bracket.peak_in_reach: 2, bracket.worth_refining: 2}
    for rule, arity in cases.items():
        compiled = numba.njit(rule)
        for _ in range(400):
            arguments = [number() for _ in range(arity)]
            assert repr(compiled(*arguments)) == repr(rule(*arguments)), (rule.__name__, arguments)
    for rule in (decision.pulse_holds, decision.finite_holds):
        compiled = numba.njit(rule)
        for _ in range(400):
            arguments = [rng.randrange(6)] + [number() for _ in range(2 if rule is decision.pulse_holds else 3)]
            assert compiled(*arguments) == rule(*arguments), (rule.__name__, arguments)
    compiled = numba.njit(stiffness.fixed_stiffness)
    for _ in range(400):
        arguments = (abs(number()), rng.choice([2.0, 2.78, math.inf]), rng.choice([1.25, math.inf]), rng.randrange(3))
        assert repr(compiled(*arguments)) == repr(stiffness.fixed_stiffness(*arguments)), arguments


def test_the_stiffness_verdict_counts_a_streak_or_one_step_far_beyond():
    from switching.rules.stiffness import fixed_stiffness

    assert fixed_stiffness(15.0, 2.0, 1.25, 2) == (0, 0.0)  # calm: the streak restarts
    assert fixed_stiffness(math.nan, 2.0, 1.25, 2) == (0, 0.0)  # no estimate counts as calm
    assert fixed_stiffness(17.0, 2.0, 1.25, 0) == (1, 17.0**0.25)
    assert fixed_stiffness(17.0, 2.0, 1.25, 2)[0] == -1  # the third step in a row
    assert fixed_stiffness(2.6**4, 2.0, 1.25, 0)[0] == -1  # once, 30 % beyond the limit
    assert fixed_stiffness(2.6**4, 2.0, math.inf, 0)[0] == 1  # … not for a flow driven by inputs


# ---------------------------------------------------------------- Brent's maximisation


def _peak(margin, a, b):
    state = maximize_begin(a, b)
    done, evaluations = False, 0
    while not done:
        done, state = maximize_next(state, margin(state[-1]))
        evaluations += 1
    return state[-1], evaluations


def test_brent_finds_the_maximum_of_a_parabola_to_its_tolerance():
    """The margin stays below 0: the search ends at the maximum before its
    cap of evaluations, as close as the margin's round-off lets values tell
    points apart (√ε relative: the parabola is flat to ε within 1e-8 of its top)."""
    for peak in (0.1, 0.37, 0.5, 0.93):
        tau, evaluations = _peak(lambda t, p=peak: -1.0 - (t - p) ** 2, 0.0, 1.0)
        assert abs(tau - peak) < 3e-8 and evaluations < 40
    tau, evaluations = _peak(lambda t: -1.0 - (t - 1.0) ** 2, 0.0, 1.0)  # at the end of the interval
    assert 1.0 - 3e-8 < tau <= 1.0 and evaluations < 50


def test_brent_stops_at_the_first_point_where_the_margin_is_not_negative():
    tau, evaluations = _peak(lambda t: 1.0, 2.0, 4.0)
    assert (tau, evaluations) == (2.0 + GOLDEN * 2.0, 1)  # the golden section, evaluated first
    seen = []

    def margin(t):
        seen.append(t)
        return 1e-3 - (t - 0.8) ** 2  # ≥ 0 within 0.03 of 0.8

    tau, _ = _peak(margin, 0.0, 1.0)
    points = list(seen)
    assert tau == points[-1] and margin(tau) >= 0.0 and all(margin(t) < 0.0 for t in points[:-1])


def test_brent_python_and_compiled_agree_to_the_bit():
    """The rule called by Python and compiled by numba: the same points, the
    same answer, on smooth and non-smooth margins."""
    numba = pytest.importorskip("numba")
    begin, step = numba.njit(maximize_begin), numba.njit(maximize_next)
    rng = random.Random(27)
    for _ in range(300):
        c, w, h = rng.uniform(-1, 1), rng.uniform(0.01, 3), rng.uniform(-2, 0.3)
        power, wiggle = rng.choice([1, 2, 4]), rng.uniform(-0.1, 0.1)
        a = rng.uniform(-2, 0)
        b = a + rng.uniform(1e-9, 3)

        def margin(t):
            return h - w * abs(t - c) ** power + wiggle * math.sin(7 * t)

        python, compiled = maximize_begin(a, b), begin(a, b)
        done = False
        while not done:
            assert python == compiled
            value = margin(python[-1])
            done, python = maximize_next(python, value)
            done_compiled, compiled = step(compiled, value)
            assert done_compiled == done
        assert python == compiled


# ---------------------------------------------------------------- the fixed-step steppers


def test_the_steppers_are_eulers_step_and_the_classical_rk4():
    """On y' = y from y = 1: Euler gives 1 + h, RK4 the Taylor polynomial of
    eᴴ to h⁴; on arrays, component by component the same as on floats."""
    import numpy as np

    from switching.rules.steppers import euler_step, rk4_combine

    h = 0.1
    assert euler_step(1.0, 1.0, h) == 1.0 + h
    k1 = 1.0
    k2 = euler_step(1.0, k1, h / 2)
    k3 = euler_step(1.0, k2, h / 2)
    k4 = euler_step(1.0, k3, h)
    assert abs(rk4_combine(1.0, k1, k2, k3, k4, h) - (1 + h + h**2 / 2 + h**3 / 6 + h**4 / 24)) < 1e-16
    rng = np.random.default_rng(27)
    y, f1, f2, f3, f4 = rng.normal(size=(5, 50))
    whole = rk4_combine(y, f1, f2, f3, f4, h)
    assert list(whole) == [rk4_combine(*values, h) for values in zip(y.tolist(), f1.tolist(), f2.tolist(),
                                                                      f3.tolist(), f4.tolist())]
    assert list(euler_step(y, f1, h)) == [euler_step(a, b, h) for a, b in zip(y.tolist(), f1.tolist())]


def test_the_hermite_interpolant_meets_the_ends_and_is_exact_for_cubics():
    """Values and slopes at both ends; a cubic reproduced inside the step."""
    from switching.rules.steppers import hermite_cubic

    def cubic(t):
        return 1.0 - 2.0 * t + 0.5 * t**2 + 3.0 * t**3

    def slope(t):
        return -2.0 + t + 9.0 * t**2

    t0, h = 0.25, 0.5
    ends = (cubic(t0), slope(t0), cubic(t0 + h), slope(t0 + h), h)
    assert hermite_cubic(*ends, 0.0) == cubic(t0) and hermite_cubic(*ends, 1.0) == cubic(t0 + h)
    for theta in (0.1, 0.5, 0.77):
        assert abs(hermite_cubic(*ends, theta) - cubic(t0 + theta * h)) < 1e-14


def test_the_steppers_python_and_compiled_agree_to_the_bit():
    numba = pytest.importorskip("numba")
    import numpy as np

    from switching.rules.steppers import euler_step, hermite_cubic, rk4_combine

    euler, combine, hermite = numba.njit(euler_step), numba.njit(rk4_combine), numba.njit(hermite_cubic)
    rng = np.random.default_rng(6)
    for values in rng.normal(size=(200, 5)).tolist():
        h = abs(values[0]) * 1e-2
        assert euler(values[1], values[2], h) == euler_step(values[1], values[2], h)
        assert combine(*values, h) == rk4_combine(*values, h)
        theta = abs(values[4]) % 1.0
        assert hermite(*values[:4], h, theta) == hermite_cubic(*values[:4], h, theta)


def test_a_dense_value_beyond_the_steps_ends_within_its_terms_round_off_is_the_nearer_end():
    """RODAS4P's extension of a step from exactly 0 to 2.47e-23 dips to −1.9e-39 inside it (``y₁ + q₁``, a
    difference of two numbers of ``y₁``'s size): that is the end value 0, exactly; a dip beyond the round-off
    of the terms, and any value between the ends, is kept; arrays give the same values as floats."""
    import numpy as np

    from switching.rules.steppers import DENSE_ULPS, nearer_end

    terms = 5e-23
    assert nearer_end(-1.9e-39, 0.0, 2.47e-23, terms) == 0.0
    assert nearer_end(2.47e-23 + 1e-39, 0.0, 2.47e-23, terms) == 2.47e-23
    assert nearer_end(-1.9e-39, 2.47e-23, 0.0, terms) == 0.0  # (either end may be the lower)
    beyond = -2 * DENSE_ULPS * 2.220446049250313e-16 * terms
    assert nearer_end(beyond, 0.0, 2.47e-23, terms) == beyond
    assert nearer_end(1.2e-23, 0.0, 2.47e-23, terms) == 1.2e-23
    assert math.isnan(nearer_end(math.nan, 0.0, 1.0, 1.0))
    values = [-1.9e-39, 2.47e-23 + 1e-39, beyond, 1.2e-23]
    whole = nearer_end(np.array(values), np.zeros(4), np.full(4, 2.47e-23), np.full(4, terms))
    assert whole.tolist() == [nearer_end(v, 0.0, 2.47e-23, terms) for v in values]


def test_the_hermite_terms_magnitudes_are_the_cubic_of_the_magnitudes_with_the_last_slope_negated():
    """For θ in [0, 1] the weights h₀₀, h₁₀, h₀₁ are ≥ 0 and h₁₁ ≤ 0 (the interpolants' round-off scale)."""
    import numpy as np

    from switching.rules.steppers import hermite_cubic

    rng = np.random.default_rng(8)
    for y0, f0, y1, f1, h in rng.normal(size=(200, 5)).tolist():
        for theta in (0.0, 1e-9, 0.3, 0.5, 0.99, 1.0):
            t2, t3 = theta * theta, theta * theta * theta
            weights = (2 * t3 - 3 * t2 + 1, t3 - 2 * t2 + theta, -2 * t3 + 3 * t2, t3 - t2)
            explicit = sum(abs(w * v) for w, v in zip(weights, (y0, h * f0, y1, h * f1)))
            assert hermite_cubic(abs(y0), abs(f0), abs(y1), -abs(f1), abs(h), theta) == pytest.approx(explicit,
                                                                                                   rel=1e-12)


def test_the_nearer_end_python_and_compiled_agree_to_the_bit():
    numba = pytest.importorskip("numba")
    import numpy as np

    from switching.rules.steppers import nearer_end

    compiled = numba.njit(nearer_end)
    rng = np.random.default_rng(7)
    for y0, y1, scale, theta in rng.normal(size=(300, 4)).tolist():
        terms = abs(y0) + abs(y1)
        v = y0 + (y1 - y0) * theta * 1.5 + scale * 1e-16 * terms  # beyond the ends, by a little or a lot
        assert compiled(v, y0, y1, terms) == nearer_end(v, y0, y1, terms)


# ---------------------------------------------------------------- the pulse at a jump


def _pulse_cases():
    import numpy as np

    yield np.array([1.0, 2.0, 3.0]), np.array([1.0 + 1e-15, -2.0, 3.0]), np.array([0, 1]), 2  # round-off and a jump
    yield np.array([1.0, 2.0]), np.array([1.0 + 1e-15, 2.0 - 4e-16]), np.array([0, 1]), 2  # round-off only
    yield np.array([1.0, 2.0]), np.array([5.0, 2.0]), np.array([0, 1]), 0  # no moved state: no pulse
    yield np.array([1e-20, 0.0]), np.array([0.0, 0.0]), np.array([1]), 1  # below the absolute band
    yield np.array([1.0, math.nan]), np.array([0.5, math.nan]), np.array([0, 1]), 2  # NaN does not count in s
    yield np.array([0.0, 1e3]), np.array([1e-10, -1e3]), np.array([0, 1]), 2  # small beside a large state


def test_the_pulse_drops_round_off_within_the_band():
    import numpy as np

    from switching.rules.jumps import jump_pulse

    rtol, atol = 1e-12, 1e-15
    expected = [([0.0, -4.0, 0.0], False), ([0.0, 0.0], True), ([0.0, 0.0], True), ([0.0, 0.0], True),
                ([-0.5, math.nan], False), ([0.0, -2e3], False)]
    for (x, xp, moved, count), (delta, none) in zip(_pulse_cases(), expected, strict=True):
        d = np.empty(len(x))
        assert jump_pulse(x, xp, moved, count, rtol, atol, np.zeros(len(x)), d) == none
        np.testing.assert_array_equal(d, delta)


def test_a_change_within_the_states_motion_over_the_round_off_of_t_is_no_jump():
    """A bridge's line inductor located at its current's zero 8.2e-17 off (its flux moving 784 V·ulp(t)
    = 6.8e-16 within one ulp of t = 4.86 ms) and set to exactly 0 carries no pulse; a change beyond the
    motion band still does (the band is per state: the other state's motion does not cover it)."""
    import numpy as np

    from switching.rules.jumps import MOTION_ULPS, jump_pulse

    t, rate = 0.004859073984259327, 784.0
    motion = np.array([MOTION_ULPS * np.spacing(t) * rate, 0.0])
    d = np.empty(2)
    assert jump_pulse(np.array([-8.2e-17, 0.4596]), np.array([0.0, 0.4596]), np.array([0]), 1, 1e-12, 0.0,
                      motion, d)
    np.testing.assert_array_equal(d, [0.0, 0.0])
    assert not jump_pulse(np.array([-1e-12, 0.4596]), np.array([0.0, 0.4596]), np.array([0]), 1, 1e-12, 0.0,
                          motion, d)
    assert d[0] == 1e-12
    swapped = motion[::-1].copy()  # the motion of another state covers nothing here
    assert not jump_pulse(np.array([-8.2e-17, 0.4596]), np.array([0.0, 0.4596]), np.array([0]), 1, 1e-12, 0.0,
                          swapped, d)


def test_the_pulse_python_and_compiled_agree_to_the_bit():
    numba = pytest.importorskip("numba")
    import numpy as np

    from switching.rules.jumps import jump_pulse

    compiled = numba.njit(jump_pulse)
    for x, xp, moved, count in _pulse_cases():
        d_python, d_compiled = np.empty(len(x)), np.empty(len(x))
        motion = np.full(len(x), 1e-16)
        assert jump_pulse(x, xp, moved, count, 1e-12, 1e-15, motion, d_python) == compiled(
            x, xp, moved, count, 1e-12, 1e-15, motion, d_compiled)
        assert d_python.tobytes() == d_compiled.tobytes()


def _drive_instant(begin, step, script, max_steps, capacity=8, n=2):
    """Run the instant rule on a script: each entry ``(fired, target, x)`` answers one of its requests."""
    import numpy as np

    chain = np.zeros(max_steps + 1, dtype=np.int64)
    pin_modes, pin_x = np.zeros(capacity, dtype=np.int64), np.zeros((capacity, n))
    state = begin(0, chain)
    trail = [tuple(state)]
    for fired, target, x in script:
        if state[0] not in (instants.JUMP_AND_DECIDE, instants.DECIDE_AS_FLOW):
            break
        state = step(state, fired, target, np.array(x, dtype=float), max_steps, chain, pin_modes, pin_x)
        trail.append(tuple(state))
    return trail


#: scripts of answers (fired, target mode, state) and the rule's last verdict
_INSTANT_SCRIPTS = {
    "continuous at once": ([(False, 0, [0, 0]), (False, 0, [1, 0])], "CONTINUOUS", -1),
    "a mythical chain that returns": ([(True, 1, [0, 0]), (True, 2, [0, 0]), (True, 1, [0, 0])],
                                      "REPEATS_IN_CHAIN", 1),
    "mythical then a pinnacle then continuous": (
        [(True, 1, [0, 0]), (False, 1, [0, 0]), (True, 2, [1, 0]), (False, 2, [1, 0]), (False, 2, [2, 0])],
        "CONTINUOUS", -1),
    "a pinnacle repeating its state": (
        [(False, 0, [0, 0]), (True, 1, [1, 1]), (False, 1, [1, 1]), (True, 0, [2, 2]),
         (False, 0, [1, 1]), (True, 1, [1, 1 + 1e-14])],
        "PINNACLE_REPEATS", 0),
    "pinnacles of other states go on to the cap": (
        [(False, 0, [0, 0]), (True, 0, [1, 0]), (False, 0, [1, 0]), (True, 0, [2, 0]), (False, 0, [2, 0]),
         (True, 0, [3, 0])],
        "TOO_MANY_STEPS", -1),
}


@pytest.mark.parametrize("name", sorted(_INSTANT_SCRIPTS))
def test_the_instant_rule_passes_mythical_modes_and_pinnacles_and_finds_divergences(name):
    script, verdict, detail = _INSTANT_SCRIPTS[name]
    trail = _drive_instant(instants.instant_begin, instants.instant_next, script, max_steps=3)
    assert trail[-1][0] == getattr(instants, verdict) and trail[-1][5] == detail, trail


def test_the_instant_rule_says_when_it_has_no_room_and_changes_nothing():
    script = [(False, 0, [0, 0]), (True, 1, [1, 0]), (False, 1, [1, 0]), (True, 0, [2, 0])]
    trail = _drive_instant(instants.instant_begin, instants.instant_next, script, max_steps=10, capacity=1)
    assert trail[-1][0] == instants.NO_ROOM and trail[-1][1:5] == trail[-2][1:5]


def test_the_instant_rule_decides_as_in_flow_only_on_a_first_pass_without_pulse():
    import numpy as np

    state = instants.instant_begin(3, np.zeros(4, dtype=np.int64))
    assert instants.decides_as_in_flow(state, True) and not instants.decides_as_in_flow(state, False)
    later = instants.instant_next(state, True, 4, np.zeros(1), 3, np.zeros(4, dtype=np.int64), np.zeros(1, np.int64),
                                  np.zeros((1, 1)))
    assert later[:3] == (instants.JUMP_AND_DECIDE, 2, 4) and not instants.decides_as_in_flow(later, True)


def test_the_instant_rule_python_and_compiled_agree():
    numba = pytest.importorskip("numba")
    begin, step = numba.njit(instants.instant_begin), numba.njit(instants.instant_next)
    for name, (script, _, _) in sorted(_INSTANT_SCRIPTS.items()):
        python = _drive_instant(instants.instant_begin, instants.instant_next, script, max_steps=3)
        compiled = _drive_instant(begin, step, script, max_steps=3)
        assert python == compiled, name
