"""A rimless wheel rolling down a slope: plastic impact of the next spoke.

The wheel is a point mass ``m`` at the hub on massless spokes of length
``l``, ``2α`` apart (``π/α`` spokes), on a slope of angle ``γ`` under
gravity ``g``.  In stance the hub turns about the planted foot (an inverted
pendulum); when the stance spoke is ``α`` past the slope normal the next
spoke touches the slope, the impact is plastic on the new foot and the old
foot leaves the ground.

Coordinates (the slope frame): ``x`` along the slope, downhill; ``y``
normal to it, up.  The *stance angle* ``θ`` is the angle of the planted
spoke from the slope normal, positive when the hub is downhill of the foot:
the hub is at ``foot + l (sin θ, cos θ)``, above the foot in the true
vertical at ``θ = −γ``.

Bond graph (power directions by arrows; ``σ = ±1`` the stance parity, a
value of the automaton's state; ``ψ`` the position state, below)::

    Se: m g sin γ ──► 1_vx ──► I: m  (p_x)       Se: −m g cos γ ──► 1_vy ──► I: m  (p_y)
                       │  │                                           │
                       │  └──► MTF: σ sin ψ ──► 0_leg ◄── MTF: cos ψ ◄─┘
                       │                         │ bond "radial"
                       │                         ▼
                       │                       Sf: 0   (ground: the foot is pinned)
                       └──► MTF: σ/(l cos ψ) ──► Se: 0  (free_spin; ψ = ∫ its flow dt)

* The hub is a planar point mass: momenta ``p_x``, ``p_y`` [N·s], gravity
  ``m g (sin γ, −cos γ)`` as two effort sources.
* The planted foot is a *radial* velocity constraint: ``0_leg`` sums
  ``u · v``, the rate at which the planted spoke would lengthen, with
  ``u = (σ sin ψ, cos ψ) = (sin θ, cos θ)`` the unit vector from the foot to
  the hub, and ``Sf: 0`` holds it at 0 (the radial momentum is dependent).
  A massless spoke pinned at its foot and free to turn there pushes only
  along itself (no torque acts on a massless wheel), so the constraint is
  radial alone; the effort on bond ``radial`` is the spoke's push:
  ``normal_force = −e_radial`` [N], positive when the ground pushes the hub.
* ``ψ`` [rad] is the one position state: ``dψ/dt`` is the flow into the
  zero-effort source ``free_spin``, ``σ v_x/(l cos ψ)``, which on the
  stance constraint ``v = l ω (cos θ, −sin θ)`` is ``σ ω``; the zero effort
  means this bookkeeping exerts no force (``cos ψ >= cos α > 0``).

**The modelling choice.** The state space never changes size and
positions cannot jump at an instant (conservation of state jumps momenta
only, and moduli are evaluated at positions that do not move), so the stance
angle ``θ`` measured from the *current* foot, which steps from ``+α`` to
``−α`` at every impact, cannot be a state, nor can a hub position
re-referenced to the new foot.  Absolute foot positions held while planted
would be honest but grow without bound down the slope: no periodic orbit.
The model keeps ``ψ = σ θ``, the stance angle with the sign of the stance
parity (``σ = +1`` on the even spokes, ``−1`` on the odd ones): ``ψ`` is
continuous at an impact (``θ⁻ = α`` on one foot, ``θ⁺ = −α`` on the next,
``ψ = ±α`` on both sides) and runs back and forth between ``−α`` and ``α``.
Flipping ``σ`` reflects the contact geometry about the hub's slope normal,
which carries the old foot exactly onto the new one (the next spoke touches
at ``hub + l (sin α, −cos α)``, the mirror of the old foot at ``hub + l
(−sin α, −cos α)``) — and onto the previous spoke when the wheel rolls back
(``θ = −α``).  The leg length is ``l`` by construction (no drift of a
holonomic constraint), and the wheel's progress down the slope, ``2 l sin α``
a stride, is not a state.  One contact switched by ``σ``, rather than two
alternating feet each on a controlled junction: two radial constraints on the
same two velocities close a loop of the junction structure (a shipped model's
is a tree, drawn bond by bond), and their double support would only say what
the impulses below say in closed form.  A hub inertia is left out: with a
rotational inertia ``J`` the impact law becomes ``ω⁺/ω⁻ = (m l² cos 2α +
J)/(m l² + J)`` and the foot would hold both velocity components.

Automaton ``stance`` (states ``even`` with ``sigma = 1``, initial, and
``odd`` with ``sigma = −1``; neither sets a junction):

* ``even → odd`` and ``odd → even`` when ``psi >= alpha and dpsi > 0 or psi
  <= -alpha and dpsi < 0`` — **a priori**: the touchdown of the next spoke
  is a collision (time-scale abstraction of a compliant contact), judged on
  the state before it: the stance angle reaches ``±α`` moving outward
  (forward at ``θ = α`` with ``ω > 0``, backward at ``θ = −α`` with
  ``ω < 0``); the ``dpsi`` condition keeps the new stance, which starts on
  that boundary moving inward, from firing again.

The jump into the new stance is conservation of state: the hub's momentum
along the free direction (the new spoke's normal) is conserved and the
new radial velocity vanishes, ``v⁺ = v⁻ − (u_new · v⁻) u_new`` (the mass
metric is ``m I``).  With ``v⁻ = l ω⁻ (cos α, −sin α)`` and ``u_new = (−sin
α, cos α)`` this is the plastic impact law

    ω⁺ = cos 2α · ω⁻     (angular momentum about the new foot conserved),

with the impulse ``m l ω⁻ sin 2α`` along the new spoke.  The old foot leaves
the ground: were both feet held (double support, the hub stopped), the
impulses through the spokes would be ``−m l ω⁻ cot 2α`` (old: a pull for
``α < π/4``) and ``m l ω⁻ / sin 2α`` (new) — the unilateral ground cannot
give the pull (the a posteriori judgement, in closed form).
``tests/models/test_model_rimless_wheel.py`` derives these impulses from a
two-contact bond graph (each foot its controlled junction and automaton,
released a posteriori when its push would be ``<= 0``) and checks that it
walks exactly as this model, double support passed as a mythical mode.  In flow the foot is held: a
spoke that would pull in stance would make the wheel hop, and a massless
wheel in the air has no defined orientation, so ``build`` refuses such
parameters (below).

Stance (the closed forms the tests check).  The energy about the foot is
``½ m l² ω² + m g l cos(θ + γ)``, so ``θ̈ = (g/l) sin(θ + γ)`` and, from
``θ = −α`` to ``θ = α``,

    ω⁻² = ω⁺² + (2g/l) (cos(γ − α) − cos(γ + α)) = ω⁺² + (4g/l) sin α sin γ.

With ``E = ω⁺²`` the stride map is ``E_{k+1} = cos² 2α (E_k + 4 (g/l) sin α
sin γ)``, affine with slope ``cos² 2α``: its fixed point
``ω⁻*² = 4 (g/l) sin α sin γ / (1 − cos² 2α)`` attracts every gait that keeps
rolling; it exists when the hub passes the vertical at that speed, ``γ >= α`` or
``ω⁺*² > (2g/l)(1 − cos(α − γ))`` (otherwise every wheel comes to rest).
The stance time is ``∫_{−α}^{α} dθ / ω(θ)``.  The normal force is
``N = m (g cos(θ + γ) − l ω²) = m (3 g cos(θ + γ) − l C)`` with ``C = ω² +
(2g/l) cos(θ + γ)`` constant in a stance; its least value is at ``θ = α``.

The gait as a periodic orbit: ``periodic_orbit(model, section="stance: even
-> odd", period=2.0)`` (``hbg orbit rimless-wheel --section
"stance:even->odd" --period 2``).  The parity flips at every impact, so the
state ``(p_x, p_y, psi)`` returns after *two* strides (the period is twice
the stance time); the monodromy's multipliers are 1 (trivial, along the
flow), ``cos⁴ 2α`` (the stride map's slope, twice) and 0 (the radial
momentum, which the stance constraint removes at once).  ``cos⁴ 2α`` does not
depend on the slope: continued in ``γ`` (``continue_orbit(build, "gamma",
...)``, or ``hbg orbit --continue gamma=a:b:n``, which build every point and
so check it for lift-off; parameters changed in place on a built model are
not checked) the gait neither folds nor flips.

Sign conventions and units: kg, m, s, rad, N.  ``theta`` (``θ``) and
``omega`` (``ω = dθ/dt``) are the planted spoke's angle and rate (positive
rolling downhill).

Parameters: ``m`` [kg], ``l`` [m], ``g`` [m/s²], ``alpha`` [rad] (half the
angle between spokes, default ``π/8``: eight spokes), ``gamma`` [rad] (the
slope), ``phase0`` (the initial stance angle as a fraction of ``α``, on an
even spoke: ``θ0 = phase0·α``, default −1: just after an impact), ``omega0``
[rad/s] (the initial stance rate; the hub's velocity is tangential).

States: ``p_x``, ``p_y`` [N·s] (slope frame), ``psi`` [rad].  Signals:
``theta``, ``omega``, ``normal_force`` [N], ``hub_x`` (the hub along the
slope from the planted foot, ``l sin θ`` [m]), ``hub_y`` (its height above
the slope, ``l cos θ`` [m]) and ``dpsi`` [rad/s].

Valid range (exercised by ``tests/models/test_model_ranges.py``):
``0 < α < π/4`` (more than four spokes: from ``π/4`` on the old spoke would
push at an impact, and the wheel would stop on two feet, which this model
does not hold), ``|phase0| <= 1`` (beyond, the next spoke would be below
the slope): ``build`` raises :class:`~bondgraph.errors.InvalidGraphError`
outside these; ``0 <= γ < π/2`` (a warning outside); and any ``omega0`` that
keeps the spoke pushing: ``build`` raises
:class:`~bondgraph.errors.ParameterValueError` (naming ``omega0`` or
``gamma``) when ``l · max(C₁, C*) >= 3 g cos(α + γ)`` with ``C₁`` the first
stance's ``C`` and ``C*`` the steady gait's (a sufficient condition for
``N > 0``: ``C`` never exceeds the larger of the two, the stride map being
affine with slope below 1 and a backward impact lowering ``C``).  Tested: ``α`` from π/20
to π/5, ``γ`` from 0.01 to 0.3 rad, ``l`` from 1e-3 to 1e3 m with ``g``
from 1.62 to 274 m/s², started at the steady gait's ``ω⁺*`` (stance times
against quadrature where it rolls, the refusal where it would hop, Zeno where
it rocks).  A wheel
too slow to carry its hub over the vertical (``θ = −γ``) rolls back onto the
previous spoke and rocks between two feet, each impact shrinking ``ω`` by
``cos 2α``: the impacts accumulate (Zeno) and a run past the accumulation
time raises :class:`~switching.ZenoError` (its ``accumulation_time`` is the
sum of the rocking half-swings), or ends there with ``on_zeno="stop"``; so
does a wheel on level ground (``γ = 0``), which always comes to rest.
"""

from __future__ import annotations

import math

import sympy as sp

from bondgraph import TF, BondGraph, I, One, Se, Sf, Zero
from bondgraph.errors import ParameterValueError
from switching import Automaton, HybridModel

from ._common import Range, annotated, merged, positive

__all__ = ["build", "DEFAULTS", "RANGES", "RUN", "SIGNALS", "UNITS", "stance", "fixed_point", "error_estimate"]

DEFAULTS = {
    "m": 1.0,
    "l": 1.0,
    "g": 9.81,
    "alpha": math.pi / 8,
    "gamma": 0.08,
    "phase0": -1.0,
    "omega0": 1.0,
}
#: physical ranges: a value outside gives a PhysicalRangeWarning
RANGES = {
    "m": positive("a mass"),
    "l": positive("a spoke length"),
    "g": positive("gravity pulling the wheel down the slope"),
    "alpha": Range("half the angle between spokes (more than four spokes)", 0.0, math.pi / 4, low_open=True,
                   high_open=True, required=True),
    "gamma": Range("a slope angle (downhill)", 0.0, math.pi / 2, high_open=True),
    "phase0": Range("the initial stance angle over alpha (beyond ±1 the next spoke is below the slope)", -1.0, 1.0,
                    required=True),
}
RUN = {"t_end": 6.0, "rtol": 1e-10, "atol": 1e-12}
SIGNALS = ("theta", "omega", "normal_force", "hub_x", "hub_y")
#: the unit of each parameter, state and signal (shown on plots, kept in model files)
UNITS = {"m": "kg", "l": "m", "g": "m/s²", "alpha": "rad", "gamma": "rad", "phase0": "1", "omega0": "rad/s",
         "p_x": "N·s", "p_y": "N·s", "psi": "rad", "theta": "rad", "omega": "rad/s", "dpsi": "rad/s",
         "normal_force": "N", "hub_x": "m", "hub_y": "m"}

#: the touchdown of the next spoke: the stance angle reaches ±α moving outward (``ψ ψ̇ > 0``)
_TOUCHDOWN = "psi >= alpha and dpsi > 0 or psi <= -alpha and dpsi < 0"


def _hub(graph: BondGraph):
    """The hub as a planar point mass under gravity in the slope frame: 1-junctions ``vx``, ``vy``
    (momenta ``p_x``, ``p_y`` [N·s]; gravity ``m g (sin γ, −cos γ)`` [N])."""
    m, g, gamma = sp.symbols("m g gamma")
    vx, vy = graph.add(One("vx")), graph.add(One("vy"))
    graph.connect(vx, I("I_x", m, state="p_x"))
    graph.connect(vy, I("I_y", m, state="p_y"))
    graph.connect(Se("gravity_x", m * g * sp.sin(gamma)), vx)
    graph.connect(Se("gravity_y", -m * g * sp.cos(gamma)), vy)
    return vx, vy


def _foot(graph: BondGraph, vx, vy, psi, sigma) -> None:
    """The planted spoke: the radial flow ``u · v`` (``u = (σ sin ψ, cos ψ)``, foot → hub) summed at
    ``0_leg`` and held at 0 along bond ``radial`` by ``Sf: 0`` (the foot pinned)."""
    leg = graph.add(Zero("leg"))
    for source, name, modulus in ((vx, "ux", sigma * sp.sin(psi)), (vy, "uy", sp.cos(psi))):
        graph.connect(source, TF(name, modulus))
        graph.connect(name, leg)
    graph.connect(leg, Sf("ground", 0), name="radial")


def _spin(graph: BondGraph, vx, psi, sigma) -> None:
    """``dψ/dt = σ v_x/(l cos ψ)`` as the flow into the zero-effort source ``free_spin``: on the
    stance constraint ``v = l ω (cos θ, −sin θ)`` this is ``σ ω`` (no force on the hub)."""
    graph.connect(vx, TF("spin", sigma / (sp.Symbol("l") * sp.cos(psi))))
    graph.connect("spin", Se("free_spin", 0))
    graph.displacement("psi", of="free_spin")


def _automaton() -> Automaton:
    """``stance``: ``even`` (``σ = +1``, the initial state) and ``odd`` (``σ = −1``), each to the
    other at a touchdown (a priori)."""
    stance = Automaton("stance", {"even": {}, "odd": {}}, "even",
                       values={"even": {"sigma": 1}, "odd": {"sigma": -1}})
    stance.add_transition("even", "odd", _TOUCHDOWN, "a priori")
    stance.add_transition("odd", "even", _TOUCHDOWN, "a priori")
    return stance


def _pendulum_level(omega: float, theta: float, g: float, l: float, gamma: float) -> float:
    """``C = ω² + (2g/l) cos(θ + γ)`` [1/s²]: constant in a stance (the energy about the foot over ``m l²/2``)."""
    return omega**2 + 2 * g / l * math.cos(theta + gamma)


def fixed_point(alpha: float, gamma: float, l: float, g: float) -> tuple[float, float]:
    """The steady gait's stance rates ``(ω⁻*, ω⁺*)`` [rad/s] just before and after an impact:
    ``ω⁻*² = 4 (g/l) sin α sin γ / (1 − cos² 2α)``, ``ω⁺* = cos 2α · ω⁻*`` (``γ > 0``)."""
    before = math.sqrt(4 * g / l * math.sin(alpha) * math.sin(gamma) / (1 - math.cos(2 * alpha) ** 2))
    return before, math.cos(2 * alpha) * before


def _check_ground_contact(p: dict) -> None:
    """Raise :class:`ParameterValueError` where the planted spoke could pull (see the module docstring)."""
    alpha, gamma, l, g = p["alpha"], p["gamma"], p["l"], p["g"]
    first = _pendulum_level(p["omega0"], p["phase0"] * alpha, g, l, gamma)
    steady = _pendulum_level(fixed_point(alpha, gamma, l, g)[1], -alpha, g, l, gamma) if 0 < gamma < math.pi / 2 else 0.0
    limit = 3 * g * math.cos(alpha + gamma) / l
    if max(first, steady) >= limit:
        culprit, what = (("omega0", f"its first stance (omega0 = {p['omega0']:g} rad/s): lower omega0") if first >= steady
                         else ("gamma", f"its steady gait (gamma = {gamma:g} rad): a gentler slope or more spokes"))
        raise ParameterValueError(
            f"rimless_wheel: the wheel would leave the ground in {what}. The spoke's push m (3 g cos(theta + "
            f"gamma) − l C) turns negative at theta = alpha: C = {max(first, steady):.6g} 1/s² against "
            f"3 g cos(alpha + gamma)/l = {limit:.6g} (l = {l:g} m, g = {g:g} m/s²); a massless wheel in the air "
            "is outside this model", culprit, p[culprit])


def build(**parameters) -> HybridModel:
    """The rimless wheel with ``DEFAULTS`` overridden by ``parameters``: the even foot planted at
    the stance angle ``θ0 = phase0·α`` with the rate ``omega0`` [rad/s] (the velocity tangential)."""
    p = merged(DEFAULTS, parameters, RANGES, "rimless_wheel")
    _check_ground_contact(p)
    graph = BondGraph("rimless_wheel")
    vx, vy = _hub(graph)
    psi, sigma = sp.symbols("psi sigma")
    _foot(graph, vx, vy, psi, sigma)
    _spin(graph, vx, psi, sigma)
    signals = {
        "normal_force": "-e_radial",
        "dpsi": "f_free_spin",
        "theta": "sigma*psi",
        "omega": "sigma*dpsi",
        "hub_x": "l*sin(theta)",
        "hub_y": "l*cos(psi)",
    }
    model_parameters = {k: p[k] for k in ("m", "l", "g", "alpha", "gamma", "phase0", "omega0")}
    return HybridModel(
        graph,
        [_automaton()],
        model_parameters,
        # on the even spoke at θ0 = phase0·α, the hub's velocity l ω0 (cos θ0, −sin θ0)
        initial_state={"psi": "phase0*alpha", "p_x": "m*l*omega0*cos(phase0*alpha)",
                       "p_y": "-m*l*omega0*sin(phase0*alpha)"},
        signals=signals,
        name="rimless_wheel",
        **annotated(UNITS, RANGES, DEFAULTS, model_parameters),
    )


def stance(x, mode, l: float, m: float) -> tuple[float, float]:
    """The stance angle and rate ``(θ, ω)`` [rad, rad/s] of a state ``x = (p_x, p_y, ψ)`` in a
    single-support ``mode``: ``θ = σ ψ``, ``ω = p · (cos θ, −sin θ)/(m l)`` (the hub's velocity
    along the stance spoke's normal over ``l``), ``σ = +1`` on the even foot, −1 on the odd."""
    sigma = 1 if mode.state_of("stance") == "even" else -1
    theta = sigma * float(x[2])
    return theta, (float(x[0]) * math.cos(theta) - float(x[1]) * math.sin(theta)) / (m * l)


def error_estimate(trajectory) -> str:
    """Largest relative error of the impacts' ``ω⁺/ω⁻`` against ``cos 2α`` and of the strides'
    ``ω⁻² − ω⁺²`` against ``(4g/l) sin α sin γ`` (forward strides between two impacts)."""
    values = {s.name: v for s, v in trajectory.model.parameter_values.items()}
    alpha, gamma, l, m, g = (values[k] for k in ("alpha", "gamma", "l", "m", "g"))
    instants = trajectory.at_instants()
    impacts = [k for k in range(len(instants.t)) if instants.t[k] > trajectory.t[0]]
    if not impacts:
        return "n/a (no impact)"
    ratio, energy, previous = [], [], None
    for k in impacts:
        _, before = stance(instants.x_before[k], instants.modes_before[k], l, m)
        _, after = stance(instants.x_after[k], instants.modes_after[k], l, m)
        ratio.append(abs(after / before / math.cos(2 * alpha) - 1))
        if previous is not None and previous > 0 and before > 0:
            gain = 4 * g / l * math.sin(alpha) * math.sin(gamma)
            energy.append(abs((before**2 - previous**2) / gain - 1))
        previous = after
    text = f"{max(ratio):.2e} on {len(ratio)} impact ratios (cos 2α)"
    if energy:
        text += f", {max(energy):.2e} on {len(energy)} stance energy gains"
    return text

