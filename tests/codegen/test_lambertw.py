"""Lambert's W in generated code, through the Wright omega function (issue 28, item 5).

``ω(z) = W₀(eᶻ)`` (:func:`codegen.omega.wrightomega`) against scipy's and
mpmath's over ``[−700, 10⁶]``, in Python and compiled both ways; the rewrite
of :func:`codegen.lambert.omega_form` against the expressions it rewrites,
symbolically (on the branch ``X = w·eʷ``, where ``W₀(X) = w``) and
numerically; and the README's diode law with numbers,
``R("D", flow_law=lambda e: Is*(sp.exp(e/VT) - 1))`` with ``Is, VT = 1e-12,
0.025`` in series with ``V = 5 V``, ``R = 1 kΩ`` and ``C = 1 µF``: derived in
about a second, simulated, and checked against a hand Newton solution of the
loop ``R·i + VT·ln(1 + i/Is) = V − q/C`` and against the exact time course

    t(i) = C·R·ln(i₀/i) + (C·VT/Is)·[ln(1 + Is/i) − ln(1 + Is/i₀)],

from ``dt = dq/i`` with ``dq = −C·(R + VT/(i + Is))·di`` along the loop.  As
``t → ∞`` it gives ``i → 0`` and ``v_C = V − R·i − VT·ln(1 + i/Is) → V``: the
capacitor charges to the source's voltage, ever more slowly (the diode's
small-signal resistance ``VT/(i + Is)`` grows without bound).
"""

from __future__ import annotations

import math
import time
import warnings

import mpmath
import numpy as np
import pytest
import scipy.special
import sympy as sp

from bondgraph import C, R, BondGraph, One, Se
from codegen.lambert import WrightOmega, omega_form
from codegen.omega import wrightomega
from codegen.runtime import H, Hyper, PulseError
from codegen.safety import GeneratedCodeError, check_source, execute
from codegen.source import Argument, FunctionSpec, UnprintableExpressionError, function_source, module_namespace
from switching import HybridModel

IS, VT, V, RES, CAP = 1e-12, 0.025, 5.0, 1000.0, 1e-6
EPS = 2.0**-52


def grid() -> np.ndarray:
    """Real arguments over [−700, 10⁶]: evenly, geometrically, at random, and at the regions' edges."""
    rng = np.random.default_rng(28)
    edges = [-36.0, np.nextafter(-36.0, 0), np.nextafter(-36.0, -1), -2.0, np.nextafter(-2.0, 0), 0.0, 5e-324,
             -5e-324, 1.0, np.nextafter(1.0, 2), np.nextafter(1.0, 0), 1e6]
    return np.concatenate([np.linspace(-700.0, 60.0, 3041), np.geomspace(1.0, 1e6, 1201),
                           rng.uniform(-40.0, 40.0, 2000), rng.uniform(-3.0, 2.0, 1000), edges])


# ------------------------------------------------------------------ ω itself

def test_omega_matches_scipy_over_the_real_line():
    z = grid()
    ours = np.array([wrightomega(float(v)) for v in z])
    np.testing.assert_allclose(ours, scipy.special.wrightomega(z), rtol=1e-14, atol=0)


def test_omega_is_within_two_units_in_the_last_place_of_the_exact_value():
    """mpmath at 40 digits: ``W₀(eᶻ)`` of the very double ``z``."""
    z = grid()[::5]
    with mpmath.workdps(40):
        exact = [mpmath.lambertw(mpmath.exp(mpmath.mpf(float(v)))).real for v in z]
    errors = [abs(wrightomega(float(v)) - float(e)) / float(e) for v, e in zip(z, exact)]
    assert max(errors) <= 2 * EPS, max(errors)


def test_omega_solves_its_equation_and_has_its_limits():
    for z in (-30.0, -5.0, -1.0, 0.0, 0.5, 3.0, 50.0, 1e4, 1e6):
        w = wrightomega(z)
        assert w > 0 and w + math.log(w) == pytest.approx(z, rel=4 * EPS, abs=8 * EPS)
    assert wrightomega(1.0) == 1.0                                   # W(e) = 1
    assert wrightomega(0.0) == pytest.approx(0.5671432904097838, rel=EPS)  # the omega constant, Ω·e^Ω = 1
    for z in (-36.5, -100.0, -700.0):                                # ω = eᶻ − e²ᶻ + O(e³ᶻ)
        assert wrightomega(z) == math.exp(z) - math.exp(2 * z)
    assert wrightomega(-math.inf) == 0.0 and wrightomega(-800.0) == 0.0
    assert wrightomega(math.inf) == math.inf and math.isnan(wrightomega(math.nan))
    for z in (1e300, 1.7976931348623157e308):                        # ω = z − log z + …: no overflow on the way
        assert wrightomega(z) == pytest.approx(z - math.log(z), rel=EPS)


def test_omega_compiled_by_numba_and_translated_natively_gives_the_same_bits_as_python():
    pytest.importorskip("numba")
    from switching_models import scalar_function_both_ways

    source = ("import math\nfrom math import *\nimport numpy as np\nfrom numba import carray\n\n"
              "from codegen.compiled_omega import wrightomega\n\n\n"
              "def f(z):\n    return wrightomega(z)\n")
    ours, theirs = scalar_function_both_ways(source, "hbg_test_lambertw_omega")
    z = np.concatenate([grid()[::7], [-np.inf, np.inf, 1e300]])
    got = np.array([ours(float(v)) for v in z])
    assert got.tobytes() == np.array([theirs(float(v)) for v in z]).tobytes()
    assert got.tobytes() == np.array([wrightomega(float(v)) for v in z]).tobytes()
    assert math.isnan(ours(math.nan)) and math.isnan(theirs(math.nan))


# ------------------------------------------------------------------ ω in sympy

def test_the_sympy_function_differentiates_evaluates_and_rewrites():
    x = sp.Symbol("x", real=True)
    w = WrightOmega(x**2)
    assert sp.simplify(sp.diff(w, x) - 2 * x * w / (1 + w)) == 0          # dω/dz = ω/(1 + ω)
    assert WrightOmega(1) == 1 and WrightOmega(-sp.oo) == 0 and WrightOmega(sp.oo) == sp.oo
    assert w.is_positive and w.is_real
    assert float(WrightOmega(sp.Float(3)).evalf()) == pytest.approx(wrightomega(3.0), rel=EPS)
    assert abs(WrightOmega(sp.Integer(-2)).evalf(40) - sp.LambertW(sp.exp(-2)).evalf(40)) < 1e-38
    assert w.rewrite(sp.LambertW) == sp.LambertW(sp.exp(x**2))
    # the derivative, numerically: a central difference of the function itself
    for z in (-20.0, -1.0, 0.3, 7.0, 300.0):
        h = 1e-6 * max(1.0, abs(z))
        slope = (wrightomega(z + h) - wrightomega(z - h)) / (2 * h)
        exact = float(sp.diff(WrightOmega(x), x).subs(x, z))
        assert slope == pytest.approx(exact, rel=1e-8)


# ------------------------------------------------------------------ the rewrite

a, b, c, K = sp.symbols("a b c K", positive=True)
x = sp.Symbol("x", real=True)
w = sp.Symbol("w", positive=True)

#: expressions with W₀(a·e^{b·x}) and, on the branch, the value of ``a`` that makes its argument ``w·eʷ``
REWRITES = [
    sp.LambertW(a * sp.exp(b * x)),
    K * sp.exp(c * x - sp.LambertW(a * sp.exp(b * x))),                       # the diode loop's form
    K * sp.exp(c * x - 1.0 * sp.LambertW(a * sp.exp(b * x))) - c,               # ... with sympy's float −1.0
    sp.exp(2 * sp.LambertW(a * sp.exp(b * x))) + sp.LambertW(a * sp.exp(b * x)) ** 2,
    sp.exp(-sp.Rational(3, 2) * sp.LambertW(a * sp.exp(b * x)) + x) / (1 + sp.LambertW(a * sp.exp(b * x))),
    sp.sin(sp.exp(-sp.LambertW(a * sp.exp(b * x))) * K),
]


def _on_the_branch(expr):
    """``expr`` with ``a = w·e^{w − b·x}``, where ``a·e^{b·x} = w·eʷ`` and so ``W₀ = ω = w`` (``w > 0``)."""
    expr = expr.subs(a, w * sp.exp(w - b * x))

    def value(f):
        inner = f.args[0]
        if isinstance(f, WrightOmega):
            assert sp.simplify(sp.expand_log(inner, force=True) - (w + sp.log(w))) == 0, inner
        else:
            assert sp.simplify(inner - w * sp.exp(w)) == 0, inner
        return w

    # (sympy's −1.0 as −1: ``exp(−1.0·w)`` and ``exp(−w)`` are one number, which simplify does not see)
    return sp.nsimplify(expr.replace(lambda f: isinstance(f, (WrightOmega, sp.LambertW)), value), rational=True)


@pytest.mark.parametrize("expr", REWRITES, ids=range(len(REWRITES)))
def test_the_rewrite_is_an_identity(expr):
    (rewritten,) = omega_form([expr])
    assert not rewritten.has(sp.LambertW) and rewritten.has(WrightOmega)
    assert sp.simplify(_on_the_branch(rewritten) - _on_the_branch(expr)) == 0
    # and numerically, where the original is computed without trouble (mpmath, 30 digits)
    values = {a: sp.Float("0.37", 40), b: sp.Float("1.3", 40), c: sp.Float("0.45", 40), K: sp.Float("2.2", 40),
              x: sp.Float("0.8", 40)}
    assert abs(sp.N(rewritten.subs(values), 30) - sp.N(expr.subs(values), 30)) < 1e-25


def test_omega_of_a_log_argument_reads_back_as_the_lambert_w():
    (rewritten,) = omega_form([sp.LambertW(a * sp.exp(b * x))])
    assert rewritten == WrightOmega(b * x + sp.log(a))
    assert sp.simplify(rewritten.rewrite(sp.LambertW) - sp.LambertW(a * sp.exp(b * x))) == 0


def test_huge_factors_cancel_symbolically():
    """The diode loop as sympy's solve gives it: ``K·e^{−αq − W(X·e^{−αq})}`` with ``K`` and ``X`` beyond
    what ``exp`` of the exponents leaves finite is ``(K/X)·ω(log X − αq)``: no exp of ``q`` is left."""
    q = sp.Symbol("q_C")
    loop = sp.sympify("7.22597405716471e+74*exp(-40000000.0*q_C - 1.0*LambertW(2.89038962286588e+79*"
                      "exp(-40000000.0*q_C))) - 1.0e-12")
    (rewritten,) = omega_form([loop])
    assert not rewritten.has(sp.exp) and not rewritten.has(sp.LambertW)
    omega = WrightOmega(sp.log(sp.Float("2.89038962286588e+79"), evaluate=False) - sp.Float(4e7) * q)
    ratio = sp.Float("7.22597405716471e+74") / sp.Float("2.89038962286588e+79")
    assert rewritten == ratio * omega - sp.Float(1e-12)
    assert float(ratio) == pytest.approx(VT / RES, rel=1e-14)                  # VT/R


@pytest.mark.parametrize("q", [0.0, 1e-6, 3e-6, 4.5e-6])
def test_the_rewritten_diode_loop_computes_what_the_original_means(q):
    """Where the original overflows (``exp(40·10⁶·q)`` at q = 3 µC...), its value at 50 digits."""
    loop = sp.sympify("7.22597405716471e+74*exp(-40000000.0*q_C - 1.0*LambertW(2.89038962286588e+79*"
                      "exp(-40000000.0*q_C))) - 1.0e-12")
    fn = _python_function([loop])
    exact = sp.N(loop.subs(sp.Symbol("q_C"), sp.Float(q, 50)), 50)
    assert fn(q) == pytest.approx(float(exact), rel=1e-13)


def test_another_branch_and_a_negative_argument_are_refused_by_name():
    with pytest.raises(UnprintableExpressionError, match="principal branch.*k = -1"):
        _python_function([sp.LambertW(sp.exp(sp.Symbol("q_C")), -1)])
    with pytest.raises(UnprintableExpressionError, match="argument is negative"):
        _python_function([sp.LambertW(-3 * sp.exp(sp.Symbol("q_C")))])


# ------------------------------------------------------------------ the generated code

Q = sp.Symbol("q_C")


def _spec(outputs, raw=False):
    return FunctionSpec("f", (Argument("x", (Q,)),), tuple(outputs), raw=raw)


def _python_function(outputs):
    source = function_source(_spec(outputs))
    namespace = execute(source, module_namespace(), "<test lambertw>")
    return lambda q: namespace["f"](np.array([q]), np.empty(len(outputs)))[0]


def test_generated_code_calls_the_one_helper_and_passes_the_check():
    expr = sp.LambertW(2 * sp.exp(Q)) + sp.exp(Q - sp.LambertW(2 * sp.exp(Q)))
    source = function_source(_spec([expr]))
    assert "(3/2)*wrightomega(q_C + log(2))" in source and "LambertW" not in source   # ω + e^{q−W}·… = 3ω/2
    check_source(source)
    namespace = execute(source, module_namespace(), "<test lambertw>")
    out = namespace["f"](np.array([0.3]), np.empty(1))
    exact = float(sp.N(expr.subs(Q, sp.Float("0.3", 30)), 30))
    assert out[0] == pytest.approx(exact, rel=4 * EPS)
    # vectorized (scipy's ufunc) and raw (Hyper values) alike
    vectorized = execute(source, module_namespace(vectorized=True), "<test lambertw numpy>")
    samples = np.array([[0.3, -2.0, 40.0]])
    np.testing.assert_allclose(vectorized["f"](samples, np.empty((1, 3)))[0],
                               [float(sp.N(expr.subs(Q, v), 30)) for v in (0.3, -2.0, 40.0)], rtol=1e-14)
    raw = function_source(_spec([expr], raw=True))
    assert "H.wrightomega(" in raw
    result = execute(raw, module_namespace(), "<test lambertw raw>")["f"]([Hyper(0.0, 0.3)])
    assert result[0].finite == pytest.approx(exact, rel=4 * EPS)
    with pytest.raises(PulseError):
        H.wrightomega(Hyper(1.0, 0.3))


def test_the_check_stays_strict_around_the_helper():
    """Only ``wrightomega`` joins the allowed names; a symbol of that name is renamed, not called."""
    named = sp.Symbol("wrightomega")
    source = function_source(FunctionSpec("f", (Argument("x", (named,)),), (named + 1,)))
    assert "wrightomega_ = x[0]" in source
    for other in ("lambertw", "wright_omega", "special"):
        with pytest.raises(GeneratedCodeError):
            check_source(f"def f(x, out):\n    out[0] = {other}(x[0])\n    return out\n")


# ------------------------------------------------------------------ the README's diode law with numbers

def diode_loop() -> BondGraph:
    g = BondGraph("shockley")
    loop = g.add(One("loop"))
    g.connect(Se("V", V), loop)
    g.connect(loop, R("R", RES))
    g.connect(loop, R("D", flow_law=lambda e: IS * (sp.exp(e / VT) - 1)))
    g.connect(loop, C("C", CAP))
    return g


def newton_current(q: float) -> float:
    """The diode's current from the capacitor's charge: ``R·i + VT·ln(1 + i/Is) = u = V − q/C`` by Newton's
    method on ``s = ln(1 + i/Is)``: ``h(s) = R·Is·(eˢ − 1) + VT·s − u`` is convex and increasing, so from
    ``s₀ = min(u/VT, ln(1 + u/(R·Is)))`` (where ``h ≥ 0``, ``u ≥ 0``) the steps fall monotonically onto the
    root."""
    u = V - q / CAP
    s = min(u / VT, math.log1p(u / (RES * IS)))
    for _ in range(100):
        step = (RES * IS * math.expm1(s) + VT * s - u) / (RES * IS * math.exp(s) + VT)
        s -= step
        if abs(step) <= 1e-16 * abs(s):
            break
    i = IS * math.expm1(s)
    assert abs(RES * i + VT * math.log1p(i / IS) - u) <= 1e-14 * max(abs(u), 1.0)
    return i


def time_of(i: float, i0: float) -> float:
    """The exact time at which the loop's current has fallen from ``i0`` to ``i`` (module docstring)."""
    return CAP * RES * math.log(i0 / i) + CAP * VT / IS * (math.log1p(IS / i) - math.log1p(IS / i0))


def test_the_readme_diode_law_derives_in_about_a_second_with_the_closed_form_inverse():
    start = time.perf_counter()
    equations = diode_loop().equations()
    seconds = time.perf_counter() - start
    print(f"derivation of the diode loop: {seconds:.2f} s")
    assert seconds < 5                                   # ~0.7 s alone; it took hours inside sympy.solve once
    rate = equations.rate(Q)
    assert rate.has(sp.LambertW)                          # sympy's closed form of the loop
    (rewritten,) = omega_form([rate])
    # by hand: i + Is = (VT/R)·W((R·Is/VT)·e^{(u + R·Is)/VT}), u = V − q/C
    z = math.log(RES * IS / VT) + (V + RES * IS) / VT
    by_hand = VT / RES * WrightOmega(z - Q / (CAP * VT)) - IS
    fn = _python_function([rewritten])
    for q in np.linspace(0.0, 4.6e-6, 24):
        assert fn(q) == pytest.approx(float(by_hand.subs(Q, q).evalf(30)), rel=1e-13)


def test_the_rates_of_the_generated_code_are_the_newton_solution():
    model = HybridModel(diode_loop(), [], {})
    rates = model.compiled_mode(model.initial_mode).rates
    rng = np.random.default_rng(5)
    for q in rng.uniform(0.0, 4.6e-6, 100):                # v_C from 0 to 4.6 V: i from 4.5 mA to 0.2 µA
        assert rates(np.array([q]), 0.0)[0] == pytest.approx(newton_current(q), rel=1e-12)


@pytest.mark.parametrize("method", ["RK45", "Radau", "RK45-jit"])
def test_the_readme_diode_law_simulates_on_the_newton_solution_and_its_exact_time_course(method):
    if method.endswith("-jit"):
        pytest.importorskip("numba")
    model = HybridModel(diode_loop(), [], {}, signals={"i_D": "f_D", "v_C": "e_C"})
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)          # (a mode numba cannot compile flows in Python)
        run = model.simulate(1e-2, method, rtol=1e-10, atol=1e-18, t_eval=np.linspace(1e-3, 1e-2, 10))
    print(f"{method}: 10 ms of the diode loop in {time.perf_counter() - start:.2f} s")
    q, current = run.state("q_C"), run.signal("i_D")
    newton = np.array([newton_current(v) for v in q])
    np.testing.assert_allclose(current, newton, rtol=1e-9)
    i0 = newton_current(0.0)
    np.testing.assert_allclose([time_of(i, i0) for i in newton], run.t, rtol=1e-7)
    # charging towards V: the current falls, v_C rises and stays below V
    assert np.all(np.diff(current) < 0) and np.all(np.diff(run.signal("v_C")) > 0)
    assert run.signal("v_C")[-1] == pytest.approx(V - RES * newton[-1] - VT * math.log1p(newton[-1] / IS),
                                                  rel=1e-12)


def test_the_capacitor_charges_towards_the_source_voltage_at_the_exact_pace():
    """Over 10⁵ s (``t·Is/(C·VT) = 4``): the current falls to ``Is/(e⁴ − 1)`` and v_C to within
    ``VT·ln(e⁴/(e⁴ − 1)) = 0.46 mV`` of V, on ``t(i)``."""
    model = HybridModel(diode_loop(), [], {}, signals={"i_D": "f_D", "v_C": "e_C"})
    times = np.geomspace(1e-3, 1e5, 17)
    run = model.simulate(1e5, "RK45", rtol=1e-10, atol=1e-18, t_eval=times)
    current, v_c = run.signal("i_D"), run.signal("v_C")
    i0 = newton_current(0.0)
    np.testing.assert_allclose([time_of(i, i0) for i in current], times, rtol=1e-5)
    late = IS / math.expm1(1e5 * IS / (CAP * VT))                    # t(i) without the R and i₀ terms
    assert current[-1] == pytest.approx(late, rel=1e-4)
    assert V - v_c[-1] == pytest.approx(VT * math.log1p(late / IS), rel=1e-4)
    assert np.all(np.diff(V - v_c) < 0)


def test_an_exported_module_carries_the_omega_function_and_needs_only_math(tmp_path):
    from switching_models import exported_rates

    model = HybridModel(diode_loop(), [], {})
    model.compiled_mode(model.initial_mode)
    charges = (0.0, 2e-6, 4.5e-6)
    rates = model.compiled_mode(model.initial_mode).rates
    assert exported_rates(model, tmp_path, "diode_modes", charges) == [rates(np.array([q]), 0.0)[0] for q in charges]


def test_the_jacobian_and_the_sensitivity_differentiate_through_omega():
    """The implicit methods' generated Jacobian (sympy's derivative of the loop's Lambert W, printed
    through ω) is ``di/dq = −1/(C·(R + VT/(i + Is)))``, by differentiating the loop; the forward
    sensitivity ``∂q(t)/∂q(0) = i(q(t))/i(q(0))`` (the autonomous ``dq/dt = i(q)`` carries a shift of its
    start along itself)."""
    from switching.library.jacobian import flow_jacobian

    model = HybridModel(diode_loop(), [], {}, signals={"i_D": "f_D"})
    cm = model.compiled_mode(model.initial_mode)
    jacobian = flow_jacobian(model, cm, np.zeros(1))
    source = model.library.jacobians[cm.mode].source
    assert "wrightomega(" in source and "LambertW" not in source
    for q in np.linspace(0.0, 4.6e-6, 12):
        i = newton_current(q)
        assert jacobian.dense(0.0, np.array([q]))[0, 0] == pytest.approx(-1 / (CAP * (RES + VT / (i + IS))),
                                                                         rel=1e-11)
    times = np.linspace(1e-3, 1e-2, 10)
    run = model.simulate(1e-2, "RK45", rtol=1e-11, atol=1e-19, t_eval=times, sensitivities=["x0:q_C"])
    np.testing.assert_allclose(run.sensitivity("q_C", "x0:q_C"), run.signal("i_D") / newton_current(0.0),
                               rtol=1e-6)


def test_the_diode_loops_mode_function_is_the_same_compiled_by_numba_and_translated_natively():
    pytest.importorskip("numba")
    from codegen.cache import SourceCache
    from switching.library.jit_model import mode_function_source
    from test_native import assert_modes_agree_with_numba

    model = HybridModel(diode_loop(), [], {})
    model.cache = SourceCache(None)
    model.simulate(1e-3, "RK45")
    assert "from codegen.compiled_omega import wrightomega" in mode_function_source(model, model.initial_mode)
    assert_modes_agree_with_numba(model)
