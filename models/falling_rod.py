"""A thin rod falling onto a floor with Coulomb friction (the paper's Figs. 7–9, 19–20).

The rod (mass ``m``, inertia ``J`` about its centre) is
:func:`models.components.rigid_planar_body`; its tip ``A`` is at distance
``l`` from the centre, at ``r_A = r − l (cos θ, sin θ)`` (the paper's
convention with ``l → −l``: its ``l = −0.1`` is our ``l = 0.1``).

Bond graph (the rod's ports ``tip_x``, ``tip_y`` carry the tip velocity)::

    rod.tip_y ──► 0_cy (controlled: contact) ──► Sf: 0            bond "normal"

    rod.tip_x ──► 1_A ──► 0_cx (controlled: contact) ──► 0_stick (controlled: friction) ──► Sf: 0
          bond     └────► Se: σ·μ·N      (Coulomb friction, σ set by the friction state)
       "tangent"

An off controlled 0-junction carries no force.  In contact the floor holds
the tip's vertical velocity at zero; stuck, ``0_cx`` and ``0_stick`` hold its
horizontal velocity too; sliding, a Coulomb force ``−σ μ N`` opposes the
tip's motion, with the mode-dependent constant ``σ`` = +1 (sliding towards
+x), −1 (towards −x), 0 (stuck).  ``N`` is the normal force, itself a bond
variable: the friction source is modulated by it (an algebraic loop, solved
symbolically); in the air ``N = 0`` and so is the friction.

Forces on the rod: ``normal_force N = −e_normal`` (up), ``friction_force
F = −e_tangent`` (along +x).

Automata and guards:

``contact``
    free → contact   ``tip_y <= 0 and (tip_vy < 0 or tip_vy <= 0 and N_contact > 0)``
                     a priori — a collision (time-scale abstraction), judged on
                     the velocity before it; ``tip_vy < 0`` keeps a separating
                     rod from re-colliding (the paper's section 4.2 fix); a tip
                     at rest on the floor comes into contact when the floor
                     would have to push it (``N_contact``: the normal force of
                     the contact mode, friction as it is), i.e. when it would
                     otherwise fall through: after a sticking impact whose
                     stuck mode would need a pulling floor and more friction
                     than the cone allows, both automata step (to free,
                     sliding) and this brings the tip back to sliding contact;
    contact → free   ``normal_force <= 0``          a posteriori — the floor
                     can only push (parameter abstraction of a stiff floor).
``friction``
    stuck → slide_pos / slide_neg   ``F < −μN`` / ``F > μN``   a posteriori —
                     Coulomb's law judged on the forces the stuck state would
                     need, impulses included (Lemma 5.3: pulses dominate);
    slide_± → stuck  ``|tip_vx| <= v_th and |F_stick| < μ N_stick``  a posteriori
                     — the paper's Eq. (25) ``|v⁺_Ax| ≤ v_th``, judged on the state
                     the sliding mode jumps to (entering it at an impact, the
                     tip's velocity after the frictionless impact, not the one
                     before), plus its section 5.6 fix: stick only if the forces
                     of the stuck mode, computed from ``h(g_stuck(x))``
                     (``InMode`` signals ``F_stick``, ``N_stick``), allow it;
                     otherwise a slide → stuck → slide loop would stop time;
                     strictly inside the cone, as the slip out of stuck needs
                     strictly outside it: on the cone's edge (within the
                     comparison band) the tip keeps what it does, so a slip
                     located in flow is not undone at once; and only a floor
                     that pushes can hold the tip (in the air both forces are
                     0 and ``<=`` would be vacuous).  The stick's plastic jump
                     (the remaining ``|tip_vx| <= v_th`` set to 0) abstracts
                     the last of a continuous deceleration, not a collision:
                     the transition is marked ``pulses=False``, so the stuck
                     mode judges its finite forces, not the pulses of that
                     jump (which would exceed the cone and undo the stick);
    slide_± → slide_∓  the tip velocity changes sign (a posteriori);
    slide_± → stuck  ``tip_y > y_lift and normal_force <= 0`` a priori: in the
                     air the friction automaton returns to its initial state
                     (the floor not pushing: in contact the tip's height drifts
                     with the integration error, since the contact holds its
                     velocity, and may pass ``y_lift``).

Impacts are plastic (no restitution).  Friction during an impact, option
``impact_law``:

``"paper"`` (default)
    the friction force of a sliding tip stays finite, as in the paper (its
    tiny μ values): the impact carries no tangential impulse (jump law
    ``"conservation"``);
``"newton-coulomb"``
    the friction source, modulated by the normal force, carries a pulse with
    it: a sliding impact with normal impulse ``P_n`` gets the tangential
    impulse ``P_t = −σ μ P_n`` (jump law ``"impulse balance"``).  With the
    tip velocity ``v_A`` before the impact,
    ``P_n = −v_Ay / (1/m + l² cos θ (cos θ + σ μ sin θ)/J)``.  A stuck impact
    is the same under both laws.

The paper does not print ``m`` and ``J``; ``m = 1 kg``, ``J = 1 kg·m²``
reproduce its Figs. 19–20: at impact the stuck mode needs a tangential
impulse ``|P_x| = 0.0049 P_n``, so ``μ = 0.005`` sticks and smaller ``μ``
slide.  ``mu`` sweep (defaults θ0 = 0.862, y0 = 0.23, l = 0.1, v_th = 0.0015): small
μ (0.002, 0.004) slide right after impact — the stuck mode is passed as
*mythical*; large μ (0.005) sticks.  A long rod (``l = 10``, ``y0 = 23``)
slides for a point in time and lifts off (Fig. 20).

Units: kg, m, s, rad, N.  Signals: ``theta``, ``omega``, ``vx``, ``vy``,
``x_cm``, ``y_cm``, ``tip_x``, ``tip_y``, ``tip_vx``, ``tip_vy``,
``normal_force``, ``friction_force`` (and ``F_stick``, ``N_stick``, ``N_contact``).

Valid range (exercised by ``tests/models/test_model_ranges.py``): the documented
points above, each run to t = 2 s (defaults, ``mu = 0.002``, ``mu = 0.004``,
the long rod ``l = 10, y0 = 23, mu = 0.002``, and ``mu = 0.002`` with
``impact_law="newton-coulomb"``); the slow grid takes ``mu`` from 1e-4 to 1
and ``l`` from 0.1 to 10 m (``y0 = 2.3 l``, ``theta0`` at its default) under
both impact laws.  Masses, lengths and ``g`` may be given in any consistent
units (``tests/switching/simulate/test_units.py``; scale ``v_th`` and ``y_lift`` with the
lengths).  No error is documented in this range: every
:class:`~switching.DivergenceOfTimeError` there is a defect.  Beyond it,
``tests/models/test_rod_reference.py`` runs a uniform rod (``J = m (2l)²/12``) over
``theta0`` 0.2 to 1.4, ``mu`` 0.01 to 5, ``l`` 0.1 and 0.5 m and both impact
laws to the time the far end reaches the floor (which the model does not
see), against an independent simulation: the same modes and states there.
Painlevé's singularity: sliding with direction ``σ``, the normal force is
``(…)/k_σ`` with ``k_σ = 1/m + l² cos θ (cos θ + σ μ sin θ)/J``, which
vanishes when ``cos θ + σ μ sin θ`` is negative enough (friction large
against the rod's inclination); as a sliding rod turns towards it the force
grows without bound and the run stops with :class:`~switching.StepSizeError`
(the rigid model has no solution there: the paradox).  In the slow grid the
long rod ``l = 10`` with ``mu = 1`` reaches it.
"""

from __future__ import annotations

import math

import sympy as sp

from bondgraph import BondGraph, One, Se, Sf, Zero
from switching import Automaton, HybridModel, InMode, ModelDefinitionError

from ._common import annotated, merged, nonnegative, positive
from .components import rigid_planar_body

__all__ = ["build", "DEFAULTS", "IMPACT_LAWS", "RUN", "SIGNALS", "UNITS"]

DEFAULTS = {
    "m": 1.0,
    "l": 0.1,
    "J": 1.0,
    "g": 9.81,
    "mu": 0.005,
    "v_th": 0.0015,
    "theta0": 0.862,
    "y0": 0.23,
    "x0": 0.0,
    "y_lift": 1e-9,
    "impact_law": "paper",
}
#: physical ranges: a value outside gives a PhysicalRangeWarning
RANGES = {
    "m": positive("a mass"),
    "l": positive("a length"),
    "J": positive("a moment of inertia"),
    "g": positive("gravity pulling the rod to the floor"),
    "mu": nonnegative("a friction coefficient"),
    "v_th": nonnegative("a sticking threshold speed"),
    "y_lift": nonnegative("a lift-off height"),
}
RUN = {"t_end": 0.5, "rtol": 1e-9, "atol": 1e-12}
#: the unit of each parameter, state and signal (shown on plots, kept in model files)
UNITS = {"m": "kg", "J": "kg·m²", "l": "m", "g": "m/s²", "mu": "1", "v_th": "m/s", "y_lift": "m",
         "theta0": "rad", "y0": "m", "x0": "m", "rod/p_x": "N·s", "rod/p_y": "N·s", "rod/p_J": "N·m·s",
         "rod/x": "m", "rod/y": "m", "rod/theta": "rad", "omega": "rad/s", "vx": "m/s", "vy": "m/s",
         "tip_x": "m", "tip_y": "m", "tip_vx": "m/s", "tip_vy": "m/s", "normal_force": "N",
         "friction_force": "N", "F_stick": "N", "N_stick": "N", "N_contact": "N"}

SIGNALS = (
    "theta",
    "omega",
    "vx",
    "vy",
    "x_cm",
    "y_cm",
    "tip_x",
    "tip_y",
    "tip_vx",
    "tip_vy",
    "normal_force",
    "friction_force",
)


IMPACT_LAWS = {"paper": "conservation", "newton-coulomb": "impulse balance"}


def build(**parameters) -> HybridModel:
    """The falling rod with ``DEFAULTS`` overridden by ``parameters``.

    ``y0`` is the height of the centre, ``theta0`` the initial angle; the rod
    starts at rest.  ``impact_law``: ``"paper"`` (no tangential impulse at an
    impact, the default) or ``"newton-coulomb"`` (see the module docstring)."""
    p = merged(DEFAULTS, parameters, RANGES, "falling_rod")
    if p["impact_law"] not in IMPACT_LAWS:
        raise ModelDefinitionError(f"unknown impact_law {p['impact_law']!r}; choose one of: {', '.join(IMPACT_LAWS)}")
    mu = sp.Symbol("mu")

    scene = BondGraph("falling_rod")
    rod = scene.add_submodel(rigid_planar_body(), "rod", share=["m", "J", "l", "g"])
    cy = scene.add(Zero("cy", controlled=True))
    scene.connect(rod.port("tip_y"), cy, name="normal")
    scene.connect(cy, Sf("floor_y", 0))
    normal = -scene.effort("normal")

    hub = scene.add(One("A"))
    scene.connect(rod.port("tip_x"), hub, name="tangent")
    cx, stick = scene.add(Zero("cx", controlled=True)), scene.add(Zero("stick", controlled=True))
    scene.connect(hub, cx)
    scene.connect(cx, stick)
    scene.connect(stick, Sf("floor_x", 0))
    scene.connect(hub, Se("coulomb", sp.Symbol("sigma") * mu * normal))

    contact = Automaton(
        "contact", {"free": {"cy": False, "cx": False}, "contact": {"cy": True, "cx": True}}, "free"
    )
    contact.add_transition("free", "contact", "tip_y <= 0 and (tip_vy < 0 or tip_vy <= 0 and N_contact > 0)",
                           "a priori")
    contact.add_transition("contact", "free", "normal_force <= 0", "a posteriori")

    friction = Automaton(
        "friction",
        {"stuck": {"stick": True}, "slide_pos": {"stick": False}, "slide_neg": {"stick": False}},
        "stuck",
        values={"stuck": {"sigma": 0}, "slide_pos": {"sigma": 1}, "slide_neg": {"sigma": -1}},
    )
    friction.add_transition("stuck", "slide_pos", "friction_force < -mu*normal_force", "a posteriori")
    friction.add_transition("stuck", "slide_neg", "friction_force > mu*normal_force", "a posteriori")
    for state, sign in (("slide_pos", 1), ("slide_neg", -1)):
        friction.add_transition(state, "stuck", "tip_y > y_lift and normal_force <= 0", "a priori")
        near = "tip_vx <= v_th" if sign > 0 else "tip_vx >= -v_th"
        friction.add_transition(state, "stuck", f"{near} and abs(F_stick) < mu*N_stick",
                                "a posteriori", pulses=False)
        other = "slide_neg" if sign > 0 else "slide_pos"
        friction.add_transition(state, other, "tip_vx < 0" if sign > 0 else "tip_vx > 0", "a posteriori")

    signals = {
        "theta": "rod/theta",
        "omega": "rod/p_J/J",
        "vx": "rod/p_x/m",
        "vy": "rod/p_y/m",
        "x_cm": "rod/x",
        "y_cm": "rod/y",
        "tip_x": "rod/x - l*cos(rod/theta)",
        "tip_y": "rod/y - l*sin(rod/theta)",
        "tip_vx": "vx + l*sin(rod/theta)*omega",
        "tip_vy": "vy - l*cos(rod/theta)*omega",
        "normal_force": "-e_normal",
        "friction_force": "-e_tangent",
        "F_stick": InMode("-e_tangent", friction="stuck"),
        "N_stick": InMode("-e_normal", friction="stuck"),
        "N_contact": InMode("-e_normal", contact="contact"),
    }
    model_parameters = {k: p[k] for k in ("m", "J", "l", "g", "mu", "v_th", "y_lift", "theta0", "y0", "x0")}
    return HybridModel(
        scene,
        [contact, friction],
        model_parameters,
        initial_state={"rod/theta": "theta0", "rod/y": "y0", "rod/x": "x0"},
        signals=signals,
        name="falling_rod",
        **annotated(UNITS, RANGES, DEFAULTS, model_parameters),
        jump_law=IMPACT_LAWS[p["impact_law"]],
    )


def impact_time(y0: float, theta0: float, l: float, g: float = 9.81) -> float:
    """When the tip of a rod released at rest reaches the floor: ``sqrt(2 (y0 − l sin θ0)/g)``."""
    return math.sqrt(2 * (y0 - l * math.sin(theta0)) / g)
