"""The energy ledger (issue 18, item 3): stored energy from the storage laws,
energy before/after every instant and the energy lost, against exact answers."""

from __future__ import annotations

import pickle
import warnings

import numpy as np
import pytest
import sympy as sp

from bondgraph import C, I, R, BondGraph, EnergyGainWarning, HybridBondGraphError, One, PhysicalRangeWarning, Se
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


def joined_capacitors(V1, V2, C1=1e-3, C2=2e-3):
    """Two capacitors charged to V1 and V2 that start joined (a closed switch): the start projects
    their charges onto one common voltage ``(C1 V1 + C2 V2)/(C1 + C2)``."""
    from bondgraph import Zero
    from switching import Automaton, HybridModel

    g = BondGraph("joined")
    for k in (1, 2):
        g.connect(g.add(Zero(f"n{k}")), C(f"cap{k}", f"C{k}", state=f"q{k}"))
    g.connect("n1", g.add(One("switch", controlled=True)))
    g.connect("switch", "n2")
    automaton = Automaton("sw", {"closed": {"switch": True}, "open": {"switch": False}}, "closed")
    automaton.add_transition("closed", "open", "t >= 1")
    return HybridModel(g, [automaton], {"C1": C1, "C2": C2}, initial_state={"q1": C1 * V1, "q2": C2 * V2})


def test_the_projection_of_the_start_is_in_the_ledger():
    """Charge sharing at the start loses ``C1 C2 ΔV²/(2 (C1 + C2))``, recorded at t0
    as the ledger's first entry and printed by the summary."""
    from switching import InitialStateProjected

    C1, C2, V1, V2 = 1e-3, 2e-3, 5.0, 1.0
    model = joined_capacitors(V1, V2, C1, C2)
    with pytest.warns(InitialStateProjected):
        run = model.simulate(0.5, "RK45")
    (first,) = run.energy_ledger()
    assert first.what == "initial projection" and first.t == 0.0
    assert first.before == pytest.approx((C1 * V1**2 + C2 * V2**2) / 2, rel=1e-12)
    assert first.lost == pytest.approx(C1 * C2 * (V1 - V2) ** 2 / (2 * (C1 + C2)), rel=1e-12)
    assert f"energy lost at the initial projection: {first.lost:.6g} J" in run.summary()
    x0 = model.given_initial_state  # a start given explicitly is the run's own: nothing projected
    assert model.simulate(0.5, "RK45", x0=model.initial_state()).energy_ledger() == []
    assert np.allclose(x0, [C1 * V1, C2 * V2])


def test_a_loss_within_round_off_is_printed_as_zero_with_its_bound():
    run = bouncing_ball.build(e=1.0).simulate(1.5, "RK45", rtol=1e-10, atol=1e-12)
    ledger = run.energy_ledger()
    scale = max(max(abs(r.before), abs(r.after)) for r in ledger)
    assert abs(sum(r.lost for r in ledger)) <= 1e-9 * scale  # a perfectly elastic ball loses nothing
    assert "energy lost at instants: 0 J (within round-off, |ΔE| ≤ " in run.summary()


@pytest.mark.parametrize("method, options", [("RK45", {}), ("rk4", {"dt": 0.1}), ("euler", {"dt": 0.1})])
def test_a_model_without_storage_runs_stores_nothing_and_summarises(method, options):
    """No C or I: no state (n = 0); the energy watch and the summary still work, the stored energy is 0,
    the resistor takes v²/R of the source's v = sin t."""
    from bondgraph.symbols import t as time
    from switching import HybridModel

    g = BondGraph("resistive")
    loop = g.add(One("loop"))
    g.connect(Se("V", sp.sin(time)), loop)
    g.connect(loop, R("R", 2.0))
    run = HybridModel(g, [], {}, signals={"v": "e_R"}).simulate(1.0, method, **options)
    assert run.x.shape == (len(run.t), 0)
    assert np.all(run.energy() == 0.0)
    assert run.signal("v") == pytest.approx(np.sin(run.t), abs=1e-15)
    assert "0 instants" in run.summary()
