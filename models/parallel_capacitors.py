"""Two capacitors at different voltages joined by a switch (charge sharing).

Bond graph (power directions by arrows)::

    C: C1 ◄── 0_n1 ──► 1_sw (controlled) ──► 0_n2 ──► C: C2
    (q1)                  │                           (q2)
                          ▼
                        R: R          (only when R > 0)

``1_sw`` is the switch: off (``open``) it imposes zero current on its bonds,
on (``closed``) it is an ordinary 1-junction whose common flow is the
current ``i`` from capacitor 1 to capacitor 2.

* ``R = 0`` (the default): the R element is left out.  Closed, the switch
  forces ``v1 = v2``: one capacitor is in derivative causality (dependent),
  and entering ``closed`` the jump map (conservation of state) shares the
  charge: ``q1 + q2`` is conserved and both voltages become
  ``(q1 + q2)/(C1 + C2)``.  The current is a Dirac pulse of area
  ``Δq1 = C1 C2/(C1 + C2)·(v1 − v2)``, and the energy
  ``ΔE = C1 C2/(2 (C1 + C2))·(v1 − v2)²`` is lost in the jump: it is the
  energy a resistance of *any* value would dissipate (parameter
  abstraction of the wires and the switch).
* ``R > 0``: the R element sits on ``1_sw`` (in series with the switch).
  Closed, both capacitors keep integral causality and exchange charge
  continuously, ``i = (v1 − v2)/R`` decaying with
  ``τ = R C1 C2/(C1 + C2)``: the same final state is reached with the same
  ``ΔE`` dissipated in ``R`` (``∫ R i² dt``), now over time.

(``R = 0`` cannot be a resistor of zero value: its conductance form
``i = Δv/R`` would divide by zero.  The structure is chosen when the model is
built.)

Automaton ``switch`` (states ``open``, ``closed``):

* ``open → closed`` when ``t >= t_close`` (**a priori**: an external command
  on time, not a consequence of the jump — it is the same evaluated on
  ``x`` or on ``x⁺``).  ``closed`` has no outgoing transition, so with
  ``R = 0`` the mode after the jump is continuous (it is not a pinnacle:
  the capacitors stay connected).

Sign conventions and units: charges ``q1``, ``q2`` [C] on the positive
plates; voltages ``v1 = q1/C1``, ``v2 = q2/C2`` [V] across each capacitor
(the negative plates share the common return); the current [A] is positive
from capacitor 1 to capacitor 2; ``C1``, ``C2`` [F], ``R`` [Ω], ``t_close``
[s]; energies [J].

States: ``q1``, ``q2``.
Signals: ``v1``, ``v2`` (voltages), ``q_total = q1 + q2`` (conserved at every
instant and during flow), ``energy = q1²/(2 C1) + q2²/(2 C2)`` (the stored
electric energy).

Valid range (exercised by ``tests/models/test_model_ranges.py``): ``C1, C2 > 0``
(tested 1e-12 to 1 F, ratios 1e-3 to 1e3), ``R >= 0`` (0, and 1e-3 to 1e6 Ω),
any initial voltages (tested 1e-6 to 1e6 V, equal or opposite).  One instant at
``t_close``; ``q_total`` is conserved throughout.  With ``R > 0`` the time
constant is ``τ = R C1 C2/(C1 + C2)``; when ``τ`` is far below the run (below
about 1e-3 of it) an explicit method (RK45) stops with
:class:`~switching.StiffnessError` after the switch closes; use Radau, BDF
or LSODA (or ``R = 0``, the ideal limit).  A ``τ`` at the round-off of the time
itself (below about 1e-11 of ``t_close``: a milliohm on femtofarads) cannot be
stepped by any method when the voltages differ: :class:`~switching.StepSizeError`;
use ``R = 0``.
"""

from __future__ import annotations

from bondgraph import C, BondGraph, One, R, Zero
from switching import Automaton, HybridModel

from ._common import annotated, merged, nonnegative, positive

__all__ = ["build", "DEFAULTS", "RUN", "SIGNALS", "error_estimate", "UNITS"]

DEFAULTS = {
    "C1": 1e-3,
    "C2": 2e-3,
    "V1": 5.0,
    "V2": 1.0,
    "R": 0.0,
    "t_close": 0.01,
}
#: physical ranges: a value outside gives a PhysicalRangeWarning
RANGES = {
    "C1": positive("a capacitance", required=True),
    "C2": positive("a capacitance", required=True),
    "R": nonnegative("a resistance", required=True),
}
#: a meaningful default run (used by ``hbg run``): the switch closes at 10 ms
RUN = {"t_end": 0.05, "rtol": 1e-9, "atol": 1e-12}
#: the unit of each parameter, state and signal (shown on plots, kept in model files)
UNITS = {"C1": "F", "C2": "F", "R": "Ω", "t_close": "s", "V1": "V", "V2": "V", "q1": "C", "q2": "C",
         "v1": "V", "v2": "V", "q_total": "C", "energy": "J"}

SIGNALS = ("v1", "v2", "q_total", "energy")


def build(**parameters) -> HybridModel:
    """The two capacitors with ``DEFAULTS`` overridden by ``parameters``."""
    p = merged(DEFAULTS, parameters, RANGES, "parallel_capacitors")
    g = BondGraph("parallel_capacitors")
    n1, sw, n2 = g.add(Zero("n1")), g.add(One("sw", controlled=True)), g.add(Zero("n2"))
    g.connect(n1, C("cap1", "C1", state="q1"))
    g.connect(n2, C("cap2", "C2", state="q2"))
    g.connect(n1, sw, name="i1")
    g.connect(sw, n2, name="i2")
    if p["R"] > 0:
        g.connect(sw, R("resistor", "R"))
    switch = Automaton("switch", {"open": {"sw": False}, "closed": {"sw": True}}, initial="open")
    switch.add_transition("open", "closed", "t >= t_close", "a priori")
    names = ["C1", "C2", "t_close", "V1", "V2"] + (["R"] if p["R"] > 0 else [])
    model_parameters = {name: p[name] for name in names}
    return HybridModel(
        g,
        [switch],
        model_parameters,
        initial_state={"q1": "C1*V1", "q2": "C2*V2"},
        signals={
            "v1": "q1/C1",
            "v2": "q2/C2",
            "q_total": "q1 + q2",
            "energy": "q1**2/(2*C1) + q2**2/(2*C2)",
        },
        name="parallel_capacitors",
        **annotated(UNITS, RANGES, DEFAULTS, model_parameters),
    )


def error_estimate(trajectory) -> str:
    """Largest error of ``v1``, ``v2`` against the closed form (constant while
    open; then the charge-sharing jump, or the RC exponential when R > 0)."""
    import numpy as np

    model = trajectory.model
    values = {s.name: v for s, v in model.parameter_values.items()}
    C1, C2, t_close, R_ = values["C1"], values["C2"], values["t_close"], values.get("R", 0.0)
    V1, V2 = trajectory.signal("v1")[0], trajectory.signal("v2")[0]
    if trajectory.t[0] > t_close:
        return "n/a (closed form for a run starting before t_close)"
    v = (C1 * V1 + C2 * V2) / (C1 + C2)
    t = trajectory.t
    closed = np.zeros(len(t), dtype=bool)
    if trajectory.events:
        closed[trajectory.event_index[0]:] = True
    decay = np.exp(-np.maximum(t - t_close, 0.0) / (R_ * C1 * C2 / (C1 + C2))) if R_ > 0 else np.zeros(len(t))
    exact1 = np.where(closed, v + (V1 - v) * decay, V1)
    exact2 = np.where(closed, v + (V2 - v) * decay, V2)
    error = max(np.max(np.abs(trajectory.signal("v1") - exact1)), np.max(np.abs(trajectory.signal("v2") - exact2)))
    return f"{error:.2e} V on v1, v2 (closed form)"
