"""The flow's Jacobian derived symbolically (issue 30, item 1): against a
hand-derived Jacobian, against finite differences through the constraints,
and used by scipy's implicit methods with the same results."""

import numpy as np
import pytest
import sympy as sp

import models
from switching.library.jacobian import flow_jacobian
from switching.model.modes import Mode
from switching.simulate import python_flow
from switching.simulate.flow_rates import flow_functions


def _chain(N=2, k=1e4, b=3.0):
    return models.load("ball_chain").build(N=N, compliant=True, k=k, b=b)


def test_the_jacobian_of_a_damped_contact_is_the_hand_derived_one():
    """Two balls touching through a spring k and a damper b (states p1, p2, q1, pos1, pos2):
    ṗ1 = −(k q + b (p1 − p2)/m), ṗ2 = −ṗ1, q̇ = (p1 − p2)/m, pȯs_i = p_i/m."""
    model = _chain()
    mode = Mode(("touch",), ("contact1",))
    cm = model.compiled_mode(mode)
    jac = flow_jacobian(model, cm, model.initial_state())
    names = [model.state_names[i] for i in cm.independent]
    p1, p2, x1, x2, q = sp.symbols("p1 p2 x1 x2 q1")
    m, k, b = 1.0, 1e4, 3.0
    force = k * q + b * (p1 - p2) / m
    rates = {"p1": -force, "p2": force, "pos1": p1 / m, "pos2": p2 / m, "q1": (p1 - p2) / m}
    symbols = {"p1": p1, "p2": p2, "pos1": x1, "pos2": x2, "q1": q}
    expected = sp.Matrix([[sp.diff(rates[a], symbols[c]) for c in names] for a in names])
    y = np.array([0.3, -0.2, 0.1, 0.19, 0.01])
    derived = sp.Matrix(jac.dense(0.0, y))
    assert all(sp.simplify(d - e) == 0 for d, e in zip(derived, expected))
    assert jac.sparsity.sum() == sum(1 for e in expected if e != 0)


@pytest.mark.parametrize("contact", [False, True])
def test_the_jacobian_matches_finite_differences_through_the_constraints(contact):
    """The falling rod: trigonometric rates; in contact the tip's height is a constraint
    (dependent states), so ∂ẏ/∂y carries ∂f/∂x_D · ∂φ/∂x_I."""
    model = models.load("falling_rod").build()
    mode = Mode(("contact" if contact else "free", "stuck"), ("contact", "friction"))
    cm = model.compiled_mode(mode)
    if contact:
        assert len(cm.dependent)
    rng = np.random.default_rng(7)
    x = model.initial_state() + rng.normal(scale=0.1, size=len(model.states))
    fun, _, y0 = flow_functions(model, cm, cm.complete(x.copy(), 0.0))
    jac = flow_jacobian(model, cm, x)
    for _ in range(5):
        y = y0 + rng.normal(scale=0.2, size=len(y0))
        numeric = np.empty((len(y), len(y)))
        for j in range(len(y)):
            h = 1e-6 * max(1.0, abs(y[j]))
            up, down = y.copy(), y.copy()
            up[j] += h
            down[j] -= h
            numeric[:, j] = (np.asarray(fun(0.0, up)) - np.asarray(fun(0.0, down))) / (2 * h)
        assert np.allclose(jac.dense(0.0, y), numeric, rtol=1e-6, atol=1e-6 * np.abs(numeric).max())


def test_a_large_sparse_jacobian_is_handed_over_sparse_and_equals_the_dense_one():
    model = _chain(N=25)
    mode = Mode(("touch",) * 24, tuple(f"contact{i}" for i in range(1, 25)))
    cm = model.compiled_mode(mode)
    jac = flow_jacobian(model, cm, model.initial_state())
    y = np.linspace(-1, 1, jac.k)
    assert jac.sparse and np.array_equal(jac(0.0, y).toarray(), jac.dense(0.0, y))


@pytest.mark.parametrize("method", ["Radau", "BDF", "LSODA"])
def test_the_implicit_methods_with_the_derived_jacobian_give_the_instants_of_finite_differences(method,
                                                                                                 monkeypatch):
    """A stiff damped chain (k = 1e8, ζ = 0.5: the overlap crosses zero at release; at ζ = 10 round-off decides
    the release, issue 30 item 3): the same instants and final velocities whether the method
    estimates J by finite differences or takes the derived one."""
    k, m = 1e8, 1.0
    model = _chain(N=4, k=k, b=2 * 0.5 * np.sqrt(k * m / 2))
    derived = model.simulate(0.3, method, rtol=1e-8, atol=1e-10, output="events")
    calls = []
    original = python_flow.flow_jacobian
    monkeypatch.setattr(python_flow, "flow_jacobian", lambda *a: calls.append(a) or None)
    estimated = model.simulate(0.3, method, rtol=1e-8, atol=1e-10, output="events")
    assert calls and original is not None
    assert [(e.mode_before, e.mode_after) for e in derived.events] == \
        [(e.mode_before, e.mode_after) for e in estimated.events]
    assert np.allclose(derived.event_times, estimated.event_times, rtol=1e-6, atol=1e-9)
    velocities = [model.state_index[s] for s in model.states if s.name.startswith("p")]
    assert np.allclose(derived.x[-1][velocities], estimated.x[-1][velocities], rtol=1e-6, atol=1e-8)


def test_an_explicit_method_derives_no_jacobian(monkeypatch):
    model = _chain()
    monkeypatch.setattr(python_flow, "flow_jacobian", lambda *a: pytest.fail("derived for RK45"))
    model.simulate(0.2, "RK45", output="events")


def test_modes_that_share_a_rate_differentiate_it_once(monkeypatch):
    """The Jacobians of two modes of a four-ball chain that differ in the
    last contact only: the first two balls' rates are the same expressions,
    differentiated once for both (the model's gradient memo), and each
    mode's Jacobian is still its own (against a fresh model's)."""
    from switching.library import jacobian

    calls = []
    differentiate = jacobian.real_gradient
    monkeypatch.setattr(jacobian, "real_gradient", lambda e, v: calls.append(e) or differentiate(e, v))
    model = _chain(N=4)
    free, touching = (Mode(("touch", "touch", last), ("contact1", "contact2", "contact3"))
                      for last in ("free", "touch"))
    k = len(model.compiled_mode(free).independent)
    jacobian.jacobian_entries(model, free, tuple(model.compiled_mode(free).independent))
    first = len(calls)
    shared = jacobian.jacobian_entries(model, touching, tuple(model.compiled_mode(touching).independent))
    assert first == k and 0 < len(calls) - first < k
    fresh = _chain(N=4)
    alone = jacobian.jacobian_entries(fresh, touching, tuple(fresh.compiled_mode(touching).independent))
    assert shared[:2] == alone[:2]
    assert all(sp.simplify(a - b) == 0 for a, b in zip(shared[2], alone[2]))
