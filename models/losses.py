"""The losses of a circuit's switching devices over a window: conduction from the run, switching from a
datasheet's energies.

A switch or diode ``name`` of a :class:`~models.circuits.Circuit` has the signals ``v_<name>`` (across
it, first terminal minus second) and ``i_<name>`` (through it): the power it dissipates is
``v·i`` — zero in an ideal device, ``r_on·i² + v_f·i`` with an on-resistance and a forward drop.  Its
**conduction loss** over a window ``[a, b]`` is ``(1/T)·∫ v·i dt`` [W], integrated exactly piece by piece
(:mod:`switching.simulate.measurements`).

Its **switching loss** is what the ideal switch's instants cannot show: a datasheet's turn-on and turn-off
energies ``E_on(i)``, ``E_off(i)`` [J] at a test voltage ``V_test`` [V], scaled linearly with the voltage
switched (the datasheets' own rule): a closing at an instant costs ``E_on(i⁺)·v⁻/V_test`` (the current
after it, the voltage across the switch before it), an opening ``E_off(i⁻)·v⁺/V_test``; their sum over
the window divided by ``T`` [W].  Between the table's currents the energy is interpolated linearly, and
beyond them extrapolated from the nearest two points.  A MOSFET ``Q1`` (:meth:`Circuit.mosfet`) is the
switch ``Q1`` and its body diode ``Q1_D``: ask for each.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from bondgraph.errors import ParameterValueError
from switching.simulate.dense_rows import numbered
from switching.simulate.measurements import mean_product, window_of
from switching.simulate.signal_values import signal_table

__all__ = ["SwitchingEnergy", "DeviceLosses", "device_losses"]


@dataclass(frozen=True)
class SwitchingEnergy:
    """A datasheet's switching energies: ``currents`` [A] (increasing), ``e_on`` and ``e_off`` [J] at
    each current, measured at ``voltage`` [V] (the test voltage ``V_CE``/``V_DS``)."""

    currents: tuple
    e_on: tuple
    e_off: tuple
    voltage: float

    def __post_init__(self):
        currents = np.asarray(self.currents, dtype=float)
        for name, values in (("e_on", self.e_on), ("e_off", self.e_off)):
            if np.shape(values) != currents.shape:
                raise ParameterValueError(f"SwitchingEnergy: {name} has {np.size(values)} values for "
                                          f"{currents.size} currents: give one energy [J] per current", name, values)
        if currents.size < 2 or not np.all(np.diff(currents) > 0):
            raise ParameterValueError("SwitchingEnergy: give at least two currents [A], increasing",
                                      "currents", self.currents)
        if not float(self.voltage) > 0:
            raise ParameterValueError(f"SwitchingEnergy: the test voltage must be > 0 V, got {self.voltage!r}",
                                      "voltage", self.voltage)

    def energy(self, which: str, current: float, voltage: float) -> float:
        """``E_on`` or ``E_off`` [J] (``which``) at ``|current|`` [A] switched against ``|voltage|`` [V]."""
        table = np.asarray(self.e_on if which == "on" else self.e_off, dtype=float)
        currents = np.asarray(self.currents, dtype=float)
        i = abs(float(current))
        k = int(np.clip(np.searchsorted(currents, i) - 1, 0, len(currents) - 2))
        slope = (table[k + 1] - table[k]) / (currents[k + 1] - currents[k])
        return float(table[k] + slope * (i - currents[k])) * abs(float(voltage)) / float(self.voltage)


class DeviceLosses(NamedTuple):
    """A device's mean losses over the window [W]: ``conduction``, ``switching`` (0 without a table),
    ``total``; ``closings`` and ``openings`` counted in the window; ``window`` ``(a, b)`` [s]."""

    conduction: float
    switching: float
    total: float
    closings: int
    openings: int
    window: tuple


def device_losses(run, device: str, energies: SwitchingEnergy | None = None, **window) -> DeviceLosses:
    """The losses of switch or diode ``device`` over the window (``t_from``/``t_to`` [s] or ``periods``
    with ``period``, as :meth:`Trajectory.measure`), the module docstring's rules."""
    a, b = window_of(run, window.get("t_from"), window.get("t_to"), window.get("periods"), window.get("period"))
    voltage, current = f"v_{device}", f"i_{device}"
    conduction = mean_product(run, voltage, current, t_from=a, t_to=b)
    closings = openings = 0
    spent = 0.0
    for instant, before, after in _transitions(run, device, a, b):
        closing = after[2]
        closings, openings = closings + closing, openings + (not closing)
        if energies is not None:
            spent += (energies.energy("on", after[1], before[0]) if closing
                      else energies.energy("off", before[1], after[0]))
    switching = spent / (b - a)
    return DeviceLosses(conduction, switching, conduction + switching, closings, openings, (a, b))


def _transitions(run, device: str, a: float, b: float):
    """``(instant, (v, i, on) before, (v, i, on) after)`` of every instant in ``(a, b]`` at which the
    automaton ``device`` changed state (``on``: its junction conducts)."""
    model = run.model
    automaton = next((x for x in model.automata if x.name == device), None)
    if automaton is None:
        raise ParameterValueError(f"{device!r} is no switch or diode of {model.name!r} (its automata: "
                                  f"{', '.join(x.name for x in model.automata)})", "device", device)
    changed = [e for e in run.events if a < e.t <= b and e.mode_before.state_of(device) != e.mode_after.state_of(device)]
    if not changed:
        return []
    t = np.array([e.t for e in changed] * 2)
    x = np.array([e.x_before for e in changed] + [e.x_after for e in changed], dtype=float)
    modes = numbered([e.mode_before for e in changed] + [e.mode_after for e in changed])
    table = signal_table(model, [f"v_{device}", f"i_{device}"], t, x, modes)
    v, i, n = table[f"v_{device}"], table[f"i_{device}"], len(changed)
    conducts = [model.configuration_of(m).get(device, False) for m in
                [e.mode_before for e in changed] + [e.mode_after for e in changed]]
    return [(e, (v[k], i[k], conducts[k]), (v[n + k], i[n + k], conducts[n + k])) for k, e in enumerate(changed)]
