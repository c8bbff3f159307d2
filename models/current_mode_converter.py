"""A peak-current-mode controlled boost converter: a clock turns the switch on, the inductor current turns it off.

Circuit: the source ``Vin`` drives the inductor ``L`` (series resistance
``R_L``) into the switch node A; an ideal switch ``S`` connects A to ground;
an ideal diode ``D`` conducts from A to the output.  The output is either
(``load="rc"``, the default) the capacitor ``C`` with the load ``R_load`` in
parallel, or (``load="source"``) a voltage source ``Vout`` that holds it: the
textbook setting of the sub-harmonic instability, where every flow is a
straight line and the period map is exactly piecewise affine.

Bond graph (power directions by arrows; junctions as ``0:name`` / ``1:name``,
bond names in brackets)::

    Se: Vin ──[Vin]──► 1:iL ──[node]──► 0:A ──[diode]──► 1:D (controlled) ──[out]──► 0:B ──[C]──► C: C
                       │   │             │                                          │
                   [L] ▼   ▼ [R_L]   [switch]                                  [R_load]
                    I: L   R: R_L        ▼                                          ▼
                                   1:S (controlled) ──[ground]──► Se: 0         R: R_load

    load="source":  ... 1:D (controlled) ──[out]──► Se: Vout        (in place of 0:B, C and R_load)

``1:iL`` carries the inductor current ``i_L``; ``0:A`` is the switch node
(voltage ``v_sw``); the bond ``out`` carries the output voltage ``v_out``
(``v_C`` with the RC load, ``Vout`` with the source).  The controlled
1-junction ``S`` is the switch (off: no current to ground; on: ``v_sw = 0``),
the controlled 1-junction ``D`` the diode (off: no current; on: ``v_sw =
v_out``).

Signals of the controller (``T = 1/f_sw``, ``θ = 2π f_sw t``)::

    clock      = cos(θ − π w_clock) − cos(π w_clock)       > 0 exactly in the pulses (kT, (k + w_clock) T)
    ramp       = (atan2(−sin θ, −cos θ) + π)/(2π)           the sawtooth (t mod T)/T, 0 at t = kT, → 1 before it
    i_ref_comp = i_ref − m_c T · ramp                       the compensated reference, i_ref − m_c (t mod T)

Automaton ``switch`` (states ``on``: ``S`` on, ``off``: ``S`` off; initial
``on``, the clock's pulse at t = 0 having turned it on):

* ``off → on``  when ``clock > 0`` (a priori): the clock's rising edge at
  ``t = kT``;
* ``on → off``  when ``i_L > i_ref_comp and clock < 0`` (a priori): the
  comparator, blanked during the clock's pulse.

Both are *a priori*: the clock and the comparator are a time-scale
abstraction of the gate drive and of a fast comparator, decided on time and
the current at the instant, not on what switching would do.  The pulse is a
*leading-edge blanking*: the switch cannot turn off during it, so a current
above the reference at the clock (the switch then opens at the pulse's end,
``t = kT + w_clock T``) never turns the switch on and off in a loop, and the
sawtooth's jump at ``kT`` (inside the pulse) never decides the turn-off.
The pulse's width does not enter the period-1 orbit, the multipliers nor the
run, as long as the switch turns off after the pulse (on time ``D T >
w_clock T``): the turn-on is the pulse's rising edge whatever its width (the
switch, on from then, cannot turn off inside the pulse, so the guard that
holds on the whole pulse turns it on once), and the turn-off is where
``i_L`` meets ``i_ref_comp``.  Orbits whose on time would be shorter than
the pulse (the period-2 orbits just beyond the period doubling, see
``tests/models/test_model_current_mode_converter.py``) do depend on it:
their short on time ends at the pulse's end.

Automaton ``diode`` (states ``off``, ``on``; initial ``off``), an ideal
diode as in :mod:`models.boost_converter`:

* ``off → on``  when ``v_D > 0`` (a posteriori);
* ``on → off``  when ``i_D < 0`` (a posteriori); with ``load="source"``:
  ``i_D < 0 or clock > 0``.

A posteriori: the ideal diode is a parameter abstraction judged on the
consequences of switching, impulses included.  The switch opening with the
inductor carrying current forces ``v_D = +∞`` in the mode with ``S`` and
``D`` off (mythical), so the diode turns on; the switch closing while the
diode conducts shorts the capacitor, ``i_D = −∞``, so the diode turns off
(the mode ``S`` on, ``D`` on is mythical).  With the output held by a source
that mode would connect two effort sources (a causality conflict, not a
mode), so the diode's turn-off takes the clock's edge itself: the two
automata step together at ``kT``, to the mode the capacitor's impulse would
reach.  Discontinuous conduction: when ``i_L`` falls to 0 with the switch
off the diode turns off, and in the mode ``switch=off, diode=off`` the
inductor is dependent (``p_L = 0``) until the next clock edge.

Peak-current-mode analysis (``load="source"``, ``R_L = 0``, continuous
conduction): the current rises at ``m1 = Vin/L`` while on and falls at
``m2 = (Vout − Vin)/L`` while off, duty ``D = 1 − Vin/Vout``
(``m1 D = m2 (1 − D)``).  From the turn-on current ``i_k``, the switch opens
after ``t_on = (i_ref − i_k)/(m1 + m_c)``, and
``i_{k+1} = i_ref − m2 T + (m2 − m_c)(i_ref − i_k)/(m1 + m_c)``: an affine
map of slope ``μ = −(m2 − m_c)/(m1 + m_c)`` (without compensation
``−m2/m1 = −D/(1 − D)``), the one Floquet multiplier of the period-1 orbit
(the turn-off's saltation; the clock edges have none).  Its fixed point
``i* = i_ref − m2 T (m1 + m_c)/(m1 + m2)``.  The orbit period-doubles at
``μ = −1``: ``D = 1/2`` (``Vout = 2 Vin``) without compensation; with it,
``|μ| < 1`` exactly when ``m_c > (m2 − m1)/2``.  With the output held, ``m2 −
m1 = (Vout − 2 Vin)/L`` grows towards ``Vout/L`` as ``D → 1``, so ``m_c ≥
Vout/(2 L)`` (half the largest falling slope) keeps the orbit stable for
every duty.  Over all currents ``i`` at a clock edge the period map is
``g(i) = max(0, i + m1 τ − m2 (T − τ))`` with the on time
``τ = clamp((i_ref − i)/(m1 + m_c), w_clock T, T)``: the comparator's piece
above, a turn-off at the pulse's end (slope 1), a switch on all period
(slope 1), discontinuous conduction (0).

Periodic orbits: ``periodic_orbit(model, period=1/f_sw, max_step=...)``
from a first guess ``x0`` whose switch turns off by the comparator (``i_L0``
a little below the orbit's valley current): from ``i_L = 0`` with the output
held the switch may stay on for the whole period, a piece of the period map
of slope 1, where the monodromy is 1 and Newton cannot move.  The orbit
starts at ``t = 0``, a clock edge, in ``switch=on, diode=off``.

Sign conventions and units: voltages [V] from node to ground, currents [A];
``i_L`` from the source into node A, ``i_D`` from A to the output
(forward), ``v_D = v_sw − v_out`` (forward voltage; 0 while on), ``i_sw``
from A to ground.  ``L`` [H], ``C`` [F], resistances [Ω], ``f_sw`` [Hz],
``i_ref`` [A], ``m_c`` [A/s], ``w_clock`` the pulse's width as a fraction of
the period.  States: ``p_L`` [V·s] (flux linkage, ``i_L = p_L/L``) and,
with the RC load, ``q_C`` [C] (charge, ``v_out = q_C/C``).

Signals: ``i_L``, ``v_out``, ``v_L`` (inductor voltage), ``v_sw``,
``i_sw``, ``i_D``, ``v_D``, ``i_ref_comp``, ``ramp``, ``clock``.

Valid range (exercised by ``tests/models/test_model_ranges.py``): ``Vin`` 1
to 100 V, ``L`` 1e-5 to 1e-2 H, ``C`` 1e-6 to 1e-3 F, ``R_load`` 2 to 2000 Ω,
``f_sw`` 1e3 to 1e5 Hz, ``i_ref`` 0.1 to 10 A (from below to far above the
load's current: continuous and discontinuous conduction, turn-offs at the
pulse's end, clock edges with the switch still on, or a current that never
reaches the reference), ``m_c`` 0 to 1e5 A/s, ``w_clock`` 0.01 to 0.2, and
the output held at ``Vout = 2.5 Vin`` (D = 0.6: irregular without
compensation, a stable orbit with it).  Pass ``max_step <= w_clock/(2 f_sw)``
(a guard on time holds only during the pulse; ``RUN`` does).  Every turn-on
falls at a clock edge ``k/f_sw``, every turn-off where ``i_L = i_ref_comp``
or at the pulse's end, and the inductor current never reverses; no error is
documented in this range.
"""

from __future__ import annotations

from bondgraph import BondGraph, C, I, One, R, Se, Zero
from switching import Automaton, HybridModel, ModelDefinitionError

from ._common import Range, annotated, merged, nonnegative, positive

__all__ = ["build", "DEFAULTS", "RUN", "SIGNALS", "UNITS", "LOADS", "controller_signals"]

#: the output's two forms: the capacitor with its load, or a voltage source holding it
LOADS = ("rc", "source")

DEFAULTS = {
    "Vin": 12.0,
    "L": 1e-3,
    "R_L": 0.0,
    "C": 100e-6,
    "R_load": 20.0,
    "load": "rc",
    "Vout": 18.0,
    "f_sw": 10e3,
    "i_ref": 2.0,
    "m_c": 0.0,
    "w_clock": 0.05,
    "v_C0": 12.0,
    "i_L0": 0.0,
}
#: physical ranges: a value outside gives a PhysicalRangeWarning (w_clock outside: an error)
RANGES = {
    "L": positive("an inductance"),
    "C": positive("a capacitance"),
    "R_L": nonnegative("the inductor's resistance"),
    "R_load": positive("a load resistance"),
    "Vout": positive("the held output voltage"),
    "f_sw": positive("a switching frequency", required=True),
    "m_c": nonnegative("a compensation slope"),
    "w_clock": Range("the clock pulse's width as a fraction of the period", 0.0, 1.0, low_open=True,
                     high_open=True, required=True),
}
#: a meaningful default run (used by ``hbg run``): the start-up from v_out = Vin over 200 periods, to about
#: 20.7 V (the period-1 orbit: D ≈ 0.42, stable), with steps within the clock's pulse
RUN = {"t_end": 0.02, "rtol": 1e-8, "max_step": 0.5 * DEFAULTS["w_clock"] / DEFAULTS["f_sw"]}
SIGNALS = ("i_L", "v_out", "v_L", "v_sw", "i_sw", "i_D", "v_D", "i_ref_comp", "ramp", "clock")
#: the unit of each parameter, state and signal (shown on plots, kept in model files; ``q_C`` with the RC load)
UNITS = {"Vin": "V", "L": "H", "R_L": "Ω", "C": "F", "R_load": "Ω", "Vout": "V", "f_sw": "Hz", "i_ref": "A",
         "m_c": "A/s", "w_clock": "1", "v_C0": "V", "i_L0": "A", "p_L": "V·s", "q_C": "C", "i_L": "A",
         "v_out": "V", "v_L": "V", "v_sw": "V", "i_sw": "A", "i_D": "A", "v_D": "V", "i_ref_comp": "A",
         "ramp": "1", "clock": "1"}


def controller_signals() -> dict:
    """The clock, the sawtooth and the compensated reference (module
    docstring) as signal texts; ``θ = 2π f_sw t``.  ``clock`` [-] is positive
    exactly for ``t mod T`` in ``(0, w_clock T)``; ``ramp`` [-] is ``(t mod T)/T``
    (``atan2(−sin θ, −cos θ) = θ − π`` modulo 2π, in ``(−π, π]``);
    ``i_ref_comp`` [A] is ``i_ref − m_c (t mod T)``."""
    return {
        "clock": "cos(2*pi*f_sw*t - pi*w_clock) - cos(pi*w_clock)",
        "ramp": "(atan2(-sin(2*pi*f_sw*t), -cos(2*pi*f_sw*t)) + pi)/(2*pi)",
        "i_ref_comp": "i_ref - m_c*ramp/f_sw",
    }


def _graph(load: str) -> BondGraph:
    """The converter's bond graph (module docstring) with the output ``load``."""
    g = BondGraph("current_mode_converter")
    loop = g.add(One("iL"))
    a = g.add(Zero("A"))
    switch, diode = g.add(One("S", controlled=True)), g.add(One("D", controlled=True))
    g.connect(Se("Vin", "Vin"), loop)
    g.connect(loop, I("L", "L"))
    g.connect(loop, R("R_L", "R_L"))
    g.connect(loop, a, name="node")
    g.connect(a, switch, name="switch")
    g.connect(switch, Se("ground", 0))
    g.connect(a, diode, name="diode")
    if load == "source":
        g.connect(diode, Se("Vout", "Vout"), name="out")
    else:
        b = g.add(Zero("B"))
        g.connect(diode, b, name="out")
        g.connect(b, C("C", "C"))
        g.connect(b, R("R_load", "R_load"))
    return g


def _automata(load: str) -> list:
    """The clocked switch with its blanked comparator, and the ideal diode (module docstring)."""
    switch = Automaton("switch", {"on": {"S": True}, "off": {"S": False}}, initial="on")
    switch.add_transition("on", "off", "i_L > i_ref_comp and clock < 0", "a priori")
    switch.add_transition("off", "on", "clock > 0", "a priori")
    diode = Automaton("diode", {"off": {"D": False}, "on": {"D": True}}, initial="off")
    diode.add_transition("off", "on", "v_D > 0", "a posteriori")
    diode.add_transition("on", "off", "i_D < 0 or clock > 0" if load == "source" else "i_D < 0", "a posteriori")
    return [switch, diode]


def build(**parameters) -> HybridModel:
    """The current-mode converter with ``DEFAULTS`` overridden by ``parameters``;
    ``load`` is ``"rc"`` (states ``p_L``, ``q_C``) or ``"source"`` (state ``p_L``;
    ``C``, ``R_load`` and ``v_C0`` unused; ``Vout`` the held output)."""
    p = merged(DEFAULTS, parameters, RANGES, "current_mode_converter")
    load = p["load"]
    if load not in LOADS:
        raise ModelDefinitionError(f"unknown load {load!r} of current_mode_converter; choose one of: "
                                   f"{', '.join(LOADS)}")
    names = ["Vin", "L", "R_L", "f_sw", "i_ref", "m_c", "w_clock"]
    names += ["Vout"] if load == "source" else ["C", "R_load", "v_C0"]
    names += ["i_L0"]
    initial = {"p_L": "L*i_L0"}
    if load == "rc":
        initial["q_C"] = "C*v_C0"
    signals = {
        "i_L": "p_L/L",
        "v_out": "e_out",
        "v_L": "e_L",
        "v_sw": "e_node",
        "i_sw": "f_switch",
        "i_D": "f_diode",
        "v_D": "e_diode - e_out",
        **controller_signals(),
    }
    model_parameters = {k: p[k] for k in names}
    return HybridModel(_graph(load), _automata(load), model_parameters, initial_state=initial,
                       signals=signals, name="current_mode_converter",
                       **annotated({k: v for k, v in UNITS.items() if k != "q_C" or load == "rc"}, RANGES, DEFAULTS,
                                   model_parameters))
