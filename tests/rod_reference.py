"""An independent reference simulator of a rigid rod falling onto a floor.

Written with numpy and scipy only (no ``bondgraph``, ``switching``,
``codegen`` or ``models``), to check ``models.falling_rod`` against physics
derived by hand.  Conventions are those of ``models.falling_rod``:

Bodies and coordinates (SI units: kg, m, s, rad, N)
    A rod of mass ``m`` [kg], inertia ``J`` [kg·m²] about its centre and
    half-length ``l`` [m] moves in the vertical plane under gravity ``g``
    [m/s²].  Its centre is ``r = (x, y)``, its angle ``θ``; the tip
    ``A = r − l (cos θ, sin θ)`` can touch the floor ``y = 0``; the far end is
    ``B = r + l (cos θ, sin θ)``.

State ``s = (x, y, θ, p_x, p_y, p_J)``
    positions [m, m, rad] and momenta ``p_x = m v_x``, ``p_y = m v_y`` [N·s],
    ``p_J = J ω`` [N·m·s].

Tip kinematics (``c = cos θ``, ``s = sin θ``)
    ``v_A = (v_x + l s ω,  v_y − l c ω)``,
    ``a_A = a⁰ + K (F, N)`` where ``(F, N)`` is the floor's force on the tip
    (``F`` along +x, ``N`` up), ``a⁰ = (l c ω²,  −g + l s ω²)`` the tip's
    acceleration without it, and the (symmetric, positive definite) tip
    mobility [1/kg]::

        K = [[1/m + l² s²/J,   −l² s c/J    ],
             [ −l² s c/J,      1/m + l² c²/J]]

Newton–Euler
    ``dp_x/dt = F``, ``dp_y/dt = N − m g``, ``dp_J/dt = l s F − l c N``
    (the torque about the centre of a force applied at ``A``),
    ``dx/dt = p_x/m``, ``dy/dt = p_y/m``, ``dθ/dt = p_J/J``.

Modes: ``(contact, friction)`` with the model's automaton state names
    * ``free``: ``F = N = 0``;
    * ``contact, stuck``: ``a_A = 0`` ⇒ ``(F, N) = −K⁻¹ a⁰``;
    * ``contact, slide_pos / slide_neg`` (tip sliding towards ±x,
      ``σ = ±1``): Coulomb ``F = −σ μ N`` and ``a_Ay = 0`` ⇒
      ``N = −a⁰_y / (K₂₂ − σ μ K₂₁) = (g − l s ω²) / (1/m + l² c (c + σ μ s)/J)``.

Impacts (free → contact when the tip reaches ``y = 0`` moving down), plastic
    An impulse ``P = (P_t, P_n)`` [N·s] at the tip changes the momenta by
    ``Δp_x = P_t``, ``Δp_y = P_n``, ``Δp_J = l s P_t − l c P_n`` and the tip
    velocity by ``K P``.  The stuck impulse makes ``v_A⁺ = 0``:
    ``P = −K⁻¹ v_A``.  If ``|P_t| ≤ μ P_n`` the tip sticks; otherwise it slides
    with ``σ = −sign(P_t)`` (the direction of the tip's tangential velocity
    after the frictionless impact) and

    * ``impact_law="paper"``: ``P_t = 0``, ``P_n = −v_Ay / K₂₂``;
    * ``impact_law="newton-coulomb"``: ``P_t = −σ μ P_n``,
      ``P_n = −v_Ay / (K₂₂ − σ μ K₂₁)``.

    Both conserve the angular momentum about the tip,
    ``L_A = J ω + m l (c v_y − s v_x)``, and the first also ``p_x``.

Transitions at once (after any impact or transition), on finite forces
    * a stuck tip (at rest) stays stuck if ``N > 0`` and ``|F| ≤ μN``;
      otherwise it takes the consistent mode among: slide ``σ`` with
      ``N_σ > 0`` and ``σ a_Ax ≥ 0``, free with ``a⁰_y ≥ 0`` (a lifting tip
      must accelerate away from the floor).  A stuck contact whose required
      friction leaves the cone with ``N > 0`` thus slips (``F < −μN`` →
      ``slide_pos``, ``F > μN`` → ``slide_neg``); one whose stuck normal
      force would be negative lifts off if ``a⁰_y ≥ 0`` and slides otherwise.
      When the consistent mode is not unique (Painlevé's paradox) the model's
      friction rule names it, and the run's ``notes`` say so.
    * a sliding tip sticks if the stick condition below holds, reverses if
      its velocity changed sign, and lifts off if ``N_σ ≤ 0``.

Transitions in flow (located with event functions on the dense output of
scipy's DOP853, roots refined with ``brentq``)
    * stuck: slip when ``F`` reaches ``∓μN``; lift-off when ``N`` reaches 0;
    * slide_σ: lift-off when ``N`` reaches 0 from above; reversal to
      ``slide_−σ`` when ``σ v_Ax`` reaches 0 without sticking; stick when
      ``σ v_Ax ≤ v_th`` **and** the stuck mode's forces, taken at the state
      ``g_stuck(s)`` after a plastic jump that sets ``v_Ax`` to 0 (the
      impulse ``P = −K⁻¹ (v_Ax, 0)`` at the tip, so momentum is conserved
      along every direction the stuck constraint leaves free), lie in the
      cone with ``N > 0``; then the state jumps to ``g_stuck(s)``.  (The
      threshold ``v_th`` [m/s] is the model's, Eq. (25) of the paper: a tip
      slower than it sticks.)  The impulse of that small jump is *not*
      judged against the cone: it is an artefact of the threshold, not a
      collision;
    * free: impact when the tip reaches ``y = 0`` moving down.  The model's
      friction automaton keeps a sliding state in the air until the tip
      rises above ``y_lift`` [m] (then ``stuck``), and names the slip
      direction of a stuck tip that lifts off by its stuck forces
      (``F < −μN`` → ``slide_pos``, ``F > μN`` → ``slide_neg``); the friction
      force is 0 in the air whatever that state, so this only names the
      mode, and the reference names it the same way.  An impact is always
      decided by the stuck test above (physics: the friction state in the
      air has no meaning; ``notes`` record an impact met in a sliding state);
    * the run ends when the far end reaches the floor, ``y + l sin θ = 0``,
      at time ``t_B``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import DOP853
from scipy.optimize import brentq

__all__ = ["RodResult", "RodReference", "simulate", "STATE_ORDER", "TOOLKIT_NAMES"]

#: the order of the reference's state vector
STATE_ORDER = ("x", "y", "theta", "p_x", "p_y", "p_J")
#: reference state name → the toolkit's state name (models.falling_rod)
TOOLKIT_NAMES = {
    "x": "rod/x",
    "y": "rod/y",
    "theta": "rod/theta",
    "p_x": "rod/p_x",
    "p_y": "rod/p_y",
    "p_J": "rod/p_J",
}

SIGMA = {"slide_pos": 1.0, "slide_neg": -1.0}
#: band of the instantaneous decisions, in the signals' units (m/s, N, N·s)
TOL = 1e-10


@dataclass
class RodResult:
    """The outcome of one reference run.

    ``modes``      continuous modes in the order they were lived, as
                   ``(contact, friction)`` pairs (zero-duration ones omitted);
    ``segments``   ``(contact, friction, t_start, t_end)`` of each of them [s];
    ``events``     ``(t, text)`` of every instant [s];
    ``t_B``        when the far end ``B`` reached the floor [s];
    ``state_B``    the state at ``t_B`` in :data:`STATE_ORDER`;
    ``notes``      remarks on unusual instants (e.g. a sliding impact leaving
                   the tip slower than ``v_th``).
    """

    modes: list
    segments: list
    events: list
    t_B: float
    state_B: np.ndarray
    notes: list = field(default_factory=list)

    def toolkit_state(self, state_names) -> np.ndarray:
        """``state_B`` reordered into the toolkit's ``state_names``."""
        index = {TOOLKIT_NAMES[name]: k for k, name in enumerate(STATE_ORDER)}
        return np.array([self.state_B[index[name]] for name in state_names])

    @property
    def mode_labels(self) -> list:
        return [f"{c}|{f}" for c, f in self.modes]


class RodReference:
    """The rod's mechanics (see the module docstring)."""

    def __init__(self, m=1.0, J=1.0, l=0.1, g=9.81, mu=0.005, v_th=0.0015, y_lift=1e-9, impact_law="paper"):
        if impact_law not in ("paper", "newton-coulomb"):
            raise ValueError(f"unknown impact law {impact_law!r}")
        self.m, self.J, self.l, self.g, self.mu = float(m), float(J), float(l), float(g), float(mu)
        self.v_th, self.y_lift, self.impact_law = float(v_th), float(y_lift), impact_law

    # ------------------------------------------------------------ kinematics

    def velocities(self, s):
        """``(v_x, v_y, ω)`` [m/s, m/s, rad/s]."""
        return s[3] / self.m, s[4] / self.m, s[5] / self.J

    def tip_velocity(self, s):
        """``v_A = (v_x + l sin θ ω, v_y − l cos θ ω)`` [m/s]."""
        vx, vy, w = self.velocities(s)
        c, sn = math.cos(s[2]), math.sin(s[2])
        return np.array([vx + self.l * sn * w, vy - self.l * c * w])

    def tip_y(self, s):
        return s[1] - self.l * math.sin(s[2])

    def far_end_y(self, s):
        return s[1] + self.l * math.sin(s[2])

    def mobility(self, theta):
        """The tip mobility ``K`` [1/kg]: tip velocity change per tip impulse."""
        c, sn = math.cos(theta), math.sin(theta)
        l2 = self.l**2 / self.J
        return np.array([[1 / self.m + l2 * sn * sn, -l2 * sn * c], [-l2 * sn * c, 1 / self.m + l2 * c * c]])

    def free_tip_acceleration(self, s):
        """``a⁰ = (l cos θ ω², −g + l sin θ ω²)`` [m/s²]."""
        w = s[5] / self.J
        return np.array([self.l * math.cos(s[2]) * w * w, -self.g + self.l * math.sin(s[2]) * w * w])

    def energy(self, s):
        """``(p_x² + p_y²)/(2m) + p_J²/(2J) + m g y`` [J]."""
        return (s[3] ** 2 + s[4] ** 2) / (2 * self.m) + s[5] ** 2 / (2 * self.J) + self.m * self.g * s[1]

    def tip_angular_momentum(self, s):
        """``L_A = J ω + m l (cos θ v_y − sin θ v_x)`` [N·m·s], about the tip."""
        vx, vy, w = self.velocities(s)
        return self.J * w + self.m * self.l * (math.cos(s[2]) * vy - math.sin(s[2]) * vx)

    # ------------------------------------------------------------ forces

    def forces(self, contact, friction, s):
        """The floor's force ``(F, N)`` [N] on the tip in a mode."""
        if contact == "free":
            return 0.0, 0.0
        K = self.mobility(s[2])
        a0 = self.free_tip_acceleration(s)
        if friction == "stuck":
            F, N = np.linalg.solve(K, -a0)
            return float(F), float(N)
        sigma = SIGMA[friction]
        N = -a0[1] / (K[1, 1] - sigma * self.mu * K[1, 0])
        return -sigma * self.mu * N, N

    def rhs(self, contact, friction):
        l, m, J, g = self.l, self.m, self.J, self.g

        def f(t, s):
            F, N = self.forces(contact, friction, s)
            c, sn = math.cos(s[2]), math.sin(s[2])
            return np.array([s[3] / m, s[4] / m, s[5] / J, F, N - m * g, l * sn * F - l * c * N])

        return f

    # ------------------------------------------------------------ jumps

    def apply_impulse(self, s, Pt, Pn):
        """The state after a tip impulse ``(P_t, P_n)`` [N·s]."""
        out = np.array(s, dtype=float)
        c, sn = math.cos(s[2]), math.sin(s[2])
        out[3] += Pt
        out[4] += Pn
        out[5] += self.l * sn * Pt - self.l * c * Pn
        return out

    def stuck_impulse(self, s):
        """``P = −K⁻¹ v_A``: the impulse that stops the tip."""
        return np.linalg.solve(self.mobility(s[2]), -self.tip_velocity(s))

    def jump_stuck(self, s):
        """Plastic jump onto ``v_A = 0`` (conserving momentum along the free directions)."""
        Pt, Pn = self.stuck_impulse(s)
        return self.apply_impulse(s, Pt, Pn)

    def slide_impulse(self, s, sigma):
        """``(P_t, P_n)`` of a sliding impact (direction ``sigma``) under the impact law."""
        K = self.mobility(s[2])
        vAy = self.tip_velocity(s)[1]
        if self.impact_law == "paper":
            return 0.0, -vAy / K[1, 1]
        Pn = -vAy / (K[1, 1] - sigma * self.mu * K[1, 0])
        return -sigma * self.mu * Pn, Pn

    def jump_slide(self, s, sigma):
        Pt, Pn = self.slide_impulse(s, sigma)
        return self.apply_impulse(s, Pt, Pn)

    # ------------------------------------------------------------ conditions

    def stick_possible(self, s, sigma, tol=TOL):
        """The slide → stuck condition: ``σ v_Ax ≤ v_th`` and the stuck forces at
        ``g_stuck(s)`` inside the cone."""
        if sigma * self.tip_velocity(s)[0] > self.v_th + tol:
            return False
        F, N = self.forces("contact", "stuck", self.jump_stuck(s))
        return N > 0 and abs(F) <= self.mu * N + tol

    def event_functions(self, contact, friction):
        """``(name, g(s), conjunctive)`` with the transition taken when ``g`` rises through 0."""
        mu = self.mu
        events = [("B_floor", lambda s: -self.far_end_y(s), False)]
        if contact == "free":
            events.append(("impact", lambda s: -self.tip_y(s), False))
            if friction != "stuck":
                events.append(("rise", lambda s: self.tip_y(s) - self.y_lift, False))
            return events
        if friction == "stuck":

            def liftoff(s):
                return -self.forces("contact", "stuck", s)[1]

            def slip_pos(s):
                F, N = self.forces("contact", "stuck", s)
                return -(F + mu * N)

            def slip_neg(s):
                F, N = self.forces("contact", "stuck", s)
                return F - mu * N

            events += [("liftoff", liftoff, False), ("slip_pos", slip_pos, False), ("slip_neg", slip_neg, False)]
            return events
        sigma = SIGMA[friction]

        def liftoff_slide(s):
            return -self.forces(contact, friction, s)[1]

        def reverse(s):
            return -sigma * self.tip_velocity(s)[0]

        def slow(s):
            return self.v_th - sigma * self.tip_velocity(s)[0]

        def cone_hi(s):
            F, N = self.forces("contact", "stuck", self.jump_stuck(s))
            return mu * N - F

        def cone_lo(s):
            F, N = self.forces("contact", "stuck", self.jump_stuck(s))
            return mu * N + F

        events += [
            ("liftoff", liftoff_slide, False),
            ("reverse", reverse, False),
            ("stick_slow", slow, True),
            ("stick_cone_hi", cone_hi, True),
            ("stick_cone_lo", cone_lo, True),
        ]
        return events

    # ------------------------------------------------------------ instants

    def slide_tip_acceleration(self, s, sigma):
        """``a_Ax`` [m/s²] of a tip sliding in direction ``sigma`` (``F = −σ μ N``, ``a_Ay = 0``)."""
        K = self.mobility(s[2])
        F, N = self.forces("contact", "slide_pos" if sigma > 0 else "slide_neg", s)
        return self.free_tip_acceleration(s)[0] + K[0, 0] * F + K[0, 1] * N

    def at_rest(self, t, s, notes):
        """The mode of a tip at rest on the floor (``v_A = 0``) that cannot stay stuck.

        Physics: a mode is consistent if its forces and accelerations have the
        right signs — slide ``σ``: ``N_σ > 0`` and ``σ a_Ax ≥ 0``; free: the
        tip's free acceleration ``a⁰_y ≥ 0``.  The model's automaton names the
        slip direction from the stuck forces (``F < −μN`` → ``slide_pos``,
        ``F > μN`` → ``slide_neg``) and keeps that name in the air; when the
        consistent mode is not unique (Painlevé's paradox) that rule decides.
        Returns ``(contact, friction)``."""
        F, N = self.forces("contact", "stuck", s)
        label = "slide_pos" if F < -self.mu * N else "slide_neg" if F > self.mu * N else "stuck"
        candidates = []
        for sigma, name in ((1.0, "slide_pos"), (-1.0, "slide_neg")):
            N_s = self.forces("contact", name, s)[1]
            if N_s > TOL and sigma * self.slide_tip_acceleration(s, sigma) > -TOL:
                candidates.append(("contact", name))
        if self.free_tip_acceleration(s)[1] > -TOL:
            candidates.append(("free", label))
        if len(candidates) == 1:
            return candidates[0]
        preferred = ("contact", label) if ("contact", label) in candidates else ("free", label)
        notes.append(f"t={t:.12g}: {len(candidates)} consistent modes for a tip at rest "
                     f"({candidates}); took {preferred} by the model's friction rule")
        return preferred

    def settle(self, t, s, contact, friction, notes):
        """Transitions at once after an instant, on finite forces (module docstring).
        Returns ``(s, contact, friction, passed)``; ``passed`` lists the modes left at once."""
        passed = []
        for _ in range(10):
            if contact == "free":
                if friction != "stuck" and self.tip_y(s) > self.y_lift:
                    passed.append((contact, friction))
                    friction = "stuck"
                return s, contact, friction, passed
            if friction == "stuck":
                F, N = self.forces(contact, friction, s)
                if N > TOL and abs(F) <= self.mu * N + TOL:
                    return s, contact, friction, passed
                passed.append((contact, friction))
                contact, friction = self.at_rest(t, s, notes)
                continue
            sigma = SIGMA[friction]
            F, N = self.forces(contact, friction, s)
            vAx = self.tip_velocity(s)[0]
            # strictly inside the cone: a slip located on the cone's edge must not stick again at once
            if self.stick_possible(s, sigma, tol=-1e-9 * max(1.0, abs(N))):
                passed.append((contact, friction))
                s = self.jump_stuck(s)
                friction = "stuck"
                continue
            if sigma * vAx < -TOL:
                passed.append((contact, friction))
                friction = "slide_neg" if sigma > 0 else "slide_pos"
                continue
            if N <= TOL:
                if self.free_tip_acceleration(s)[1] < -TOL and abs(self.tip_velocity(s)[1]) < 1e-9:
                    notes.append(f"t={t:.12g}: {friction} needs N = {N:.3g} <= 0 but the free tip would "
                                 "accelerate into the floor (Painlevé)")
                passed.append((contact, friction))
                contact = "free"
                continue
            return s, contact, friction, passed
        raise RuntimeError(f"reference: no consistent mode at t = {t!r} (passed {passed})")

    def impact(self, t, s, friction, notes):
        """A plastic impact at ``t``; returns ``(s⁺, friction)`` (before :meth:`settle`)."""
        if friction != "stuck":
            notes.append(f"t={t:.12g}: impact while the friction automaton is still {friction}")
        Pt, Pn = self.stuck_impulse(s)
        if abs(Pt) <= self.mu * Pn:
            return self.jump_stuck(s), "stuck"
        sigma = -math.copysign(1.0, Pt)
        s_plus = self.jump_slide(s, sigma)
        vAx = self.tip_velocity(s_plus)[0]
        if sigma * vAx < 0:
            notes.append(f"t={t:.12g}: sliding impact reversed the tip's tangential velocity ({vAx:.3g} m/s)")
        if sigma * vAx <= self.v_th:
            notes.append(f"t={t:.12g}: sliding impact left the tip slower than v_th ({vAx:.3g} m/s)")
        return s_plus, "slide_pos" if sigma > 0 else "slide_neg"

    # ------------------------------------------------------------ flow

    def flow(self, t0, s0, contact, friction, t_max, rtol, atol):
        """Integrate one mode until an event; returns ``(t, s, name)`` (``name`` None at ``t_max``)."""
        f = self.rhs(contact, friction)
        events = self.event_functions(contact, friction)
        band = 1e-12
        armed = [g(s0) < -band for _, g, _ in events]
        solver = DOP853(f, t0, np.array(s0, dtype=float), t_max, rtol=rtol, atol=atol)
        values = [g(s0) for _, g, _ in events]
        while True:
            if solver.status != "running":
                return solver.t, solver.y.copy(), None
            t_prev = solver.t
            message = solver.step()
            if solver.status == "failed":
                raise RuntimeError(f"reference integration failed at t = {t_prev}: {message}")
            dense = solver.dense_output()
            t_new = solver.t
            # sample inside the step too, so that a double crossing is not missed
            ts = np.linspace(t_prev, t_new, 6)
            states = [dense(tk) for tk in ts]
            found = []
            for i, (name, g, conj) in enumerate(events):
                vals = [values[i]] + [g(sk) for sk in states[1:]]
                if armed[i]:
                    for k in range(1, len(ts)):
                        if vals[k - 1] < 0 <= vals[k]:
                            root = brentq(lambda tt: g(dense(tt)), ts[k - 1], ts[k], xtol=1e-15, rtol=1e-15,
                                          maxiter=200)
                            # the first time the condition holds, not a point just before it
                            if g(dense(root)) < 0:
                                root = np.nextafter(root, ts[k])
                            found.append((root, i))
                            break
                values[i] = vals[-1]
            for root, i in sorted(found):
                name, g, conj = events[i]
                s = dense(root)
                if conj and not self.stick_possible(s, SIGMA[friction], tol=1e-9):
                    # one part of the stick condition crossed, the other does not hold: flow on
                    return self.flow(root, s, contact, friction, t_max, rtol, atol)
                return root, s, name
            for i, (name, g, conj) in enumerate(events):
                if not armed[i] and values[i] < -band:
                    armed[i] = True

    def run(self, s0, t_max=20.0, rtol=1e-12, atol=1e-14) -> RodResult:
        """From ``s0`` (released in mode free|stuck) until the far end reaches the floor."""
        t, s = 0.0, np.array(s0, dtype=float)
        contact, friction = "free", "stuck"
        notes: list = []
        if self.tip_y(s) <= 0 or self.far_end_y(s) <= 0:
            raise ValueError("the rod must start clear of the floor")
        segments, events = [], []
        for _ in range(10000):
            t_end, s_end, name = self.flow(t, s, contact, friction, t_max, rtol, atol)
            if t_end > t:
                segments.append((contact, friction, t, t_end))
            if name is None:
                raise RuntimeError(f"reference: the far end did not reach the floor by t = {t_max}")
            if name == "B_floor":
                modes = []
                for c, fr, a, b in segments:
                    if b - a > 1e-12 and (not modes or modes[-1] != (c, fr)):
                        modes.append((c, fr))
                return RodResult(modes, segments, events, t_end, s_end, notes)
            t, s = t_end, s_end
            before = (contact, friction)
            if name == "impact":
                if self.tip_velocity(s)[1] >= 0:
                    raise RuntimeError(f"reference: grazing impact at t = {t!r}")
                s, friction = self.impact(t, s, friction, notes)
                contact = "contact"
            elif name == "rise":
                friction = "stuck"
            elif name == "liftoff" and friction == "stuck":
                contact, friction = self.at_rest(t, s, notes)
            elif name == "liftoff":
                contact = "free"
            elif name == "slip_pos":
                friction = "slide_pos"
            elif name == "slip_neg":
                friction = "slide_neg"
            elif name == "reverse":
                friction = "slide_neg" if friction == "slide_pos" else "slide_pos"
            elif name.startswith("stick"):
                s = self.jump_stuck(s)
                friction = "stuck"
            s, contact, friction, passed = self.settle(t, s, contact, friction, notes)
            events.append((t, f"{name}: {before[0]}|{before[1]} -> {contact}|{friction}"
                           + (f" (passed {', '.join(c + '|' + f for c, f in passed)})" if passed else "")))
        raise RuntimeError("reference: too many events")


def initial_state(theta0, y0, x0=0.0):
    """The rod released at rest: ``(x0, y0, θ0, 0, 0, 0)``."""
    return np.array([x0, y0, theta0, 0.0, 0.0, 0.0])


def simulate(m=1.0, J=1.0, l=0.1, mu=0.005, theta0=0.862, y0=0.23, x0=0.0, g=9.81, v_th=0.0015, y_lift=1e-9,
             impact_law="paper", t_max=20.0, rtol=1e-12, atol=1e-14) -> RodResult:
    """Run the reference with the parameter names of ``models.falling_rod.build``."""
    ref = RodReference(m=m, J=J, l=l, g=g, mu=mu, v_th=v_th, y_lift=y_lift, impact_law=impact_law)
    return ref.run(initial_state(theta0, y0, x0), t_max=t_max, rtol=rtol, atol=atol)
