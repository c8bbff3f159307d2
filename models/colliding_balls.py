"""Two balls colliding on a line (the paper's Fig. 10, section 3.1.2).

Bond graph (power directions by arrows; no external forces)::

    I: m1 ◄── 1_v1 ──► 0_contact (controlled) ──► 1_v2 ──► I: m2
    (p1, pos1 = ∫ v1 dt)                          (p2, pos2 = ∫ v2 dt)

The controlled 0-junction ``contact`` carries the contact force (its common
effort).  Off (``free``) it imposes zero force: each ball keeps its momentum.
On (``collide``) it is an ordinary 0-junction: its flows balance, so the two
velocities are equal and one momentum becomes dependent.  Entering it, the
jump map (conservation of state) conserves the total momentum and equalises
the velocities (the plastic impact); the restitution ``e`` on the
``collide`` state turns this into Newton's rule
``x⁺ = x + (1 + e)(g(x) − x)``:

* momentum is conserved: ``m1 v1⁺ + m2 v2⁺ = m1 v1 + m2 v2``;
* ``v2⁺ − v1⁺ = −e (v2 − v1)`` (the paper's Eqs. 7-9);
* kinetic energy lost ``ΔE = (1 − e²)/2 · m1 m2/(m1 + m2) · (v1 − v2)²``.

Automaton ``contact`` (states ``free``, ``collide`` with restitution ``e``):

* ``free → collide`` when ``x2 - x1 <= r1 + r2 and v1 - v2 > v_th``
  (**a priori**: a collision is a time-scale abstraction — the elastic
  compression and release of the balls is collapsed into a point in time —
  so it is judged on the state *before* the impact: the balls touch and
  approach each other faster than ``v_th``);
* ``collide → free`` when ``v1 <= v2`` (**a priori**, evaluated on the state
  after the Newton jump: ``collide`` is left at once, it is a *pinnacle*).

Why ``v_th`` (the paper's section 4.2): without the approach condition the
balls still overlap (``x2 - x1 <= r1 + r2``) right after the jump, so
``free → collide`` would fire again at the same instant, a loop of
instantaneous mode changes (divergence of time).  Requiring the balls to
approach faster than ``v_th >= 0`` makes the state after the jump
(separating, or moving together when ``e = 0``) belong to ``free`` only;
``v_th → 0`` recovers the plain condition ``v1 > v2``.  Impacts slower than
``v_th`` are not collisions: the balls pass into one another without
interacting (choose ``v_th`` below every speed of interest).

Sign conventions and units: positions ``x1``, ``x2`` [m] of the ball centres
along the line, ball 2 to the right of ball 1 (``x2 > x1``); velocities
``v1``, ``v2`` [m/s] positive to the right; momenta ``p1``, ``p2`` [N·s];
masses ``m1``, ``m2`` [kg]; radii ``r1``, ``r2`` [m]; ``v_th`` [m/s]; ``e``
dimensionless in [0, 1].

States: ``p1``, ``p2`` (momenta) and ``pos1``, ``pos2`` (the integrated
displacements, i.e. the positions).
Signals: ``x1``, ``x2`` (positions, = ``pos1``, ``pos2``), ``v1``, ``v2``
(velocities ``p/m``).

The defaults: ball 1 (1 kg) at 0 m moving right at 1 m/s, ball 2 (2 kg) at
1 m moving left at 0.5 m/s, radii 0.1 m: they touch at t = 0.8/1.5 ≈ 0.533 s
and collide once with ``e = 0.8``.

Valid range (exercised by ``tests/models/test_model_ranges.py``): ``0 <= e <= 1``,
positive masses and radii, ``v_th >= 0`` (``0`` included: a plastic impact
leaves the balls moving together, which ``v1 > v2`` does not re-trigger);
tested mass ratios from 1e-3 to 1e3 and lengths and speeds scaled from 1e-3
to 1e3.  Two balls on a line meet at most once: one instant, then free flight
to ``t_end``; no error is documented in this range.
"""

from __future__ import annotations

from bondgraph import BondGraph, I, One, Zero
from switching import Automaton, HybridModel

from ._common import Range, annotated, merged, nonnegative, positive

__all__ = ["build", "DEFAULTS", "RUN", "SIGNALS", "error_estimate", "UNITS"]

DEFAULTS = {
    "m1": 1.0,
    "m2": 2.0,
    "e": 0.8,
    "v_th": 1e-6,
    "r1": 0.1,
    "r2": 0.1,
    "x1_0": 0.0,
    "x2_0": 1.0,
    "v1_0": 1.0,
    "v2_0": -0.5,
}
#: physical ranges: a value outside gives a PhysicalRangeWarning
RANGES = {
    "m1": positive("a mass"),
    "m2": positive("a mass"),
    "e": Range("a restitution coefficient", 0.0, 1.0),
    "v_th": nonnegative("a separation threshold speed"),
    "r1": nonnegative("a radius"),
    "r2": nonnegative("a radius"),
}
#: a meaningful default run (used by ``hbg run``): one collision at t ≈ 0.533 s
RUN = {"t_end": 1.5, "rtol": 1e-9, "atol": 1e-12}
#: the unit of each parameter, state and signal (shown on plots, kept in model files)
UNITS = {"m1": "kg", "m2": "kg", "e": "1", "v_th": "m/s", "r1": "m", "r2": "m", "x1_0": "m", "x2_0": "m",
         "v1_0": "m/s", "v2_0": "m/s", "p1": "N·s", "p2": "N·s", "pos1": "m", "pos2": "m", "v1": "m/s",
         "v2": "m/s"}

SIGNALS = ("x1", "x2", "v1", "v2")


def build(**parameters) -> HybridModel:
    """Two colliding balls with ``DEFAULTS`` overridden by ``parameters``."""
    p = merged(DEFAULTS, parameters, RANGES, "colliding_balls")
    g = BondGraph("colliding_balls")
    for i in (1, 2):
        v = g.add(One(f"v{i}"))
        g.connect(v, I(f"ball{i}", f"m{i}", state=f"p{i}"))
        g.displacement(f"pos{i}", of=v)
    contact_junction = g.add(Zero("contact", controlled=True))
    g.connect("v1", contact_junction, name="push1")
    g.connect(contact_junction, "v2", name="push2")
    contact = Automaton(
        "contact",
        {"free": {"contact": False}, "collide": {"contact": True}},
        initial="free",
        restitution={"collide": "e"},
    )
    contact.add_transition("free", "collide", "x2 - x1 <= r1 + r2 and v1 - v2 > v_th", "a priori")
    contact.add_transition("collide", "free", "v1 <= v2", "a priori")
    model_parameters = {k: p[k] for k in ("m1", "m2", "e", "v_th", "r1", "r2", "x1_0", "x2_0", "v1_0", "v2_0")}
    return HybridModel(
        g,
        [contact],
        model_parameters,
        initial_state={
            "pos1": "x1_0",
            "pos2": "x2_0",
            "p1": "m1*v1_0",
            "p2": "m2*v2_0",
        },
        signals={"x1": "pos1", "x2": "pos2", "v1": "p1/m1", "v2": "p2/m2"},
        name="colliding_balls",
        **annotated(UNITS, RANGES, DEFAULTS, model_parameters),
    )


def error_estimate(trajectory) -> str:
    """Largest error of the collision time and the velocities after it against
    the closed form (free flight, then Newton's rule with momentum)."""
    model = trajectory.model
    values = {s.name: v for s, v in model.parameter_values.items()}
    m1, m2, e, v_th = values["m1"], values["m2"], values["e"], values["v_th"]
    x1, x2 = trajectory.signal("x1")[0], trajectory.signal("x2")[0]
    v1, v2 = trajectory.signal("v1")[0], trajectory.signal("v2")[0]
    distance = x2 - x1 - values["r1"] - values["r2"]
    if distance < 0 or v1 - v2 <= v_th:
        return f"n/a (closed form needs approaching, separated balls); {len(trajectory.events)} collisions"
    t_c = trajectory.t[0] + distance / (v1 - v2)
    if t_c > trajectory.t[-1]:
        return "no collision before t_end (as the closed form says)" if not trajectory.events else "collision found too early"
    if len(trajectory.events) != 1:
        return f"expected one collision, found {len(trajectory.events)}"
    u1 = ((m1 - e * m2) * v1 + (1 + e) * m2 * v2) / (m1 + m2)
    u2 = ((m2 - e * m1) * v2 + (1 + e) * m1 * v1) / (m1 + m2)
    k = trajectory.event_index[0]
    dv = max(abs(trajectory.signal("v1")[k] - u1), abs(trajectory.signal("v2")[k] - u2))
    return f"collision time {abs(trajectory.events[0].t - t_c):.2e} s, velocities after {dv:.2e} m/s (closed form)"
