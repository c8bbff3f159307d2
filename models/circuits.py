"""Electrical circuits written as netlists: components between named nodes.

:class:`Circuit` collects two-terminal components between nodes (ground is
node ``"0"``) and builds the textbook bond graph of the netlist:

* every node other than ground is a 0-junction ``node_<node>`` (one voltage,
  the currents into it balance);
* every two-terminal branch between two nodes is a 1-junction
  ``branch_<name>`` (one current) with a bond from the first node's
  0-junction and a bond to the second's, and the component on a third bond,
  so that its effort is ``v(n1) − v(n2)``;
* ground (0 V) is eliminated: a branch with one terminal at ground is bonded
  straight to its other node;
* an ideal diode or switch is a *controlled* 1-junction named after the
  component, driven by an automaton of the same name.

The result of :meth:`Circuit.build` is an ordinary
:class:`~switching.HybridModel`: simulate it, save it to a model file
(``model.save(path)``, ``switching.load_model(path)``), draw its graph with
:func:`bondgraph.draw_bond_graph`.

Sign conventions and units (V, A, Ω, F, H, s):

* ``v_<node>`` is the voltage of a node above ground;
* ``v_<name>`` is the voltage across a component, its first terminal minus
  its second (``n1 − n2``; a source ``V``: ``n_plus − n_minus``; a current
  source: ``n_from − n_to``; a diode: anode − cathode);
* ``i_<name>`` is the current through it from its first terminal to its
  second (passive convention: ``v_<name>·i_<name>`` is the power it takes;
  for a voltage source that is minus the power it delivers, for a current
  source ``I(name, n_from, n_to, value)`` the current is ``value``);
* states: ``q_<C>`` the charge [C] of a capacitor (``v = q/C``), ``p_<L>``
  the flux linkage [V·s] of an inductor (``i = p/L``).  A component whose
  first terminal is ground is bonded in the reverse direction, so its state
  carries the opposite sign (``q_C = −C·v_C``); the signals ``v_<name>`` and
  ``i_<name>`` keep the convention above.

Values: a number (it becomes a parameter named after the component, e.g.
``R1``, overridable in :meth:`Circuit.build`) or the name of a parameter
given to :meth:`Circuit.build`.  Sources also take an expression of ``t`` as
text (``"Vm*sin(w*t)"``, parsed without executing code) or a declared input
(:class:`Input`, its function given to :meth:`Circuit.build`).  ``R``, ``C``
and ``L`` take a nonlinear law as the element constructors do (a function of
one argument: ``R``'s ``flow_law(v)`` or ``effort_law(i)``, ``C``'s
``effort_law(q)``, ``L``'s ``flow_law(p)``).

Ideal diodes (:meth:`Circuit.diode`, automaton states ``blocking``/``conducting``,
read as ``off``/``on`` too, the names they had)::

    blocking   → conducting  when  v_<D> > v_f   (a posteriori)
    conducting → blocking    when  i_<D> < 0     (a posteriori)

Both guards are *a posteriori*: the ideal diode is a parameter abstraction
(a resistance that is 0 or ∞), judged on the state the switch would produce,
impulses included — a switch opening on an inductor's current gives, with
the diode off, a pulse ``v_D = +∞`` that turns the diode on (the paper's
mythical mode).  Both comparisons are *strict*: a diode at ``v_D = v_f``
with ``i_D = 0`` (every diode of a circuit at rest at t = 0) stays where it
is until the flow carries ``v_D`` above ``v_f``, and a diode turning off
against a capacitor (``i_D < 0`` at the located crossing, ``v_D = v_f``
after it) stays off.  With inclusive ``>=``/``<=`` the diode at rest would
turn on, find ``i_D <= 0`` and turn off again — a cycle of switches each
enabled only at a tie, which takes none of them and rests
(:mod:`switching.rules.instants`) — but the one turning off would find
``v_D >= v_f`` at a tie after a switch beyond its band: a divergence of
time.

Ideal switches (:meth:`Circuit.switch`, states ``open``/``closed``) follow
a condition on time, parameters or signals (``closed_when="t < t_open"``),
or a :class:`PWM` schedule; their transitions are *a priori* (an external
command, not a consequence of switching).

Example — a capacitor charged through a resistor::

    >>> from models.circuits import Circuit
    >>> rc = Circuit("rc")
    >>> rc.V("V1", "in", "0", 10.0)
    >>> rc.R("R1", "in", "out", 1e3)
    >>> rc.C("C1", "out", "0", 1e-6)
    >>> model = rc.build()
    >>> run = model.simulate(5e-3, "RK45", rtol=1e-9, atol=1e-15)
    >>> round(float(run.signal("v_C1")[-1]), 4)    # 10 (1 − e^−5)
    9.9326

Floating parts: a mode where every diode and switch around a group of nodes
blocks leaves those nodes floating (their voltage, and the voltage across
each blocking element, is not fixed by the ideal elements: a full bridge
rectifier with every diode off).  Such a mode runs as the limit of
vanishing leaks across the blocking elements (DESIGN.md §6b,
:func:`bondgraph.regularize.floating_limit`): the leaks divide the voltage
across the blocking elements equally, so a bridge's diode turns on exactly
where ``|v_in|`` meets ``v_out``; an element the mode ties stays a
dependent state (an inductor alone across a bridge's load: its current 0
while every diode blocks).  A circuit with a floating mode that has no
limit (a free direction no diode or switch touches) is refused when it is
built, with a :class:`~bondgraph.errors.FloatingPartError` that names the
mode and the floating nodes (their 0-junctions ``node_<n>``) and says it is
under-determined (:mod:`models.circuit_topology` finds the candidates on
the netlist; ``build(allow_floating=True)`` skips the check, and a run that
reaches such a mode stops there with the same error).  ``build(gmin=1e-12)`` puts a leak conductance across
every diode and switch (SPICE's ``GMIN``; explicit, off by default): no node
then floats, and the leaks divide the network's voltage over the blocking
elements as it would divide over equal reverse resistances, so each diode
turns on when its share exceeds ``v_f``.  In a bridge the leaks give every
blocking diode ``v_D = (|v_in| − v_out)/2`` (with ``v_f = 0``): the diodes
turn on exactly where ``|v_in|`` meets ``v_out``, and the leak only moves
the instants by a relative O(gmin·R), without adding any (a leak from each
node to ground instead puts the floating nodes at arbitrary voltages and
adds spurious instants).  A mode in which
ideal elements short an ideal voltage source — a switch closing while an ideal
diode across the source's path conducts (a buck converter's freewheeling
diode) — is over-determined: it is passed at the instant as a *mythical*
mode whose guards are judged in the limit of a vanishing resistance in
every conducting switch and diode (:mod:`switching.library.conflicts`): the
shorted source drives the diode's current backwards, an impulse, so
``i_D < 0`` holds and the diode turns off — the ideal buck runs as drawn.
A conflict no automaton leaves (a switch tying two voltage sources) stops
the run at its instant with a
:class:`~bondgraph.errors.CausalityConflictError` naming the mode.  A PWM
switch needs integrator steps shorter than its shortest on or off interval
(``max_step <= min(duty, 1 − duty)·period``).
"""

from __future__ import annotations

import difflib
import functools
import itertools
import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import sympy as sp
from scipy.optimize import brentq

from bondgraph import GY, TF, C, I, One, R, Se, Sf, Zero
from bondgraph.errors import (DuplicateNameError, FloatingPartError, InvalidGraphError, MissingParameterError,
                              NameCollisionError, ParameterValueError, UnknownNameError)
from bondgraph.namespace import Owner
from bondgraph.floating import floating_part
from switching import Automaton, HybridModel
from switching.model.source_periods import PERIOD_FRACTION

from ._common import Range
from .circuit_topology import first_floating_mode
from .circuit_words import DIODE_ALIASES, OFF, ON, conflict_loop
from .carriers import CARRIERS, sawtooth_pwm
from .controllers import Hysteresis, build_controllers, controller_placeholder, controller_values, modulated_duty
from .netlist import (REFERENCE, BuiltFrom, Netlist, NetlistBuilder, Part, checked_argument, checked_name,
                      checked_node, checked_number, holds_at_start, parameter_name, source_value, units_by_prefix)

__all__ = ["Circuit", "Input", "PWM", "Hysteresis", "GROUND", "floating_modes", "FLOATING_CHECK_MODES"]

#: the ground node (0 V)
GROUND = REFERENCE
#: the units of the signals and states a circuit names, by prefix (capacitors' charges ``q_``,
#: inductors' flux linkages ``p_``; a PWM switch's carrier is a pure number)
CIRCUIT_UNITS = {"v_": "V", "i_": "A", "carrier_": "1", "q_": "C", "p_": "V·s"}



@dataclass(frozen=True)
class Input:
    """A source value supplied at simulation time: the declared input
    ``name``, whose function of ``t`` is given to :meth:`Circuit.build`
    (``inputs={"u": f}``)."""

    name: str


@dataclass(frozen=True)
class PWM:
    """A periodic switching schedule: closed during
    ``[k·period + delay, k·period + delay + duty·period)`` for every integer ``k``.

    ``period`` [s] and ``duty`` (0 < duty < 1) are numbers (they become the
    parameters ``<switch>_period`` and ``<switch>_duty``) or parameter names.
    The schedule compares the triangle carrier
    ``acos(cos(2π(t − delay)/period − π·duty))/π`` (between 0 and 1, equal to
    ``duty`` at each edge) with ``duty``: closed while ``carrier <= duty``.

    A ``duty`` that varies — a controller's name (:meth:`Circuit.pid`) or a text of signals and ``t``
    (``"0.5 + 0.4*sin(2*pi*50*t)"``) — is compared with the fixed carrier
    ``acos(cos(2π(t − delay)/period))/π``: pulses centred on ``k·period + delay``
    (:mod:`models.controllers`); with ``carrier="sawtooth"``, with the ramp ``(t − delay)/period mod 1``:
    pulses from ``k·period + delay`` to where the ramp reaches the duty (trailing-edge modulation,
    :mod:`models.carriers`).  A fixed duty's pulses are the same with either carrier."""

    period: float | str
    duty: float | str
    delay: float = 0.0
    carrier: str = "triangle"

    def checked(self, owner: str) -> "PWM":
        """This schedule with its values checked (:func:`~models.netlist.checked_argument`): ``period``
        a positive number or a parameter name, ``duty`` one in [0, 1] or a parameter name, ``delay`` a
        finite number; else a :class:`~bondgraph.errors.ParameterValueError` naming ``owner`` and the value."""
        period = checked_argument(self.period, f"the PWM period of {owner}")
        duty = checked_argument(self.duty, f"the PWM duty of {owner}", ("number", "name", "expression"))
        delay = checked_number(self.delay, f"the PWM delay of {owner}")
        if not isinstance(period, str) and period <= 0:
            raise ParameterValueError(f"the PWM period of {owner} is {period:g} s: give a positive period",
                                      "period", period)
        if not isinstance(duty, str) and not 0.0 <= duty <= 1.0:
            raise ParameterValueError(f"the PWM duty of {owner} is {duty:g}: give a duty between 0 and 1",
                                      "duty", duty)
        if self.carrier not in CARRIERS:
            raise ParameterValueError(f"the PWM carrier of {owner} is {self.carrier!r}: give one of {CARRIERS}",
                                      "carrier", self.carrier)
        return PWM(period, duty, delay, self.carrier)


class Circuit(Netlist):
    """A netlist: components between named nodes; ground is node ``"0"``.

    Add components with :meth:`R`, :meth:`C`, :meth:`L`, :meth:`V`,
    :meth:`I`, :meth:`diode`, :meth:`switch` (and :meth:`mosfet`,
    :meth:`igbt`, :meth:`half_bridge`), :meth:`transformer`,
    :meth:`coupled_inductors` and :meth:`gyrator`; :meth:`build` returns the
    :class:`~switching.HybridModel`.  Component names are identifiers and
    unique; node names are letters, digits and ``_`` (``"1"``, ``"out"``).
    See the module documentation for the conventions.
    """

    def __init__(self, name: str = "circuit"):
        super().__init__(name, "circuit name", "'buck', 'bridge_1'")

    # ------------------------------------------------------------ components

    def R(self, name: str, n1, n2, value=None, *, effort_law=None, flow_law=None) -> None:
        """A resistor [Ω] between ``n1`` and ``n2``: ``v = R i`` (or the law given)."""
        self._add("R", name, (n1, n2), value=_passive_value(value, "resistance", name),
                  laws={"effort_law": effort_law, "flow_law": flow_law})

    def C(self, name: str, n1, n2, value=None, *, v0: float = 0.0, effort_law=None) -> None:
        """A capacitor [F] between ``n1`` and ``n2``: ``i = C dv/dt``, ``v = v0`` at t = 0
        (with a law ``v = Φ(q)``, the charge with ``Φ(q) = v0``)."""
        self._add("C", name, (n1, n2), value=_passive_value(value, "capacitance", name),
                  laws={"effort_law": effort_law}, initial=checked_number(v0, f"the initial voltage v0 of C {name!r}"))

    def L(self, name: str, n1, n2, value=None, *, i0: float = 0.0, flow_law=None) -> None:
        """An inductor [H] between ``n1`` and ``n2``: ``v = L di/dt``, ``i = i0`` at t = 0 (n1 → n2;
        with a law ``i = Φ(p)``, the flux linkage with ``Φ(p) = i0``)."""
        self._add("L", name, (n1, n2), value=_passive_value(value, "inductance", name),
                  laws={"flow_law": flow_law}, initial=checked_number(i0, f"the initial current i0 of L {name!r}"))

    def V(self, name: str, n_plus, n_minus, value) -> None:
        """A voltage source: ``v(n_plus) − v(n_minus) = value`` [V] (a number,
        a parameter name, an expression of ``t`` as text, or an :class:`Input`)."""
        self._add("V", name, (n_plus, n_minus), value=source_value(value, name, (Input,)))

    def I(self, name: str, n_from, n_to, value) -> None:  # noqa: E743 - the netlist letter
        """A current source: ``value`` [A] flows through it from ``n_from`` to
        ``n_to`` (it leaves node ``n_from`` and enters ``n_to``)."""
        self._add("I", name, (n_from, n_to), value=source_value(value, name, (Input,)))

    def diode(self, name: str, anode, cathode, r_on=None, v_f=None, *, on: bool = False) -> None:
        """An ideal diode from ``anode`` to ``cathode``, automaton ``name``
        with states ``off`` (no current) and ``on`` (``v = v_f + r_on·i``;
        both 0 when not given); ``on``: its state at t = 0.  Guards: see the
        module documentation."""
        r_on, v_f = (None if value is None else checked_argument(value, f"the {what} of diode {name!r}")
                     for value, what in ((r_on, "on-resistance r_on"), (v_f, "forward drop v_f")))
        self._add("D", name, (anode, cathode), r_on=r_on, v_f=v_f, on=_flag(on, "on", name))

    def switch(self, name: str, n1, n2, closed_when, *, open_when: str | None = None,
               closed: bool | None = None, r_on=None) -> None:
        """An ideal switch between ``n1`` and ``n2``, automaton ``name`` with
        states ``open`` and ``closed``.  ``closed_when`` is a condition as text
        (``"t >= t_on"``, ``"t < 1e-3 or t >= 2e-3"``; time, parameters and
        signals) or a :class:`PWM` schedule; the switch opens when it stops
        holding, or, with ``open_when``, when that condition holds (a relay
        with hysteresis: ``closed_when="v_out < 6", open_when="v_out > 8"``;
        a relay without it chatters, a Zeno error).  ``closed``: its state at
        t = 0; by default ``closed_when`` at t = 0 when it depends on time and
        parameters only, else open (a condition on signals then closes it at
        the first instant).  ``r_on`` [Ω]: its resistance while closed (a MOSFET's R_DS(on); none: ideal)."""
        if isinstance(closed_when, Hysteresis):
            if open_when is not None:
                raise InvalidGraphError(f"switch {name!r}: a Hysteresis schedule says when it opens: leave out "
                                        "open_when", [str(name)])
            closed_when, open_when = closed_when.checked(f"switch {name!r}").conditions()
        if not isinstance(closed_when, (str, PWM)):
            raise InvalidGraphError(f"switch {name!r}: closed_when must be a condition as text, a PWM or a "
                                    f"Hysteresis, got {closed_when!r}", [str(name)])
        if open_when is not None and not (isinstance(open_when, str) and isinstance(closed_when, str)):
            raise InvalidGraphError(f"switch {name!r}: open_when must be a condition as text, given with a "
                                    f"closed_when condition (not a PWM), got {open_when!r}", [str(name)])
        if isinstance(closed_when, PWM):
            closed_when = closed_when.checked(f"switch {name!r}")
        closed = None if closed is None else _flag(closed, "closed", name)
        r_on = None if r_on is None else checked_argument(r_on, f"the on-resistance r_on of switch {name!r}")
        self._add("S", name, (n1, n2), closed_when=closed_when, open_when=open_when, closed=closed, r_on=r_on)

    def mosfet(self, name: str, drain, source, closed_when, *, open_when: str | None = None,
               closed: bool | None = None, r_on=None, diode_r_on=None, diode_v_f=None) -> None:
        """A MOSFET as power electronics uses it: a switch ``name`` from ``drain`` to ``source`` (its
        channel, ``r_on`` [Ω] its R_DS(on)), ruled as :meth:`switch`, and its body diode ``<name>_D``
        from ``source`` to ``drain`` (``diode_r_on`` [Ω], ``diode_v_f`` [V]), which conducts the
        reverse current while the channel is open (a bridge leg's dead time)."""
        self.switch(name, drain, source, closed_when, open_when=open_when, closed=closed, r_on=r_on)
        self.diode(f"{name}_D", source, drain, r_on=diode_r_on, v_f=diode_v_f)

    def igbt(self, name: str, collector, emitter, closed_when, *, open_when: str | None = None,
             closed: bool | None = None, r_on=None, diode_r_on=None, diode_v_f=None) -> None:
        """An IGBT with its anti-parallel diode, as :meth:`mosfet` (collector, emitter): the switch
        ``name`` conducts from collector to emitter (``r_on`` [Ω]), the diode ``<name>_D`` back."""
        self.mosfet(name, collector, emitter, closed_when, open_when=open_when, closed=closed, r_on=r_on,
                    diode_r_on=diode_r_on, diode_v_f=diode_v_f)

    def half_bridge(self, name: str, plus, minus, out, period, duty, dead_time=0.0, *, r_on=None,
                    diode_r_on=None, diode_v_f=None) -> None:
        """A half-bridge leg: MOSFETs ``<name>_H`` (``plus`` to ``out``) and ``<name>_L`` (``out`` to
        ``minus``) with body diodes, driven complementarily at ``period`` [s] and ``duty`` with
        ``dead_time`` [s] after each opening during which both are open (a body diode carries the load
        current): the low side closed over ``[0, (1 − duty)·period − dead_time)`` of each period, the
        high side over ``[(1 − duty)·period, period − dead_time)`` — the low side closed at t = 0, so
        that an inductor's initial current has a path.  ``period``, ``duty`` and ``dead_time`` are
        numbers here (each switch's PWM parameters take its own name)."""
        period, duty, dead = (checked_number(v, f"the {what} of half-bridge {name!r}") for v, what in
                              ((period, "period"), (duty, "duty"), (dead_time, "dead time")))
        if not (period > 0 and 0 <= dead and 0 <= duty <= 1 and dead < duty * period
                and dead < (1.0 - duty) * period):
            raise ParameterValueError(f"half-bridge {name!r}: period {period:g} s, duty {duty:g} and dead time "
                                      f"{dead:g} s leave a switch no closed time: give 0 ≤ dead time < "
                                      "duty·period and dead time < (1 − duty)·period", "dead_time", dead)
        low = PWM(period, 1.0 - duty - dead / period)
        high = PWM(period, duty - dead / period, delay=(1.0 - duty) * period)
        self.mosfet(f"{name}_H", plus, out, high, r_on=r_on, diode_r_on=diode_r_on, diode_v_f=diode_v_f)
        self.mosfet(f"{name}_L", out, minus, low, r_on=r_on, diode_r_on=diode_r_on, diode_v_f=diode_v_f)

    def transformer(self, name: str, p1, p2, s1, s2, ratio) -> None:
        """An ideal transformer with turns ratio ``ratio`` = N_p/N_s:
        ``v_p = ratio·v_s`` and ``i_s = ratio·i_p``, where ``v_p = v(p1) − v(p2)``,
        ``i_p`` flows into ``p1`` through the primary, ``v_s = v(s1) − v(s2)``
        and ``i_s`` flows out of ``s1`` into the circuit.  Signals
        ``v_<name>_p``, ``i_<name>_p``, ``v_<name>_s``, ``i_<name>_s``."""
        self._add("T", name, (p1, p2, s1, s2),
                  value=checked_argument(ratio, f"the turns ratio of transformer {name!r}", ("number", "name", "sympy")))

    def coupled_inductors(self, name: str, p1, p2, s1, s2, L1, L2, k) -> None:
        """Two magnetically coupled windings (SPICE's ``L1``, ``L2`` and ``K``): the primary from ``p1``
        to ``p2``, the secondary from ``s1`` to ``s2``, both currents into the dotted terminals ``p1``,
        ``s1``: ``v₁ = L1·di₁/dt + M·di₂/dt``, ``v₂ = M·di₁/dt + L2·di₂/dt`` with ``M = k·√(L1·L2)``
        [H], ``0 < k ≤ 1``.  Built as its T-equivalent: a leakage inductance ``(1 − k²)·L1`` in series with
        the primary, a magnetizing inductance ``k²·L1`` across an ideal transformer of ratio ``k·√(L1/L2)``
        (``k = 1``: no leakage, a transformer with its magnetizing inductance: a flyback's).  Both currents
        start at 0.  Parameters ``<name>_L1``, ``<name>_L2``, ``<name>_k`` (or the names given); signals
        ``v_<name>_p``, ``i_<name>_p``, ``v_<name>_s``, ``i_<name>_s`` (the windings' voltages and
        currents) and ``i_<name>_m`` (the magnetizing current, referred to the primary: ``i₁ + i₂·√(L2/L1)/k``)."""
        values = {key: checked_argument(value, f"{what} of coupled inductors {name!r}", ("number", "name", "sympy"))
                  for key, value, what in (("L1", L1, "the primary's inductance L1"),
                                           ("L2", L2, "the secondary's inductance L2"),
                                           ("k", k, "the coupling coefficient k"))}
        self._add("K", name, (p1, p2, s1, s2), **values)

    def gyrator(self, name: str, p1, p2, s1, s2, r) -> None:
        """An ideal gyrator with ratio ``r`` [Ω]: ``v_p = r·i_s`` and
        ``v_s = r·i_p`` (a DC machine's electrical and mechanical ports in an
        electrical analogue), the ports as for :meth:`transformer`."""
        self._add("G", name, (p1, p2, s1, s2),
                  value=checked_argument(r, f"the ratio r of gyrator {name!r}", ("number", "name", "sympy")))

    def dc_machine(self, name: str, p1, p2, s1, s2, k) -> None:
        """A DC machine with constant ``k`` [V·s/rad = N·m/A]: a :meth:`gyrator`
        whose primary is the armature and whose secondary is the shaft in the
        force–voltage analogy: ``v_<name>_s`` is the torque [N·m] and
        ``i_<name>_s`` the angular speed [rad/s] (torque ``k·i_a``, back-emf
        ``k·ω``).  Elements turning with the shaft are in series in the
        secondary loop: the inertia ``J`` an ``L`` [kg·m²], viscous friction
        ``b`` an ``R`` [N·m·s], a load torque a ``V`` source.

        Example — ``V("Va", "a", "0", 12)``, ``R("Ra", "a", "b", 2)``,
        ``dc_machine("M", "b", "0", "w", "0", 0.1)``, ``L("J", "w", "m", 1e-3)``,
        ``R("b", "m", "0", 1e-3)``: the speed ``i_J`` rises as
        ``ω = k V/(Ra b + k²) (1 − e^{−t/τ})``, ``τ = J/(b + k²/Ra)``."""
        self.gyrator(name, p1, p2, s1, s2, k)

    def pid(self, name: str, measure: str, reference, kp, ki=0.0, kd=0.0, *, limits=None, tracking=None,
            derivative_filter=None, initial: float = 0.0, sample_period=None, sample_delay=None) -> None:
        """A PID controller ``name`` (no terminals): its output is the signal ``name``,
        ``clamp(kp·e + I + D, *limits)`` of the error ``e = reference − measure`` — ``measure`` a text of the
        circuit's signals (``"v_out"``), ``reference`` a number, a parameter name or a text of ``t`` (a
        reference step) — with back-calculation anti-windup (``tracking`` [s], default ``kp/ki``), a
        derivative filtered by ``derivative_filter`` [s] (default ``kd/(10·kp)``) and the integral term
        starting at ``initial``.  Use its name as a PWM's duty (``PWM(1e-5, "PI1")``), in a source's value
        or a condition.  The equations and states: :mod:`models.controllers`.  ``sample_period`` [s] makes it a
        digital controller sampled at ``k·sample_period + sample_delay``, its output held between samples
        and computed a sample before it is applied (:mod:`models.sampled_controllers`)."""
        values = controller_values(name, measure, reference, kp, ki, kd, limits, tracking, derivative_filter,
                                   initial, sample_period, sample_delay)
        self._add("PI", name, (), **values)

    def pi(self, name: str, measure: str, reference, kp, ki, **options) -> None:
        """A PI controller: :meth:`pid` without the derivative."""
        self.pid(name, measure, reference, kp, ki, 0.0, **options)

    def draw(self, mode=None):
        """The circuit's schematic (:func:`models.schematic.draw_circuit`), its diodes and switches in the
        states of ``mode`` — a mode of a model built from it, or ``"S1=closed, D1=blocking"`` — or at t = 0:
        ``.svg()``, ``.save(path)``, shown inline in notebooks."""
        from .schematic import draw_circuit

        return draw_circuit(self, mode)

    def to_spice(self, run=None, **options) -> str:
        """This circuit as a SPICE netlist ngspice runs (:func:`models.spice.write`; ``run``: the ``.tran``
        settings, ``{"t_end": …, "max_step": …}``)."""
        from .spice_writer import write

        return write(self, run, **options)

    # ------------------------------------------------------------ queries

    # ------------------------------------------------------------ input checks

    def _add(self, kind, name, nodes, **values):
        name = checked_name(name, "component name", "'R1', 'D_out'")
        if name in self._parts:
            raise DuplicateNameError(f"circuit {self.name!r}: component {name!r} is already defined "
                                     f"({self._parts[name].kind} between {', '.join(self._parts[name].nodes)}); "
                                     "give each component its own name", name)
        nodes = tuple(checked_node(n, name, "ground") for n in nodes)
        for a, b in zip(nodes[::2], nodes[1::2]):
            if a == b:
                raise InvalidGraphError(f"component {name!r} has both terminals on node {a!r}: it would be "
                                        "shorted; connect it between two different nodes", [name])
        if kind in ("R", "C", "L"):
            laws = {k: v for k, v in values.pop("laws").items() if v is not None}
            if len(laws) > 1 or (laws and values.get("value") is not None):
                raise InvalidGraphError(f"{kind} {name!r}: give either a value or one law", [name])
            values["law"] = next(iter(laws.items()), None)
            if laws and not callable(next(iter(laws.values()))):
                raise InvalidGraphError(f"{kind} {name!r}: give the law as a function of one argument, "
                                        "e.g. lambda v: Is*(exp(v/VT) - 1)", [name])
        if "value" in values and isinstance(values["value"], str) and kind not in ("V", "I"):
            parameter_name(values["value"], f"value of {name!r}")
        self._parts[name] = Part(kind, name, nodes, values)

    def _check_topology(self):
        parts = list(self._parts.values())
        if not parts:
            raise InvalidGraphError(f"circuit {self.name!r} has no components")
        nodes = self.nodes
        names = set(self._parts)
        for n in nodes:
            if n in names:
                raise DuplicateNameError(f"node {n!r} has the name of a component: the signals v_{n} would "
                                         "clash; rename the node or the component", n)
        if GROUND not in nodes:
            raise InvalidGraphError(f"circuit {self.name!r} has no ground: connect a component to node "
                                    f"{GROUND!r}")
        terminals = {n: 0 for n in nodes}
        for p in parts:
            for n in p.nodes:
                terminals[n] += 1
        for n, count in terminals.items():
            if count == 1 and n != GROUND:
                (owner,) = [p.name for p in parts if n in p.nodes]
                close = difflib.get_close_matches(n, [m for m in nodes if m != n], n=1)
                hint = f"; did you mean {close[0]!r}?" if close else "; connect a second component to it"
                raise UnknownNameError(f"node {n!r} of {owner!r} is connected to nothing else (a floating "
                                       f"terminal){hint}", n)
        # galvanic connection to ground: every node must reach it
        edges = [(p.nodes[0], p.nodes[1], p) for p in parts if len(p.nodes) >= 2]  # (a controller has none)
        edges += [(p.nodes[2], p.nodes[3], p) for p in parts if len(p.nodes) == 4]
        reached = _components(nodes, [(a, b) for a, b, _ in edges])
        floating = [n for n in nodes if reached[n] != reached[GROUND]]
        if floating:
            raise InvalidGraphError(f"node(s) {', '.join(map(repr, floating))} have no path to ground "
                                    f"{GROUND!r}: their voltage is undefined; connect them to ground (a "
                                    "transformer's secondary needs a reference too)", floating)
        # loops of capacitors and voltage sources: their voltages are not independent
        loop = _loop(nodes, [(a, b, p.name) for a, b, p in edges if p.kind in ("C", "V")])
        if loop:
            raise InvalidGraphError(f"{', '.join(loop)} form a loop of capacitors and voltage sources: "
                                    "their voltages are tied (a state would be dependent, a source "
                                    "contradicted); put a resistor in the loop or merge the capacitors",
                                    loop)
        # cutsets of inductors and current sources: their currents are not independent
        others = [(a, b) for a, b, p in edges if p.kind not in ("L", "I", "K")]
        groups = _components(nodes, others)
        if len(set(groups.values())) > 1:
            cut = sorted({p.name for a, b, p in edges if p.kind in ("L", "I", "K") and groups[a] != groups[b]})
            raise InvalidGraphError(f"{', '.join(cut)} form a cutset of inductors and current sources: "
                                    "their currents are tied (a state would be dependent, a source "
                                    "contradicted); add a resistor across one of them or merge the inductors",
                                    cut)

    # ------------------------------------------------------------ building

    def build(self, parameters: Mapping | None = None, name: str | None = None,
              inputs: Mapping[str, Callable] | None = None, *, gmin=None, allow_floating: bool = False,
              **options) -> HybridModel:
        """The :class:`~switching.HybridModel` of the netlist.

        ``parameters`` gives values to the parameter names used and overrides
        the numbers given with the components (``{"R1": 2e3}``); ``inputs``
        the functions of ``t`` of declared inputs; ``name`` names the model
        (default: the circuit's name); other ``options`` go to
        :class:`~switching.HybridModel` (``tolerance``, …).

        ``gmin`` [S] (off by default): a leak conductance across every ideal
        diode and switch, as SPICE's ``GMIN`` across every pn junction — a
        resistor ``<name>_gmin`` of resistance ``1/gmin`` between the
        element's two nodes, so that no mode leaves a node floating (see the
        module documentation).  A number (the parameter ``gmin``) or a
        parameter name.  The element's ``i_<name>`` stays the current of the
        ideal element, which its guards judge; the leak carries
        ``i_<name>_gmin = gmin·v_<name>`` besides.  Across an element at rest
        the leaks of a bridge divide the voltages symmetrically, so a blocking
        diode's ``v_D`` is the share of the network's voltage it actually
        takes and turns it on when that share exceeds ``v_f``: the leak moves
        the instants by a relative O(gmin·R) of the circuit's resistances and
        adds none.

        Without ``gmin``, a mode that leaves nodes floating (a bridge's load
        with all four diodes blocking) runs as the limit of vanishing leaks;
        a circuit with such a mode that has no limit (a free direction no diode
        or switch touches) is refused here, with a
        :class:`~bondgraph.errors.FloatingPartError` naming the mode, the
        floating nodes and the fixes (found on the netlist, whatever the
        number of modes: :mod:`models.circuit_topology`; the candidates are
        derived here, as a run would derive them when it meets them).
        ``allow_floating=True`` builds it all the same, for a circuit whose
        floating modes are never reached (a run that reaches one stops with
        that error then)."""
        self._check_topology()
        builder = _Builder(self, dict(parameters or {}), inputs or {})
        builder.gmin = gmin
        model = builder.model(name or self.name, options)
        model.conflict_words = functools.partial(conflict_loop, tuple(self._parts.values()))
        if builder.windows:  # an adaptive step spans at most half of the shortest PWM window
            model.max_step_hint = min(builder.windows) / 2
        if gmin is None and not allow_floating:
            floating = first_floating_mode(list(self._parts.values()), model, floating_modes,
                                           lambda mode: _runs(model, mode))
            if floating:
                mode, error = floating
                raise FloatingPartError(
                    f"circuit {self.name!r} floats in mode {mode.describe()}: {error} Build it with "
                    "gmin=1e-12 (a leak across every diode and switch), or with allow_floating=True if no run "
                    "reaches such a mode.", error.elements, error.cut, error.configuration, error.kind)
        return BuiltFrom.record(model, self, parameters, inputs,
                                {"gmin": gmin, "allow_floating": allow_floating, **options})


#: the most modes :func:`floating_modes` checks (beyond, the check is skipped)
FLOATING_CHECK_MODES = 1024


def floating_modes(model) -> list:
    """``[(mode, FloatingPartError), ...]``: every mode of ``model``'s
    automata whose configuration leaves part of the graph under-determined
    (:func:`bondgraph.floating.floating_part`: nodes no conducting element
    ties to a known voltage, or a loop of ideal conductors), in the order of
    the automata's states; empty when none does, or when the automata have
    more than :data:`FLOATING_CHECK_MODES` modes (not checked).  Whether a
    circuit has such a mode at all, and a mode that shows each floating
    part, are found on its netlist without enumerating
    (:func:`models.circuit_topology.floating_witnesses`, which
    :meth:`Circuit.build` uses)."""
    states = [tuple(a.states) for a in model.automata]
    if math.prod(len(s) for s in states) > FLOATING_CHECK_MODES:
        return []
    found = []
    for combination in itertools.product(*states):
        mode = model.mode(dict(zip((a.name for a in model.automata), combination)))
        error = floating_part(model.graph, dict(model.configuration_of(mode)))
        if error is not None:
            found.append((mode, error))
    return found


def _components(nodes, edges) -> dict:
    parent = {n: n for n in nodes}

    def find(n):
        while parent[n] != n:
            parent[n] = parent[parent[n]]
            n = parent[n]
        return n

    for a, b in edges:
        parent[find(a)] = find(b)
    return {n: find(n) for n in nodes}


def _loop(nodes, edges) -> list:
    """The names of the edges of one loop in ``edges`` (a, b, name), or []."""
    adjacency = {n: [] for n in nodes}
    parent = {n: n for n in nodes}

    def find(n):
        while parent[n] != n:
            n = parent[n]
        return n

    for a, b, label in edges:
        if find(a) == find(b):  # a path a … b exists: find it
            path = _path(adjacency, a, b)
            return [label] + path
        parent[find(a)] = find(b)
        adjacency[a].append((b, label))
        adjacency[b].append((a, label))
    return []


def _path(adjacency, start, goal) -> list:
    stack, seen = [(start, [])], {start}
    while stack:
        node, labels = stack.pop()
        if node == goal:
            return labels
        for nxt, label in adjacency[node]:
            if nxt not in seen:
                seen.add(nxt)
                stack.append((nxt, labels + [label]))
    return []


class _Builder(NetlistBuilder):
    """One build of a :class:`Circuit` (graph, automata, parameters, signals):
    each node a 0-junction, each series branch a 1-junction."""

    def __init__(self, circuit: Circuit, parameters: dict, inputs: Mapping):
        super().__init__(circuit, parameters, inputs, Zero, One, Input)
        self.circuit = circuit
        self.initial: dict[str, tuple] = {}  # state name → (storage element, its output at t = 0)
        self.gmin = None  # leak conductance across ideal diodes and switches (Circuit.build)
        self.windows: list[float] = []  # the PWM switches' shortest on and off windows [s]
        #: the controllers' names (a PWM whose duty names one is modulated by it)
        self.controllers = {p.name for p in circuit._parts.values() if p.kind == "PI"}

    # -- names and values

    def source_value(self, part) -> sp.Expr:
        """A source's value; a controller's name drives it with the controller's output (a controlled
        source, :func:`models.controllers.drive_sources`)."""
        driven = controller_placeholder(self, part.values["value"])
        if driven is not None:
            return driven
        return self.expression_value(part.values["value"], f"source {part.name!r}", part.name)

    def start_unit_state(self, storage, value: float) -> None:
        """The state of a unit capacity ``storage`` starts at ``value``."""
        self.initial[storage.state.name] = (storage, value)

    def across_and_through(self, part, bond, sign: int, owner: str) -> None:
        """The signals ``v_<name>`` and ``i_<name>`` of a two-terminal part whose element is on
        ``bond``: ``v = sign·e``, ``i = sign·f``."""
        minus = "-" if sign < 0 else ""
        self.signal(f"v_{part.name}", f"{minus}e_{bond.name}", owner)
        self.signal(f"i_{part.name}", f"{minus}f_{bond.name}", owner)

    # -- graph pieces

    def passive(self, part, owner: str | None = None):
        kind, name = part.kind, part.name
        owner = owner or f"{kind} {name!r}"
        law = part.values.get("law")
        what = {"R": "resistance", "C": "capacitance", "L": "inductance"}[kind]
        value = None if law else self.number_or_parameter(
            part.values.get("value"), name, f"{what} of {owner}", rename=f"rename {owner}",
            allowed=Range(f"the {what} of {owner}", 0.0, low_open=kind != "R"))

        def element(sign):
            if law:
                key, function = law
                wrapped = function if sign == 1 else (lambda x, f=function: -f(-x))
                return {"R": R, "C": C, "L": I}[kind](name, **{key: wrapped})
            return {"R": R, "C": C, "L": I}[kind](name, value)

        sign, bond = self.branch(part, element)
        self.across_and_through(part, bond, sign, owner)
        if kind in ("C", "L") and part.values.get("initial"):
            storage = self.graph.elements[name]
            self.initial[storage.state.name] = (storage, sign * part.values["initial"])

    def voltage_source(self, part):
        name, (plus, minus) = part.name, part.nodes
        value = self.source_value(part)
        if plus != GROUND and minus != GROUND:
            junction = self.graph.add(One(self.internal(f"branch_{name}")))
            bond = self.graph.connect(Se(name, value), junction)
            self.note(plus, self.graph.connect(junction, self.node(plus)))
            self.note(minus, self.graph.connect(self.node(minus), junction))
            sign = 1
        elif minus == GROUND:
            bond = self.graph.connect(Se(name, value), self.node(plus))
            self.note(plus, bond)
            sign = 1
        else:
            bond = self.graph.connect(Se(name, -value), self.node(minus))
            self.note(minus, bond)
            sign = -1
        owner = f"voltage source {name!r}"
        self.signal(f"v_{name}", f"{'-' if sign < 0 else ''}e_{bond.name}", owner)
        self.signal(f"i_{name}", f"{'' if sign < 0 else '-'}f_{bond.name}", owner)

    def current_source(self, part):
        name, (source, target) = part.name, part.nodes
        value = self.source_value(part)
        if source != GROUND and target != GROUND:
            junction = self.graph.add(One(self.internal(f"branch_{name}")))
            bond = self.graph.connect(Sf(name, value), junction)
            self.note(target, self.graph.connect(junction, self.node(target)))
            self.note(source, self.graph.connect(self.node(source), junction))
            sign = 1
        elif source == GROUND:
            bond = self.graph.connect(Sf(name, value), self.node(target))
            self.note(target, bond)
            sign = 1
        else:
            bond = self.graph.connect(Sf(name, -value), self.node(source))
            self.note(source, bond)
            sign = -1
        self.signal(f"i_{name}", f"{'-' if sign < 0 else ''}f_{bond.name}", f"current source {name!r}")
        self.later.append((name, part.nodes, f"current source {name!r}"))

    def controlled(self, part, owner: str, extra=()):
        """A controlled 1-junction ``name`` between the part's nodes; its signal ``i_<name>`` is the
        current from its first node to its second."""
        name, (a, b) = part.name, part.nodes[:2]
        junction = self.graph.add(One(name, controlled=True))
        current = None
        if a != GROUND:
            bond = self.graph.connect(self.node(a), junction, name=self.bond_name(f"{name}_in"))
            self.note(a, bond)
            current = f"f_{bond.name}"
        if b != GROUND:
            bond = self.graph.connect(junction, self.node(b), name=self.bond_name(f"{name}_out"))
            self.note(b, bond)
            current = current or f"f_{bond.name}"
        for element in extra:
            self.graph.connect(junction, element)
        if len(self.graph.bonds_of(name)) < 2:  # an ideal branch to ground: the other side is 0 V
            self.graph.connect(junction, Se(self.internal(f"{name}_ground"), 0))
        self.signal(f"i_{name}", current, owner)
        self.later.append((name, part.nodes, owner))

    def diode(self, part):
        name = part.name
        owner = f"diode {name!r}"
        extra, threshold = [], "0"
        if part.values["v_f"] is not None:
            v_f = self.number_or_parameter(part.values["v_f"], f"{name}_v_f", f"forward drop v_f of {owner}")
            extra.append(Se(self.internal(f"{name}_drop"), v_f))
            threshold = str(v_f)
        if part.values["r_on"] is not None:
            r_on = self.number_or_parameter(part.values["r_on"], f"{name}_r_on", f"on-resistance r_on of {owner}",
                                            allowed=Range(f"the on-resistance of {owner}", 0.0))
            extra.append(R(self.internal(f"{name}_resistance"), r_on))
        self.controlled(part, owner, extra)
        blocking, conducting = OFF["D"], ON["D"]  # (read as off and on too)
        automaton = Automaton(name, {blocking: {name: False}, conducting: {name: True}},
                              initial=conducting if part.values["on"] else blocking, aliases=DIODE_ALIASES)
        automaton.add_transition(blocking, conducting, f"v_{name} > {threshold}", "a posteriori")
        automaton.add_transition(conducting, blocking, f"i_{name} < 0", "a posteriori")
        self.automata.append(automaton)

    def switch(self, part):
        name, rule = part.name, part.values["closed_when"]
        owner = f"switch {name!r}"
        extra = []
        if part.values.get("r_on") is not None:
            r_on = self.number_or_parameter(part.values["r_on"], f"{name}_r_on", f"on-resistance r_on of {owner}",
                                            allowed=Range(f"the on-resistance of {owner}", 0.0))
            extra.append(R(self.internal(f"{name}_resistance"), r_on))
        self.controlled(part, owner, extra)
        modulated = modulated_duty(self, rule, self.controllers) if isinstance(rule, PWM) else None
        if modulated is not None:
            closing, opening, initial = self.modulated_pwm(part, rule, modulated)
        elif isinstance(rule, PWM):
            period = self.number_or_parameter(rule.period, f"{name}_period", f"PWM period of {owner}",
                                              allowed=Range(f"the PWM period of {owner}", 0.0, low_open=True,
                                                            required=True))
            duty = self.number_or_parameter(rule.duty, f"{name}_duty", f"PWM duty of {owner}",
                                            allowed=Range(f"the PWM duty of {owner}", 0.0, 1.0, required=True))
            delay = float(rule.delay)
            values = {sp.Symbol(k): v for k, v in {**self.defaults, **self.given}.items()
                      if isinstance(v, numbers.Real)}
            try:  # the shortest on or off window, which no step may span (a whole window would pass unseen)
                d, T = float(duty.xreplace(values)), float(period.xreplace(values))
                window = min(d, 1.0 - d) * T
            except (TypeError, ValueError):
                window = 0.0
            if window > 0.0:
                self.windows.append(window)
            phase = f"t - {delay!r}" if delay else "t"
            carrier = f"acos(cos(2*pi*({phase})/{period} - pi*{duty}))/pi"
            self.signal(f"carrier_{name}", carrier, owner)
            closing, opening = f"carrier_{name} <= {duty}", f"carrier_{name} > {duty}"
            initial = part.values["closed"]
            if initial is None:
                initial = delay <= 0.0
        else:
            closing = self.user_text(rule)
            opening = self.user_text(part.values["open_when"] or f"not ({rule})")
            initial = part.values["closed"]
            if initial is None:
                initial = holds_at_start(closing, {**self.defaults, **self.given})
        opened, closed = OFF["S"], ON["S"]
        automaton = Automaton(name, {opened: {name: False}, closed: {name: True}},
                              initial=closed if initial else opened)
        automaton.add_transition(opened, closed, closing, "a priori")
        automaton.add_transition(closed, opened, opening, "a priori")
        self.automata.append(automaton)

    def modulated_pwm(self, part, rule, duty: str) -> tuple[str, str, bool]:
        """``(closing, opening, closed at t = 0)`` of a PWM switch whose duty varies: the fixed triangle
        carrier ``carrier_<name>`` against the duty signal (:mod:`models.controllers`); a step spans at
        most a sixteenth of the period (:data:`~switching.model.source_periods.PERIOD_FRACTION`)."""
        name, owner = part.name, f"switch {part.name!r}"
        period = self.number_or_parameter(rule.period, f"{name}_period", f"PWM period of {owner}",
                                          allowed=Range(f"the PWM period of {owner}", 0.0, low_open=True,
                                                        required=True))
        values = {sp.Symbol(k): v for k, v in {**self.defaults, **self.given}.items() if isinstance(v, numbers.Real)}
        try:
            self.windows.append(2.0 * float(period.xreplace(values)) / PERIOD_FRACTION)
        except (TypeError, ValueError):
            pass
        if rule.carrier == "sawtooth":
            return sawtooth_pwm(self, part, rule, period, duty)
        phase = f"t - {float(rule.delay)!r}" if rule.delay else "t"
        self.signal(f"carrier_{name}", f"acos(cos(2*pi*({phase})/{period}))/pi", owner)
        closed = part.values["closed"]
        return f"carrier_{name} < {duty}", f"carrier_{name} > {duty}", True if closed is None else closed

    def windings(self, part) -> tuple:
        """The 1-junctions ``<name>_primary`` and ``<name>_secondary`` of a two-port part, in series between
        its nodes: ``p1 → primary → p2`` and ``s1 ← secondary ← s2`` (the secondary's flow out of ``s1``)."""
        name = part.name
        p1, p2, s1, s2 = part.nodes
        primary = self.graph.add(One(self.internal(f"{name}_primary")))
        secondary = self.graph.add(One(self.internal(f"{name}_secondary")))
        for n, bond in ((p1, lambda: self.graph.connect(self.node(p1), primary)),
                        (p2, lambda: self.graph.connect(primary, self.node(p2))),
                        (s1, lambda: self.graph.connect(secondary, self.node(s1))),
                        (s2, lambda: self.graph.connect(self.node(s2), secondary))):
            if n != GROUND:
                self.note(n, bond())
        return primary, secondary

    def two_port(self, part):
        name = part.name
        owner = f"{'transformer' if part.kind == 'T' else 'gyrator'} {name!r}"
        modulus = self.number_or_parameter(part.values["value"], name, f"ratio of {owner}",
                                           rename=f"rename {owner}")
        element = (TF if part.kind == "T" else GY)(name, modulus)
        primary, secondary = self.windings(part)
        bond_p = self.graph.connect(primary, element, name=self.bond_name(f"{name}_p"))
        bond_s = self.graph.connect(element, secondary, name=self.bond_name(f"{name}_s"))
        for side, bond in (("p", bond_p), ("s", bond_s)):
            self.signal(f"v_{name}_{side}", f"e_{bond.name}", owner)
            self.signal(f"i_{name}_{side}", f"f_{bond.name}", owner)

    def coupled(self, part):
        """The T-equivalent of coupled inductors (:meth:`Circuit.coupled_inductors`): ``p1 → 1_primary → p2``
        with the leakage ``I`` on the 1-junction and a bond to the core's 0-junction, which holds the
        magnetizing ``I`` and the transformer to the secondary's 1-junction (``s1 → 1_secondary → s2``)."""
        name = part.name
        owner = f"coupled inductors {name!r}"
        inductance = {key: self.number_or_parameter(
            part.values[key], f"{name}_{key}", f"{what} of {owner}", rename=f"rename {owner}",
            allowed=Range(f"the {what} of {owner}", 0.0, low_open=True))
            for key, what in (("L1", "primary's inductance"), ("L2", "secondary's inductance"))}
        k = self.number_or_parameter(part.values["k"], f"{name}_k", f"coupling coefficient of {owner}",
                                     rename=f"rename {owner}",
                                     allowed=Range(f"the coupling coefficient of {owner}", 0.0, 1.0, low_open=True,
                                                   required=True))
        L1, L2 = inductance["L1"], inductance["L2"]
        primary, secondary = self.windings(part)
        core = self.graph.add(Zero(self.internal(f"{name}_core")))
        into_core = self.graph.connect(primary, core, name=self.bond_name(f"{name}_core"))
        across = f"e_{into_core.name}"
        if part.values["k"] != 1:  # (k = 1: no leakage)
            leakage = self.graph.add(I(self.internal(f"{name}_leakage"), (1 - k ** 2) * L1))
            bond = self.graph.connect(primary, leakage, name=self.bond_name(f"{name}_leakage"))
            across = f"e_{bond.name} + {across}"
        magnetizing = self.graph.add(I(self.internal(f"{name}_magnetizing"), k ** 2 * L1))
        bond_m = self.graph.connect(core, magnetizing, name=self.bond_name(f"{name}_magnetizing"))
        element = self.graph.add(TF(self.internal(f"{name}_transformer"), k * sp.sqrt(L1 / L2)))
        self.graph.connect(core, element, name=self.bond_name(f"{name}_p"))
        bond_s = self.graph.connect(element, secondary, name=self.bond_name(f"{name}_s"))
        self.signal(f"v_{name}_p", across, owner)
        self.signal(f"i_{name}_p", f"f_{into_core.name}", owner)
        self.signal(f"v_{name}_s", f"e_{bond_s.name}", owner)
        self.signal(f"i_{name}_s", f"-f_{bond_s.name}", owner)
        self.signal(f"i_{name}_m", f"f_{bond_m.name}", owner)

    def leaks(self):
        """A resistor ``<name>_gmin`` of resistance ``1/gmin`` across every
        ideal diode and switch (:meth:`Circuit.build`'s ``gmin``)."""
        gmin = self.gmin
        if isinstance(gmin, bool) or not isinstance(gmin, (str, numbers.Real)):
            raise ParameterValueError(f"circuit {self.circuit.name!r}: gmin must be a conductance [S] (a positive "
                                      f"number, e.g. 1e-12) or a parameter name, got {gmin!r}", "gmin", gmin)
        if not isinstance(gmin, str) and not (math.isfinite(gmin) and gmin > 0):
            raise ParameterValueError(f"circuit {self.circuit.name!r}: gmin = {gmin!r} is not a positive finite "
                                      "conductance [S]; give e.g. gmin=1e-12, or leave it out for no leak",
                                      "gmin", gmin)
        conductance = self.number_or_parameter(
            gmin, "gmin", "leak conductance gmin given to build()",
            rename="give gmin as a parameter name of your own (build(gmin='g_leak'))",
            allowed=Range("the leak conductance gmin", 0.0, low_open=True, required=True))
        for part in list(self.circuit._parts.values()):
            if part.kind not in ("D", "S"):
                continue
            leak = f"{part.name}_gmin"
            if leak in self.circuit._parts:
                raise NameCollisionError(f"circuit {self.circuit.name!r}: gmin puts a leak named {leak!r} across "
                                         f"{part.name!r}, and a component has that name; rename it", leak,
                                         (f"the leak across {part.name!r}", f"component {leak!r}"))
            self.passive(Part("R", leak, part.nodes[:2], {"value": 1 / conductance}),
                         owner=f"the leak across {part.name!r}")

    # -- the model

    def model(self, name: str, options: dict) -> HybridModel:
        self.later = []
        parts = self.circuit._parts.values()
        for part in parts:
            {"R": self.passive, "C": self.passive, "L": self.passive, "V": self.voltage_source,
             "I": self.current_source, "D": self.diode, "S": self.switch, "PI": lambda part: None,
             "T": self.two_port, "G": self.two_port, "K": self.coupled}[part.kind](part)
        if self.gmin is not None:
            self.leaks()
        node_signals = {}
        for n, bond in self.node_bond.items():
            self.names.claim(f"v_{n}", Owner(f"signal 'v_{n}' (the voltage of node {n!r})", f"rename node {n!r}",
                                             "signal"))
            node_signals[f"v_{n}"] = f"e_{bond}"
        for name_, (a, b), owner in self.later:
            self.signal(f"v_{name_}", f"{_node_signal(a)} - {_node_signal(b)}", owner)
        controllers = [part for part in parts if part.kind == "PI"]
        if controllers:  # (their states read every other signal)
            build_controllers(self, controllers, {**node_signals, **self.signals})
        self.claim_graph_names({})
        self.claim_text_names()
        signals = {**node_signals, **self.signals}
        parameters = self.parameters_checked()
        initial_state = {}
        for state, (storage, output) in self.initial.items():
            initial_state[state] = _initial_state(storage, output, parameters)
        missing_inputs = sorted(set(self.graph.inputs) - set(self.inputs))
        if missing_inputs:
            raise InvalidGraphError(f"circuit {self.circuit.name!r}: input(s) {', '.join(missing_inputs)} have "
                                    "no function: give build(inputs={name: function of t})", missing_inputs)
        names = list(signals) + [s.name for s in self.graph.states]
        units = units_by_prefix(names, CIRCUIT_UNITS, self.unitless)
        return HybridModel(self.graph, self.automata, parameters, initial_state=initial_state,
                           signals=signals, inputs=self.inputs or None, name=name, units=units, **options)


def _initial_state(storage, output: float, parameters: Mapping) -> float:
    """The state of ``storage`` (a C's charge, an L's flux linkage) whose law
    gives ``output`` (its voltage, its current) with the ``parameters``: the
    law inverted symbolically, or else its real root found numerically (a
    monotonic law has one)."""
    values = {sp.Symbol(k): v for k, v in parameters.items()}
    law = storage.law.subs(values)
    q = storage.state
    if law.free_symbols - {q}:
        raise MissingParameterError(sorted(s.name for s in law.free_symbols - {q}))
    if output == 0.0 and law.subs(q, 0) == 0:
        return 0.0
    residual = sp.lambdify(q, law - output, "math")
    span = 1.0
    for _ in range(400):
        low, high = residual(-span), residual(span)
        if low * high <= 0:
            return float(brentq(residual, -span, span, xtol=1e-300, rtol=4 * np.finfo(float).eps))
        span *= 2.0
    what = "voltage" if storage.kind == "C" else "current"
    raise InvalidGraphError(f"{storage.name!r}: its law never reaches the initial {what} {output:g}; give an "
                            "initial value its law can take", [storage.name])


def _node_signal(n):
    return "0" if n == GROUND else f"v_{n}"


def _passive_value(value, what: str, name: str):
    """An R's, C's or L's value as :meth:`Circuit.R` takes it: ``None`` (the parameter ``name``), a number,
    a parameter name or a sympy expression."""
    if value is None:
        return None
    kind = {"resistance": "R", "capacitance": "C", "inductance": "L"}[what]
    return checked_argument(value, f"the {what} of {kind} {name!r}", ("number", "name", "sympy"))


def _flag(value, what: str, name: str) -> bool:
    """A true/false argument (``on``, ``closed``) of component ``name``: ``True``/``False`` (numpy's too)."""
    if isinstance(value, (bool, np.bool_)) or (isinstance(value, numbers.Integral) and value in (0, 1)):
        return bool(value)
    raise ParameterValueError(f"{what!r} of {name!r} must be True or False, got {value!r}", what, value)


def _runs(model, mode) -> bool:
    """Whether ``mode`` of ``model`` has equations — its own, or, where part of it floats, the limit of
    vanishing leaks (:func:`bondgraph.regularize.floating_limit`)."""
    try:
        model.mode_equations(mode)
    except FloatingPartError:
        return False
    return True
