"""The energy ledger (issue 18, item 3): stored energy from the storage laws,
energy before/after every instant and the energy lost, against exact answers."""

from __future__ import annotations

import pickle
import warnings

import numpy as np
import pytest
import sympy as sp

from bondgraph import C, I, BondGraph, EnergyGainWarning, HybridBondGraphError, One, PhysicalRangeWarning
from bondgraph import energy_function, storage_energy, stored_energy
from models import ball_chain, bouncing_ball, parallel_capacitors


def test_linear_laws_store_quadratic_energy():
    q, p = sp.symbols("q1 p")
    assert storage_energy(C("cap1", "C1", state="q1")) == q**2 / (2 * sp.Symbol("C1"))
    assert storage_energy(I("ball", "m", state="p")) == p**2 / (2 * sp.Symbol("m"))


def test_nonlinear_capacitor_law_is_integrated():
    C3 = sp.Symbol("C3")
    element = C("spring", effort_law=lambda q: q**3 / C3, state="q")
    derived = storage_energy(element)
    assert sp.simplify(derived - sp.Symbol("q") ** 4 / (4 * C3)) == 0
    # a saturating inductor f = tanh(p)/a: E(0) = 0 and dE/dp = f (E = log(cosh p)/a)
    a, p = sp.symbols("a p")
    derived = storage_energy(I("coil", flow_law=lambda s: sp.tanh(s) / a, state="p"))
    assert derived.subs(p, 0) == 0
    assert sp.simplify(sp.diff(derived, p) - sp.tanh(p) / a) == 0
    assert float(derived.subs({p: 1.5, a: 2.0})) == pytest.approx(np.log(np.cosh(1.5)) / 2, rel=1e-14)


def test_stored_energy_of_a_graph_and_its_numeric_evaluator():
    g = BondGraph("oscillator")
    v = g.add(One("v"))
    g.connect(v, I("mass", "m", state="p"))
    g.connect(v, C("spring", effort_law=lambda q: q**3 / sp.Symbol("C3"), state="q"))
    q, p, m, C3 = sp.symbols("q p m C3")
    assert sp.simplify(stored_energy(g) - (p**2 / (2 * m) + q**4 / (4 * C3))) == 0
    fn = energy_function(g, g.states, {m: 2.0, C3: 0.5})
    x = np.array([[1.0, 2.0], [3.0, -1.0]])  # columns p, q
    assert fn(x, [0.0, 1.0]) == pytest.approx([1 / 4 + 16 / 2, 9 / 4 + 1 / 2], rel=1e-15)
    assert fn(x[0], 0.0) == pytest.approx(1 / 4 + 16 / 2, rel=1e-15)


def test_charge_sharing_loses_the_exact_energy_at_the_switch_instant():
    C1, C2, V1, V2 = 1e-3, 2e-3, 5.0, 1.0
    run = parallel_capacitors.build(C1=C1, C2=C2, V1=V1, V2=V2, R=0.0).simulate(0.05, "RK45", rtol=1e-9,
                                                                                atol=1e-12)
    ledger = run.energy_ledger()
    assert len(ledger) == 1
    record = ledger[0]
    assert record.t == pytest.approx(0.01)
    assert record.before == pytest.approx(C1 * V1**2 / 2 + C2 * V2**2 / 2, rel=1e-12)
    assert record.lost == pytest.approx(C1 * C2 * (V1 - V2) ** 2 / (2 * (C1 + C2)), rel=1e-12)
    assert record.lost == pytest.approx(record.before - record.after, rel=1e-15)
    energy = run.energy()
    assert energy.shape == run.t.shape
    assert np.allclose(energy, run.signal("energy"), rtol=1e-14, atol=0)
    summary = run.summary()
    assert f"energy lost at instants: {record.lost:.6g} J" in summary


def test_a_bounce_loses_one_minus_e_squared_of_the_kinetic_energy():
    m, g, e, y0 = 2.0, 9.81, 0.8, 1.0
    run = bouncing_ball.build(m=m, g=g, e=e, y0=y0).simulate(0.6, "RK45", rtol=1e-10)
    ledger = run.energy_ledger()
    assert len(ledger) == 1  # one bounce before t = 0.6 s
    v = -run.events[0].x_before[run.state_names.index("p")] / m
    assert ledger[0].before == pytest.approx(m * v**2 / 2, rel=1e-12)
    assert ledger[0].lost == pytest.approx((1 - e**2) * m * v**2 / 2, rel=1e-12)
    # the speed at impact is the free-fall one, so the loss is (1 − e²)·m·g·y0
    assert ledger[0].lost == pytest.approx((1 - e**2) * m * g * y0, rel=1e-6)
    assert "energy lost at instants:" in run.summary()


def test_a_lossless_chain_loses_nothing_beyond_round_off():
    run = ball_chain.build(N=4, e=1.0).simulate(0.5, "RK45", rtol=1e-9, atol=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error", EnergyGainWarning)
        ledger = run.energy_ledger()
    assert ledger
    for record in ledger:
        assert abs(record.lost) <= 1e-12 * record.before
    assert np.ptp(run.energy()) <= 1e-12 * run.energy()[0]


def test_a_jump_that_creates_energy_warns_with_its_time_and_modes():
    with pytest.warns(PhysicalRangeWarning):
        model = bouncing_ball.build(e=1.2)
    run = model.simulate(0.6, "RK45", rtol=1e-10)
    with pytest.warns(EnergyGainWarning, match=r"t = 0\.45\d+ \(contact=flight .*contact=impact \[pinnacle\]"):
        ledger = run.energy_ledger()
    assert ledger[0].lost < 0
    with warnings.catch_warnings():
        warnings.simplefilter("error", EnergyGainWarning)
        assert "energy lost at instants: -" in run.summary()  # the summary reports, it does not warn


def test_without_kept_instants_the_ledger_is_empty_and_the_summary_has_no_line():
    run = bouncing_ball.build().simulate(0.6, "RK45", keep_instants=False)
    assert run.energy_ledger() == []
    assert "energy lost" not in run.summary()
    assert run.energy().shape == run.t.shape


def test_an_unpickled_trajectory_needs_its_model_for_energy():
    run = parallel_capacitors.build().simulate(0.05, "RK45")
    copy = pickle.loads(pickle.dumps(run))
    with pytest.raises(HybridBondGraphError, match="unpickled without its model"):
        copy.energy()
    with pytest.raises(HybridBondGraphError, match="unpickled without its model"):
        copy.energy_ledger()
    assert "energy lost" not in copy.summary()
    copy.model = run.model
    assert np.array_equal(copy.energy(), run.energy())
