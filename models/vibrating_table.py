"""A ball bouncing on a sinusoidally vibrating table, with Newton's restitution
relative to the table and a sticking mode.

The table is not a body of the model but a prescribed motion: its position
``s(t) = A sin(ω t)`` [m] is imposed whatever the ball does (a shaker heavy
enough not to feel the ball).  Its velocity ``ṡ(t) = A ω cos(ω t)`` is a flow
source.

Bond graph (power directions by arrows; bond names in brackets)::

    Se: −m·g ──► 1_v ──► I: m                  (p = m v, y = ∫ v dt)
                  │
                  ▼ [contact]
               0_table (controlled) ──► 1_s ◄── Sf: ṡ(t) = A ω cos(ω t)

``1_v`` carries the ball's velocity ``v``, ``1_s`` the table's ``ṡ``.  The
controlled 0-junction ``table`` is off in flight (no force between ball and
table) and on in contact, where it makes the two velocities equal, ``v = ṡ``:
the ball's inertia is then in derivative causality (dependent storage,
``p = m ṡ(t)``) and the contact force is the effort of the bond ``contact``,
``N = −e_contact = m (s̈ + g)`` (up, on the ball).  This is the floor of
:mod:`models.bouncing_ball` with a moving flow source (its floor's ``Sf`` is 0).

Automaton ``contact`` (states ``flight``: ``table`` off; ``impact``: ``table``
on, restitution ``e``; ``stick``: ``table`` on; initial ``flight``), with the
gap ``gap = y − s(t)`` and the relative velocity ``vrel = v − ṡ(t)``:

* ``flight → stick``  when ``gap <= 0 and vrel <= 0 and -vrel <= v_stick and
  N_stick > 0`` (a priori: a landing slower than ``v_stick`` on a table that
  pushes is plastic — the time-scale abstraction of the end of a chattering
  sequence, whose bounces would otherwise accumulate; ``N_stick`` is the
  force the stick mode would need, finite part, see below);
* ``flight → impact`` when ``gap <= 0 and vrel < 0`` (a priori: the collision
  is judged on the approach velocity before it, as for the bouncing ball);
* ``impact → flight`` when ``vrel >= 0`` (a priori, on the state after the
  jump: the impact is a pinnacle);
* ``stick → flight``  when ``N_stick < 0`` (a priori: the table can only push;
  the force it needs to carry the ball, ``m (s̈ + g)``, is a function of time
  alone, so the instant the table's acceleration drops below ``−g`` is
  located in flow and the ball leaves it tangentially, ``gap = vrel = 0``).

The first two guards are listed in that order, so a slow landing sticks
rather than bounces.  ``N_stick`` is ``InMode("-e_contact", contact="stick")``:
the contact force of the stick mode at the state its jump map gives, finite
part only (the impulse of the plastic jump is left out, so a landing is
judged on the force that would hold the ball, not on the landing's pulse).

Impact (the toolkit's restitution jump ``x⁺ = x + (1 + e)(g(x) − x)``, ``g``
the conservation-of-state jump into the contact configuration, ``p ← m ṡ(t)``):
``p⁺ = p + (1 + e)(m ṡ − p)``, i.e. ``v⁺ − ṡ = −e (v⁻ − ṡ)`` — Newton's law
on the velocity *relative to the table*, with the table's velocity at the
impact instant (the table, a flow source, does not feel the impulse).
``e = 0`` leaves the ball at the table's velocity; it then sticks if the
table pushes (``flight → stick`` at the same instant) and flies off
tangentially otherwise.

Resting on the table (``gap0 = 0, vrel0 = 0``; the default start is a drop
from ``gap0 = 0.1`` m) is the stick mode: the ball rides the table while
``A ω² sin(ω t) < g`` and leaves it at the first ``t`` with
``sin(ω t) = g/(A ω²)`` (never when ``Γ = A ω²/g <= 1``).  In flight
``y(t) = y_k + v_k (t − t_k) − g (t − t_k)²/2``.

Period-1 orbit (one impact per table period ``T = 2π/ω``, tested in
``tests/models/test_model_vibrating_table.py``): flight time ``T`` needs
``v⁺ = g T/2``, ``v⁻ = −g T/2``, and the restitution law gives the impact
phase ``cos θ = π g (1 − e)/(A ω² (1 + e))``, ``θ = +acos(…)``; it exists for
``Γ >= π (1 − e)/(1 + e)`` and is stable until its multiplier passes −1 at
``Γ² = π² (1 − e)²/(1 + e)² + 4 (1 + e²)²/(1 + e)⁴`` (period doubling).  The
model is forced (time is not a state), so its periodic orbits have the
forcing's period: find them with ``periodic_orbit(model, period=2π/ω, t0=…)``
(a stroboscopic start in flight), not with an autonomous ``section=``
(which restarts every return at the same ``t0``).  From the command line:
``hbg orbit vibrating-table --period 0.2 --warmup 10`` (the defaults' orbit
from ``t = 0``), and its bifurcation diagram with ``--continue
A=0.013:0.017:9 --doubled`` from a start on the orbit (``--set p=-0.8 --set
y=0.0235``; the default drop's warmup may settle on another attractor
instead, the ball locked to the table by chattering and sticking, whose
multipliers are 0).

Sign conventions and units: ``y`` [m] the ball's height, ``v`` [m/s] its
velocity, both up and in the laboratory frame (the table's mean position is
``y = 0``); ``A`` [m] the table's amplitude, ``omega`` [rad/s] its angular
frequency, ``m`` [kg], ``g`` [m/s²], ``e`` [-], ``v_stick`` [m/s]; the
initial state is given relative to the table at ``t = 0`` (where ``s = 0``,
``ṡ = A ω``): ``gap0`` [m] the height above it, ``vrel0`` [m/s] the velocity
relative to it.  States: ``p`` [kg·m/s], ``y`` [m].

Signals: ``y``, ``v``, ``table`` (``s``), ``table_v`` (``ṡ``), ``table_a``
(``s̈``), ``gap``, ``vrel``, ``contact_force`` (the force of the table on the
ball [N], with a Dirac pulse of area ``m (v⁺ − v⁻)`` at each impact),
``N_stick`` (the force the stick mode needs, ``m (s̈ + g)``).

Valid range (exercised by ``tests/models/test_model_ranges.py``):
``0 <= e <= 1``, ``A >= 0``, ``omega > 0``, ``m > 0``, ``g > 0``, ``gap0 >= 0``
over orders of magnitude (tested ``Γ = A ω²/g`` from 0.5 to 4, ``A`` from
1e-4 to 1e2 m, so ``omega`` from 0.2 to 630 rad/s, ``e`` from 0 to 0.9,
``m`` from 1e-3 to 1e3 kg), starting at rest on the table or dropped from
``10 A``, with ``v_stick = 1e-3 A ω`` (scale it with the velocities: the
default 1e-3 m/s suits the default table).  Every impact there obeys the
restitution law relative to the table, every release happens where
``A ω² sin(ω t) = g``, and the ball never goes through the table.  A ball
whose impacts accumulate (chattering: a landing on a table that keeps
pushing, as it always does when ``Γ < 1``) ends the sequence with the stick
rule; with ``v_stick = 0`` and ``0 < e < 1`` the accumulation is a
:class:`~switching.ZenoError` (its ``accumulation_time`` the end of the
chattering), or ends the run with ``on_zeno="stop"``.  No other error is
documented in this range.
"""

from __future__ import annotations

import math

import sympy as sp

from bondgraph import BondGraph, I, One, Se, Sf, Zero, t
from switching import Automaton, HybridModel, InMode

from ._common import Range, annotated, merged, nonnegative, positive

__all__ = ["build", "DEFAULTS", "RANGES", "RUN", "SIGNALS", "UNITS", "table_motion"]

DEFAULTS = {
    "m": 1.0,
    "g": 9.81,
    "e": 0.5,
    "A": 0.0125,
    "omega": 10 * math.pi,
    "gap0": 0.1,
    "vrel0": 0.0,
    "v_stick": 1e-3,
}
#: physical ranges: a value outside gives a PhysicalRangeWarning
RANGES = {
    "m": positive("a mass"),
    "g": positive("gravity pulling the ball to the table"),
    "e": Range("a restitution coefficient", 0.0, 1.0),
    "A": nonnegative("the table's amplitude"),
    "omega": positive("the table's angular frequency"),
    "gap0": nonnegative("a height above the table"),
    "v_stick": nonnegative("a sticking threshold speed"),
}
#: a meaningful default run (used by ``hbg run``): a drop onto the table, settling on the period-1 orbit
RUN = {"t_end": 3.0, "rtol": 1e-9}
SIGNALS = ("y", "v", "table", "table_v", "table_a", "gap", "vrel", "contact_force", "N_stick")
#: the unit of each parameter, state and signal (shown on plots, kept in model files)
UNITS = {"m": "kg", "g": "m/s²", "e": "1", "A": "m", "omega": "rad/s", "gap0": "m", "vrel0": "m/s", "v_stick": "m/s",
         "p": "N·s", "y": "m", "v": "m/s", "table": "m", "table_v": "m/s", "table_a": "m/s²", "gap": "m",
         "vrel": "m/s", "contact_force": "N", "N_stick": "N"}


def table_motion(A, omega) -> tuple:
    """``(s, ṡ, s̈)`` as sympy expressions of ``t``: the table's position
    ``A sin(ω t)`` [m], velocity ``A ω cos(ω t)`` [m/s] and acceleration
    ``−A ω² sin(ω t)`` [m/s²] (``A``, ``omega`` numbers or symbols)."""
    s = A * sp.sin(omega * t)
    return s, sp.diff(s, t), sp.diff(s, t, 2)


def _graph() -> BondGraph:
    """The bond graph of the module docstring (parameters as symbols)."""
    m, g, A, omega = sp.symbols("m g A omega")
    graph = BondGraph("vibrating_table")
    ball = graph.add(One("v"))
    graph.connect(Se("gravity", -m * g), ball)
    graph.connect(ball, I("ball", "m", state="p"))
    graph.displacement("y", of=ball)
    table = graph.add(Zero("table", controlled=True))
    graph.connect(ball, table, name="contact")
    drive = graph.add(One("s"))
    graph.connect(table, drive)
    graph.connect(Sf("shaker", table_motion(A, omega)[1]), drive)
    return graph


def _automaton() -> Automaton:
    """The automaton ``contact`` of the module docstring."""
    contact = Automaton(
        "contact",
        {"flight": {"table": False}, "impact": {"table": True}, "stick": {"table": True}},
        initial="flight",
        restitution={"impact": "e"},
    )
    contact.add_transition("flight", "stick", "gap <= 0 and vrel <= 0 and -vrel <= v_stick and N_stick > 0",
                           "a priori")
    contact.add_transition("flight", "impact", "gap <= 0 and vrel < 0", "a priori")
    contact.add_transition("impact", "flight", "vrel >= 0", "a priori")
    contact.add_transition("stick", "flight", "N_stick < 0", "a priori")
    return contact


#: the signals (text, parsed by the model): table motion, gap and relative velocity, forces
_SIGNALS = {
    "v": "p/m",
    "table": "A*sin(omega*t)",
    "table_v": "A*omega*cos(omega*t)",
    "table_a": "-A*omega**2*sin(omega*t)",
    "gap": "y - table",
    "vrel": "v - table_v",
    "contact_force": "-e_contact",
}


def build(**parameters) -> HybridModel:
    """The ball on the vibrating table with ``DEFAULTS`` overridden by ``parameters``."""
    p = merged(DEFAULTS, parameters, RANGES, "vibrating_table")
    # at t = 0 the table is at s = 0 moving at A ω
    model_parameters = {k: p[k] for k in ("m", "g", "e", "A", "omega", "v_stick", "gap0", "vrel0")}
    return HybridModel(
        _graph(),
        [_automaton()],
        model_parameters,
        initial_state={"y": "gap0", "p": "m*(A*omega + vrel0)"},
        signals={**_SIGNALS, "N_stick": InMode("-e_contact", contact="stick")},
        name="vibrating_table",
        **annotated(UNITS, RANGES, DEFAULTS, model_parameters),
    )
