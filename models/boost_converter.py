"""A DC–DC boost converter: PWM switch, ideal diode, continuous and discontinuous conduction.

Circuit: the source ``Vin`` drives the inductor ``L`` (series resistance
``R_L``) into the switch node A; an ideal switch ``S`` connects A to ground;
an ideal diode ``D`` conducts from A to the output node B, where the
capacitor ``C`` and the load ``R_load`` sit in parallel.

Bond graph (power directions by arrows; junctions as ``0:name`` / ``1:name``,
bond names in brackets)::

    Se: Vin ──[Vin]──► 1:iL ──[node]──► 0:A ──[diode]──► 1:D (controlled) ──[out]──► 0:B ──[C]──► C: C
                       │   │             │                                          │
                   [L] ▼   ▼ [R_L]   [switch]                                  [R_load]
                    I: L   R: R_L        ▼                                          ▼
                                   1:S (controlled) ──[ground]──► Se: 0         R: R_load

``1:iL`` carries the inductor current ``i_L``; ``0:A`` is the switch node
(voltage ``v_A``); ``0:B`` the output node (``v_C``).  The controlled
1-junction ``S`` is the switch (off: no current to ground; on: ``v_A = 0``),
the controlled 1-junction ``D`` the diode (off: no current; on: ``v_A = v_C``).

Automaton ``pwm`` (states ``on``: ``S`` on, ``off``: ``S`` off; initial ``on``)
compares a triangle carrier with the duty ratio (trailing-edge modulation,
the switch is on during ``[k/f_sw, (k + D)/f_sw)``)::

    carrier = acos(cos(2·pi·f_sw·t − pi·D))/pi      (triangle between 0 and 1,
                                                      carrier = D at t = k/f_sw and (k + D)/f_sw)

* ``on → off``  when ``carrier > D``  (a priori);
* ``off → on``  when ``carrier <= D`` (a priori).

Both are *a priori*: the switching instants are a clock, a time-scale
abstraction of the gate drive, decided on time alone and not on the
consequences of switching.  The one strict and one inclusive comparison make
the pair exclusive inside the tolerance band: a located edge never
re-triggers the other one, and ``t = 0`` (where ``carrier = D``) starts in
``on`` without an event.  Because a guard on time holds only during an
interval, every integrator step must be shorter than the shortest on/off
interval: pass ``max_step <= min(D, 1 − D)/f_sw`` (``RUN`` does, for the
defaults; the simulator tests guards at step ends).

Automaton ``diode`` (states ``off``, ``on``; initial ``off``), an ideal diode:

* ``off → on``  when ``v_D > 0`` (a posteriori);
* ``on → off``  when ``i_D < 0`` (a posteriori).

Both are *a posteriori*: the ideal diode is a parameter abstraction (a
resistance that is 0 or ∞), judged on the consequences of the switch, impulses
included — with the switch opening while the inductor carries current, the
mode with ``S`` and ``D`` off forces ``i_L`` to 0 with an infinite voltage
pulse ``v_D = +∞``, so the diode turns on (that mode is mythical); closing
the switch while the diode conducts would short the capacitor, ``i_D = −∞``,
so the diode turns off.  Strict comparisons on both sides keep ``i_L = 0``
with ``v_D = 0`` from looping.

Discontinuous conduction: when ``i_L`` falls to 0 with the switch off, the
diode turns off and the mode ``pwm=off, diode=off`` flows — there the
inductor is in derivative causality (dependent, ``p_L = 0``): its current is
held at zero by the two open branches and ``v_A = Vin``.  The switch closing
leaves it (``p_L`` becomes independent again, from 0).

Expected averages (ideal, ``R_L = 0``): continuous conduction
``v_C = Vin/(1 − D)`` (volt-second balance of ``L``); discontinuous conduction
``v_C/Vin = (1 + sqrt(1 + 4 D²/K))/2`` with ``K = 2 L f_sw/R_load``, which
holds when ``K < D (1 − D)²``.

Sign conventions and units: voltages [V] from node to ground, currents [A];
``i_L`` from the source into node A, ``i_D`` from A to B (forward), ``v_D =
v_A − v_C`` (forward voltage; 0 while on).  ``L`` [H], ``C`` [F], resistances
[Ω], ``f_sw`` [Hz], ``D`` the duty ratio (0 < D < 1).  States: ``p_L`` [V·s]
(flux linkage, ``i_L = p_L/L``), ``q_C`` [C] (charge, ``v_C = q_C/C``).

Signals: ``i_L``, ``v_C``, ``v_in``, ``v_L`` (inductor voltage; Dirac
pulses when the current is forced to zero), ``i_D``, ``v_D``, ``v_sw``
(switch-node voltage ``v_A``), ``i_sw`` (switch current), ``i_load``,
``carrier``.

Valid range (exercised by ``tests/models/test_model_ranges.py``): ``0 < D < 1``
(tested 0.1 to 0.9), ``R_load`` 2 to 2000 Ω, ``L`` 1e-5 to 1e-3 H, ``C`` 1e-6
to 1e-2 F, ``f_sw`` 1e3 to 1e5 Hz, in continuous and discontinuous conduction,
with ``max_step <= min(D, 1 − D)/f_sw`` as said above.  Every PWM edge falls
at ``k/f_sw`` or ``(k + D)/f_sw`` and the inductor current never reverses; no
error is documented in this range.
"""

from __future__ import annotations

from bondgraph import BondGraph, C, I, One, R, Se, Zero
from switching import Automaton, HybridModel

from ._common import Range, annotated, merged, nonnegative, positive

__all__ = ["build", "DEFAULTS", "RUN", "SIGNALS", "UNITS"]

DEFAULTS = {
    "Vin": 12.0,
    "L": 1e-3,
    "R_L": 0.0,
    "C": 100e-6,
    "R_load": 20.0,
    "f_sw": 10e3,
    "D": 0.5,
    "v_C0": 12.0,
    "i_L0": 0.0,
}
#: physical ranges: a value outside gives a PhysicalRangeWarning
RANGES = {
    "L": positive("an inductance"),
    "C": positive("a capacitance"),
    "R_L": nonnegative("the inductor's resistance"),
    "R_load": positive("a load resistance"),
    "f_sw": positive("a switching frequency"),
    "D": Range("a duty cycle", 0.0, 1.0, low_open=True, high_open=True),
}
#: a meaningful default run (used by ``hbg run``): the start-up from v_C = Vin over 200 periods
RUN = {"t_end": 0.02, "rtol": 1e-8, "max_step": 0.1 / DEFAULTS["f_sw"]}
#: the unit of each parameter, state and signal (shown on plots, kept in model files)
UNITS = {"Vin": "V", "L": "H", "R_L": "Ω", "C": "F", "R_load": "Ω", "f_sw": "Hz", "D": "1", "i_L0": "A",
         "v_C0": "V", "p_L": "V·s", "q_C": "C", "i_L": "A", "v_C": "V", "v_in": "V", "v_L": "V", "i_D": "A",
         "v_D": "V", "v_sw": "V", "i_sw": "A", "i_load": "A", "carrier": "1"}

SIGNALS = ("i_L", "v_C", "v_in", "v_L", "i_D", "v_D", "v_sw", "i_sw", "i_load", "carrier")


def build(**parameters) -> HybridModel:
    """The boost converter with ``DEFAULTS`` overridden by ``parameters``."""
    p = merged(DEFAULTS, parameters, RANGES, "boost_converter")
    g = BondGraph("boost_converter")
    loop = g.add(One("iL"))
    a, b = g.add(Zero("A")), g.add(Zero("B"))
    switch, diode = g.add(One("S", controlled=True)), g.add(One("D", controlled=True))
    g.connect(Se("Vin", "Vin"), loop)
    g.connect(loop, I("L", "L"))
    g.connect(loop, R("R_L", "R_L"))
    g.connect(loop, a, name="node")
    g.connect(a, switch, name="switch")
    g.connect(switch, Se("ground", 0))
    g.connect(a, diode, name="diode")
    g.connect(diode, b, name="out")
    g.connect(b, C("C", "C"))
    g.connect(b, R("R_load", "R_load"))

    pwm = Automaton("pwm", {"on": {"S": True}, "off": {"S": False}}, initial="on")
    pwm.add_transition("on", "off", "carrier > D", "a priori")
    pwm.add_transition("off", "on", "carrier <= D", "a priori")
    ideal_diode = Automaton("diode", {"off": {"D": False}, "on": {"D": True}}, initial="off")
    ideal_diode.add_transition("off", "on", "v_D > 0", "a posteriori")
    ideal_diode.add_transition("on", "off", "i_D < 0", "a posteriori")

    model_parameters = {k: p[k] for k in ("Vin", "L", "R_L", "C", "R_load", "f_sw", "D", "i_L0", "v_C0")}
    return HybridModel(
        g,
        [pwm, ideal_diode],
        model_parameters,
        initial_state={"p_L": "L*i_L0", "q_C": "C*v_C0"},
        signals={
            "i_L": "p_L/L",
            "v_C": "q_C/C",
            "v_in": "e_Vin",
            "v_L": "e_L",
            "i_D": "f_diode",
            "v_D": "e_diode - e_out",
            "v_sw": "e_node",
            "i_sw": "f_switch",
            "i_load": "f_R_load",
            "carrier": "acos(cos(2*pi*f_sw*t - pi*D))/pi",
        },
        name="boost_converter",
        **annotated(UNITS, RANGES, DEFAULTS, model_parameters),
    )
