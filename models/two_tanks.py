"""Two tanks in cascade with level-switched valves (hydraulic domain).

A pump delivers a constant volume flow ``Q_in`` into tank 1.  A transfer
valve (in series with the pipe resistance ``R_v``) lets tank 1 drain into
tank 2; a drain valve (in series with the outlet resistance ``R_out``) lets
tank 2 drain to the atmosphere.  Each valve is switched by an on/off level
controller with hysteresis.

Bond graph (power directions by arrows; junctions as ``0:name`` / ``1:name``,
bond names in brackets)::

    Sf: Q_in ──[pump]──► 0:n1 ──[tank1]──► C: tank1     (state V1, C = A1/(rho·g))
                          │
                      [transfer]
                          ▼
                         1:V (controlled) ──[R_v]──► R: R_v
                          │
                        [pipe]
                          ▼
                         0:n2 ──[tank2]──► C: tank2     (state V2, C = A2/(rho·g))
                          │
                       [outlet]
                          ▼
                         1:O (controlled) ──[R_out]──► R: R_out   (to the atmosphere, 0 Pa gauge)

``0:n1`` / ``0:n2`` carry the (gauge) pressures at the bottoms of the tanks,
``p = rho·g·h``; the tanks are linear C elements whose states are the stored
volumes ``V1``, ``V2`` [m³] (``h = V/A``).  The controlled 1-junction ``V``
is the transfer valve (off: no flow between the tanks; on: ``Q = (p1 −
p2)/R_v``), ``O`` the drain valve (off: no outflow; on: ``Q_out = p2/R_out``).

Automaton ``valve`` (states ``closed``: ``V`` off, ``open``: ``V`` on; initial ``closed``):

* ``closed → open``  when ``h1 >= h1_high`` (a priori);
* ``open → closed``  when ``h1 <= h1_low`` (a priori).

Automaton ``drain`` (states ``closed``: ``O`` off, ``open``: ``O`` on; initial ``closed``):

* ``closed → open``  when ``h2 >= h2_high`` (a priori);
* ``open → closed``  when ``h2 <= h2_low`` (a priori).

All four guards are *a priori*: they are controllers acting on the measured
level, a time-scale abstraction of a valve that moves fast compared with the
tank dynamics; the decision depends on the state before the switch, not on
its consequences (and no storage becomes dependent, so no state jumps).  The
hysteresis (``h_low < h_high``) keeps the switching from chattering: after a
valve moves, the level must travel across the band before it moves back.
The valve cycles for ever (rather than staying open) when
``Q_in·(R_v + R_out) < rho·g·h1_low`` — the level of tank 1 with both
valves open in steady state is below ``h1_low`` (true for the defaults).

Closed forms used by the tests: with the transfer valve closed, ``h1(t) =
h1(0) + Q_in·t/A1`` (it opens at ``t = A1·(h1_high − h1(0))/Q_in``); with
it open and the drain closed, the difference ``d = h1 − h2`` relaxes as
``d∞ + (d0 − d∞)·exp(−t/τ)``, ``τ = R_v/(rho·g·(1/A1 + 1/A2))``, ``d∞ =
Q_in·τ/A1``, while the total volume grows as ``Q_in·t``.

Sign conventions and units: volumes [m³], levels [m] above each tank's
outlet, pressures [Pa] gauge, volume flows [m³/s] in the direction of the
arrows (pump into tank 1, tank 1 → tank 2, tank 2 → atmosphere), ``A1``,
``A2`` [m²], ``rho`` [kg/m³], ``g`` [m/s²], resistances [Pa·s/m³].

Signals: ``h1``, ``h2`` (levels), ``p1``, ``p2`` (pressures), ``Q_pump``
(pump flow), ``Q_valve`` (flow through the transfer valve), ``Q_out``
(outflow through the drain), ``V_total`` (stored volume).

Valid range (exercised by ``tests/models/test_model_ranges.py``): positive
``Q_in``, areas, resistances, ``rho`` and ``g``, with ``h_low < h_high`` for
each valve (tested ``Q_in`` 1e-3 to 1e-1 m³/s, ``A1`` 0.1 to 10 m² with
``A2 = A1/2``, ``R_v`` 5e4 to 5e6 Pa·s/m³).  Each valve moves exactly at its
thresholds, alternately open and closed.  Outside the cycling condition above
(a large ``Q_in``) the valves open and stay open while the levels rise without
bound (the tanks have no overflow): no further events, no error.
"""

from __future__ import annotations

import sympy as sp

from bondgraph import BondGraph, C, One, R, Sf, Zero
from switching import Automaton, HybridModel

from ._common import annotated, merged, nonnegative, positive

__all__ = ["build", "DEFAULTS", "RUN", "SIGNALS", "UNITS"]

DEFAULTS = {
    "Q_in": 0.01,
    "A1": 1.0,
    "A2": 0.5,
    "R_v": 5e5,
    "R_out": 2e5,
    "rho": 1000.0,
    "g": 9.81,
    "h1_low": 1.0,
    "h1_high": 1.5,
    "h2_low": 0.3,
    "h2_high": 0.8,
    "h1_0": 0.5,
    "h2_0": 0.0,
}
#: physical ranges: a value outside gives a PhysicalRangeWarning
RANGES = {
    "Q_in": nonnegative("an inflow"),
    "A1": positive("a tank's area"),
    "A2": positive("a tank's area"),
    "R_v": positive("a valve's resistance"),
    "R_out": positive("an outlet's resistance"),
    "rho": positive("a density"),
    "g": positive("gravity"),
}
#: a meaningful default run (used by ``hbg run``): several valve cycles
RUN = {"t_end": 1000.0, "rtol": 1e-8}
#: the unit of each parameter, state and signal (shown on plots, kept in model files)
UNITS = {"Q_in": "m³/s", "A1": "m²", "A2": "m²", "R_v": "Pa·s/m³", "R_out": "Pa·s/m³", "rho": "kg/m³",
         "g": "m/s²", "h1_low": "m", "h1_high": "m", "h2_low": "m", "h2_high": "m", "h1_0": "m", "h2_0": "m",
         "V1": "m³", "V2": "m³", "h1": "m", "h2": "m", "p1": "Pa", "p2": "Pa", "Q_pump": "m³/s",
         "Q_valve": "m³/s", "Q_out": "m³/s", "V_total": "m³"}

SIGNALS = ("h1", "h2", "p1", "p2", "Q_pump", "Q_valve", "Q_out", "V_total")


def build(**parameters) -> HybridModel:
    """The two tanks with ``DEFAULTS`` overridden by ``parameters``."""
    p = merged(DEFAULTS, parameters, RANGES, "two_tanks")
    rho, g_, A1, A2 = (sp.Symbol(n) for n in ("rho", "g", "A1", "A2"))
    g = BondGraph("two_tanks")
    n1, n2 = g.add(Zero("n1")), g.add(Zero("n2"))
    valve, outlet = g.add(One("V", controlled=True)), g.add(One("O", controlled=True))
    g.connect(Sf("pump", "Q_in"), n1)
    g.connect(n1, C("tank1", A1 / (rho * g_), state="V1"))
    g.connect(n1, valve, name="transfer")
    g.connect(valve, R("R_v", "R_v"))
    g.connect(valve, n2, name="pipe")
    g.connect(n2, C("tank2", A2 / (rho * g_), state="V2"))
    g.connect(n2, outlet, name="outlet")
    g.connect(outlet, R("R_out", "R_out"))

    transfer = Automaton("valve", {"closed": {"V": False}, "open": {"V": True}}, initial="closed")
    transfer.add_transition("closed", "open", "h1 >= h1_high", "a priori")
    transfer.add_transition("open", "closed", "h1 <= h1_low", "a priori")
    drain = Automaton("drain", {"closed": {"O": False}, "open": {"O": True}}, initial="closed")
    drain.add_transition("closed", "open", "h2 >= h2_high", "a priori")
    drain.add_transition("open", "closed", "h2 <= h2_low", "a priori")

    names = ("Q_in", "A1", "A2", "R_v", "R_out", "rho", "g", "h1_low", "h1_high", "h2_low", "h2_high", "h1_0", "h2_0")
    model_parameters = {k: p[k] for k in names}
    return HybridModel(
        g,
        [transfer, drain],
        model_parameters,
        initial_state={"V1": "A1*h1_0", "V2": "A2*h2_0"},
        signals={
            "h1": "V1/A1",
            "h2": "V2/A2",
            "p1": "e_tank1",
            "p2": "e_tank2",
            "Q_pump": "f_pump",
            "Q_valve": "f_transfer",
            "Q_out": "f_outlet",
            "V_total": "V1 + V2",
        },
        name="two_tanks",
        **annotated(UNITS, RANGES, DEFAULTS, model_parameters),
    )
