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
residual and the estimated relative error of the start (the larger of one
more Newton step's size and ``residual / min |1 − μ|``) are both at most
``tol``: the start is then within ``tol`` of the orbit's relative to each
state's amplitude, also near a fold (:mod:`switching.analysis.orbit_newton`,
which also says how a failed iteration is told apart: still converging, the
runs' round-off, or no fixed point near the guess).

**The period's end** (fixed period).  A clock edge at ``t0 + T`` is located
to a few ulps of ``t``: ``cos(2π f t − π w) − cos(π w)`` at ``t = 1/f`` may
vanish one ulp after ``t0 + T`` (a 50 kHz clock's edge at
2.0000000000000005e-05 s).  An instant within ``EDGE_ULPS`` ulps after
``t0 + T`` belongs to the period: each run goes that far, a period with such
an instant ends just after it (its mode the next period's start mode, as
the clock's own instant says), one without ends at ``t0 + T`` (the last
sample moved back by the flow over those ulps, ``x − f·δt``, within the
state's round-off).

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

from ..errors import (GrazingError, ModeSequenceChangedError, NoOrbitError, OptionError, OrbitConvergenceError,
                      OrbitError, SimulationError, UnknownOptionError)
from .orbit_arguments import checked_orbit_arguments
from .orbit_newton import FINER, is_singular, newton_step, shrinking

__all__ = ["PeriodicOrbit", "periodic_orbit", "EDGE_ULPS"]

#: an instant within this many ulps of ``t`` after ``t0 + T`` belongs to the period (module docstring)
EDGE_ULPS = 64


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
    near a tangential touch, 0 with clock events only); ``error``: the
    estimated relative error of the orbit (at most ``tol``), the largest of
    ``step_error`` (one more Newton step's size), ``residual_error``
    (``residual / min |1 − μ|``) and ``period_error`` (an autonomous
    period's, ``|τ_x·δx| / T``); ``x0_error`` (n,): each state's, in its
    units (:mod:`switching.analysis.orbit_newton`).

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
    #: the estimated relative error of the orbit (:mod:`switching.analysis.orbit_newton`): the largest of
    #: ``step_error``, ``residual_error`` and ``period_error``
    error: float = 0.0
    #: the size of one more Newton step, ``max_i |δx_i| / s_i``
    step_error: float = 0.0
    #: an autonomous orbit's period's: ``|τ_x·δx| / T`` (0 for a fixed period)
    period_error: float = 0.0
    #: ``residual / min |1 − μ|`` (μ the eigenvalues of the period map's Jacobian)
    residual_error: float = 0.0
    #: ``|δx|`` (n,): the estimated error of each state of ``x0``, in its units
    x0_error: np.ndarray | None = None
    #: ``(shooter, mode)``: the runs' settings and the mode the orbit's runs start in (for :meth:`small_signal`)
    shooting: tuple | None = field(default=None, repr=False, compare=False)

    @property
    def residual(self) -> float:
        """The residual of the returned orbit."""
        return self.residuals[-1]

    @property
    def mode_names(self) -> list:
        return [m.describe() for m in self.modes]

    def measure(self, signal, what="mean", **window):
        """A measurement over the orbit, one exact period by default (:meth:`Trajectory.measure`: ``mean``,
        ``rms``, ``ripple``, ``thd``, …, the flow integrated piece by piece); ``window`` as there."""
        if not window:
            window = dict(t_from=float(self.trajectory.t[0]), t_to=float(self.trajectory.t[0]) + self.period)
        window.setdefault("fundamental", 1.0 / self.period)
        return self.trajectory.measure(signal, what, **window)

    def sampled(self, samples: int = 1000):
        """The orbit over one period at ``samples`` equal times plus its instants' before/after rows
        (``simulate(..., samples=N)`` from ``x0`` in the orbit's first mode, with the runs' method,
        tolerances and options): a trajectory of the whole period, every signal available, for plots and
        files (:attr:`trajectory` keeps the solver's steps, about ten a period)."""
        shooter, mode = self.shooting
        return shooter.model.simulate(self.t0 + self.period, shooter.method, t0=self.t0, x0=self.x0, mode=mode,
                                      rtol=shooter.rtol, atol=shooter.atol, samples=samples, **shooter.options)

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
    def __init__(self, model, checked: dict, options: dict):
        self.model = model
        self.states = [s.name for s in model.states]
        self.n = len(self.states)
        self.names = [f"x0:{s}" for s in self.states]
        #: model parameters whose sensitivities the runs also carry (columns after the initial states)
        self.parameters: list = []
        for name in ("period", "section", "crossings", "t0", "method", "rtol", "atol", "tol", "max_iterations",
                     "grazing_limit", "criterion"):
            setattr(self, name, checked[name])
        self.options = options
        if self.section is not None:
            max_period = checked["max_period"]
            self.horizon = max_period if max_period is not None else 4.0 * self.period
        self.residuals: list = []
        #: every iterate's ``(x, mode, NewtonStep)``
        self.trail: list = []

    # ---------------------------------------------------------------- one run

    def run(self, x, mode, t_end, iterate):
        try:
            return self.model.simulate(t_end, self.method, t0=self.t0, x0=x, mode=mode, rtol=self.rtol,
                                       atol=self.atol, sensitivities=self.columns, sensitivity_rtol=self.rtol,
                                       sensitivity_atol=self.atol, **self.options)
        except (OptionError, UnknownOptionError):  # an option of the runs refused: the request, not the guess
            raise
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
            tr = self.period_run(x, mode, iterate)
            x_end = np.array(tr.x[-1], dtype=float)
            derivative = self.sensitivity_matrix(tr, -1)
            last, end_mode = None, tr.modes[-1]
        else:
            tr, last = self.section_run(x, mode, iterate)
            event = tr.events[last]
            row = tr.event_index[last]
            T = event.t - self.t0
            tr = tr.take(np.arange(row + 1))  # one period: up to the section's event, its instant the last
            tr.events = list(tr.events[:last + 1])
            x_end = np.array(event.x_after, dtype=float)
            S = self.sensitivity_matrix(tr, row)
            f_plus = np.asarray(self.model.compiled_mode(event.mode_after).rates(x_end, event.t), dtype=float)
            tau = np.array([tr.event_time_sensitivity(last, p) for p in self.columns])
            self.tau_x = tau[:self.n]
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

    def section_run(self, x, mode, iterate):
        """``(trajectory, k)``: a run from ``x`` that reaches the section, ``k`` the index of its section event;
        the horizon doubles (up to 1e3 times the first) while it does not."""
        searched = None
        while True:
            try:
                tr = self.run(x, mode, self.t0 + self.horizon, iterate)
            except OrbitConvergenceError as error:
                if searched is None:
                    raise
                raise self.missed_section(x, iterate, searched, f"the run to {self.horizon:.6g} s then failed: "
                                          f"{error.__cause__}") from error
            last = self.section_event(tr)
            if last is not None:
                return tr, last
            searched = self.horizon
            if self.at_rest(tr):
                raise self.missed_section(x, iterate, searched, "the run comes to rest there, at x = "
                                          f"{self.show(tr.x[-1])} in mode {tr.modes[-1].describe()}, so it never will")
            if self.horizon > 1e3 * self.first_horizon:
                raise self.missed_section(x, iterate, searched, "")
            self.horizon *= 2.0

    def at_rest(self, tr) -> bool:
        """The run ends at rest: no instant in its second half, over which no state moves by more than ten
        times its integration tolerance (``atol + rtol·|x|``)."""
        t0, t1 = float(tr.t[0]), float(tr.t[-1])
        middle = 0.5 * (t0 + t1)
        if any(event.t > middle for event in tr.events):
            return False
        half = tr.x[tr.t >= middle]
        band = 10.0 * (self.atol + self.rtol * np.max(np.abs(half), axis=0))
        return bool(len(half) > 1 and np.all(np.ptp(half, axis=0) <= band))

    def missed_section(self, x, iterate, searched: float, why: str) -> OrbitConvergenceError:
        """The error of a run that never takes the section's transition."""
        why = f": {why}" if why else ""
        return OrbitConvergenceError(
            f"periodic_orbit: iterate {iterate} (x0 = {self.show(x)}) never crosses the section "
            f"{self.section_text()} (crossing {self.crossings}) within {searched:.6g} s{why}. Check the section's "
            "automaton and transition (the orbit must take it once a period), the parameters (does the orbit "
            "exist?) and the guess x0=, or pass a larger max_period=", iterate, x, float("nan"), self.residuals)

    def period_run(self, x, mode, iterate):
        """The run over one fixed period from ``x`` (module docstring: the period's end): to
        ``t0 + T + EDGE_ULPS`` ulps, ended just after the last instant beyond ``t0 + T``, or at ``t0 + T``."""
        end = self.t0 + float(self.period)
        late = end + EDGE_ULPS * float(np.spacing(abs(end)))
        tr = self.run(x, mode, late, iterate)
        beyond = [k for k, event in enumerate(tr.events) if event.t > end]
        if beyond:
            row = tr.event_index[beyond[-1]]
            events = list(tr.events[:beyond[-1] + 1])
            tr = tr.take(np.arange(row + 1))
            tr.events = events
            return tr
        tr = tr.take(np.arange(len(tr.t)))  # (its own arrays)
        rates = np.asarray(self.model.compiled_mode(tr.modes[-1]).rates(tr.x[-1], tr.t[-1]), dtype=float)
        tr.x[-1] = tr.x[-1] - rates * (tr.t[-1] - end)
        tr.t[-1] = end
        return tr

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
            residual = float(np.max(np.abs(F) / scale)) if self.n else 0.0
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
            newton = newton_step(F, J, scale, residual, None if self.section is None else self.tau_x, T)
            self.trail.append((x, mode, newton))
            if residual <= self.tol and (self.criterion == "residual" or newton.error <= self.tol):
                return self.result(tr, T, x, modes, M, iterate, started, mode, newton)
            if is_singular(newton):
                self.refuse_singular(x, iterate, residual, newton, scale)
            if iterate == self.max_iterations:
                break
            x = x + newton.step
            if self.section is None:
                mode = end_mode  # a periodic orbit starts in the mode it ends in
        raise self.failure()

    def refuse_singular(self, x, iterate, residual, newton, scale):
        """The :class:`OrbitConvergenceError` of a singular ``M − I`` (:mod:`switching.analysis.orbit_newton`)."""
        weights = newton.direction * scale / np.max(np.abs(newton.direction * scale))
        along = ", ".join(f"{s}: {w:+.3g}" for s, w in zip(self.states, weights) if abs(w) >= 1e-3)
        jacobian = "M − I" if self.section is None else "DP − I (the return map's)"
        raise OrbitConvergenceError(
            f"periodic_orbit: at iterate {iterate} (x0 = {self.show(x)}, residual {residual:.3g}) {jacobian} is "
            f"singular: a multiplier is 1 up to round-off (|1 − μ| = {newton.gap:.3g}), so the period map has "
            f"slope 1 along ({along}) (relative to the states' amplitudes) and Newton cannot tell how far to "
            "move along it (every step would be the same): the guess lies on a piece of the map "
            "that does not restore that direction (a switch that stays on, or off, for the whole period; a "
            "state nothing pulls back). Start from a guess whose period flows through the orbit's modes (x0=, or "
            "warmup= periods of plain simulation first)", iterate, x, residual, self.residuals)

    def failure(self) -> OrbitError:
        """The error of an iteration that did not converge (:mod:`switching.analysis.orbit_newton`)."""
        history = ", ".join(f"{r:.3g}" for r in self.residuals)
        sizes = [newton.size for _, _, newton in self.trail]
        k = int(np.argmin(self.residuals))
        x, mode, newton = self.trail[k]
        x_last = self.trail[-1][0]
        head = (f"periodic_orbit: Newton did not converge in {self.max_iterations} iteration(s): iterate "
                f"{len(self.residuals) - 1} (x0 = {self.show(x_last)}) has residual {self.residuals[-1]:.3g} and "
                f"estimated error {self.trail[-1][2].error:.3g} (tol = {self.tol:g}; residuals: {history})")
        more = ("start from a guess closer to the orbit (x0=, or warmup= periods of plain simulation first), or "
                "allow more max_iterations=")
        if len(sizes) < 4 or shrinking(sizes):
            return OrbitConvergenceError(f"{head}. Try: {more}", len(self.residuals) - 1, x_last,
                                         self.residuals[-1], self.residuals)
        finer = None if self.residuals[k] <= self.rtol else self.finer_residual(x, mode, k)
        if finer is None and self.residuals[k] > self.rtol:
            return OrbitConvergenceError(f"{head}; Newton's steps do not shrink. Try: {more}", len(self.residuals) - 1,
                                         x_last, self.residuals[-1], self.residuals)
        if finer is None or finer <= 0.1 * self.residuals[k]:
            since = ("within rtol" if finer is None else
                     f"{finer:.3g} with rtol and atol {FINER:g} times smaller")
            return OrbitConvergenceError(
                f"{head}; Newton's steps do not shrink and the closest iterate's residual is the runs' round-off "
                f"({self.residuals[k]:.3g}, {since}): the start is "
                f"determined only to about {newton.residual_error:.3g} (residual / min|1 − μ|, min|1 − μ| = "
                f"{newton.gap:.3g}). Try: lower rtol/atol, or raise tol (now {self.tol:g})", k, x,
                self.residuals[k], self.residuals)
        return NoOrbitError(
            f"periodic_orbit: no orbit: the map has no fixed point near x0; closest residual {self.residuals[k]:.3g} "
            f"at iterate {k} (x0 = {self.show(x)}; {finer:.3g} with runs {FINER:g} times more accurate, so no "
            f"round-off), and Newton's steps do not shrink in {self.max_iterations} iterations (relative sizes "
            + ", ".join(f"{z:.2g}" for z in sizes) + "), as beyond a fold where the orbit has disappeared "
            f"(min|1 − μ| there {newton.gap:.3g}). Check the parameters (the orbit may exist only on one side of "
            "a value), or start from another guess (x0=, warmup=)", k, x, self.residuals[k], self.residuals)

    def finer_residual(self, x, mode, iterate):
        """The residual of ``x`` with ``rtol`` and ``atol`` ``FINER`` times smaller (``None`` when they cannot
        be lowered or the run fails)."""
        rtol = max(self.rtol / FINER, 1e-13)
        if rtol >= self.rtol:
            return None
        shooter = copy.copy(self)
        shooter.rtol, shooter.atol = rtol, self.atol * rtol / self.rtol
        shooter.residuals = list(self.residuals)
        try:
            F, *_, scale, _, _ = shooter.evaluate(np.asarray(x, dtype=float), mode, iterate)
        except OrbitError:
            return None
        return float(np.max(np.abs(F) / scale))

    def result(self, tr, T, x, modes, M, iterations, started, mode, newton) -> PeriodicOrbit:
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
                             error=newton.error, step_error=newton.size, residual_error=newton.residual_error,
                             period_error=newton.period_error,
                             x0_error=np.abs(newton.step), shooting=(self, mode))


def periodic_orbit(model, period: float | None = None, *, section=None, crossings: int = 1, x0=None, mode=None,
                   t0: float = 0.0, method: str = "RK45", rtol: float = 1e-10, atol: float = 1e-12,
                   tol: float = 1e-8, max_iterations: int = 20, max_period: float | None = None, warmup: int = 0,
                   grazing_limit: float = 1e3, criterion: str = "error", **options) -> PeriodicOrbit:
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
    sensitivities are integrated with the same ``rtol``/``atol``; a compiled
    ``method`` or ``"auto"`` runs as its Python equivalent, which integrates
    sensitivities: ``"RK45-jit"`` as ``"RK45"``).
    ``tol``: the scaled residual and the estimated relative error of the
    start to reach (module docstring; ``criterion="residual"``: the
    residual alone, as before the error estimate — for locating a
    bifurcation, where the orbit near a fold is ill-determined but its
    multipliers are what is asked; the orbit still carries its ``error``);
    ``max_iterations`` Newton steps
    at most; ``warmup``: periods of plain iteration ``x ← φ(x)`` before
    Newton (to settle into the orbit's mode sequence); ``grazing_limit``:
    see :class:`~switching.errors.GrazingError`.

    Every argument is checked first
    (:mod:`switching.analysis.orbit_arguments`:
    :class:`~switching.errors.OrbitArgumentError`).  Returns a
    :class:`PeriodicOrbit` (its ``error``: the estimated relative error of
    ``x0``); raises :class:`~switching.errors.OrbitConvergenceError`
    (:class:`~switching.errors.NoOrbitError` where the map has no fixed point
    near the guess),
    :class:`~switching.errors.ModeSequenceChangedError` or
    :class:`~switching.errors.GrazingError`.
    """
    checked = checked_orbit_arguments(model, period, section, crossings, x0, t0, method, rtol, atol, tol,
                                      max_iterations, max_period, warmup, grazing_limit, criterion, mode)
    shooter = _Shooter(model, checked, options)
    return shooter.solve(checked["x0"], mode, checked["warmup"])
