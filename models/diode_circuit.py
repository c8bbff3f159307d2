"""The paper's Fig. 1: an inductor switched off into a freewheeling diode.

Circuit: a source ``V`` feeds, through a switch, a node ``n``; from ``n`` the
inductor ``L`` with its series resistance ``R`` runs to ground, and an ideal
diode (forward drop ``V_th``) conducts from ground up into ``n`` when the
inductor's current must go on after the switch opens.

Bond graph::

    Se: V ──► 1_sw (controlled: switch) ──► 0_n ──► 1_loop ──► I: L     (p_L = L i_L)
                                             │         └────► R: R
                                             ▼  bond "diode"
                                       1_D (controlled: diode) ──► Se: −V_th

``e`` of a bond into ``0_n`` is the node voltage ``v_n``; the diode's
forward voltage is ``v_D = −v_n`` (ground minus node) and its forward current
``i_D = −f_diode`` (up into the node).

Automata:

* ``switch`` (closed → open when ``t >= t_open``, a priori: an external
  command at a given time);
* ``diode`` (off → on when ``v_D >= V_th``; on → off when ``i_D <= I_th``;
  both **a posteriori**: an ideal diode is a parameter abstraction of a
  steep nonlinear resistor, so it is judged on the state the switch would
  produce — opening the switch with the diode off would force the inductor's
  flux to vanish, a pulse ``v_D = +∞`` that turns the diode on).

Opening the switch therefore passes the *mythical* mode (open, off): the
inductor's flux is the same before and after (invariance of state), and the
current decays through the diode as ``i(τ) = (i₀ + V_th/R) e^{−Rτ/L} − V_th/R``
until it reaches ``I_th``.  With ``I_th`` above the current at that moment —
e.g. ``I_th`` larger than the current when the switch opens — the diode turns
off, the inductor's flux would vanish, the diode turns on, …: the paper's
divergence-of-time loop, reported as an error that shows the loop.

Units: V, A, Ω, H, s.  Signals: ``i_L``, ``v_L``, ``i_D``, ``v_D``.

Valid range (exercised by ``tests/models/test_model_ranges.py``): ``I_th = 0`` (the
ideal diode turns off when its current reaches zero), ``V``, ``R``, ``L``
over orders of magnitude (tested ``V`` from 1e-2 to 1e4 V (with
``V_th = 0.07·V``), ``R`` from 1e-2 to 1e2 Ω, ``L`` from 1e-6 to 10 H).  The
switch opens at ``t_open`` with the current ``i_open``; the current then
reaches zero at ``t_open + (L/R)·ln(1 + R·i_open/V_th)``, where the diode
turns off (``open|off``, no current) for the rest of the run.  Any holding
current ``I_th > 0`` is met by the decaying current, at
``t_open + (L/R)·ln((i_open + V_th/R)/(I_th + V_th/R))``, or at ``t_open``
itself when ``I_th >= i_open``: there the run raises
:class:`~switching.DivergenceOfTimeError` — the loop described above, a
property of the ideal model (an inductor's current cannot be interrupted), not
of round-off.  When ``L/R`` is far below the run length, an explicit method
(RK45) stops with :class:`~switching.StiffnessError` while the switch is
closed; use Radau, BDF or LSODA.
"""

from __future__ import annotations

import sympy as sp

from bondgraph import BondGraph, I, One, R, Se, Zero
from switching import Automaton, HybridModel

from ._common import annotated, merged, nonnegative, positive

__all__ = ["build", "DEFAULTS", "RUN", "SIGNALS", "UNITS"]

DEFAULTS = {"V": 10.0, "R": 1.0, "L": 0.1, "V_th": 0.7, "I_th": 0.0, "t_open": 0.5, "i0": 0.0}
#: physical ranges: a value outside gives a PhysicalRangeWarning
RANGES = {
    "R": positive("a resistance"),
    "L": positive("an inductance"),
    "V_th": nonnegative("the diode's threshold voltage"),
    "I_th": nonnegative("the diode's holding current"),
}
RUN = {"t_end": 1.0, "rtol": 1e-8}
#: the unit of each parameter, state and signal (shown on plots, kept in model files)
UNITS = {"V": "V", "R": "Ω", "L": "H", "V_th": "V", "I_th": "A", "t_open": "s", "i0": "A",
         "p_L": "V·s", "i_L": "A", "v_L": "V", "i_D": "A", "v_D": "V"}

SIGNALS = ("i_L", "v_L", "i_D", "v_D")


def build(**parameters) -> HybridModel:
    """The diode circuit with ``DEFAULTS`` overridden by ``parameters``
    (``i0``: inductor current at t = 0)."""
    p = merged(DEFAULTS, parameters, RANGES, "diode_circuit")
    g = BondGraph("diode_circuit")
    sw, node, loop = g.add(One("sw", controlled=True)), g.add(Zero("n")), g.add(One("loop"))
    diode = g.add(One("D", controlled=True))
    g.connect(Se("V", "V"), sw)
    g.connect(sw, node)
    g.connect(node, loop)
    g.connect(loop, I("L", "L"))
    g.connect(loop, R("R", "R"))
    g.connect(node, diode, name="diode")
    g.connect(diode, Se("drop", -sp.Symbol("V_th")))

    switch = Automaton("switch", {"closed": {"sw": True}, "open": {"sw": False}}, "closed")
    switch.add_transition("closed", "open", "t >= t_open", "a priori")
    ideal_diode = Automaton("diode", {"off": {"D": False}, "on": {"D": True}}, "off")
    ideal_diode.add_transition("off", "on", "v_D >= V_th", "a posteriori")
    ideal_diode.add_transition("on", "off", "i_D <= I_th", "a posteriori")
    model_parameters = {k: p[k] for k in ("V", "R", "L", "V_th", "I_th", "t_open", "i0")}
    return HybridModel(
        g,
        [switch, ideal_diode],
        model_parameters,
        initial_state={"p_L": "L*i0"},
        signals={"i_L": "p_L/L", "v_L": "e_L", "i_D": "-f_diode", "v_D": "-e_diode"},
        name="diode_circuit",
        **annotated(UNITS, RANGES, DEFAULTS, model_parameters),
    )
