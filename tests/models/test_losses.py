"""A switching device's losses (models/losses.py) against the conduction and switching-loss formulas."""

import pytest

from bondgraph.errors import ParameterValueError
from models.circuits import PWM, Circuit
from models.losses import SwitchingEnergy, device_losses

V, R, R_ON, D, T = 100.0, 10.0, 0.5, 0.4, 1e-4


def chopper():
    """A source switched onto a resistor through ``r_on``: the switch carries ``I = V/(R + r_on)`` while
    closed, and blocks ``V`` while open."""
    c = Circuit("chopper")
    c.V("V1", "in", 0, V)
    c.switch("S1", "in", "x", PWM(T, D), r_on=R_ON)
    c.R("R1", "x", 0, R)
    return c.build()


def test_the_conduction_loss_is_d_times_i_squared_r_on():
    run = chopper().simulate(10 * T)
    losses = device_losses(run, "S1", periods=5, period=T)
    current = V / (R + R_ON)
    assert losses.conduction == pytest.approx(D * current**2 * R_ON, rel=1e-12)
    assert (losses.switching, losses.closings, losses.openings) == (0.0, 5, 5)


def test_the_switching_loss_sums_the_datasheet_energies_scaled_to_the_voltage_switched():
    """``E_on = a·i``, ``E_off = b·i`` at 50 V: each period closes against ``V`` onto ``I`` and opens
    ``I`` against ``V``, ``P = f·(a + b)·I·V/50``."""
    a, b = 2e-6, 3e-6
    table = SwitchingEnergy(currents=(0.0, 20.0), e_on=(0.0, 20 * a), e_off=(0.0, 20 * b), voltage=50.0)
    run = chopper().simulate(10 * T)
    losses = device_losses(run, "S1", table, periods=5, period=T)
    current = V / (R + R_ON)
    assert losses.switching == pytest.approx((a + b) * current * V / 50.0 / T, rel=1e-9)
    assert losses.total == pytest.approx(losses.conduction + losses.switching, rel=1e-15)


def test_a_table_extrapolates_from_its_nearest_points():
    table = SwitchingEnergy(currents=(1.0, 2.0, 4.0), e_on=(1.0, 2.0, 3.0), e_off=(1.0, 1.0, 1.0), voltage=10.0)
    assert table.energy("on", 3.0, 10.0) == pytest.approx(2.5)
    assert table.energy("on", 8.0, 20.0) == pytest.approx(2 * 5.0)  # (beyond: the last slope, the voltage ×2)
    assert table.energy("on", -1.5, 10.0) == pytest.approx(1.5)  # (|i|)


@pytest.mark.parametrize("arguments, said", [
    (dict(currents=(1.0,), e_on=(1.0,), e_off=(1.0,), voltage=1.0), "two currents"),
    (dict(currents=(1.0, 2.0), e_on=(1.0,), e_off=(1.0, 2.0), voltage=1.0), "one energy"),
    (dict(currents=(1.0, 2.0), e_on=(1.0, 2.0), e_off=(1.0, 2.0), voltage=0.0), "test voltage"),
])
def test_a_table_that_cannot_be_is_refused(arguments, said):
    with pytest.raises(ParameterValueError, match=said):
        SwitchingEnergy(**arguments)


def test_a_device_that_is_not_one_is_refused_naming_the_switches():
    run = chopper().simulate(2 * T)
    with pytest.raises(ParameterValueError, match="S1"):
        device_losses(run, "R1")
