"""The options of one run, grouped by what they govern.

``simulate``'s keywords, once checked
(:func:`switching.simulate.run_options.checked_options`), become a
:class:`RunOptions`: the method, the end of the run and five small frozen
groups — where it starts (:class:`Start`), how a flow steps
(:class:`Stepping`), how instants are found and watched (:class:`Events`),
the work it may do (:class:`Limits`), and what it keeps and tells
(:class:`Output`).  Each group's fields are the keywords of ``simulate`` by
the same names, with their values as given (so the integrators see exactly
what the caller passed), except ``x0`` and ``t_eval``, which are the checked
arrays (with ``samples=N``, ``t_eval`` holds its ``N`` uniform times).  Units: times in seconds, ``rtol`` relative (1), ``atol`` in the
states' units.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

__all__ = ["Start", "Stepping", "Events", "Limits", "Output", "GROUPS", "RunOptions", "group_of", "keyword_names"]


@dataclass(frozen=True, eq=False)
class Start:
    """Where the run starts: time ``t0`` [s], state ``x0`` (``None``: the
    model's initial state), mode ``mode`` (``None``: the model's)."""

    t0: float
    x0: object
    mode: object


@dataclass(frozen=True)
class Stepping:
    """How a flow steps: the fixed step ``dt`` [s] (euler, rk4), or the
    adaptive step's tolerances ``rtol`` [1] and ``atol`` [states' units: ``None`` when not
    given, then each state's own, an array in the states' order once the run starts,
    :mod:`switching.simulate.state_tolerances`],
    bounded by ``max_step`` [s] and started at ``first_step`` [s]; with
    ``stiffness_check`` the explicit methods stop beyond their stability
    limit (``|h·λ|``)."""

    dt: float | None
    rtol: float
    atol: object  # a number, None, or (once the run starts) an array of the states' own
    max_step: float
    first_step: float | None
    stiffness_check: bool

    def integrator_options(self) -> dict:
        """The keywords of :meth:`switching.simulate.methods.Method.stepper` they set."""
        return dict(dt=self.dt, rtol=self.rtol, atol=self.atol, max_step=self.max_step, first_step=self.first_step,
                    stiffness_check=self.stiffness_check)


@dataclass(frozen=True)
class Events:
    """How instants are found and watched: guards tested at
    ``event_samples`` interior points of each step; Zeno behaviour (events
    in geometrically shrinking time, over the last ``zeno_window`` gaps, the
    latest below ``zeno_min_gap`` [s], ``None``: 1e-9 of the run) raises
    (``on_zeno="raise"``) or ends the run (``"stop"``)."""

    event_samples: int
    on_zeno: str
    zeno_window: int
    zeno_min_gap: float | None


@dataclass(frozen=True)
class Limits:
    """The work a run may do: ``max_steps`` accepted steps, ``max_events`` instants."""

    max_steps: int
    max_events: int


@dataclass(frozen=True, eq=False)
class Output:
    """What the run keeps and tells: every step (``output="steps"``), the
    instants only (``"events"``), or the samples at the sorted times
    ``t_eval`` [s] — with ``samples=N`` the ``N`` times
    ``linspace(t0, t_end, N)`` and the instants' before/after rows; the
    instants' records (``keep_instants``); ``progress(t)`` called as the run
    goes."""

    output: str
    t_eval: object
    keep_instants: bool
    progress: object
    samples: int | None = None

    @property
    def recorded(self) -> str:
        """What is recorded besides the instants: ``"steps"``, or ``"events"`` (also with ``t_eval``, ``samples``)."""
        return "events" if self.t_eval is not None else self.output


#: the groups, in the order of :class:`RunOptions`
GROUPS = (Start, Stepping, Events, Limits, Output)


def keyword_names() -> tuple:
    """The keywords of ``simulate`` the groups carry (each in one group)."""
    return tuple(f.name for group in GROUPS for f in fields(group))


def group_of(keyword: str) -> type:
    """The group that carries ``keyword``."""
    for group in GROUPS:
        if any(f.name == keyword for f in fields(group)):
            return group
    raise KeyError(keyword)


@dataclass(frozen=True, eq=False)
class RunOptions:
    """The options of one run: ``method`` (a name of the method table),
    ``t_end`` [s] and the groups."""

    method: str
    t_end: float
    start: Start
    stepping: Stepping
    events: Events
    limits: Limits
    output: Output

    @classmethod
    def from_keywords(cls, method: str, t_end: float, keywords: dict) -> RunOptions:
        """The groups of ``keywords`` (``simulate``'s, checked; ``mode`` among them)."""
        k = keywords  # (written out: this runs at every simulate call, a generator of dicts costs microseconds)
        return cls(method, t_end, Start(k["t0"], k["x0"], k["mode"]),
                   Stepping(k["dt"], k["rtol"], k["atol"], k["max_step"], k["first_step"], k["stiffness_check"]),
                   Events(k["event_samples"], k["on_zeno"], k["zeno_window"], k["zeno_min_gap"]),
                   Limits(k["max_steps"], k["max_events"]),
                   Output(k["output"], k["t_eval"], k["keep_instants"], k["progress"], k.get("samples")))
