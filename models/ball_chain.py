"""A chain of N balls on a line: ball 1 hits a row of touching balls (the
paper's Figs. 13-15, section 4.1).

Ball 1 starts ``distance`` to the left of ball 2 and moves right at ``v0``;
balls 2…N are at rest, ``gap`` apart (0: touching, the paper's set-up).
All balls have mass ``m`` and radius ``r``.  Two contact models:

**Ideal contacts** (``compliant=False``, the default; Figs. 13-14).  Bond
graph, for each neighbour pair i, i+1 (power directions by arrows)::

    I: m ◄── 1_v1 ──► 0_c1 ──► 1_v2 ──► 0_c2 ──► 1_v3 ··· 0_c(N-1) ──► 1_vN ──► I: m
             (p1, pos1)   ▲     (p2, pos2) ▲    (p3, pos3)             (pN, posN)
                      controlled        controlled                     (each 1_vi
                                                                        has its I: m)

``0_ci`` off: no force between balls i and i+1; on: their velocities are
equal (one momentum dependent), and the jump into it is the impact.
Automaton ``contact<i>`` (states ``free``, ``collide`` with restitution ``e``):

* ``free → collide`` when ``x<i+1> - x<i> <= 2*r and v<i> - v<i+1> > v_th``
  (**a priori**: the collision is a time-scale abstraction judged on the
  velocities before the impact; the separating-velocity threshold ``v_th``
  of the paper's section 4.2 ensures divergence of time — after the jump the
  balls still touch but no longer approach, so ``collide`` is not re-entered);
* ``collide → free`` when ``v<i> <= v<i+1>`` (**a priori** on the state after
  the Newton jump: ``collide`` is a *pinnacle*).

With touching balls one impact makes the next pair approach: the instant
passes N − 1 pinnacles in a row (``collide|free|…``, ``free|collide|…``, …),
each a two-ball Newton impact; for equal masses and ``e = 1`` the velocities
become (0, …, 0, v0).  Only the modes visited are derived (N of them, not
2^(N−1)).  With ``e < 1`` the pairs collide back and forth within the
instant (disjoint pairs may collide in one pinnacle together); the chain of
pinnacles ends when no pair approaches faster than ``v_th`` (for ``e = 0``:
all balls at ``v0/N`` to within about ``v_th``, after a number of pinnacles
that grows like ``log(1/v_th)``).

**Compliant contacts** (``compliant=True``; Fig. 15).  Each contact is a
spring ``k`` (and a damper ``b``, Kelvin-Voigt, present only when ``b > 0``)
acting on the overlap, engaged only while the balls overlap::

    1_vi ──► 0_ci (controlled) ──► 1_v(i+1)
                 │
                 ▼
               1_kvi ──► C: 1/k   (q_i = compression = overlap while engaged)
                 │
                 ▼
               R: b               (only when b > 0; otherwise C sits on 0_ci)

The common flow of ``1_kvi`` (the flow leaving ``0_ci``) is the approach
speed ``v<i> − v<i+1>``, so ``q_i`` integrates the overlap; the contact
force is ``q_i·k + b·(v<i> − v<i+1>)``.  ``0_ci`` off imposes zero force:
with ``b = 0`` the spring is then in derivative causality with ``q_i = 0``
(a relaxed spring), with ``b > 0`` it relaxes through the damper.
Automaton ``contact<i>`` (states ``free``, ``touch``), both guards
**a priori** (a switch of the compliant model, no abstraction of fast
dynamics — the contact dynamics is resolved, so no restitution and no
threshold is needed).  Undamped (``b = 0``), on the gap:

* ``free → touch`` when ``x<i+1> - x<i> <= 2*r`` (overlap begins; touching
  balls start engaged, with ``q_i = 0`` and no force);
* ``touch → free`` when ``x<i+1> - x<i> > 2*r`` (the overlap has ended).

``<=`` includes and ``>`` excludes the tolerance band at zero gap, so each
state admits exactly one mode (divergence of time holds).

Damped (``b > 0``), a contact that **only pushes**: it lets go when its
force would pull, not when the overlap ends (a Kelvin–Voigt contact released
on the geometry pulls the balls together before it lets go, and a heavily
damped one approaches zero overlap without crossing it, so round-off
decided its release).  With the *unloaded overlap* ``u_i = q_i + (b/k)·(v<i>
− v<i+1>)`` (the force over ``k``, [m]):

* ``free → touch`` when ``x<i+1> - x<i> <= 2*r - q_i and u_i >= 0`` (the
  balls reach the spring's surface, which relaxes through the damper at the
  rate ``k/b`` while free, and the contact would push);
* ``touch → free`` when ``u_i < 0`` (the force would become tensile).

At the release the force is zero, so the spring's surface then recedes
exactly as fast as the balls part and the balls do not touch it again unless
they approach.  Touching balls at rest carry a force of exactly zero: the
model's guard tolerance takes lengths below ``LENGTH_ROUNDOFF·r`` as zero,
so that the integrator's round-off does not make them pull.  Every method
then gives the same instants (Radau, BDF, LSODA, RK45 where it runs).  The
effective restitution of a two-ball contact is ``e = −u̇(t*)/v0`` at the
release ``tan(ω_d t*) = −2ζ√(1−ζ²)/(1−2ζ²)`` (``tests/switching/simulate/test_extremes.py``).

The linear contact has no length scale of its own: with touching balls
(``gap = 0``) the motion in the time unit ``sqrt(m/k)`` is the same for every
``k``, so the final velocities do *not* approach (0, …, 0, v0) as ``k`` grows
(only the transfer time ``∝ sqrt(m/k)`` shrinks to the ideal point in time);
with ``gap > 0`` the binary impacts separate and the result becomes exactly
the ideal one once ``k > π² m v0² / (8 gap²)`` (the front ball's travel
during one impact, ``π v0 sqrt(m/(2k))/2``, fits in the gap).

Sign conventions and units: positions ``x<i>`` [m] of the ball centres,
increasing to the right (``x1 < x2 < …``); velocities ``v<i>`` [m/s]
positive to the right; momenta ``p<i>`` [N·s]; ``m`` [kg], ``r`` [m],
``k`` [N/m], ``b`` [N·s/m], spring compressions ``q<i>`` [m].

States: ``p1…pN`` (momenta), ``q1…q(N−1)`` (spring compressions, compliant
only), ``pos1…posN`` (integrated displacements: the positions).
Signals: ``x1…xN`` (positions, = ``pos<i>``), ``v1…vN`` (velocities ``p/m``).

Valid range (exercised by ``tests/models/test_model_ranges.py``).  Ideal contacts:
``N >= 2``, ``0 <= e <= 1``, ``v_th`` from 1e-9·v0 to 1e-3·v0 (tested ``N`` up
to 8, ``v0`` and ``m`` from 1e-3 to 1e3): one instant, momentum conserved,
after it no pair approaches faster than ``v_th``.  ``e = 0`` with
``v_th = 0`` and ``N >= 3``: the plastic pinnacles reach the common velocity
only in the limit of infinitely many steps at one instant; the relative
velocities halve at each pass, and when they reach round-off either the
remaining ones fall inside the comparison bands first and the instant ends at
the limit (all balls at ``v0/N``, as for ``N = 3``), or a pinnacle repeats its
state within round-off and the run raises
:class:`~switching.DivergenceOfTimeError` (``N = 4, 5``; or its subclass
``TooManyStepsError`` after ``max_steps_per_instant``).  Give ``v_th > 0``.
Compliant contacts: ``k`` from 1e2 to 1e8 N/m, ``b >= 0``, ``gap >= 0``.  With
``b > 0`` a free spring relaxes through the damper at the rate ``k/b``: when
that rate is far above the run's (``k/b`` ≳ 1e5/s here) an explicit method
(RK45) stops with :class:`~switching.StiffnessError`; use Radau, BDF or LSODA.
"""

from __future__ import annotations

import sympy as sp

from bondgraph import C, BondGraph, I, One, R, Zero
from bondgraph.errors import InvalidGraphError
from switching import Automaton, HybridModel, Tolerance

from ._common import Range, annotated, merged, nonnegative, positive

#: a damped contact's guards (lengths: overlaps, the force over k) take lengths below this fraction of
#: the radius as zero: touching balls at rest carry a force of exactly zero, which the integrator's
#: round-off (far below this) must not turn into a pull
LENGTH_ROUNDOFF = 1e-12

__all__ = ["build", "LENGTH_ROUNDOFF", "DEFAULTS", "RUN", "SIGNALS", "UNITS", "signals_for", "units_for", "error_estimate"]

DEFAULTS = {
    "N": 4,
    "m": 1.0,
    "r": 0.05,
    "v0": 1.0,
    "distance": 0.1,
    "gap": 0.0,
    "e": 1.0,
    "v_th": 1e-6,
    "compliant": False,
    "k": 1e4,
    "b": 0.0,
}
#: physical ranges: a value outside gives a PhysicalRangeWarning
RANGES = {
    "m": positive("a mass", required=True),
    "r": positive("a radius", required=True),
    "e": Range("a restitution coefficient", 0.0, 1.0),
    "v_th": nonnegative("a separation threshold speed", required=True),
    "distance": nonnegative("the distance between neighbours' centres", required=True),
    "gap": nonnegative("a gap", required=True),
    "k": positive("a contact stiffness", required=True),
    "b": nonnegative("a contact damping", required=True),
}
#: a meaningful default run (used by ``hbg run``): the impact at t = 0.1 s,
#: then ball N moves away
RUN = {"t_end": 0.5, "rtol": 1e-9, "atol": 1e-12}
SIGNALS = ("x1", "x2", "x3", "x4", "v1", "v2", "v3", "v4")
#: the unit of each parameter (states and signals: :func:`units_for`)
UNITS = {"m": "kg", "r": "m", "v0": "m/s", "distance": "m", "gap": "m", "e": "1", "v_th": "m/s", "k": "N/m",
         "b": "N·s/m"}


def units_for(N: int) -> dict:
    """The units of the states and signals of a chain of ``N`` balls (``q<i>``: a compliant contact's compression)."""
    units = {}
    for i in range(1, N + 1):
        units.update({f"p{i}": "N·s", f"pos{i}": "m", f"x{i}": "m", f"v{i}": "m/s"})
    units.update({f"q{i}": "m" for i in range(1, N)})
    return units


def signals_for(N: int) -> tuple:
    """The signal names of a chain of ``N`` balls."""
    return tuple(f"x{i}" for i in range(1, N + 1)) + tuple(f"v{i}" for i in range(1, N + 1))


def build(**parameters) -> HybridModel:
    """The ball chain with ``DEFAULTS`` overridden by ``parameters``."""
    p = merged(DEFAULTS, parameters, RANGES, "ball_chain")
    n = p["N"]
    if n < 2:
        raise InvalidGraphError(f"parameter 'N' must be at least 2 (a chain of balls), got {n}")
    compliant = p["compliant"]
    damped = compliant and p["b"] > 0
    g = BondGraph("ball_chain")
    for i in range(1, n + 1):
        v = g.add(One(f"v{i}"))
        g.connect(v, I(f"ball{i}", "m", state=f"p{i}"))
    automata = []
    for i in range(1, n):
        c = g.add(Zero(f"c{i}", controlled=True))
        g.connect(f"v{i}", c, name=f"push{i}")
        g.connect(c, f"v{i + 1}", name=f"pushed{i}")
        touching = f"x{i + 1} - x{i} <= 2*r"
        if compliant:
            spring = C(f"spring{i}", 1 / sp.Symbol("k"), state=f"q{i}")
            if damped:
                kv = g.add(One(f"kv{i}"))
                g.connect(c, kv, name=f"contact{i}")
                g.connect(kv, spring)
                g.connect(kv, R(f"damper{i}", "b"))
            else:
                g.connect(c, spring, name=f"contact{i}")
            contact = Automaton(f"contact{i}", {"free": {f"c{i}": False}, "touch": {f"c{i}": True}}, initial="free")
            if damped:  # a contact that only pushes: released when its force would pull, engaged when it pushes
                unloaded = f"q{i} + b/k*(v{i} - v{i + 1})"  # the force over k [m]
                contact.add_transition("free", "touch", f"x{i + 1} - x{i} <= 2*r - q{i} and {unloaded} >= 0",
                                       "a priori")
                contact.add_transition("touch", "free", f"{unloaded} < 0", "a priori")
            else:
                contact.add_transition("free", "touch", touching, "a priori")
                contact.add_transition("touch", "free", f"x{i + 1} - x{i} > 2*r", "a priori")
        else:
            contact = Automaton(
                f"contact{i}",
                {"free": {f"c{i}": False}, "collide": {f"c{i}": True}},
                initial="free",
                restitution={"collide": "e"},
            )
            contact.add_transition("free", "collide", f"{touching} and v{i} - v{i + 1} > v_th", "a priori")
            contact.add_transition("collide", "free", f"v{i} <= v{i + 1}", "a priori")
        automata.append(contact)
    # displacements last, so the state vector reads p…, (q…,) pos…
    for i in range(1, n + 1):
        g.displacement(f"pos{i}", of=f"v{i}")

    names = ["m", "r"] + (["k"] + (["b"] if damped else []) if compliant else ["e", "v_th"])
    model_parameters = {name: p[name] for name in names + ["v0", "distance"] + (["gap"] if n > 2 else [])}
    initial = {"p1": "m*v0", "pos1": 0.0}
    for i in range(2, n + 1):  # ball 2 at 2r + distance, each next one 2r + gap further
        initial[f"pos{i}"] = f"{i - 1}*2*r + distance" + (f" + {i - 2}*gap" if i > 2 else "")
    signals = {f"x{i}": f"pos{i}" for i in range(1, n + 1)}
    signals.update({f"v{i}": f"p{i}/m" for i in range(1, n + 1)})
    tolerance = Tolerance(atol=LENGTH_ROUNDOFF * p["r"]) if damped else None
    units = {**UNITS, **{k: v for k, v in units_for(n).items() if not k.startswith("q") or compliant}}
    return HybridModel(g, automata, model_parameters, initial_state=initial, signals=signals, name="ball_chain",
                       tolerance=tolerance, **annotated(units, RANGES, DEFAULTS, model_parameters))



def error_estimate(trajectory) -> str:
    """Drift of the total momentum (exact invariant), and for the ideal
    elastic chain of touching balls the error of the final velocities against
    (0, …, 0, v0) — or, compliant without damping, the energy drift."""
    import numpy as np

    model = trajectory.model
    values = {s.name: v for s, v in model.parameter_values.items()}
    m = values["m"]
    n = len(model.automata) + 1
    p = np.column_stack([trajectory.state(f"p{i}") for i in range(1, n + 1)])
    momentum = p.sum(axis=1)
    parts = [f"momentum drift {np.max(np.abs(momentum - momentum[0])):.2e} N·s"]
    if "k" in values:
        if "b" not in values:
            q = np.column_stack([trajectory.state(f"q{i}") for i in range(1, n)])
            energy = 0.5 * np.sum(p**2, axis=1) / m + 0.5 * values["k"] * np.sum(q**2, axis=1)
            parts.append(f"energy drift {np.max(np.abs(energy - energy[0])):.2e} J")
    elif values["e"] == 1.0 and trajectory.events:
        v0 = p[0, 0] / m
        gaps = np.diff([trajectory.state(f"pos{i}")[0] for i in range(2, n + 1)]) - 2 * values["r"]
        if np.all(np.abs(gaps) < 1e-12) and np.all(p[0, 1:] == 0) and trajectory.events[0].t > trajectory.t[0]:
            expected = np.zeros(n)
            expected[-1] = v0
            parts.append(f"final velocities {np.max(np.abs(p[-1] / m - expected)):.2e} m/s vs (0, …, 0, v0)")
    return "; ".join(parts)
