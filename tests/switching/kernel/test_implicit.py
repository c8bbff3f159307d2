"""The compiled implicit method ``rodas-jit`` (issue 30, item 2): RODAS4P in
the kernel with each mode's Jacobian derived symbolically and compiled.

Its order from fitted slopes on the Prothero–Robinson problem (a stiff flow
driven by an input, closed form ``x = cos t``), its dense output, its linear
algebra against numpy's, and on the stiff compliant chain the instants and
final velocities of Python's Radau."""

import math
import warnings

import numpy as np
import pytest

pytest.importorskip("numba")

from bondgraph import C, One, R, Se  # noqa: E402
from bondgraph import BondGraph  # noqa: E402
from models import ball_chain  # noqa: E402
from switching import ExpressionInput, HybridModel  # noqa: E402
from switching.kernel import implicit  # noqa: E402
from switching.rules import rosenbrock  # noqa: E402
from switching.simulate.energy_watch import energy_created  # noqa: E402

T_END = 2.0


def prothero_robinson(lam):
    """A series RC circuit driven by an effort source: ``q̇ = (u − q/c)/r``, with ``c = 1``, ``r = 1/λ`` and
    ``u = cos t − sin(t)/λ``: ``q̇ = −λ(q − cos t) − sin t``, ``q(0) = 1``, whose solution is ``q = cos t``
    (stiff for large ``λ``: the Jacobian is ``−λ``)."""
    g = BondGraph("prothero_robinson")
    u = g.input("u")
    j = g.add(One("j"))
    g.connect(Se("source", u), j)
    g.connect(j, R("r", "r"))
    g.connect(j, C("c", "c"))
    return HybridModel(g, [], {"r": 1.0 / lam, "c": 1.0}, initial_state={"q_c": 1.0},
                       inputs={"u": ExpressionInput("cos(t) - sin(t)/lam", {"lam": lam})})


def _slope(rows):
    steps, errors = np.array(rows).T
    return np.polyfit(np.log(steps), np.log(errors), 1)[0]


def _fixed_steps(model, n):
    """A run of ``n`` equal steps (every step accepted: a tolerance no error reaches, the step held at
    ``T_END/n``), its requested times four per step."""
    h = T_END / n
    return model.simulate(T_END, "rodas-jit", rtol=1e3, atol=1e3, first_step=h, max_step=h,
                          t_eval=np.linspace(0.0, T_END, 4 * n + 1))


@pytest.mark.parametrize("lam, order", [(1.0, rosenbrock.ORDER), (1000.0, 3)])
def test_the_order_from_the_fitted_slope_of_equal_steps(lam, order):
    """The end-point error falls as ``n^(−p)``: p = 4 where the flow is not stiff; p = 3 at ``λ = 1000``
    (``|h·λ|`` from 15 to 250), the order RODAS4P keeps on the Prothero–Robinson problem.  Between the
    steps, the continuous extension is of order 3 (a local error O(h⁴))."""
    model = prothero_robinson(lam)
    ends, dense = [], []
    for n in (8, 16, 32, 64, 128):
        trajectory = _fixed_steps(model, n)
        assert trajectory.stats["steps"] == n
        ends.append((n, abs(trajectory.x[-1][0] - math.cos(T_END))))
        dense.append((n, np.max(np.abs(trajectory.state("q_c") - np.cos(trajectory.t)))))
    assert -order - 0.5 < _slope(ends) < -order + 0.3, ends
    assert _slope(dense) < -3.5, dense


def test_the_error_falls_with_the_tolerance_as_the_order_says():
    """Fixed-tolerance sweeps (rtol 1e-6 … 1e-11): the end-point error against the number of steps has
    the slope −4 of the method's order (fitted), and stays within a small multiple of the tolerance."""
    model = prothero_robinson(1.0)
    rows = []
    for rtol in (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11):
        trajectory = model.simulate(T_END, "rodas-jit", rtol=rtol, atol=rtol * 1e-3, output="events")
        error = abs(trajectory.x[-1][0] - math.cos(T_END))
        assert error < 100 * rtol
        rows.append((trajectory.stats["steps"], error))
    assert -5.0 < _slope(rows) < -3.3, rows


def test_a_stiff_driven_flow_takes_few_steps():
    """At ``λ = 1000`` the steps follow the solution ``cos t``, not the fast time constant 1 ms: fewer than
    40 steps over 2 s at rtol 1e-8, the error within the tolerance's order (RODAS4's coefficients took 751
    steps here)."""
    trajectory = prothero_robinson(1000.0).simulate(T_END, "rodas-jit", rtol=1e-8, atol=1e-11, output="events")
    assert trajectory.stats["steps"] < 40
    assert abs(trajectory.x[-1][0] - math.cos(T_END)) < 1e-8


def test_a_step_whose_jacobian_falls_by_orders_within_it_is_taken_again_shorter():
    """An exponential diode (SPICE's law with GMIN) behind 1 mH and 1 Ω charging 100 µF ‖ 1 kΩ from a
    10 V, 50 Hz source: while it blocks, ``J = −(R + 1/g(v))/L`` is about −1e15/s; as it turns on, ``g``
    grows e-fold per 26 mV and ``J`` falls by orders of magnitude within one step of the blocking phase's
    size.  The stages damp the step's motion with the start's ``J`` and so does the error estimate: the
    second turn-on (t ≈ 23 ms) was stepped over, 8.66 V at 0.1 s against ngspice's 8.28618 V, no warning.
    With each step's damping checked against its end's Jacobian the default run is the resolved one
    (steps of at most 1 µs) to the tolerance's order."""
    from models import spice_reference

    parts = spice_reference.CIRCUITS["half-wave, line R and L"][0]
    model = spice_reference.circuit("rectifier", parts).build()
    resolved = model.simulate(0.03, "rodas-jit", max_step=1e-6).signal("v_p")[-1]
    assert model.simulate(0.03, "rodas-jit").signal("v_p")[-1] == pytest.approx(resolved, rel=1e-5)
    assert model.simulate(0.03, "auto").signal("v_p")[-1] == pytest.approx(resolved, rel=1e-5)


def test_the_continuous_extension_meets_the_step_ends():
    y0, y1, q1, q2 = np.array([1.0, -2.0]), np.array([3.0, 0.5]), np.array([0.7, 9.0]), np.array([-4.0, 2.0])
    assert np.array_equal(rosenbrock.rodas_dense(y0, y1, q1, q2, 0.0), y0)
    assert np.array_equal(rosenbrock.rodas_dense(y0, y1, q1, q2, 1.0), y1)


def test_the_step_control_bounds_and_rejections():
    """h_new/h within [0.2, 6]; a rejected first step becomes a tenth; no growth right after a
    rejection; a NaN error is a rejection."""
    h_new, h_acc, err_acc = rosenbrock.rodas_control(0.0, 1.0, 0.0, 0.0, False)
    assert h_new == pytest.approx(6.0) and h_acc == 1.0 and err_acc == 1e-2
    assert rosenbrock.rodas_control(1e6, 1.0, 0.5, 0.1, False)[0] == pytest.approx(0.2)
    assert rosenbrock.rodas_control(2.0, 1.0, 0.0, 0.0, False)[0] == pytest.approx(0.1)
    assert rosenbrock.rodas_control(1e-3, 1.0, 0.5, 0.1, True)[0] == 1.0
    assert rosenbrock.rodas_control(math.nan, 1.0, 0.5, 0.1, False) == (0.2, 0.5, 0.1)


@pytest.mark.parametrize("n", [1, 3, 7])
def test_the_lu_solve_is_numpys_solve(n):
    """Partial pivoting: a matrix with a zero leading entry, random ones, and a sparse one (tridiagonal, its
    leading entry zero: eliminated and solved over its nonzeros' extent)."""
    rng = np.random.default_rng(n)
    sparse = np.diag(rng.normal(size=n)) + np.diag(np.ones(n - 1), 1) + np.diag(np.ones(n - 1), -1)
    sparse[0, 0] = 0.0 if n > 1 else 1.0
    for matrix in (rng.normal(size=(n, n)), np.roll(np.eye(n), 1, axis=0) + 0.1 * rng.normal(size=(n, n)), sparse):
        b = rng.normal(size=n)
        lu, piv, x = matrix.ravel().copy(), np.zeros(3 * n, dtype=np.int64), b.copy()
        assert implicit.lu_factor.py_func(lu, piv, n)
        implicit.lu_solve.py_func(lu, piv, n, x)
        np.testing.assert_allclose(x, np.linalg.solve(matrix, b), rtol=1e-10, atol=1e-12)
    assert not implicit.lu_factor.py_func(np.zeros(n * n), np.zeros(3 * n, dtype=np.int64), n)


def _stiff_chain(N=3, zeta=10.0, k=1e8, m=1.0):
    return ball_chain.build(N=N, compliant=True, k=k, b=2 * zeta * math.sqrt(k * m / 2))


def _momenta(model, N):
    return [model.state_index[s] for s in model.states if s.name in {f"p{i}" for i in range(1, N + 1)}]


def test_the_stiff_chain_has_the_instants_and_velocities_of_python_radau():
    """Three compliant balls, k = 1e8, ζ = 10, rtol 1e-10: the same instants (modes before and after) as
    Python's Radau, their times within 1e-9 relative, the final momenta within 1e-7; no warning."""
    model = _stiff_chain()
    options = dict(rtol=1e-10, atol=1e-12, output="events")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        compiled = model.simulate(0.5, "rodas-jit", **options)
    reference = model.simulate(0.5, "Radau", **options)
    assert len(compiled.events) == len(reference.events) >= 3
    assert [(e.mode_before, e.mode_after) for e in compiled.events] == \
        [(e.mode_before, e.mode_after) for e in reference.events]
    np.testing.assert_allclose(compiled.event_times, reference.event_times, rtol=1e-9, atol=0)
    momenta = _momenta(model, 3)
    np.testing.assert_allclose(compiled.x[-1][momenta], reference.x[-1][momenta], rtol=1e-7)
    assert compiled.stats["steps"] < reference.stats["steps"]


def test_the_stiff_chain_creates_no_energy_and_raises_no_stiffness():
    """Every step of the damped chain: stored plus dissipated energy never exceeds the start (the energy
    balance of the run's steps finds nothing created), and the implicit method never stops as stiff."""
    model = _stiff_chain()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        trajectory = model.simulate(0.5, "rodas-jit", rtol=1e-8, atol=1e-10)
    balance = energy_created(trajectory)
    assert balance is not None and balance.first is None, balance
    assert trajectory.stopped is None and "failed" not in trajectory.stats


def test_without_a_compiled_jacobian_the_kernel_differences_f(monkeypatch):
    """A mode whose Jacobian is not derived (over the symbolic budget) flows with ``J`` from differences of
    ``f``: the same instants and velocities."""
    from switching.simulate import compiled_flow

    derived = []

    def counted(model, mode):
        derived.append(compiled(model, mode))
        return derived[-1]

    compiled = compiled_flow.jacobian_function
    monkeypatch.setattr(compiled_flow, "jacobian_function", counted)
    options = dict(rtol=1e-10, atol=1e-12, output="events")
    symbolic = _stiff_chain().simulate(0.5, "rodas-jit", **options)
    assert len(derived) >= 2 and all(j is not None for j in derived)
    derived.clear()
    compiled = lambda model, mode: None  # noqa: E731
    model = _stiff_chain()
    differenced = model.simulate(0.5, "rodas-jit", **options)
    assert len(derived) >= 2 and not any(derived)
    assert len(differenced.events) == len(symbolic.events)
    np.testing.assert_allclose(differenced.event_times, symbolic.event_times, rtol=1e-8, atol=0)
    momenta = _momenta(model, 3)
    np.testing.assert_allclose(differenced.x[-1][momenta], symbolic.x[-1][momenta], rtol=1e-7)


@pytest.mark.slow
def test_ten_stiff_balls_have_the_instants_of_python_radau():
    model = _stiff_chain(N=10)
    options = dict(rtol=1e-8, atol=1e-10, output="events")
    compiled = model.simulate(0.5, "rodas-jit", **options)
    reference = model.simulate(0.5, "Radau", **options)
    assert [(e.mode_before, e.mode_after) for e in compiled.events] == \
        [(e.mode_before, e.mode_after) for e in reference.events]
    np.testing.assert_allclose(compiled.event_times, reference.event_times, rtol=1e-7, atol=0)
    momenta = _momenta(model, 10)
    np.testing.assert_allclose(compiled.x[-1][momenta], reference.x[-1][momenta], atol=1e-6)


# ---------------------------------------------------------------- method="auto": explicit or implicit per mode


def test_the_spectrum_says_which_modes_of_the_chain_are_stiff():
    """In contact (k = 1e8, ζ = 10) the fastest decay is ≈ 2ζω ≈ 2.8e5 1/s: stiff over 0.5 s; apart, only the
    relaxing damper's k/b ≈ 707 1/s: not stiff (354 ≤ 1e4)."""
    from switching.library.spectrum import STIFF_SPAN, mode_stiffness
    from switching.model.modes import Mode

    model = _stiff_chain(N=2)
    x = model.initial_state()
    free = mode_stiffness(model, Mode(("free",), ("contact1",)), x, 0.0, 0.5)
    touch = mode_stiffness(model, Mode(("touch",), ("contact1",)), x, 0.0, 0.5)
    assert not free.stiff and free.value == pytest.approx(0.5 * 1e8 / (2 * 10 * math.sqrt(1e8 / 2)), rel=1e-9)
    assert touch.stiff and touch.value > 10 * STIFF_SPAN
    assert "max |Re λ|·T" in touch.reason and "> 10000" in touch.reason


def test_auto_flows_implicitly_in_the_stiff_modes_and_says_so(monkeypatch):
    from switching.library import jit_model

    # the compiled path counted as loaded and cached (otherwise the choice depends on which tests ran before in
    # this process, and on numba's disk cache: a first run after a change of the kernel compiles it either way)
    monkeypatch.setattr(jit_model, "load_seconds", lambda: 0.0)
    monkeypatch.setattr(jit_model, "kernel_compiled", lambda implicit=False: True)
    model = _stiff_chain()
    options = dict(rtol=1e-10, atol=1e-12, output="events")
    auto = model.simulate(0.5, "auto", **options)
    reference = model.simulate(0.5, "Radau", **options)
    assert auto.stats["method"] == "RK45-jit"
    assert "rodas-jit in its stiff modes" in auto.stats["method chosen by auto"]
    per_mode = dict(entry.split(": ", 1) for entry in auto.stats["method per mode (auto)"].split("; "))
    assert per_mode["contact1=free, contact2=free"].startswith("RK45-jit")
    assert per_mode["contact1=touch, contact2=touch"].startswith("rodas-jit")
    assert [(e.mode_before, e.mode_after) for e in auto.events] == \
        [(e.mode_before, e.mode_after) for e in reference.events]
    np.testing.assert_allclose(auto.event_times, reference.event_times, rtol=1e-9, atol=0)
    momenta = _momenta(model, 3)
    np.testing.assert_allclose(auto.x[-1][momenta], reference.x[-1][momenta], rtol=1e-7)


def test_auto_switches_a_mode_whose_explicit_flow_proves_stiff(monkeypatch):
    """The mode judged not stiff (a threshold no mode reaches) on the Prothero–Robinson problem at λ = 1e5:
    RK45's own stiffness test fires, and the mode flows with RODAS4P from there on instead of the run stopping
    (RK45 alone would take some 1e5 steps)."""
    from switching.library import jit_model, spectrum

    monkeypatch.setattr(spectrum, "STIFF_SPAN", 1e300)
    monkeypatch.setattr(jit_model, "load_seconds", lambda: 0.0)  # (as in the test before: the compiled path loaded)
    monkeypatch.setattr(jit_model, "kernel_compiled", lambda implicit=False: True)
    auto = prothero_robinson(1e5).simulate(T_END, "auto", rtol=1e-8, atol=1e-11, output="events")
    assert auto.stats["method"] == "RK45-jit" and auto.stopped is None
    assert "rodas-jit (RK45's stiffness test fired at t = " in auto.stats["method per mode (auto)"]
    assert auto.stats["steps"] < 1000
    assert abs(auto.x[-1][0] - math.cos(T_END)) < 1e-8


def test_auto_in_python_continues_a_flow_that_proves_stiff_with_radau(monkeypatch):
    """Without the compiled kernel (as before its first compilation) ``auto`` flows in Python with RK45; where
    RK45's stiffness test fires, the flow goes on from its last step with Radau instead of stopping."""
    from switching.library import jit_model, spectrum

    monkeypatch.setattr(spectrum, "STIFF_SPAN", 1e300)
    monkeypatch.setattr(jit_model, "kernel_compiled", lambda implicit=False: False)
    auto = prothero_robinson(1e5).simulate(T_END, "auto", rtol=1e-8, atol=1e-11, output="events")
    assert auto.stats["method"] == "RK45" and auto.stopped is None
    assert "(Radau in the modes its flows proved stiff)" in auto.stats["method chosen by auto"]
    assert "Radau in Python from t = " in auto.stats["method per mode (auto)"]
    assert abs(auto.x[-1][0] - math.cos(T_END)) < 1e-7


# ---------------------------------------------------------------- the compiled Jacobian, called through its address


def _call_jacobian(function, model, y, t, size, which=0):
    """The compiled Jacobian ``function`` (op 6; ``which`` 2: its pattern) at ``(t, y)`` through its address,
    as the kernel calls it."""
    import numba

    from switching.kernel import calls
    from switching.library.jit_model import input_substitution

    @numba.njit
    def call(address, which, y, t, p, u, out, ints):
        return calls.call(address, 6, which, t, 0.0, 0.0, y, y, p, u, y, y, y, ints, ints, out)

    out = np.full(size, np.nan)
    u = input_substitution(model)[2]
    u = u if len(u) else np.zeros(1)
    assert call(function.address, which, np.array(y, dtype=float), float(t), model.parameter_array, u, out,
                np.zeros(1, dtype=np.int64)) == 1
    return out


@pytest.mark.parametrize("contact", [False, True])
def test_the_compiled_jacobian_is_the_derived_one_through_the_constraints(contact):
    """The falling rod (trigonometric rates; in contact the tip's height is a constraint): the compiled
    function's entries equal :class:`FlowJacobian`'s (sympy's derivatives, evaluated in Python) at random
    states, zeros included; its pattern is the structural one."""
    import models
    from switching.library.jacobian import flow_jacobian
    from switching.library.jit_jacobian import jacobian_function
    from switching.model.modes import Mode

    model = models.load("falling_rod").build()
    mode = Mode(("contact" if contact else "free", "stuck"), ("contact", "friction"))
    cm = model.compiled_mode(mode)
    k = len(cm.independent)
    function = jacobian_function(model, mode)
    pattern = _call_jacobian(function, model, model.initial_state()[cm.independent], 0.0, k * k, which=2)
    sparsity = flow_jacobian(model, cm, model.initial_state()).sparsity
    assert np.array_equal(pattern.reshape(k, k), sparsity.astype(float)) and 0 < sparsity.sum() < k * k
    rng = np.random.default_rng(3)
    for _ in range(4):
        x = model.initial_state() + rng.normal(scale=0.3, size=len(model.states))
        expected = flow_jacobian(model, cm, x).dense(0.0, x[cm.independent])
        got = _call_jacobian(function, model, x[cm.independent], 0.0, k * k).reshape(k, k)
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12 * np.max(np.abs(expected)))


def test_the_compiled_jacobian_of_a_driven_flow_carries_its_time_derivative():
    """Prothero–Robinson: ``J = −λ`` and ``∂f/∂t = λ·u̇ = −λ·sin t − cos t`` after it."""
    from switching.library.jit_jacobian import jacobian_function

    lam, t = 1000.0, 0.7
    model = prothero_robinson(lam)
    out = _call_jacobian(jacobian_function(model, model.initial_mode), model, [0.3], t, 2)
    assert out[0] == pytest.approx(-lam, rel=1e-14)
    assert out[1] == pytest.approx(-lam * math.sin(t) - math.cos(t), rel=1e-14)
