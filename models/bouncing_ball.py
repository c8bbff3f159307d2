"""A ball bouncing on a floor, with Newton's restitution and a resting rule.

Bond graph (power directions by arrows)::

    Se: −m·g ──► 1_v ──► I: m          (p = m v, y = ∫ v dt)
                  │
                  ▼
               0_floor (controlled) ──► Sf: 0     (the floor does not move)

The controlled 0-junction ``floor`` is off in flight (no force) and on in
contact (the ball's velocity equals the floor's, 0).

Automaton ``contact`` (states: ``flight``, ``impact`` with restitution ``e``,
``rest``):

* ``flight → rest``   when ``y <= 0 and v < 0 and -v <= v_rest`` (a priori:
  an impact too slow to bounce, time-scale abstraction of a soft landing);
* ``flight → impact`` when ``y <= 0 and v < 0`` (a priori: the collision is
  seen on the velocity before it);
* ``impact → flight`` when ``v >= 0`` (a priori, on the state after the
  jump ``v⁺ = −e·v``: the impact is a pinnacle).

``rest`` keeps the floor on: the ball lies still.  ``v_rest = 0`` removes the
rule, and the bounces then accumulate (Zeno) at
``t∞ = t₁ (1 + e)/(1 − e)``, ``t₁ = sqrt(2 y0/g)`` (4.0637 s for the defaults).

Sign conventions: ``y`` [m] up from the floor, ``v`` [m/s] up.
Signals: ``y``, ``v``.

Valid range (exercised by ``tests/models/test_model_ranges.py``): ``0 <= e <= 1``,
``y0 > 0``, ``m > 0``, ``g > 0`` over orders of magnitude (tested ``y0`` from
1e-4 to 1e4 m, ``m`` from 1e-6 to 1e6 kg, ``g`` from 1.62 to 274 m/s²).  With
``v_rest > 0`` the ball bounces while it lands faster than ``v_rest`` (a
plastic ``e = 0`` impact leaves it on the floor, and the rest event follows at
the same time) and then lies still until ``t_end``.  With ``v_rest = 0`` and
``e < 1`` the bounces accumulate at ``t∞``: a run past ``t∞`` raises
:class:`~switching.ZenoError` (its ``accumulation_time`` is ``t∞``), or ends
there with ``on_zeno="stop"``; ``e = 1`` bounces for ever.
"""

from __future__ import annotations

import sympy as sp

from bondgraph import BondGraph, I, One, Se, Sf, Zero
from switching import Automaton, HybridModel

from ._common import Range, annotated, merged, nonnegative, positive

__all__ = ["build", "DEFAULTS", "RUN", "SIGNALS", "UNITS"]

DEFAULTS = {"m": 1.0, "g": 9.81, "e": 0.8, "y0": 1.0, "v0": 0.0, "v_rest": 0.0}
#: physical ranges: a value outside gives a PhysicalRangeWarning
RANGES = {
    "m": positive("a mass"),
    "g": positive("gravity pulling the ball to the floor"),
    "e": Range("a restitution coefficient", 0.0, 1.0),
    "y0": nonnegative("a height above the floor"),
    "v_rest": nonnegative("a resting threshold speed"),
}
#: a meaningful default run (used by ``hbg run``)
RUN = {"t_end": 2.5, "rtol": 1e-8}
#: the unit of each parameter, state and signal (shown on plots, kept in model files)
UNITS = {"m": "kg", "g": "m/s²", "e": "1", "v_rest": "m/s", "y0": "m", "v0": "m/s",
         "p": "N·s", "y": "m", "v": "m/s"}

SIGNALS = ("y", "v")


def build(**parameters) -> HybridModel:
    """The bouncing ball with ``DEFAULTS`` overridden by ``parameters``."""
    p = merged(DEFAULTS, parameters, RANGES, "bouncing_ball")
    g = BondGraph("bouncing_ball")
    v = g.add(One("v"))
    g.connect(Se("gravity", -sp.Symbol("m") * sp.Symbol("g")), v)
    g.connect(v, I("ball", "m", state="p"))
    g.displacement("y", of=v)
    floor = g.add(Zero("floor", controlled=True))
    g.connect(v, floor)
    g.connect(floor, Sf("ground", 0))
    contact = Automaton(
        "contact",
        {"flight": {"floor": False}, "impact": {"floor": True}, "rest": {"floor": True}},
        initial="flight",
        restitution={"impact": "e"},
    )
    contact.add_transition("flight", "rest", "y <= 0 and v < 0 and -v <= v_rest", "a priori")
    contact.add_transition("flight", "impact", "y <= 0 and v < 0", "a priori")
    contact.add_transition("impact", "flight", "v >= 0", "a priori")
    model_parameters = {k: p[k] for k in ("m", "g", "e", "v_rest", "y0", "v0")}
    return HybridModel(
        g,
        [contact],
        model_parameters,
        initial_state={"y": "y0", "p": "m*v0"},
        signals={"v": "p/m"},
        name="bouncing_ball",
        **annotated(UNITS, RANGES, DEFAULTS, model_parameters),
    )


def error_estimate(trajectory) -> str:
    """Largest error of the bounce times against the closed form (flight times
    ``t1 = sqrt(2 y0/g)`` then ``2 e^k v1/g``, from rest at ``y0``)."""
    import math

    model = trajectory.model
    values = {s.name: v for s, v in model.parameter_values.items()}
    g, e = values["g"], values["e"]
    y0 = float(trajectory.state("y")[0])
    v0 = float(trajectory.state("p")[0]) / values["m"]
    if v0 != 0 or not len(trajectory.events):
        return "n/a (closed form for a release from rest)"
    t1 = math.sqrt(2 * y0 / g)
    exact, t, v = [], t1, g * t1
    for k in range(len(trajectory.events)):
        exact.append(t)
        t += 2 * e ** (k + 1) * v / g
    errors = [abs(a - b) for a, b in zip(trajectory.event_times, exact)]
    return f"{max(errors):.2e} s on {len(errors)} bounce times (closed form)"
