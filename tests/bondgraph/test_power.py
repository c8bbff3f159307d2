"""Power flows as signals (issue 18, item 3): what the sources supply, what the R
elements dissipate, what the storage takes in.

Exact answers: two capacitors (C1 at V1, C2 at V2) joined through a resistor R
exchange the current ``i = ΔV/R·e^{−t/τ}``, ``τ = R C1 C2/(C1 + C2)``; the resistor
dissipates ``∫ R i² dt = ΔV² τ/(2R) = C1 C2 ΔV²/(2(C1 + C2))`` whatever R — the energy
the ideal switch (R = 0) loses at its instant.  The diode circuit's source V
supplies ``V·i_L`` while the switch is closed.
"""

from __future__ import annotations

import numpy as np
import pytest

from bondgraph.errors import HybridBondGraphError, UnknownNameError
from models import diode_circuit, falling_rod, parallel_capacitors
from switching.sweep.batch import shared_model


def test_resistor_dissipates_what_the_ideal_switch_loses():
    C1, C2, V1, V2 = 1e-3, 2e-3, 5.0, 1.0
    lost = C1 * C2 * (V1 - V2) ** 2 / (2 * (C1 + C2))
    # 20001 uniform times and the closing's two rows (τ = 3.3 ms: the exchange is over long before the end): the
    # power jumps from 0 at the closing, and its before/after rows keep the jump out of the trapezoids
    run = parallel_capacitors.build(R=5.0).simulate(0.05, "RK45", samples=20001, rtol=1e-10, atol=1e-14)
    assert len(run.t) == 20001 + 2 and len(run.event_index) == 1
    flows = run.power_balance()
    assert np.trapezoid(flows["dissipated"], run.t) == pytest.approx(lost, rel=1e-6)
    assert np.all(flows["dissipated"] >= 0.0)
    np.testing.assert_allclose(flows["supplied"], 0.0, atol=1e-15)  # no sources
    np.testing.assert_allclose(flows["stored"], -flows["dissipated"], atol=1e-12)
    ideal = parallel_capacitors.build(R=0.0).simulate(0.05, "RK45", rtol=1e-10, atol=1e-14)
    assert ideal.energy_ledger()[0].lost == pytest.approx(lost, rel=1e-12)
    np.testing.assert_allclose(ideal.power_balance()["dissipated"], 0.0)


def test_a_source_supplies_e_times_f():
    run = diode_circuit.build().simulate(0.4, "RK45", rtol=1e-10, t_eval=np.linspace(0.0, 0.4, 9))
    np.testing.assert_allclose(run.power("V"), -10.0 * run.signal("i_L"), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(run.power("R"), run.signal("i_L") ** 2 * 1.0, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(run.power("L"), run.signal("i_L") * run.signal("v_L"), rtol=1e-12, atol=1e-12)


def test_the_sliding_rods_power_balance():
    """The junction structure conserves power: supplied = dissipated + stored
    in every mode, the stored part is the rate of the stored energy, and the
    Coulomb source takes power out while the tip slides."""
    times = np.linspace(0.2, 0.4, 201)
    with shared_model(falling_rod.build, {"mu": 0.002}) as model:  # (derived modes shared with other rod tests)
        run = model.simulate(0.4, "RK45", t_eval=times, rtol=1e-11, atol=1e-13)
        np.testing.assert_array_equal(run.t, times)  # one row per requested time, no others
        flows = run.power_balance()
        energy, friction = run.energy(), run.power("coulomb")
    scale = np.max(np.abs(flows["stored"]))
    np.testing.assert_allclose(flows["supplied"] - flows["dissipated"], flows["stored"], atol=1e-12 * scale)
    rate = np.gradient(energy, times)
    np.testing.assert_allclose(flows["stored"][1:-1], rate[1:-1], atol=1e-4 * scale)
    assert np.all(friction >= 0.0) and np.max(friction) > 0.0


def test_power_flows_are_signals_by_name(tmp_path):
    run = diode_circuit.build().simulate(0.4, "RK45", rtol=1e-10, t_eval=np.linspace(0.0, 0.4, 9))
    np.testing.assert_array_equal(run.signal("power:R"), run.power("R"))
    np.testing.assert_array_equal(run.signal("power:supplied"), run.power_balance()["supplied"])
    run.to_csv(tmp_path / "run.csv", signals=["power:V", "power:dissipated"])
    assert "power:dissipated" in (tmp_path / "run.csv").read_text().splitlines()[0]


def test_power_is_for_one_port_elements():
    run = diode_circuit.build().simulate(0.1, "RK45")
    with pytest.raises(HybridBondGraphError, match="not a one-port element"):
        run.power("loop")
    with pytest.raises(UnknownNameError, match="no element 'Q'"):
        run.power("Q")
