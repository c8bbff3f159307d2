"""Errors of the switching layer; all derive from the toolkit's one base,
:class:`bondgraph.errors.HybridBondGraphError`."""

from __future__ import annotations

from bondgraph.errors import HybridBondGraphError, InvalidGraphError

__all__ = [
    "ModelDefinitionError",
    "GuardSyntaxError",
    "DivergenceOfTimeError",
    "TooManyStepsError",
    "ImpulseError",
    "SimulationError",
    "ZenoError",
    "NonFiniteStateError",
    "ComplexValueError",
    "StepSizeError",
    "StiffnessError",
    "SimulationInterrupted",
    "SweepInterrupted",
    "UnknownOptionError",
    "OptionError",
    "OptionValueError",
    "OptionTypeError",
    "WorkLimitError",
    "StepLimitError",
    "OrbitError",
    "OrbitArgumentError",
    "OrbitConvergenceError",
    "NoOrbitError",
    "ModeSequenceChangedError",
    "GrazingError",
    "ContinuationError",
]


class ModelDefinitionError(InvalidGraphError):
    """Automata that do not fit the bond graph or each other (an unknown
    junction or state, a junction driven by two automata, a controlled
    junction driven by none, conflicting restitution coefficients)."""


class GuardSyntaxError(HybridBondGraphError, ValueError):
    """A guard written as text could not be parsed; ``position`` is the
    character offset of the problem in ``text``."""

    def __init__(self, message: str, text: str = "", position: int | None = None):
        if position is not None and text:
            message = f"{message}\n    {text}\n    {' ' * position}^"
        super().__init__(message)
        self.text = text
        self.position = position


class DivergenceOfTimeError(HybridBondGraphError):
    """Mode resolution at one instant does not reach a real mode: a mode
    repeats in a chain of mythical modes, or a (mode, state) pair repeats among
    pinnacles.  ``loop`` lists the steps (mode, fired guards with their
    values); ``instant`` is the partial record of the instant."""

    def __init__(self, message: str, loop=(), instant=None):
        super().__init__(message)
        self.loop = tuple(loop)
        self.instant = instant


class TooManyStepsError(DivergenceOfTimeError):
    """More discrete steps at one instant than the configured cap."""


class ImpulseError(HybridBondGraphError):
    """A guard combines impulsive signals in a way that has no meaning
    (a product of two Dirac pulses, or a nonlinear function of one)."""


class SimulationError(HybridBondGraphError):
    """A simulation that cannot go on.  ``trajectory`` holds everything
    computed up to the failure (nothing is lost); ``t`` and ``mode`` say where."""

    def __init__(self, message: str, trajectory=None, t: float | None = None, mode=None):
        super().__init__(message)
        self.trajectory = trajectory
        self.t = t
        self.mode = mode


class ZenoError(SimulationError):
    """Events pile up in shrinking time (Zeno behaviour); ``accumulation_time``
    is the estimated time at which they would accumulate."""

    def __init__(self, message: str, trajectory=None, t=None, mode=None, accumulation_time=None):
        super().__init__(message, trajectory, t, mode)
        self.accumulation_time = accumulation_time


class NonFiniteStateError(SimulationError):
    """The state became NaN or infinite during flow."""


class ComplexValueError(NonFiniteStateError):
    """An element law gave a complex value (or none: a domain error) for
    real inputs during a run (``sqrt`` of a charge that turned negative):
    ``elements`` names the culprits, ``x`` is the state there."""

    def __init__(self, message: str, trajectory=None, t=None, mode=None, elements=(), x=None):
        super().__init__(message, trajectory, t, mode)
        self.elements = tuple(elements)
        self.x = x


class StepSizeError(SimulationError):
    """An adaptive method could not keep its step above the round-off limit
    (often a stiff problem on an explicit method, or a singularity)."""


class StiffnessError(StepSizeError):
    """An explicit method ran beyond its stability limit: the estimated
    ``|h·λ|`` of the fastest mode stayed above the method's limit (the
    problem is stiff there for this method).  ``h`` is the step and
    ``h_lambda`` the estimate; use an implicit method (Radau, BDF, LSODA) or,
    for ``euler``/``rk4``, a step below ``limit/|λ|``."""

    def __init__(self, message: str, trajectory=None, t=None, mode=None, h=None, h_lambda=None, limit=None):
        super().__init__(message, trajectory, t, mode)
        self.h = h
        self.h_lambda = h_lambda
        self.limit = limit


class SimulationInterrupted(SimulationError, KeyboardInterrupt):
    """The run was interrupted (Ctrl-C, ``KeyboardInterrupt``) while it
    computed.  ``trajectory`` holds everything computed up to the interruption;
    ``t`` and ``mode`` say where it was.  Being a ``KeyboardInterrupt`` too,
    it still ends a script that does not catch it."""


class SweepInterrupted(HybridBondGraphError, KeyboardInterrupt):
    """A sweep (:func:`switching.simulate_many`) was interrupted (Ctrl-C)
    before all its runs finished.  ``results`` holds one
    :class:`~switching.sweep.batch.RunResult` per parameter set, in their order:
    the runs that finished, and for the others a failed result whose error
    says the sweep was interrupted (``error_type`` ``"SweepInterrupted"``).
    Being a ``KeyboardInterrupt`` too, it still ends a script that does not
    catch it."""

    def __init__(self, message: str, results=()):
        super().__init__(message)
        self.results = list(results)


class UnknownOptionError(SimulationError, TypeError):
    """``simulate`` (or a sweep) was given an option it does not know; the
    message names the closest known ones.  A ``TypeError`` too, as Python
    reports an unexpected keyword argument."""


class OptionError(SimulationError):
    """An option of a run (``simulate``) that cannot be taken, refused before
    anything runs (no trajectory): ``option`` names it, ``value`` is what was
    given; the message says the value expected (see
    :mod:`switching.simulate.run_options`)."""

    def __init__(self, message: str, option: str | None = None, value=None):
        super().__init__(message)
        self.option = option
        self.value = value


class OptionValueError(OptionError, ValueError):
    """An option's value out of its bounds (a negative step, ``zeno_window=0``).
    A ``ValueError`` too."""


class OptionTypeError(OptionError, TypeError):
    """An option's value of the wrong kind: text where a number is expected
    (``dt="0.1"``), ``True`` for a number, a number for a flag.  A
    ``TypeError`` too."""


class WorkLimitError(OptionValueError):
    """The options ask for more work or memory than a run may take: more steps
    than ``max_steps`` (a step ``dt`` or ``max_step`` far below the run's
    length), a step below the resolution of ``t`` (``t + dt == t``), more
    sample times than memory allows.  ``figure`` is what the options imply,
    ``limit`` the bound it exceeds."""

    def __init__(self, message: str, option: str | None = None, value=None, figure=None, limit=None):
        super().__init__(message, option, value)
        self.figure = figure
        self.limit = limit


class StepLimitError(SimulationError):
    """A run took ``max_steps`` steps without reaching its end; ``trajectory``
    holds what it computed, ``t`` where it stopped, ``max_steps`` the bound."""

    def __init__(self, message: str, trajectory=None, t=None, mode=None, max_steps=None):
        super().__init__(message, trajectory, t, mode)
        self.max_steps = max_steps


class OrbitError(HybridBondGraphError):
    """A periodic orbit (:func:`switching.periodic_orbit`) that could not be
    found.  ``iterate`` is the Newton iterate (0: the initial guess) where it
    failed, ``x`` its initial state, ``residual`` its scaled residual
    ``‖φ(x) − x‖∞ / ‖x‖∞`` (``nan`` when not computed), ``history`` the
    residuals of all iterates so far; the message says what to try."""

    def __init__(self, message: str, iterate: int | None = None, x=None, residual: float | None = None,
                 history=()):
        super().__init__(message)
        self.iterate = iterate
        self.x = x
        self.residual = residual
        self.history = tuple(history)


class OrbitArgumentError(OrbitError, ValueError):
    """An argument of the orbit API (:func:`switching.periodic_orbit`,
    :meth:`PeriodicOrbit.small_signal`) that cannot be taken, refused before
    anything runs: ``argument`` names it, ``value`` is what was given; the
    message says what to give.  A ``ValueError`` too."""

    def __init__(self, message: str, argument: str | None = None, value=None):
        super().__init__(message)
        self.argument = argument
        self.value = value


class ContinuationError(OrbitError):
    """A continuation of a periodic orbit (:func:`switching.continue_orbit`)
    that could not go on, or was asked for wrongly.  ``value`` is the
    parameter value where it stopped (``None`` for a bad request),
    ``result`` the :class:`~switching.analysis.continuation.Continuation`
    of the points found before it (``None`` for a bad request)."""

    def __init__(self, message: str, value: float | None = None, result=None):
        super().__init__(message)
        self.value = value
        self.result = result


class OrbitConvergenceError(OrbitError):
    """Newton's iteration on the period map did not bring the residual under
    the tolerance within the allowed iterations (or it grew)."""


class NoOrbitError(OrbitConvergenceError):
    """The period map has no fixed point near the guess: Newton's steps do
    not shrink, and the closest residual stays when the runs are made 100
    times more accurate (it is no round-off), as beyond a fold where the orbit
    has disappeared.  ``iterate``, ``x`` and ``residual`` are those of the
    closest iterate; ``history`` holds every iterate's residual."""


class ModeSequenceChangedError(OrbitError):
    """Two successive Newton iterates flowed through different sequences of
    modes over one period: the period map is not smooth between them.
    ``before`` and ``after`` are the two sequences (mode descriptions)."""

    def __init__(self, message: str, iterate=None, x=None, residual=None, history=(), before=(), after=()):
        super().__init__(message, iterate, x, residual, history)
        self.before = tuple(before)
        self.after = tuple(after)


class GrazingError(OrbitError):
    """An iterate's orbit touches a guard tangentially (or nearly so): the
    event time, hence the period map, is not differentiable there.
    ``t`` is the time of the event within the period, ``ratio`` the relative
    sensitivity of its time that exceeded the limit."""

    def __init__(self, message: str, iterate=None, x=None, residual=None, history=(), t=None, ratio=None):
        super().__init__(message, iterate, x, residual, history)
        self.t = t
        self.ratio = ratio
