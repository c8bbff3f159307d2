"""Periodic orbits of a hybrid model through its jumps, by Newton shooting on
the period map (:func:`periodic_orbit`).

**Fixed period** (clock-driven switching, ``period=T`` [s]): the period map
is the flow over one period, jumps included, from ``t0``:
``φ(x0) = x(t0 + T; x0)``, and the orbit solves ``F(x0) = φ(x0) − x0 = 0``.
Newton's step uses ``J = M − I`` with the *monodromy*
``M = ∂x(t0 + T)/∂x0`` (n × n), the forward sensitivities of the run with
respect to every initial state (``sensitivities=["x0:<state>", ...]``,
:mod:`switching.analysis.sensitivity`): they cross every instant with its
saltation matrix, ``S⁺ = Ξ S⁻``, ``Ξ = G_x + (f⁺ − G_x f⁻) h_x / ḣ`` (``G_x``
the jump's Jacobian, ``f∓`` the rates before and after, ``h`` the guard
comparison that located the instant, ``ḣ = h_x f⁻ + h_t`` its rate); at a
clock event (a guard on ``t`` alone) ``h_x = 0`` and ``Ξ = G_x``.
In a start mode that holds some states dependent (on a constraint), the
run first projects x0 onto the constraint (the mode's jump map), so ``M``
maps the directions that projection removes to 0 and ``J = M − I`` is
``−I`` on them, not singular; the step is solved in least squares all the
same, and the iterates land on the constraint after one step.

**Autonomous orbits** (``section=(automaton, source, target)``): the period
is the time of the ``crossings``-th instant at which ``automaton`` takes
the transition ``source → target`` (an impact, a relay's switch), and x0
is the state just after such an instant, in the mode it leads to.  The
return map ``P(x0) = x⁺(τ(x0))`` (the state just after the section's event
at its time ``τ``) eliminates the period: ``F(x0) = P(x0) − x0`` with
``DP = S(τ⁺) + f⁺ τ_x``, ``S(τ⁺)`` the sensitivity at fixed time just after
the event, ``f⁺`` the rates there and ``τ_x = ∂τ/∂x0`` the event time's
gradient.  This is the bordered Newton system on ``(x0, T)`` with the
section as its phase condition, ``T`` solved out: ``DP`` maps the flow
direction ``f⁺(x0)`` to 0 and its other eigenvalues are the nontrivial
Floquet multipliers, so ``DP − I`` is regular for a hyperbolic orbit.  The
monodromy ``M = S(τ⁺)`` of the autonomous orbit has the *trivial*
multiplier 1 along ``f⁺(x0)``; it is identified (the eigenvector most
aligned with ``f⁺``) and reported apart.

The first run of an autonomous search goes from the guess to the section
(iterate 0 moves the guess onto it, ``x0 ← P(x0)``); Newton starts there.

Residual [dimensionless]: ``max_i |F_i| / s_i`` with ``s_i`` the amplitude
``max_t |x_i(t)|`` of state i over the iterate's period (``atol`` if that
is smaller), so states of different units weigh alike.  Converged when the
residual is at most ``tol``.

Failures raise :class:`~switching.errors.OrbitError` subclasses naming the
iterate, its residual and what to try: :class:`OrbitConvergenceError` (no
convergence in ``max_iterations``, a run that fails, no return to the
section), :class:`ModeSequenceChangedError` (two iterates flow through
different mode sequences in one period: the period map is not smooth
between them), :class:`GrazingError` (an event the orbit reaches nearly
tangentially: the ratio ``max_j |∂τ/∂x0_j| s_j / T`` of a state event
exceeds ``grazing_limit``, or the crossing rate is zero).  Near a tangency
``h(t) ≈ h_max − ḧ (t − t_p)²/2`` crossing ``h_max − δ``, the rate at the crossing is
``sqrt(2 ḧ δ)``, so the ratio grows as ``δ^{−1/2}``; transversal events give
ratios of order 1 to 10 (the shipped models' orbits: 0.1 to 3), and the
default limit 1e3 flags a guard missed by a relative ``δ`` of about 1e-9
(an event time moved by 1e3 periods per unit relative change of the state).
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import GrazingError, ModeSequenceChangedError, OrbitConvergenceError, OrbitError, SimulationError

__all__ = ["PeriodicOrbit", "periodic_orbit"]


@dataclass
class PeriodicOrbit:
    """A periodic orbit found by :func:`periodic_orbit`.

    ``trajectory``: the run over one period from ``x0`` at ``t0`` (an
    autonomous orbit's ends with the section's event); ``period`` [s];
    ``x0`` (n,): the state at the start (autonomous: just after the section's
    event); ``modes``: the modes flowed through in one period, in order (the
    start mode first; consecutive repeats merged); ``monodromy`` (n × n):
    ``∂x(t0 + T)/∂x0``; ``multipliers``: the nontrivial Floquet multipliers
    (eigenvalues of the monodromy, the trivial one removed for an autonomous
    orbit), largest modulus first; ``trivial_multiplier``: the one along the
    flow (≈ 1; ``None`` for a fixed period); ``stable``: all nontrivial
    ``|μ| < 1``; ``iterations``: Newton steps taken; ``residuals``: the
    residual of every iterate (see the module docstring); ``section``:
    ``(automaton, source, target)`` or ``None``; ``wall_time`` [s];
    ``grazing_ratio``: the largest ``max_j |∂τ_k/∂x0_j| s_j / T`` over the
    orbit's instants ``k`` (how far the orbit is from grazing a guard: large
    near a tangential touch, 0 with clock events only).

    :meth:`small_signal` and :meth:`to_control`: the discrete small-signal
    model of the period map (:mod:`switching.analysis.linear`)."""

    trajectory: object
    period: float
    x0: np.ndarray
    modes: tuple
    monodromy: np.ndarray
    multipliers: np.ndarray
    trivial_multiplier: complex | None
    stable: bool
    iterations: int
    residuals: list = field(default_factory=list)
    section: tuple | None = None
    t0: float = 0.0
    wall_time: float = 0.0
    grazing_ratio: float = 0.0
    #: ``(shooter, mode)``: the runs' settings and the mode the orbit's runs start in (for :meth:`small_signal`)
    shooting: tuple | None = field(default=None, repr=False, compare=False)

    @property
    def residual(self) -> float:
        """The residual of the returned orbit."""
        return self.residuals[-1]

    @property
    def mode_names(self) -> list:
        return [m.describe() for m in self.modes]

    def small_signal(self, inputs=(), outputs=None):
        """``δx_{k+1} = A δx_k + B δu_k``, ``y_k = C δx_k + D δu_k`` over one
        period, ``A`` the period (return) map's Jacobian, ``B`` its derivative
        with respect to the model parameters ``inputs``, ``C``, ``D`` the
        Jacobians of the signals ``outputs`` (default: the states) at the
        start: a :class:`~bondgraph.linear_system.LinearSystem` with ``dt =
        period`` (:func:`switching.analysis.linear.orbit_small_signal`)."""
        from .linear import orbit_small_signal

        return orbit_small_signal(self, inputs, outputs)

    def to_control(self, inputs=(), outputs=None):
        """:meth:`small_signal` as a discrete-time ``control.StateSpace``
        (python-control, ``pip install "hybrid-bondgraph[control]"``; at least
        one input)."""
        return self.small_signal(inputs, outputs).to_control()


def _describe(modes) -> str:
    return " → ".join(m.describe() for m in modes)


class _Shooter:
    def __init__(self, model, period, section, crossings, t0, method, rtol, atol, tol, max_iterations,
                 max_period, grazing_limit, options):
        self.model = model
        self.states = [s.name for s in model.states]
        self.n = len(self.states)
        self.names = [f"x0:{s}" for s in self.states]
        #: model parameters whose sensitivities the runs also carry (columns after the initial states)
        self.parameters: list = []
        self.period = period
        self.section = section
        self.crossings = crossings
        self.t0 = t0
        self.method = method
        self.rtol, self.atol, self.tol = rtol, atol, tol
        self.max_iterations = max_iterations
        self.grazing_limit = grazing_limit
        self.options = options
        if section is not None:
            if max_period is None and period is None:
                raise OrbitError("an autonomous orbit needs a horizon to look for its return to the section: pass "
                                 "max_period= (seconds) or a guess period= of the period")
            self.horizon = float(max_period) if max_period is not None else 4.0 * float(period)
        self.residuals: list = []

    # ---------------------------------------------------------------- one run

    def run(self, x, mode, t_end, iterate):
        try:
            return self.model.simulate(t_end, self.method, t0=self.t0, x0=x, mode=mode, rtol=self.rtol,
                                       atol=self.atol, sensitivities=self.columns, sensitivity_rtol=self.rtol,
                                       sensitivity_atol=self.atol, **self.options)
        except SimulationError as error:
            if "touches its threshold without crossing" in str(error):
                raise GrazingError(
                    f"periodic_orbit: iterate {iterate} grazes a guard (x0 = {self.show(x)}): {error}. The period "
                    "map is not differentiable at a tangential touch; start from another guess, or change a "
                    "parameter so the orbit crosses the guard transversally (or misses it)",
                    iterate, x, float("nan"), self.residuals, t=error.t, ratio=float("inf")) from error
            raise OrbitConvergenceError(
                f"periodic_orbit: the run of iterate {iterate} from x0 = {self.show(x)} failed: {error}. Try a "
                "better initial guess (x0=, or warmup= periods of plain simulation first)",
                iterate, x, float("nan"), self.residuals) from error

    def show(self, x) -> str:
        return ", ".join(f"{s} = {v:.10g}" for s, v in zip(self.states, np.asarray(x, dtype=float)))

    @property
    def columns(self) -> list:
        """The sensitivities of every run: the initial states, then :attr:`parameters`."""
        return self.names + self.parameters

    def sensitivity_matrix(self, trajectory, row) -> np.ndarray:
        """``∂x/∂(x0, p)`` (n × (n + m)) at sample ``row``."""
        return np.array([[trajectory.sensitivity(s, p)[row] for p in self.columns] for s in self.states])

    def start_mode(self, trajectory):
        events = trajectory.events
        if events and events[0].t == trajectory.t[0]:
            return events[0].mode_after
        return trajectory.modes[0]

    def sequence(self, trajectory, last_event: int | None):
        """The modes flowed through, start mode first, up to event ``last_event`` (all when ``None``)."""
        modes = [self.start_mode(trajectory)]
        t_start = trajectory.t[0]
        for k, event in enumerate(trajectory.events):
            if last_event is not None and k > last_event:
                break
            if event.t == t_start:
                continue
            if event.mode_after != modes[-1]:
                modes.append(event.mode_after)
        return tuple(modes)

    def check_grazing(self, trajectory, last_event, T, scale, x, iterate) -> float:
        """The largest ratio ``max_j |∂τ_k/∂x0_j| s_j / T`` over the period's events (0 without state
        events); raises :class:`GrazingError` above ``grazing_limit``."""
        largest = 0.0
        for k, event in enumerate(trajectory.events):
            if last_event is not None and k > last_event:
                break
            if event.t == trajectory.t[0]:
                continue
            tau_x = np.array([trajectory.event_time_sensitivity(k, p) for p in self.names])
            ratio = float(np.max(np.abs(tau_x) * scale) / T)
            if not np.isfinite(ratio) or ratio > self.grazing_limit:
                steps = " → ".join(f"{s.mode.describe()} ({s.kind})" for s in event.steps)
                raise GrazingError(
                    f"periodic_orbit: iterate {iterate} (x0 = {self.show(x)}, residual {self.residuals[-1]:.3g}) nearly grazes a guard at the event "
                    f"at t = {event.t:.12g} s ({steps}): its time moves by {ratio:.3g} periods per unit relative "
                    f"change of the initial state (limit grazing_limit = {self.grazing_limit:g}). The period map "
                    "is not smooth at a tangential touch: start from another guess, or change a parameter so the "
                    "orbit crosses the guard transversally", iterate, x, self.residuals[-1], self.residuals,
                    t=event.t, ratio=ratio)
            largest = max(largest, ratio)
        return largest

    def section_event(self, trajectory) -> int | None:
        """The index of the ``crossings``-th section event after the start, or ``None``."""
        automaton, source, target = self.section
        count = 0
        for k, event in enumerate(trajectory.events):
            if event.t == trajectory.t[0]:
                continue
            if any((f.automaton, f.source, f.target) == (automaton, source, target)
                   for step in event.steps for f in step.fired):
                count += 1
                if count == self.crossings:
                    return k
        return None

    # ---------------------------------------------------------------- the map

    def evaluate(self, x, mode, iterate):
        """``(F, J, M, T, trajectory, modes, scale, end_mode, x_end)`` at ``x``."""
        if self.section is None:
            T = float(self.period)
            tr = self.run(x, mode, self.t0 + T, iterate)
            x_end = np.array(tr.x[-1], dtype=float)
            derivative = self.sensitivity_matrix(tr, -1)
            last, end_mode = None, tr.modes[-1]
        else:
            while True:
                tr = self.run(x, mode, self.t0 + self.horizon, iterate)
                last = self.section_event(tr)
                if last is not None:
                    break
                if self.horizon > 1e3 * self.first_horizon:
                    raise OrbitConvergenceError(
                        f"periodic_orbit: iterate {iterate} (x0 = {self.show(x)}) does not reach the section "
                        f"{self.section_text()} (crossing {self.crossings}) within {self.horizon:.6g} s. Check the "
                        "section's automaton and transition names, or pass a larger max_period=",
                        iterate, x, float("nan"), self.residuals)
                self.horizon *= 2.0
            event = tr.events[last]
            row = tr.event_index[last]
            T = event.t - self.t0
            tr = tr.take(np.arange(row + 1))  # one period: up to the section's event, its instant the last
            tr.events = list(tr.events[:last + 1])
            x_end = np.array(event.x_after, dtype=float)
            S = self.sensitivity_matrix(tr, row)
            f_plus = np.asarray(self.model.compiled_mode(event.mode_after).rates(x_end, event.t), dtype=float)
            tau = np.array([tr.event_time_sensitivity(last, p) for p in self.columns])
            derivative = S + np.outer(f_plus, tau)  # the return map's, DP and ∂P/∂p
            M = S[:, :self.n]
            end_mode = event.mode_after
            self.horizon = max(self.horizon, 1.5 * T)
        if self.section is None:
            M = derivative[:, :self.n]
        J = derivative[:, :self.n] - np.eye(self.n)
        #: the period (return) map's derivative with respect to :attr:`parameters` (n × m)
        self.parameter_jacobian = derivative[:, self.n:]
        F = x_end - np.asarray(x, dtype=float)
        scale = np.maximum(np.max(np.abs(tr.x), axis=0), self.atol)
        modes = self.sequence(tr, last)
        return F, J, M, T, tr, modes, scale, end_mode, x_end

    def linearization(self, x, mode, parameters) -> tuple:
        """``(DP, ∂P/∂p)``: the period map's (autonomous: the return map's)
        Jacobians at ``x`` with respect to the state (n × n) and to the
        model parameters ``parameters`` (n × m), from one run."""
        shooter = copy.copy(self)  # (this one's runs keep their columns)
        shooter.parameters = list(parameters)
        _, J, *_ = shooter.evaluate(np.asarray(x, dtype=float), mode, len(self.residuals) - 1)
        return J + np.eye(self.n), shooter.parameter_jacobian

    def section_text(self) -> str:
        automaton, source, target = self.section
        return f"{automaton}: {source} → {target}"

    # ---------------------------------------------------------------- Newton

    def solve(self, x, mode, warmup: int) -> PeriodicOrbit:
        started = time.perf_counter()
        x = np.asarray(x, dtype=float)
        if self.section is not None:
            self.first_horizon = self.horizon
            # iterate 0: from the guess onto the section
            _, _, _, _, tr, _, _, mode, x = self.evaluate(x, mode, 0)
        for _ in range(warmup):
            _, _, _, _, tr, _, _, mode, x = self.evaluate(x, mode, 0)
        previous = None
        for iterate in range(self.max_iterations + 1):
            F, J, M, T, tr, modes, scale, end_mode, _ = self.evaluate(x, mode, iterate)
            residual = float(np.max(np.abs(F) / scale))
            self.residuals.append(residual)
            if not np.isfinite(residual):
                raise OrbitConvergenceError(
                    f"periodic_orbit: iterate {iterate} (x0 = {self.show(x)}) has a non-finite residual. Start "
                    "from a guess closer to the orbit (x0=, warmup=)", iterate, x, residual, self.residuals)
            # a grazing iterate may also change the mode sequence: the grazing is the cause to report
            self.grazing_ratio = self.check_grazing(tr, None if self.section is None else len(tr.events) - 1, T,
                                                    scale, x, iterate)
            if previous is not None and modes != previous:
                raise ModeSequenceChangedError(
                    f"periodic_orbit: iterate {iterate} (x0 = {self.show(x)}, residual {residual:.3g}) flows "
                    f"through the modes {_describe(modes)} in one period, iterate {iterate - 1} through "
                    f"{_describe(previous)}: the period map is not smooth between them. Start closer to the orbit "
                    "(warmup= periods of plain simulation, or another x0=), or check that the orbit you look for "
                    "has one mode sequence", iterate, x, residual, self.residuals, before=previous, after=modes)
            previous = modes
            if residual <= self.tol:
                return self.result(tr, T, x, modes, M, iterate, started, mode)
            if iterate == self.max_iterations:
                break
            step, *_ = np.linalg.lstsq(J, -F, rcond=None)
            x = x + step
            if self.section is None:
                mode = end_mode  # a periodic orbit starts in the mode it ends in
        history = ", ".join(f"{r:.3g}" for r in self.residuals)
        stalled = len(self.residuals) > 2 and self.residuals[-1] < 1e3 * self.rtol
        advice = (f"the residual stalls near the integration tolerance rtol = {self.rtol:g}: lower rtol/atol or "
                  f"raise tol (now {self.tol:g})" if stalled else
                  "start from a guess closer to the orbit (x0=, or warmup= periods of plain simulation first), or "
                  "allow more max_iterations=")
        raise OrbitConvergenceError(
            f"periodic_orbit: Newton did not converge in {self.max_iterations} iteration(s): iterate "
            f"{len(self.residuals) - 1} (x0 = {self.show(x)}) has residual {self.residuals[-1]:.3g} > tol = "
            f"{self.tol:g} (residuals: {history}). Try: {advice}", len(self.residuals) - 1, x, self.residuals[-1],
            self.residuals)

    def result(self, tr, T, x, modes, M, iterations, started, mode) -> PeriodicOrbit:
        values, vectors = np.linalg.eig(M)
        trivial = None
        keep = np.ones(len(values), dtype=bool)
        if self.section is not None and len(values):
            f0 = np.asarray(self.model.compiled_mode(modes[0]).rates(x, self.t0), dtype=float)
            norm = np.linalg.norm(f0)
            if norm > 0:
                alignment = np.abs(vectors.conj().T @ f0) / (np.linalg.norm(vectors, axis=0) * norm)
                k = int(np.argmax(alignment - 1e-3 * np.abs(values - 1.0)))
            else:
                k = int(np.argmin(np.abs(values - 1.0)))
            trivial = complex(values[k])
            keep[k] = False
        multipliers = values[keep]
        multipliers = multipliers[np.argsort(-np.abs(multipliers), kind="stable")]
        if np.all(np.abs(multipliers.imag) == 0):
            multipliers = multipliers.real
        return PeriodicOrbit(trajectory=tr, period=float(T), x0=np.array(x, dtype=float), modes=modes,
                             monodromy=M, multipliers=multipliers,
                             trivial_multiplier=None if trivial is None else (trivial.real if trivial.imag == 0 else trivial),
                             stable=bool(np.all(np.abs(multipliers) < 1.0)), iterations=iterations,
                             residuals=list(self.residuals), section=self.section, t0=self.t0,
                             wall_time=time.perf_counter() - started, grazing_ratio=self.grazing_ratio,
                             shooting=(self, mode))


def periodic_orbit(model, period: float | None = None, *, section=None, crossings: int = 1, x0=None, mode=None,
                   t0: float = 0.0, method: str = "RK45", rtol: float = 1e-10, atol: float = 1e-12,
                   tol: float = 1e-8, max_iterations: int = 20, max_period: float | None = None, warmup: int = 0,
                   grazing_limit: float = 1e3, **options) -> PeriodicOrbit:
    """A periodic orbit of ``model`` by Newton shooting on its period map
    (the mathematics: the module docstring).

    ``period=T`` [s] alone: an orbit of fixed period ``T`` (clock-driven
    switching), ``x(t0 + T) = x(t0)``.  ``section=(automaton, source,
    target)`` (or ``"automaton: source -> target"``): an autonomous orbit
    whose period ends at the ``crossings``-th instant where ``automaton``
    takes ``source → target``; then ``period`` is only a guess that sets the
    horizon searched for the return (``4·period``, or ``max_period`` [s]).
    ``x0`` (n,): the initial guess (default: the model's initial state),
    ``mode`` the start mode (default: the model's).  ``method``, ``rtol``,
    ``atol`` and ``options`` go to every run (``model.simulate``; the
    sensitivities are integrated with the same ``rtol``/``atol``).
    ``tol``: the scaled residual to reach; ``max_iterations`` Newton steps
    at most; ``warmup``: periods of plain iteration ``x ← φ(x)`` before
    Newton (to settle into the orbit's mode sequence); ``grazing_limit``:
    see :class:`~switching.errors.GrazingError`.

    Returns a :class:`PeriodicOrbit`; raises
    :class:`~switching.errors.OrbitConvergenceError`,
    :class:`~switching.errors.ModeSequenceChangedError` or
    :class:`~switching.errors.GrazingError`.
    """
    if isinstance(section, str):
        automaton, _, rest = section.partition(":")
        source, _, target = rest.replace("→", "->").partition("->")
        section = (automaton.strip(), source.strip(), target.strip())
        if not all(section):
            raise OrbitError(f"periodic_orbit: section {section!r} must read 'automaton: source -> target'")
    if section is None:
        if period is None or not np.isfinite(period) or period <= 0:
            raise OrbitError(f"periodic_orbit: give a positive period=T [s] (got {period!r}) for a fixed-period "
                             "orbit, or section=(automaton, source, target) for an autonomous one")
    else:
        section = tuple(section)
        automata = {a.name: a for a in model.automata}
        if section[0] not in automata:
            raise OrbitError(f"periodic_orbit: section automaton {section[0]!r} is not one of the model's "
                             f"({', '.join(automata)})")
        transitions = [(t.source, t.target) for t in automata[section[0]].transitions]
        if tuple(section[1:]) not in transitions:
            raise OrbitError(f"periodic_orbit: automaton {section[0]!r} has no transition {section[1]} → "
                             f"{section[2]}; its transitions: "
                             + ", ".join(f"{s} → {t}" for s, t in transitions))
    if int(crossings) < 1:
        raise OrbitError(f"periodic_orbit: crossings must be at least 1 (got {crossings})")
    if x0 is None:
        x0 = model.initial_state()
    shooter = _Shooter(model, period, section, int(crossings), float(t0), method, float(rtol), float(atol),
                       float(tol), int(max_iterations), max_period, float(grazing_limit), options)
    return shooter.solve(x0, mode, int(warmup))
