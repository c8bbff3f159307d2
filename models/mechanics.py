"""1-D mechanics, translational and rotational: components between named nodes.

:class:`Mechanism` collects components between *nodes* — velocity points: the
speed of a point of a translational machine, the angular speed of a shaft of a
rotational one — and builds their bond graph in the mobility analogy, as
:class:`models.circuits.Circuit` does for netlists:

* every node other than the frame ``"0"`` is a 1-junction ``node_<node>`` (one
  velocity, the forces on it balance) with an integrated displacement
  ``x_<node>`` (``theta_<node>`` when rotational): its position;
* the frame ``"0"`` does not move (velocity 0) and is eliminated: a component
  between a node and the frame is bonded straight to the node;
* a mass (inertia) is an ``I`` on its node; a force (torque) an ``Se`` on it;
* a spring or damper between two nodes sits on a 0-junction ``branch_<name>``
  (one force) between the two nodes' 1-junctions, so that its flow is the
  relative velocity ``v(n1) − v(n2)``;
* a gear is a ``TF`` from one shaft to another, a DC motor a ``GY`` from its
  armature circuit to its shaft;
* a clutch, a hard stop and a backlash are *controlled* 0-junctions named
  after the component between its two nodes (on: the nodes move together;
  off: no force between them), driven by an automaton of the same name.  The
  jump into the locked configuration is derived by the toolkit from
  conservation of momentum (DESIGN §5): a plastic engagement, or Newton's
  ``−e`` rebound with the automaton's restitution.

The result of :meth:`Mechanism.build` is an ordinary
:class:`~switching.HybridModel`: simulate it, save it to a model file, draw
its graph with :func:`bondgraph.draw_bond_graph`.

Units: SI.  Translational: m, m/s, N, kg, N/m, N·s/m.  Rotational: rad,
rad/s, N·m, kg·m², N·m/rad, N·m·s/rad.  A motor's armature: V, A, Ω, H, and
its constant ``k`` [V·s/rad = N·m/A].

Signals (translational letters; rotational ``theta``/``omega``/``T`` in place
of ``x``/``v``/``F``):

* nodes: ``v_<node>`` the velocity, ``x_<node>`` the position (a state,
  from ``x0`` given with :meth:`~Mechanism.mass` or
  :meth:`~Mechanism.position`, else 0);
* masses: ``v_<m>``, ``x_<m>`` those of their node, ``p_<m>`` the momentum
  (a state, ``p = m·v``);
* springs, dampers, clutches, stops, backlashes between ``n1`` and ``n2``:
  ``F_<name>`` the force it transmits from ``n1`` to ``n2`` (it pushes ``n2``
  forward and ``n1`` back: a compressed spring, ``n1`` behind ``n2``, has
  ``F > 0``), ``v_<name> = v(n1) − v(n2)`` the relative velocity (a clutch's
  slip speed), ``x_<name> = x(n1) − x(n2)`` the relative position (stops,
  backlashes).  A spring's state ``q_<name>`` is its deflection
  ``∫(v(n1) − v(n2))dt`` (``F = k·q``), of the opposite sign when ``n1`` is
  the frame (the signals keep the convention);
* forces and prescribed velocities: ``F_<f>`` the force on its node,
  ``v_<f>`` the node's velocity;
* gears: ``T_<g>_in`` the torque the input shaft delivers, ``T_<g>_out``
  the torque on the output shaft, ``omega_<g>_in``, ``omega_<g>_out``;
* motors: ``i_<M>`` the armature current, ``emf_<M> = k·ω`` the back-emf,
  ``T_<M> = k·i`` the torque on its shaft, ``omega_<M>`` the shaft's speed.

Values: a number (it becomes a parameter named after the component, e.g.
``m1``, overridable in :meth:`Mechanism.build`) or a parameter name.  Forces,
prescribed velocities and motor voltages also take an expression of ``t`` as text (parsed without
executing code) or a declared :class:`~models.circuits.Input`.

Clutches (:meth:`Mechanism.clutch`, automaton states ``disengaged`` and
``engaged``) follow a command: a condition on time, parameters or signals
(``engaged_when="t >= 0.5"``, or a threshold ``"omega_a >= 100"``), a priori
(an external command, not a consequence of the switch).  Without ``T_max``
an engaged clutch locks its shafts together (the engagement is a plastic
impact: momentum ``J₁ω₁ + J₂ω₂`` is conserved and the energy
``J₁J₂/(J₁+J₂)·Δω²/2`` is lost).  With ``T_max`` it is a friction clutch: it
transmits the Coulomb torque ``T_max·sign(ω₁ − ω₂)`` while it slips and
sticks when the speeds meet, as long as the torque it must carry stays below
``T_max`` (the toolkit's law switches: the law's automaton ``<name>_law`` is
``stuck`` while it sticks — the law's sliding (Filippov) mode, read as
``sliding`` too — and ``slipping_pos``/``slipping_neg`` while it slips with the
element's own slip speed positive or negative: ``v_<name>``, of the opposite
sign for a clutch whose ``n1`` is the frame).

Hard stops and backlash (:meth:`Mechanism.stop`, :meth:`Mechanism.backlash`;
automaton states ``free``, ``upper_impact``/``lower_impact`` with
restitution ``e``, ``upper``/``lower`` in contact).  With ``d = x_<name>``
the relative position and ``w = v_<name>`` the relative velocity::

    free         → upper_impact  d >= upper and w > v_th          (a priori)
    free         → upper         d >= upper and w > 0 and w <= v_th
    upper_impact → free          w < 0                            (a priori, after the jump)
    upper_impact → upper         w <= 0 and w >= 0                (after a plastic jump)
    upper        → free          F_<name> < 0                     (a posteriori)

and the mirror images at ``lower`` (``d <= lower``, ``w < −v_th``, …, and
``F_<name> > 0`` to let go).  An impact is a time-scale abstraction
judged on the velocity before it (a priori).  Both guards out of the impact
state are false on the state before the jump (``w > v_th >= 0``), so the
impact state is real, a pinnacle, and not passed as mythical:
after the jump ``w⁺ = −e·w`` it is left for ``free`` (a rebound) or, when
nothing rebounds (``e = 0``), for the contact state, which holds the nodes
together until the contact would have to pull (a posteriori, as a diode).
The comparisons are strict where the band must be excluded: ``w > v_th`` is
not met by the state after a plastic jump (``w⁺ = 0`` within the band), so
a contact is never re-entered at its own instant.  An approach slower than
``v_th`` (0 by default) lands in contact without a rebound (a
time-scale abstraction of a soft landing; with ``e > 0`` and ``v_th = 0``
a node pressed against a stop bounces ever lower, a Zeno accumulation, as
the bouncing ball with ``v_rest = 0``).

A stop or backlash may act on a node without a mass of its own whose motion
an inertia sets through gears or levers (the output shaft of a gearbox): the
impact acts on the inertia reflected through them.  The node's velocity is
read from that inertia's momentum, ``ω_out = (p_J/J)/n`` across a gear of
ratio ``n`` from ``J``'s shaft (``n·ω`` from its output side, through any
chain of gears), so the guards judge ``w = ω_out`` before the jump, and the
jump reverses it to ``−e·w`` by conservation of state through the ``TF``:
the motor turns back at ``−e`` times its speed, as an inertia ``J·n²`` on the
output itself would (energy after = ``e²`` × before; a backlash behind a gear
conserves ``n·J·ω_m + J_load·ω_load``)::

    >>> from models.mechanics import Mechanism
    >>> box = Mechanism("gearbox", "rotational")
    >>> box.inertia("J_m", "m", 2.0, omega0=8.0)   # the motor, 8 rad/s
    >>> box.gear("G", "m", "out", 4.0)             # the output turns at 2 rad/s
    >>> box.stop("end", "out", upper=1.0, e=0.5)   # no inertia of its own
    >>> run = box.build().simulate(1.0, "RK45", rtol=1e-10, atol=1e-12)
    >>> round(float(run.event_times[0]), 9), float(run.signal("omega_J_m")[-1])
    (0.5, -4.0)

Example — a mass falling 1 m onto a stop, rebounding at half its speed::

    >>> from models.mechanics import Mechanism
    >>> drop = Mechanism("drop")
    >>> drop.mass("m1", "a", 2.0, x0=1.0)
    >>> drop.force("gravity", "a", -2.0 * 9.81)
    >>> drop.stop("floor", "a", lower=0.0, e=0.5)
    >>> run = drop.build().simulate(0.5, "RK45", rtol=1e-10, atol=1e-12)
    >>> round(float(run.event_times[0]), 6)        # sqrt(2·1/9.81)
    0.451524

Limitations: two ideal clutches (or stops) that lock the same two nodes at
once leave the torque split between them undefined: such a mode is refused
when it is reached with a :class:`~bondgraph.errors.FloatingPartError` that
names the mode and the elements (give one of them ``T_max``, or merge
them).  Stops and backlashes need a mass (inertia) on, or geared to, each
of their moving nodes: their guards judge the velocities before an impact
from the masses' momenta, and a node with only springs, dampers or a
prescribed motion behind it is refused when it is built, naming the node
(its impact would be of a massless node).  A spring's ``q0`` needs a
linear spring.  Friction clutches start their law automaton ``<name>_law``
at t = 0 like any law switch (an instant at the start, or just after it,
when the shafts turn together).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import sympy as sp

from bondgraph import GY, TF, C, I, One, R, Se, Sf, Zero
from bondgraph.namespace import Owner
from bondgraph.errors import (DuplicateNameError, InvalidGraphError, MissingParameterError, ParameterValueError,
                              UnknownNameError)
from switching import Automaton, HybridModel

from .circuits import Input
from .controllers import build_controllers, controller_placeholder, controller_values
from ._common import Range
from .netlist import (REFERENCE, BuiltFrom, Netlist, NetlistBuilder, Part, checked_argument, checked_name,
                      checked_node, checked_number, holds_at_start, parameter_name, source_value, units_by_prefix)

__all__ = ["Mechanism", "Input", "FRAME", "KINDS"]

#: the fixed frame (velocity 0)
FRAME = REFERENCE
#: the two kinds of machine and their signal letters (position, velocity, force)
KINDS = {"translational": ("x", "v", "F"), "rotational": ("theta", "omega", "T")}
#: the units of the signals and states a mechanism names, by prefix (a motor's current and back-emf
#: ``i_``, ``emf_``, its shaft torque and speed; masses' momenta ``p_``, springs' deflections ``q_``)
MECHANICS_UNITS = {
    "translational": {"x_": "m", "v_": "m/s", "F_": "N", "p_": "N·s", "q_": "m", "i_": "A", "emf_": "V",
                      "T_": "N·m", "omega_": "rad/s"},
    "rotational": {"theta_": "rad", "omega_": "rad/s", "T_": "N·m", "p_": "N·m·s", "q_": "rad", "i_": "A",
                   "emf_": "V"},
}



class Mechanism(Netlist):
    """A 1-D machine: components between named nodes; the frame is node ``"0"``.

    ``kind`` is ``"translational"`` (nodes are points moving along a line;
    signals ``x``, ``v``, ``F``) or ``"rotational"`` (nodes are shafts;
    signals ``theta``, ``omega``, ``T``).  Add components with :meth:`mass`
    (:meth:`inertia`), :meth:`spring`, :meth:`damper`, :meth:`force`
    (:meth:`torque`), :meth:`velocity`, :meth:`gear`, :meth:`motor`, :meth:`clutch`,
    :meth:`stop` and :meth:`backlash`; :meth:`build` returns the
    :class:`~switching.HybridModel`.  Component names are identifiers and
    unique; node names are letters, digits and ``_``.  See the module
    documentation for the conventions.
    """

    def __init__(self, name: str = "mechanism", kind: str = "translational"):
        super().__init__(name, "mechanism name", "'drivetrain', 'press_1'")
        if kind not in KINDS:
            raise InvalidGraphError(f"mechanism {name!r}: kind must be 'translational' or 'rotational', "
                                    f"got {kind!r}")
        self.kind = kind
        self._positions: dict[str, float] = {}

    # ------------------------------------------------------------ components

    def mass(self, name: str, node, m=None, *, v0: float = 0.0, x0: float | None = None) -> None:
        """A mass ``m`` [kg] (rotational: an inertia [kg·m²]) moving with
        ``node``: ``dp/dt`` is the sum of the forces on the node, ``v = p/m``;
        ``v0`` its velocity and ``x0`` (if given) its node's position at t = 0.
        One mass per node: two masses moving together are one, ``m₁ + m₂``."""
        what = "mass" if self.kind == "translational" else "inertia"
        self._add("M", name, (node,), value=self._value(m, what, name),
                  v0=checked_number(v0, f"the initial velocity of {what} {name!r}"))
        if x0 is not None:
            self.position(node, x0)

    def inertia(self, name: str, shaft, J=None, *, omega0: float = 0.0, theta0: float | None = None) -> None:
        """A rotational inertia ``J`` [kg·m²] on ``shaft``: :meth:`mass` with
        ``omega0`` [rad/s] and ``theta0`` [rad]."""
        self.mass(name, shaft, J, v0=omega0, x0=theta0)

    def position(self, node, x0: float) -> None:
        """The position (rotational: angle) of ``node`` at t = 0 (default 0)."""
        node = checked_node(node, "position", "the frame")
        if node == FRAME:
            raise InvalidGraphError(f"the frame {FRAME!r} does not move: its position is 0")
        self._positions[node] = checked_number(x0, f"the position of node {node!r} at t = 0")

    def spring(self, name: str, n1, n2, k=None, *, q0: float = 0.0, effort_law=None) -> None:
        """A spring between ``n1`` and ``n2``: ``F = k·q`` [N, N/m] with the
        deflection ``q = ∫(v(n1) − v(n2))dt`` (compression when ``n1`` is
        behind ``n2``), ``q = q0`` at t = 0.  ``effort_law``: a nonlinear
        ``F = φ(q)`` instead of ``k`` (a function of one argument)."""
        self._add("K", name, (n1, n2), value=self._value(k, "stiffness", name), law=effort_law,
                  q0=checked_number(q0, f"the initial deflection q0 of spring {name!r}"))

    def damper(self, name: str, n1, n2, b=None, *, effort_law=None) -> None:
        """A damper between ``n1`` and ``n2``: ``F = b·(v(n1) − v(n2))``
        [N, N·s/m]; ``effort_law``: a nonlinear ``F = φ(v)`` instead (e.g.
        Coulomb friction ``lambda v: Fc*sympy.sign(v)``, whose stick/slip the
        toolkit's law switches resolve)."""
        self._add("B", name, (n1, n2), value=self._value(b, "damping", name), law=effort_law)

    def force(self, name: str, node, value) -> None:
        """A force [N] (rotational: a torque [N·m]) on ``node`` in its positive
        direction: a number, a parameter name, an expression of ``t`` as
        text, or an :class:`~models.circuits.Input`."""
        self._add("F", name, (node,), value=source_value(value, name, (Input,)))

    def torque(self, name: str, shaft, value) -> None:
        """A torque [N·m] on ``shaft``: :meth:`force`."""
        self.force(name, shaft, value)

    def velocity(self, name: str, node, value) -> None:
        """A prescribed velocity [m/s] (rotational: speed [rad/s]) of ``node``
        (an ``Sf``: a drive stiff enough to impose its motion), a number, a
        parameter name, an expression of ``t`` as text or an Input;
        ``F_<name>`` is the force it applies to the node.  A mass on the same
        node follows it (its momentum is then a dependent state)."""
        self._add("S", name, (node,), value=source_value(value, name, (Input,)))

    def gear(self, name: str, n_in, n_out, ratio) -> None:
        """An ideal gear (a ``TF``) of ratio ``n`` from shaft ``n_in`` to
        ``n_out``: ``ω_out = ω_in/n`` and ``T_out = n·T_in`` (power is
        conserved).  A translational machine reads it as a lever."""
        self._add("G", name, (n_in, n_out), value=checked_argument(ratio, f"the ratio of gear {name!r}",
                                                                   ("number", "name", "sympy")))

    def motor(self, name: str, shaft, k, *, V, R, L=None, i0: float = 0.0) -> None:
        """A DC motor (a ``GY`` of constant ``k`` [V·s/rad = N·m/A]) driving
        ``shaft``, fed by a voltage ``V`` [V] (a number, parameter name,
        expression of ``t`` as text or Input) through its armature
        resistance ``R`` [Ω] and, if given, inductance ``L`` [H] (current
        ``i0`` at t = 0): ``V = R·i + L di/dt + k·ω`` and ``T = k·i``.  Its
        parameters are ``<name>_k``, ``<name>_V``, ``<name>_R``, ``<name>_L``
        (when numbers).  Without a load the shaft reaches the no-load speed
        ``V/k``."""
        checked = {key: None if value is None else checked_argument(value, f"the {what} of motor {name!r}")
                   for key, value, what in (("k", k, "constant k"), ("R", R, "armature resistance R"),
                                            ("L", L, "armature inductance L"))}
        if checked["k"] is None or checked["R"] is None:
            raise ParameterValueError(f"motor {name!r}: give its constant k and armature resistance R (numbers or "
                                      "parameter names)", name, None)
        self._add("DC", name, (shaft,), V=source_value(V, name, (Input,)),
                  i0=checked_number(i0, f"the initial current i0 of motor {name!r}"), **checked)

    def clutch(self, name: str, n1, n2, engaged_when: str, *, disengaged_when: str | None = None,
               engaged: bool | None = None, T_max=None) -> None:
        """A clutch between shafts ``n1`` and ``n2`` (``n2 = "0"``: a brake),
        automaton ``name`` with states ``disengaged`` and ``engaged``.

        ``engaged_when``: a condition as text on time, parameters and signals
        (``"t >= t_on"``, a threshold ``"omega_a >= 100"``); it disengages when
        the condition stops holding or, with ``disengaged_when``, when that
        holds.  ``engaged``: its state at t = 0 (default: ``engaged_when`` at
        t = 0 when it depends on time and parameters only, else disengaged).
        Without ``T_max`` an engaged clutch locks the shafts (a plastic
        impact at engagement); with ``T_max`` [N·m] it slips with the
        Coulomb torque ``T_max·sign(ω₁ − ω₂)`` and sticks when the speeds
        meet while the torque it must carry stays below ``T_max``."""
        for label, condition in (("engaged_when", engaged_when), ("disengaged_when", disengaged_when)):
            if condition is not None and not isinstance(condition, str):
                raise InvalidGraphError(f"clutch {name!r}: {label} must be a condition as text (e.g. "
                                        f"'t >= 0.5'), got {condition!r}", [str(name)])
        if engaged is not None and not isinstance(engaged, bool):
            raise ParameterValueError(f"clutch {name!r}: engaged must be True or False, got {engaged!r}",
                                      "engaged", engaged)
        T_max = None if T_max is None else checked_argument(T_max, f"the slip torque T_max of clutch {name!r}")
        self._add("CL", name, (n1, n2), engaged_when=engaged_when, disengaged_when=disengaged_when,
                  engaged=engaged, T_max=T_max)

    def stop(self, name: str, node, *, upper=None, lower=None, e=0.0, v_th=0.0) -> None:
        """A hard stop on ``node``: its position stays ``<= upper`` and/or
        ``>= lower`` [m or rad]; an impact rebounds with the restitution
        ``e`` (0 ≤ e ≤ 1: ``v⁺ = −e·v``), an approach slower than ``v_th``
        lands in contact.  ``node`` carries a mass or is geared to one (the
        impact then acts on the inertia reflected through the gears).
        Guards: see the module documentation."""
        if upper is None and lower is None:
            raise InvalidGraphError(f"stop {name!r}: give its position as upper= (the node stays below it) "
                                    "and/or lower= (above it)", [str(name)])
        upper, lower = (None if value is None else checked_argument(value, f"the {side} position of stop {name!r}")
                        for side, value in (("upper", upper), ("lower", lower)))
        self._add("ST", name, (node, FRAME), upper=upper, lower=lower, **_impact_values(e, v_th, f"stop {name!r}"))

    def backlash(self, name: str, n1, n2, delta, *, e=0.0, v_th=0.0) -> None:
        """A backlash (play) of total width ``2·delta`` between ``n1`` and
        ``n2``: the relative position ``x(n1) − x(n2)`` stays within
        ``[−delta, delta]``, with impacts of restitution ``e`` at both ends
        (a hard stop between two nodes; guards: see the module
        documentation).  ``delta``: a number (the parameter
        ``<name>_delta``) or a parameter name.  Each node carries a mass or
        is geared to one (a gearbox's output shaft against its load)."""
        delta = checked_argument(delta, f"the half-width delta of backlash {name!r}")
        if not isinstance(delta, str) and delta <= 0:
            raise ParameterValueError(f"the half-width delta of backlash {name!r} is {delta:g}: give a positive "
                                      "width", "delta", delta)
        self._add("ST", name, (n1, n2), upper=delta, lower=("-", delta),
                  **_impact_values(e, v_th, f"backlash {name!r}"))

    def pid(self, name: str, measure: str, reference, kp, ki=0.0, kd=0.0, *, limits=None, tracking=None,
            derivative_filter=None, initial: float = 0.0, sample_period=None, sample_delay=None) -> None:
        """A PID controller ``name`` (no node): its output is the signal ``name``, ``clamp(kp·e + I + D,
        *limits)`` of the error ``e = reference − measure`` (``measure`` a text of the mechanism's signals,
        ``"omega_load"``), with back-calculation anti-windup; give its name as a motor's voltage ``V`` or a
        force's or torque's value to close the loop (a speed loop around a DC motor).  The equations:
        :mod:`models.controllers`, as :meth:`Circuit.pid` (``sample_period``: a digital controller,
        :mod:`models.sampled_controllers`)."""
        values = controller_values(name, measure, reference, kp, ki, kd, limits, tracking, derivative_filter,
                                   initial, sample_period, sample_delay)
        self._add("PI", name, (), **values)

    def pi(self, name: str, measure: str, reference, kp, ki, **options) -> None:
        """A PI controller: :meth:`pid` without the derivative."""
        self.pid(name, measure, reference, kp, ki, 0.0, **options)

    def draw(self, mode=None):
        """The mechanism's lumped diagram (:func:`models.lumped_diagram.draw_mechanism`), its clutches, stops
        and backlashes in the states of ``mode`` — a mode of a model built from it, or ``"K=engaged"`` — or
        at t = 0: ``.svg()``, ``.save(path)``, shown inline in notebooks."""
        from .lumped_diagram import draw_mechanism

        return draw_mechanism(self, mode)

    # ------------------------------------------------------------ input checks

    def _value(self, value, what: str, name: str):
        """A mass's, spring's or damper's value as its method takes it: ``None`` (the parameter ``name``),
        a number, a parameter name or a sympy expression."""
        if value is None:
            return None
        return checked_argument(value, f"the {what} of {name!r}", ("number", "name", "sympy"))

    def _add(self, kind, name, nodes, **values):
        name = checked_name(name, "component name", "'m1', 'clutch_A'")
        if name in self._parts:
            old = self._parts[name]
            raise DuplicateNameError(f"mechanism {self.name!r}: component {name!r} is already defined "
                                     f"(on {', '.join(old.nodes)}); give each component its own name", name)
        nodes = tuple(checked_node(n, name, "the frame") for n in nodes)
        if len(nodes) == 2 and nodes[0] == nodes[1]:
            raise InvalidGraphError(f"component {name!r} has both ends on node {nodes[0]!r}: it would act on "
                                    "nothing; connect it between two different nodes", [name])
        if kind in ("M", "F", "S", "DC") and nodes[0] == FRAME:
            raise InvalidGraphError(f"component {name!r} is on the frame {FRAME!r}, which does not move; put it "
                                    "on a moving node", [name])
        if kind == "G" and FRAME in nodes:
            raise InvalidGraphError(f"gear {name!r} has a shaft on the frame {FRAME!r}: connect it between two "
                                    "moving shafts", [name])
        if kind == "M":
            for other in self._parts.values():
                if other.kind == "M" and other.nodes == nodes:
                    raise InvalidGraphError(f"mass {name!r}: node {nodes[0]!r} already carries the mass "
                                            f"{other.name!r}; masses moving together are one: add them",
                                            [name, other.name])
        if kind in ("K", "B"):
            law = values.get("law")
            if law is not None and values.get("value") is not None:
                raise InvalidGraphError(f"{name!r}: give either a value or a law", [name])
            if law is not None and not callable(law):
                raise InvalidGraphError(f"{name!r}: give the law as a function of one argument, e.g. "
                                        "lambda q: k1*q + k3*q**3", [name])
        if isinstance(values.get("value"), str) and kind not in ("F", "S"):
            parameter_name(values["value"], f"value of {name!r}")
        self._parts[name] = Part(kind, name, nodes, values)

    def _check(self):
        if not self._parts:
            raise InvalidGraphError(f"mechanism {self.name!r} has no components")
        names = set(self._parts)
        for n in self.nodes:
            if n in names:
                raise DuplicateNameError(f"node {n!r} has the name of a component: the signals of both would "
                                         "clash; rename the node or the component", n)
        for n in self._positions:
            if n not in self.nodes:
                raise UnknownNameError(f"mechanism {self.name!r}: a position is given for node {n!r}, which no "
                                       "component uses; check the node's name", n)

    # ------------------------------------------------------------ building

    def build(self, parameters: Mapping | None = None, name: str | None = None,
              inputs: Mapping[str, Callable] | None = None, **options) -> HybridModel:
        """The :class:`~switching.HybridModel` of the machine.

        ``parameters`` gives values to the parameter names used and overrides
        the numbers given with the components (``{"m1": 2.0}``); ``inputs``
        the functions of ``t`` of declared inputs; ``name`` names the model
        (default: the mechanism's name); other ``options`` go to
        :class:`~switching.HybridModel` (``tolerance``, …)."""
        self._check()
        model = _Builder(self, dict(parameters or {}), dict(inputs or {})).model(name or self.name, options)
        return BuiltFrom.record(model, self, parameters, inputs, options)


class _Builder(NetlistBuilder):
    """One build of a :class:`Mechanism` (graph, automata, parameters, signals):
    each node a 1-junction (a common velocity), each two-node component on a
    0-junction (a common force)."""

    def __init__(self, mechanism: Mechanism, parameters: dict, inputs: dict):
        super().__init__(mechanism, parameters, inputs, One, Zero, Input)
        self.mechanism = mechanism
        self.X, self.V, self.F = KINDS[mechanism.kind]
        self.initial: dict[str, float] = {}
        self.velocity: dict[str, str] = {}  # node → its velocity from its mass's momentum
        self.gears: list[tuple[str, str, sp.Expr]] = []  # (input node, output node, ratio n) of each gear
        self.impacts: list[tuple[str, tuple]] = []  # (name, nodes) of each stop and backlash
        self.state_owners: dict[str, tuple] = {}  # state name → (what it is, how to rename it)
        #: the controllers' names (a source or motor voltage naming one is driven by its output)
        self.controllers = {p.name for p in mechanism._parts.values() if p.kind == "PI"}

    # -- names and values

    def relative(self, part):
        """The signals of the relative position and velocity of a two-node part."""
        a, b = part.nodes
        x = " - ".join(f"{self.X}_{n}" for n in (a, b) if n != FRAME)
        v = " - ".join(f"{self.V}_{n}" for n in (a, b) if n != FRAME)
        if a == FRAME:
            x, v = f"-{x}", f"-{v}"
        return x, v

    def force_and_speed(self, name: str, bond, sign: int, owner: str) -> None:
        """The signals ``F_<name>`` and ``v_<name>`` of a part whose element is on ``bond``:
        ``F = sign·e``, ``v = sign·f``."""
        minus = "-" if sign < 0 else ""
        self.signal(f"{self.F}_{name}", f"{minus}e_{bond.name}", owner)
        self.signal(f"{self.V}_{name}", f"{minus}f_{bond.name}", owner)

    def mass(self, part):
        name, (n,) = part.name, part.nodes
        what = "mass" if self.mechanism.kind == "translational" else "inertia"
        owner = f"{what} {name!r}"
        value = self.number_or_parameter(part.values["value"], name, f"{what} of {owner}", rename=f"rename {owner}",
                                         allowed=Range(f"the {what} of {owner}", 0.0, low_open=True))
        storage = I(name, value, state=f"p_{name}")
        self.state_owners[f"p_{name}"] = (f"the momentum of {owner}", f"rename {owner}")
        self.note(n, self.graph.connect(self.node(n), storage))
        # from the state, not the bond's flow: in a locked mode a dependent mass's flow is the constraint's,
        # and the guards of an impact must see the velocities before the jump
        self.velocity[n] = f"p_{name}/({value})"
        self.signal(f"{self.V}_{name}", self.velocity[n], owner)
        self.signal(f"{self.X}_{name}", f"{self.X}_{n}", owner)
        if part.values["v0"]:
            self.initial[f"p_{name}"] = (value, part.values["v0"])

    def passive(self, part):
        name, law = part.name, part.values.get("law")
        spring = part.kind == "K"
        owner = f"{'spring' if spring else 'damper'} {name!r}"
        what = "stiffness" if spring else "damping"
        value = None if law else self.number_or_parameter(part.values["value"], name, f"{what} of {owner}",
                                                          rename=f"rename {owner}",
                                                          allowed=Range(f"the {what} of {owner}", 0.0))

        def element(sign):
            if law:
                wrapped = law if sign == 1 else (lambda x, f=law: -f(-x))
                return C(name, effort_law=wrapped) if spring else R(name, effort_law=wrapped)
            return C(name, 1 / value) if spring else R(name, value)

        sign, bond = self.branch(part, element)
        self.force_and_speed(name, bond, sign, owner)
        if spring:
            self.state_owners[self.graph.elements[name].state.name] = (f"the deflection of {owner}", f"rename {owner}")
        if spring and part.values["q0"]:
            storage = self.graph.elements[name]
            if law:
                raise InvalidGraphError(f"spring {name!r}: q0 with a law is not supported; give the initial "
                                        "deflection of a linear spring, or start the law's spring relaxed", [name])
            self.initial[storage.state.name] = (None, sign * part.values["q0"])

    def start_unit_state(self, storage, value: float) -> None:
        """The state of a unit capacity ``storage`` starts at ``value``."""
        self.initial[storage.state.name] = (None, value)

    def source(self, part):
        name, (n,) = part.name, part.nodes
        value = controller_placeholder(self, part.values["value"])
        if value is None:
            value = self.expression_value(part.values["value"], repr(name), name)
        bond = self.graph.connect((Se if part.kind == "F" else Sf)(name, value), self.node(n))
        self.note(n, bond)
        self.force_and_speed(name, bond, 1, f"{'force' if part.kind == 'F' else 'prescribed velocity'} {name!r}")

    def gear(self, part):
        name, (a, b) = part.name, part.nodes
        owner = f"gear {name!r}"
        ratio = self.number_or_parameter(part.values["value"], name, f"ratio of {owner}", rename=f"rename {owner}")
        gear = TF(name, 1 / ratio)
        self.gears.append((a, b, ratio))
        ends = {"in": self.graph.connect(self.node(a), gear, name=self.bond_name(f"{name}_in")),
                "out": self.graph.connect(gear, self.node(b), name=self.bond_name(f"{name}_out"))}
        self.note(a, ends["in"])
        self.note(b, ends["out"])
        for end, bond in ends.items():
            self.signal(f"{self.F}_{name}_{end}", f"e_{bond.name}", owner)
            self.signal(f"{self.V}_{name}_{end}", f"f_{bond.name}", owner)

    def motor(self, part):
        name, (n,), values = part.name, part.nodes, part.values
        owner = f"motor {name!r}"
        k = self.number_or_parameter(values["k"], f"{name}_k", f"constant k of {owner}")
        voltage = controller_placeholder(self, values["V"])
        if voltage is None:
            voltage = self.expression_value(values["V"], owner, f"{name}_V")
        armature = self.graph.add(One(self.internal(f"{name}_armature")))
        self.graph.connect(Se(self.internal(f"{name}_V"), voltage), armature)
        resistance = self.number_or_parameter(values["R"], f"{name}_R", f"armature resistance R of {owner}",
                                              allowed=Range(f"the armature resistance of {owner}", 0.0))
        self.graph.connect(armature, R(self.internal(f"{name}_R"), resistance))
        if values["L"] is not None:
            inductance = self.number_or_parameter(values["L"], f"{name}_L", f"armature inductance L of {owner}",
                                                  allowed=Range(f"the armature inductance of {owner}", 0.0,
                                                                low_open=True))
            self.graph.connect(armature, I(self.internal(f"{name}_L"), inductance, state=f"p_{name}_L"))
            self.state_owners[f"p_{name}_L"] = (f"the armature flux linkage of {owner}", f"rename {owner}")
            if values["i0"]:
                self.initial[f"p_{name}_L"] = (inductance, values["i0"])
        elif values["i0"]:
            raise InvalidGraphError(f"motor {name!r}: i0 needs an inductance L (without one the current "
                                    "follows the voltage at once)", [name])
        gyrator = GY(name, k)
        electrical = self.graph.connect(armature, gyrator, name=self.bond_name(f"{name}_e"))
        mechanical = self.graph.connect(gyrator, self.node(n), name=self.bond_name(f"{name}_m"))
        self.note(n, mechanical)
        self.signal(f"i_{name}", f"f_{electrical.name}", owner)
        self.signal(f"emf_{name}", f"e_{electrical.name}", owner)
        self.signal(f"T_{name}", f"e_{mechanical.name}", owner)
        self.signal(f"omega_{name}", f"f_{mechanical.name}", owner)

    def locking(self, part, owner: str):
        """A controlled 0-junction ``name`` between the part's nodes (off: no
        force; on: the nodes move together); its force and relative motion signals."""
        name, (a, b) = part.name, part.nodes
        junction = self.graph.add(Zero(name, controlled=True))
        if a == FRAME:
            first = self.graph.connect(Sf(self.internal(f"{name}_frame"), 0), junction,
                                       name=self.bond_name(f"{name}_in"))
        else:
            first = self.graph.connect(self.node(a), junction, name=self.bond_name(f"{name}_in"))
            self.note(a, first)
        if b == FRAME:
            self.graph.connect(junction, Sf(self.internal(f"{name}_frame"), 0), name=self.bond_name(f"{name}_out"))
        else:
            self.note(b, self.graph.connect(junction, self.node(b), name=self.bond_name(f"{name}_out")))
        self.signal(f"{self.F}_{name}", f"e_{first.name}", owner)
        x, v = self.relative(part)
        self.signal(f"{self.V}_{name}", v, owner)
        return x

    def clutch(self, part):
        name, values = part.name, part.values
        owner = f"clutch {name!r}"
        engaging = self.user_text(values["engaged_when"])
        releasing = self.user_text(values["disengaged_when"] or f"not ({engaging})")
        initial = values["engaged"]
        if initial is None:
            initial = holds_at_start(engaging, {**self.defaults, **self.given})
        if values["T_max"] is None:
            self.locking(part, owner)
            states, extra = {"disengaged": {name: False}, "engaged": {name: True}}, {}
        else:
            t_max = self.number_or_parameter(values["T_max"], f"{name}_T_max", f"slip torque T_max of {owner}",
                                             allowed=Range(f"the slip torque of {owner}", 0.0))
            gate = sp.Symbol(self.names.claim(f"engaged_{name}", Owner(
                f"the engagement (0 or 1) of {owner}", f"rename {owner}", "mode value")))

            def element(sign):
                return R(name, effort_law=lambda w: gate * t_max * sp.sign(w))  # odd: the same either way

            sign, bond = self.branch(part, element)
            self.force_and_speed(name, bond, sign, owner)
            states = {"disengaged": {}, "engaged": {}}
            extra = {"values": {"disengaged": {gate.name: 0}, "engaged": {gate.name: 1}}}
        automaton = Automaton(name, states, initial="engaged" if initial else "disengaged", **extra)
        automaton.add_transition("disengaged", "engaged", engaging, "a priori")
        automaton.add_transition("engaged", "disengaged", releasing, "a priori")
        self.automata.append(automaton)

    def limit(self, part):
        name, values = part.name, part.values
        backlash = isinstance(values["lower"], tuple)
        owner = f"{'backlash' if backlash else 'stop'} {name!r}"
        self.impacts.append((name, part.nodes))
        x = self.locking(part, owner)
        self.signal(f"{self.X}_{name}", x, owner)
        d, w, force = f"{self.X}_{name}", f"{self.V}_{name}", f"{self.F}_{name}"
        default = f"{name}_delta" if backlash else None
        e = self.number_or_parameter(values["e"], f"{name}_e", f"restitution e of {owner}",
                                     allowed=Range(f"the restitution of {owner}", 0.0, 1.0, required=True))
        v_th = self.number_or_parameter(values["v_th"], f"{name}_v_th", f"landing speed v_th of {owner}",
                                        allowed=Range(f"the landing speed of {owner}", 0.0, required=True))
        states, restitution, transitions = {"free": {name: False}}, {}, []
        for side, sense in (("upper", ""), ("lower", "-")):
            if values[side] is None:
                continue
            bound = self.number_or_parameter(values[side], default or f"{name}_{side}",
                                             f"{'half-width delta' if backlash else side + ' position'} of {owner}")
            states[f"{side}_impact"] = {name: True}
            states[side] = {name: True}
            restitution[f"{side}_impact"] = e
            reached = f"{sense}({d} - ({bound})) >= 0"
            approach = f"{sense}{w}"
            transitions += [
                ("free", f"{side}_impact", f"{reached} and {approach} > {v_th}", "a priori"),
                ("free", side, f"{reached} and {approach} > 0 and {approach} <= {v_th}", "a priori"),
                (f"{side}_impact", "free", f"{approach} < 0", "a priori"),
                (f"{side}_impact", side, f"{approach} <= 0 and {approach} >= 0", "a priori"),
                (side, "free", f"{sense}{force} < 0", "a posteriori"),
            ]
        automaton = Automaton(name, states, initial="free", restitution=restitution)
        for transition in transitions:
            automaton.add_transition(*transition)
        self.automata.append(automaton)

    def reflected_velocity(self, node: str) -> str | None:
        """The velocity of ``node`` read from the momentum of a mass geared to it, as text, or ``None``
        when no mass is: across a gear of ratio ``n`` from ``a`` to ``b`` (``v_b = v_a/n``), a node's
        velocity is ``v_a/n`` from its input side and ``n·v_b`` from its output side, through any chain
        of gears and levers (TFs: rigid in every mode, their moduli continuous at an instant).  The
        nearest mass by gears is taken (any other gives the same velocity: the gears tie them)."""
        factor, queue = {node: sp.Integer(1)}, [node]  # v_node = factor[u]·v_u for each node u reached
        for u in queue:
            if u in self.velocity:
                return f"({factor[u]})*({self.velocity[u]})"
            for a, b, n in self.gears:
                for near, far, scale in ((a, b, n), (b, a, 1 / n)):  # v_a = n·v_b, v_b = v_a/n
                    if near == u and far not in factor:
                        factor[far] = factor[u] * scale
                        queue.append(far)
        return None

    def impact_velocities(self) -> None:
        """Each moving node of a stop or backlash with its velocity before an impact from the momenta:
        its mass's ``p/m`` or, without a mass of its own, that of a mass geared to it (the inertia
        reflected through the gears, :meth:`reflected_velocity`): in an impact or contact mode the node's
        flow is the constraint's, and the guards must see the velocity the jump reverses.  A node with
        no mass behind it (springs, dampers, prescribed motion only) is refused: its impact would be
        of a massless node."""
        for name, nodes in self.impacts:
            for n in nodes:
                if n == FRAME or n in self.velocity:
                    continue
                reflected = self.reflected_velocity(n)
                if reflected is None:
                    raise InvalidGraphError(
                        f"{name!r} acts on node(s) {n!r} without a mass: no mass (inertia) is on node {n!r} or "
                        "geared to it, so its impact would be of a massless node (springs, dampers or a "
                        f"prescribed motion only behind it); put a mass (inertia) on node {n!r}, or on a node "
                        "it is geared to (gear, lever)", [name])
                self.velocity[n] = reflected

    # -- the model

    def model(self, name: str, options: dict) -> HybridModel:
        m = self.mechanism
        parts = sorted(m._parts.values(), key=lambda part: part.kind != "M")  # masses first (the elements' order)
        for part in parts:
            {"M": self.mass, "K": self.passive, "B": self.passive, "F": self.source, "S": self.source, "G": self.gear,
             "DC": self.motor, "CL": self.clutch, "ST": self.limit, "PI": lambda part: None}[part.kind](part)
        self.impact_velocities()
        for n, junction in self.junctions.items():
            self.graph.displacement(f"{self.X}_{n}", of=junction)
            self.state_owners[f"{self.X}_{n}"] = (f"the position of node {n!r}", f"rename node {n!r}")
        signals = {}
        for n, bond in self.node_bond.items():
            self.names.claim(f"{self.V}_{n}", Owner(f"signal '{self.V}_{n}' (the velocity of node {n!r})",
                                                    f"rename node {n!r}", "signal"))
            signals[f"{self.V}_{n}"] = self.velocity.get(n, f"f_{bond}")
        controllers = [part for part in parts if part.kind == "PI"]
        if controllers:  # (their states read every other signal)
            build_controllers(self, controllers, {**signals, **self.signals})
        signals.update(self.signals)
        self.claim_graph_names(self.state_owners)
        self.claim_text_names()
        parameters = self.parameters_checked()
        initial_state = {f"{self.X}_{n}": x0 for n, x0 in m._positions.items()}
        values = {sp.Symbol(k): v for k, v in parameters.items()}
        for state, (scale, value) in self.initial.items():
            if scale is not None:
                scale = scale.subs(values)
                if scale.free_symbols:
                    raise MissingParameterError(sorted(s.name for s in scale.free_symbols))
                value = float(scale) * value
            initial_state[state] = value
        missing = sorted(set(self.graph.inputs) - set(self.inputs))
        if missing:
            raise InvalidGraphError(f"mechanism {m.name!r}: input(s) {', '.join(missing)} have no function: give "
                                    "build(inputs={name: function of t})", missing)
        prefixes = dict(MECHANICS_UNITS[m.kind])
        prefixes.update({f"p_{part.name}_L": "V·s" for part in m._parts.values() if part.kind == "DC"})
        units = units_by_prefix(list(signals) + [s.name for s in self.graph.states], prefixes, self.unitless)
        return HybridModel(self.graph, self.automata, parameters, initial_state=initial_state, signals=signals,
                           inputs=self.inputs or None, name=name, units=units, **options)


def _impact_values(e, v_th, owner: str) -> dict:
    """A stop's or backlash's restitution ``e`` (0 ≤ e ≤ 1) and landing speed ``v_th`` (≥ 0), checked:
    numbers in their range or parameter names."""
    e = checked_argument(e, f"the restitution e of {owner}")
    v_th = checked_argument(v_th, f"the landing speed v_th of {owner}")
    if not isinstance(e, str) and not 0.0 <= e <= 1.0:
        raise ParameterValueError(f"the restitution e of {owner} is {e:g}: give 0 <= e <= 1 (0 a plastic, 1 an "
                                  "elastic impact)", "e", e)
    if not isinstance(v_th, str) and v_th < 0:
        raise ParameterValueError(f"the landing speed v_th of {owner} is {v_th:g}: give a speed >= 0", "v_th", v_th)
    return {"e": e, "v_th": v_th}
