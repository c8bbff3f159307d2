"""Static divergence-of-time check (``HybridModel.verify``).

Starting from the initial mode, explore only the modes that mode resolution
actually reaches: in each explored mode, sample states on the boundary of each
guard comparison (``lhs − rhs = 0``, found by a sign change along a random
line through (state, time) space, every point put on the mode's constraints),
nudge them to either side along the line, keep those the mode can really be
in (below), resolve the instant there and record

* every divergence-of-time loop found (:class:`Loop`): its modes, the
  sampled state (names and values), time and boundary it came from, and the
  resolution's whole message, whose steps list the guards that fired with
  the values of their comparisons;
* the kinds each reached mode was seen with — modes seen only as
  *mythical* can never carry behaviour;
* the real modes reached, which are explored in turn (breadth first, capped);
* every resolved state (:class:`Sample`, ``report.sampled``), the states set
  aside and why (``rejected``), the comparisons that the mode's flow never
  crosses (``constant``) and those for which no admissible state was found
  (``unsampled``: the check says nothing about them).

``str(report)`` is what ``hbg verify`` prints.

Which sampled states count (reachability in the paper's semantics)
------------------------------------------------------------------

Every instant of a run starts either at the initial state or at an event of
the flow in a *continuous* mode α (a pinnacle's state is reached inside an
instant that itself began at such an event, and is explored by resolving that
instant).  The a priori state ``x`` of such an event therefore has three
properties, and a sampled state without all three is set aside, never
resolved:

1. **On α's constraints.**  Flow keeps dependent storage on the mode's
   algebraic constraints (``x_d = φ(x_i, t)``).  Every sampled point is put
   on them by the mode's generated ``phi``, exactly as flow keeps states
   there; the mode's jump map is then the identity on it, so the instant
   starts without a pulse, as after flow.
2. **No guard of α held just before.**  During flow no guard of α holds —
   a mode is continuous only where none holds — so at the event the guards
   that hold have just become true, and none held an instant before.  The
   comparisons at their boundary at ``x`` (the sampled one, and those zero
   up to ``BOUNDARY_RTOL``, or ten times the model's ``rtol``, of their
   size: the same surface, or one the point was moved onto) took, just
   before, the truth they have at ``x − h·f(x)``, ``t − h`` (``f`` the
   mode's rates, ``h`` a step of ``FLOW_STEP`` of the sampling scales) where
   the flow crosses them, and either truth where it is tangent to them;
   every other comparison had its present truth.  A state where some guard
   must have held just before is not one α flows through: flow would have
   left α earlier, at that guard's boundary.  E.g. a stuck contact whose
   floor pulls, whose friction force is outside the cone, or whose forces
   reach the cone's edge from outside it; a relay's threshold that its
   charging only approaches from above.  A state on the boundary of a
   comparison that the flow only touches there (tangent, though the
   comparison is not zero all along the sampling line) is a grazing, met by
   a measure-zero set of runs, or lies on a boundary the flow runs along and
   never crosses: it is set aside too (a comparison the flow never crosses
   in a mode is listed with the constant ones).  The states nudged off the
   boundary count as on it (its comparisons keep the truth found there).
3. **Consistent with how α's automaton states were entered.**  An automaton
   state ``s`` that is not its automaton's initial state was entered by one
   of its incoming transitions, whose guard held then.  A comparison that is
   a conjunct of that guard, over states and parameters only, whose
   ``lhs − rhs`` neither the flow nor the jump of any mode with the
   automaton in ``s`` changes (nor, for an a posteriori guard, the jump of
   any mode with the automaton in the transition's source) still holds while
   the automaton stays in ``s``.  ``x`` must satisfy, for each such ``s``,
   the kept comparisons of at least one incoming transition (inclusively,
   within ``ENTRY_RTOL`` or ten times the model's ``rtol``, the larger).
   The invariance is checked numerically on each such mode's generated
   functions, at ``INVARIANCE_POINTS`` random states on its constraints
   (rate and jump below ``INVARIANCE_RTOL`` of their terms).  An automaton
   state with an incoming transition that keeps no such comparison, or with
   more than ``MAX_ENTRY_MODES`` modes to check, is not constrained.  E.g.
   the falling rod's tip enters contact with ``tip_y <= 0`` and the contact
   holds its vertical velocity at zero, so in every contact mode
   ``tip_y <= 0``: no state with the tip 14 m above the floor in contact is
   sampled.  The comparisons kept are listed in the report
   (``entry_conditions``).

Each filter removes only states that no run can have at an event, up to a
set that runs meet with probability zero (comparisons crossing at exactly
the same instant, grazings), so no loop a run can meet is filtered away.
The filters do not follow the flow's history: a state that satisfies all
three may still be unreachable from any initial state (e.g. a velocity the
mode could only reach over a longer flow than its guards allow), so a loop
found is one to look at, shown with the state it came from.

Where the states the mode can have on a boundary form a thinner set (a
guard's comparison reached only where a comparison of another guard is at
its boundary too), boundary points rejected by filter 2 are, once
``samples`` lines have found too few admissible ones, moved by a root search
onto the boundary of a comparison of the blocking guards as well (up to
``MAX_REFINE`` more comparisons).  The time of each line is drawn on a scale
log-uniform between the smallest and the largest parameter size, so that
time thresholds of any size are crossed.

It is a sampling check: it finds loops, it cannot prove their absence.
"""

from __future__ import annotations

import itertools
import math
import numbers
from dataclasses import dataclass, field

import numpy as np
import sympy as sp
from scipy.optimize import brentq, root
from sympy.core.relational import Relational
from sympy.logic.boolalg import And

from bondgraph.errors import HybridBondGraphError
from codegen.roundoff import roundoff_scale
from codegen.runtime import decide
from codegen.safety import execute
from codegen.source import module_namespace

from ..library.compiled import decide_tree
from ..errors import DivergenceOfTimeError, SimulationError
from ..model.modes import Mode

__all__ = ["VerificationReport", "Sample", "Loop", "SampleError", "verify"]

#: random lines tried per wanted boundary sample before a comparison is given up
LINES_PER_SAMPLE = 5
#: the line parameter grid on which sign changes of a comparison are searched
GRID = np.linspace(-10.0, 10.0, 201)
#: the nudge to either side of a boundary point, in units of the line's direction
NUDGE = 1e-7
#: a comparison is at its boundary when ``|lhs − rhs| <= BOUNDARY_RTOL·max(|lhs|, |rhs|, R)`` (zero up to
#: round-off, a little wider than the model's own band; a root search must reach it too)
BOUNDARY_RTOL = 1e-12
#: band of the entry comparisons of filter 3 (relative to their round-off scale, inclusive; at least ten
#: times the model's rtol): they held within the model's band when the state was entered, and flow and
#: jumps keep them exactly; this leaves room for the round-off of evaluating them
ENTRY_RTOL = 1e-12
#: random states per mode for the invariance check of an entry comparison
INVARIANCE_POINTS = 12
#: relative bound of the change of an invariant (rate or jump) against its terms
INVARIANCE_RTOL = 1e-9
#: modes with one automaton state beyond which its entry comparisons are not used
MAX_ENTRY_MODES = 16
#: comparisons at their boundary in one guard beyond which it counts as just become true
MAX_FREE_RELATIONS = 8
#: the step back along the flow that tells from which side the flow reached a boundary, as a fraction
#: of the states' sampling scales (and of the largest parameter, in time); only the side is used
FLOW_STEP = 1e-6
#: comparisons brought to their boundary besides the sampled one, when another guard already held
MAX_REFINE = 2
#: states listed by name and value in a report
SHOWN_STATES = 24

HELD = "a guard of the mode held just before (flow would have left the mode earlier)"
ENTRY = "outside the comparisons kept since the mode's automaton states were entered"
NOT_FINITE = "not finite on the mode's constraints"
GRAZING = "on a comparison's boundary that the flow only touches (a grazing, met by no run but a measure-zero set)"
ALONG = "on a boundary the flow does not cross there (it runs along it, or only touches it)"
_NUMERIC = (ArithmeticError, ValueError, TypeError, HybridBondGraphError)
_UNEVALUABLE = (*_NUMERIC, NameError, KeyError, SyntaxError)  # also a lambdified function sympy cannot print


# ------------------------------------------------------------------ the report


@dataclass(frozen=True)
class Sample:
    """One sampled state that was resolved: in ``mode`` at time ``t``, on the
    boundary of ``comparison`` (of guard ``guard``), nudged by ``nudge``
    (−1, 0, +1 steps of ``NUDGE`` along the line); ``outcome`` is the mode
    resolution reached (``"divergence of time"``, ``"error"``)."""

    mode: Mode
    comparison: str
    guard: str
    x: np.ndarray = field(repr=False, compare=False)
    t: float
    nudge: int
    outcome: str
    state_names: tuple = field(repr=False, compare=False, default=())

    @property
    def values(self) -> dict:
        """State name → value."""
        return dict(zip(self.state_names, map(float, self.x)))

    def state_text(self) -> str:
        pairs = [f"{name} = {value:.12g}" for name, value in zip(self.state_names, self.x)]
        if len(pairs) > SHOWN_STATES:
            pairs = pairs[:SHOWN_STATES] + [f"… {len(pairs) - SHOWN_STATES} more states"]
        return ", ".join(pairs)

    def origin(self) -> str:
        where = "on" if self.nudge == 0 else f"nudged {self.nudge * NUDGE:+g} along the sampling line off"
        return (f"the state sampled in mode {self.mode.describe()} at t = {self.t:.12g}, {where} the boundary of "
                f"{self.comparison} (guard {self.guard})")


@dataclass
class Loop:
    """A divergence-of-time loop: its ``modes``, the resolution's ``message``
    (all lines: the steps with the guards that fired and their values), the
    first ``sample`` that led to it, the steps of the loop (``steps``, the
    error's ``loop``) and how many sampled states led to it (``count``).
    Unpacks as ``(modes, message)``."""

    modes: tuple
    message: str
    sample: Sample
    steps: tuple = ()
    count: int = 1

    def __iter__(self):
        return iter((self.modes, self.message))

    def lines(self) -> list:
        out = [" → ".join(m.describe() for m in self.modes)
               + (f"  ({self.count} sampled states lead to it)" if self.count > 1 else "")]
        out.append(f"  from {self.sample.origin()}:")
        out.append(f"    {self.sample.state_text()}")
        out += ["  " + line for line in self.message.splitlines()]
        return out


@dataclass
class SampleError:
    """Another failure of mode resolution at a sampled state (``mode``,
    ``message``, ``sample``, ``count`` of samples with the same first line).
    Unpacks as ``(mode, message)``."""

    mode: Mode
    message: str
    sample: Sample
    count: int = 1

    def __iter__(self):
        return iter((self.mode, self.message))


@dataclass
class VerificationReport:
    """What :func:`verify` found; ``str(report)`` is what ``hbg verify`` prints."""

    explored: list = field(default_factory=list)
    kinds: dict = field(default_factory=dict)  # Mode → set of kinds seen
    loops: list = field(default_factory=list)  # Loop (unpacks as (modes, message))
    errors: list = field(default_factory=list)  # SampleError (unpacks as (mode, message))
    samples: int = 0  # states resolved
    truncated: bool = False
    sampled: list = field(default_factory=list)  # Sample of every state resolved
    rejected: dict = field(default_factory=dict)  # reason → candidate states set aside
    coverage: dict = field(default_factory=dict)  # (mode, comparison, guard) → boundary points kept
    constant: list = field(default_factory=list)  # (mode, comparison, guard) the mode's flow never crosses
    entry_conditions: dict = field(default_factory=dict)  # "automaton=state" → text of the kept comparisons
    requested: int = 0  # boundary samples asked for per comparison

    @property
    def mythical_only(self) -> list:
        return [m for m, kinds in self.kinds.items() if kinds == {"mythical"}]

    @property
    def unsampled(self) -> list:
        """``(mode, comparison, guard)`` of the comparisons with no admissible boundary state."""
        return [key for key, n in self.coverage.items() if n == 0]

    @property
    def ok(self) -> bool:
        return not self.loops and not self.errors

    def __str__(self) -> str:
        lines = [
            f"explored {len(self.explored)} mode(s) from {self.samples} boundary sample(s)"
            + (" (stopped at the mode cap)" if self.truncated else "")
        ]
        if self.rejected:
            lines.append(f"set aside {sum(self.rejected.values())} sampled state(s) no run can have at an event: "
                         + "; ".join(f"{n}: {reason}" for reason, n in self.rejected.items()))
        for name, text in self.entry_conditions.items():
            lines.append(f"  in every mode with {name}: {text} (kept since it was entered)")
        for mode, kinds in self.kinds.items():
            lines.append(f"  {mode.describe()}: seen as {', '.join(sorted(kinds)) or 'start mode only'}")
        if self.mythical_only:
            lines.append("modes that are only ever mythical: " + "; ".join(m.describe() for m in self.mythical_only))
        if self.constant:
            lines.append("never crossed by the flow of their mode (constant there, or the flow runs along them): "
                         + "; ".join(f"{mode.describe()}: {comparison}" for mode, comparison, _ in self.constant))
        unsampled = self.unsampled
        if unsampled:
            lines.append(f"{len(unsampled)} guard comparison(s) with no admissible boundary state in "
                         f"{LINES_PER_SAMPLE * self.requested} random line(s) (nothing is known of them):")
            for mode, comparison, guard in unsampled:
                lines.append(f"  {mode.describe()}: {comparison} (guard {guard})")
        if self.loops:
            lines.append(f"{len(self.loops)} divergence-of-time loop(s):")
            for k, loop in enumerate(self.loops, 1):
                first, *rest = loop.lines()
                lines.append(f"loop {k}: {first}")
                lines += ["  " + line for line in rest]
        for error in self.errors:
            more = f" ({error.count} sampled states)" if error.count > 1 else ""
            lines.append(f"error from {error.mode.describe()}{more}, from {error.sample.origin()}:")
            lines.append(f"    {error.sample.state_text()}")
            lines += ["    " + line for line in error.message.splitlines()]
        if self.ok:
            lines.append("no divergence of time found")
        return "\n".join(lines)


# ------------------------------------------------------------------ arguments


def _whole(name: str, value, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise SimulationError(f"verify: {name} must be a whole number >= {minimum}, not {value!r}")
    if value < minimum:
        raise SimulationError(f"verify: {name} must be >= {minimum}, not {value}"
                              + (" (with no samples nothing would be checked)" if name == "samples" else ""))
    return int(value)


def _factor(scale) -> float:
    if scale is None:
        return 1.0
    try:
        value = float(scale)
    except (TypeError, ValueError):
        raise SimulationError(f"verify: scale must be a positive number, not {scale!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise SimulationError(f"verify: scale must be a positive finite number, not {scale!r}")
    return value


# ------------------------------------------------------------------ the check


def verify(model, samples: int = 20, seed: int = 0, max_modes: int = 200,
           scale: float | None = None) -> VerificationReport:
    """Sample guard boundaries of every reachable mode and resolve the instant
    there (see the module docstring for which states count).

    ``samples``: boundary points wanted per guard comparison and mode (each
    resolved as is and nudged to either side), from at most
    ``LINES_PER_SAMPLE·samples`` random lines; ``seed``: of the random lines;
    ``max_modes``: cap on explored modes; ``scale``: factor on the states'
    sampling scale (``max(|x0|, 1)``).  ``samples`` and ``max_modes`` must be
    whole numbers ≥ 1 (:class:`~switching.SimulationError` otherwise)."""
    samples = _whole("samples", samples, 1)
    max_modes = _whole("max_modes", max_modes, 1)
    factor = _factor(scale)
    rng = np.random.default_rng(seed)
    names = tuple(s.name for s in model.states)
    report = VerificationReport(requested=samples)
    x0 = model.given_initial_state
    state_scale = np.maximum(np.abs(x0), 1.0) * factor
    sizes = [abs(v) for v in model.parameter_values.values() if np.isfinite(v) and v != 0]
    longest = max([1.0] + sizes)
    time_scale = (longest, max(1e-9 * longest, min([1.0] + sizes)))  # (largest, smallest)
    entry = _EntryConditions(model, np.random.default_rng([seed, 1]), state_scale, time_scale)
    frontier = [model.initial_mode]
    queued = {model.initial_mode}
    loop_index: dict = {}
    error_index: dict = {}
    while frontier:
        if len(report.explored) >= max_modes:
            report.truncated = True
            break
        mode = frontier.pop(0)
        report.explored.append(mode)
        report.kinds.setdefault(mode, set())
        sampler = _ModeSampler(model, mode, entry, state_scale, time_scale[0])
        for name, text in entry.texts(mode).items():
            report.entry_conditions.setdefault(name, text)
        for boundary in sampler.boundaries:
            key = (mode, boundary.text, boundary.guard)
            lines = [_line(rng, state_scale, time_scale) for _ in range(2)]
            if sampler.constant(boundary, lines):
                report.constant.append(key)  # no boundary to sample: it cannot change in this mode
                continue
            report.coverage[key] = 0
            along = None  # whether every boundary point found is one the flow does not cross (None: none found)
            for line in range(LINES_PER_SAMPLE * samples):
                if report.coverage[key] >= samples:
                    break
                # after `samples` lines that found too few admissible states, a boundary point where another
                # guard held just before is moved onto a boundary of that guard too (the states the mode can be
                # in there may form a thinner set)
                refine = line >= samples and 2 * report.coverage[key] < samples
                start, direction = lines.pop() if lines else _line(rng, state_scale, time_scale)
                for point in sampler.crossings(boundary, start, direction):
                    states, verdicts = sampler.candidate(boundary, point, direction, rng if refine else None)
                    for reason in verdicts:
                        if reason is not None:
                            report.rejected[reason] = report.rejected.get(reason, 0) + 1
                    if all(reason is not None for reason in verdicts):
                        along = (along is not False) and verdicts[1] == ALONG
                        continue
                    report.coverage[key] += 1
                    for nudge, (x, t), reason in zip((-1, 0, 1), states, verdicts):
                        if reason is None:
                            report.samples += 1
                            _resolve_and_record(model, mode, x, t, (boundary, nudge, names), report, loop_index,
                                                error_index, frontier, queued)
                    break
            if report.coverage[key] == 0 and along:
                del report.coverage[key]  # the flow never crosses it in this mode: no event there
                report.constant.append(key)
    return report


def _line(rng, state_scale, time_scale):
    """A random line ``(start, direction)`` in (state, time) space.  Its time
    scale is drawn log-uniformly between the smallest and the largest
    parameter size (``time_scale``: (largest, smallest)), so that a time
    threshold of any of the parameters' sizes is crossed on the line's grid."""
    n = len(state_scale)
    high, low = time_scale
    scale = math.exp(rng.uniform(math.log(low), math.log(high))) if high > low else high
    start = np.concatenate([rng.normal(size=n) * state_scale, [rng.uniform(0, 2 * scale)]])
    direction = np.concatenate([rng.normal(size=n) * state_scale, [rng.normal() * scale]])
    return start, direction


def _tree_relations(tree) -> list:
    return [k for _, k, _, _ in _walk(tree)]


def _false_just_before(tree, sides, rtol, atol, at_boundary: set, before: dict) -> bool:
    """Could a guard have been false just before the flow reached ``sides``?
    Its comparisons in ``before`` (index → truth) take that truth, its other
    comparisons at their boundary either truth, the rest their truth on
    ``sides``; is there an assignment that makes the guard false?"""
    relations = set(_tree_relations(tree))
    fixed = {k: v for k, v in before.items() if k in relations}
    free = sorted((relations & at_boundary) - set(fixed))
    if len(free) > MAX_FREE_RELATIONS:
        return True
    for values in itertools.product((False, True), repeat=len(free)):
        if not decide_tree(tree, sides, rtol, atol, fixed={**fixed, **dict(zip(free, values))}):
            return True
    return False


@dataclass(frozen=True)
class _Boundary:
    k: int  # index of the comparison in the compiled mode
    text: str
    guard: str


class _ModeSampler:
    """Boundary search, projection and the reachability filters in one mode,
    on the mode's generated functions (``phi`` puts a state on the mode's
    constraints exactly as flow keeps it there; ``sides`` gives every guard
    comparison), run on whole lines of points at once where they allow it."""

    def __init__(self, model, mode, entry, state_scale, time_scale):
        self.model, self.mode, self.entry = model, mode, entry
        self.state_scale, self.time_scale = state_scale, time_scale
        self.boundary_rtol = max(BOUNDARY_RTOL, 10 * model.tolerance.rtol)
        self.cm = cm = model.compiled_mode(mode)
        self.boundaries = []
        for g in cm.guards:
            label = f"{g['automaton']}: {g['source']} → {g['target']} when {g['text']}"
            for _, k, _, text in _walk(g["tree"]):
                self.boundaries.append(_Boundary(k, text, label))
        namespace = module_namespace(vectorized=True)
        execute(cm.source, namespace, f"<hbg mode {mode.label}>")
        self._sides_many, self._phi_many = namespace["sides"], namespace["phi"]

    # ---------------------------------------------------------- projection

    def project(self, point):
        """``(x, t)`` of a line point (time taken as ``|t|``), on the mode's constraints."""
        t = abs(float(point[-1]))
        x = np.array(point[:-1], dtype=float)
        with np.errstate(all="ignore"):
            try:
                self.cm.complete(x, t)
            except _NUMERIC:
                x[:] = np.nan
        return x, t

    def _sides_of(self, points):
        """``sides`` at every line point (rows of ``points``), projected first: ``(3·relations, N)``."""
        cm, model = self.cm, self.model
        X, T = np.array(points[:, :-1].T, dtype=float), np.abs(points[:, -1])
        try:
            with np.errstate(all="ignore"):
                u = [np.array(v) for v in zip(*(model.input_values(t) for t in T))] if model.input_symbols else []
                if len(cm.dependent):
                    out = np.empty((len(cm.dependent), len(T)))
                    self._phi_many(X, T, model.parameter_array, u, out)
                    X[cm.dependent] = out
                sides = np.empty((cm.n_sides, len(T)))
                self._sides_many(X, T, model.parameter_array, u, sides)
            return sides
        except _NUMERIC:  # e.g. a conditional (Piecewise) in the generated code: point by point
            sides = np.full((cm.n_sides, len(T)), np.nan)
            for j in range(len(T)):
                x, t = self.project(points[j])
                try:
                    sides[:, j] = cm.sides(x, t)
                except _NUMERIC:
                    pass
            return sides

    def constant(self, boundary, lines) -> bool:
        """Does the comparison take one value on every point of ``lines`` (it
        does not depend on the states or time in this mode, e.g. a diode's
        forward voltage that the closed switch holds at −V)?"""
        k = boundary.k
        values = np.concatenate([
            (lambda sides: sides[3 * k] - sides[3 * k + 1])(
                self._sides_of(start[None, :] + GRID[:, None] * direction[None, :]))
            for start, direction in lines
        ])
        finite = values[np.isfinite(values)]
        return len(finite) == 0 or bool(np.all(finite == finite[0]))

    def crossings(self, boundary, start, direction):
        """Boundary points of one comparison along ``start + s·direction``, in order of ``s``."""
        k = boundary.k
        sides = self._sides_of(start[None, :] + GRID[:, None] * direction[None, :])
        values = sides[3 * k] - sides[3 * k + 1]

        def at(s):
            x, t = self.project(start + s * direction)
            with np.errstate(all="ignore"):
                triple = self.cm.sides(x, t)
            return float(triple[3 * k] - triple[3 * k + 1])

        for j in range(len(GRID) - 1):
            a, b = values[j], values[j + 1]
            if not (np.isfinite(a) and np.isfinite(b)):
                continue
            if a == 0:
                yield start + GRID[j] * direction
            elif a * b < 0:
                try:
                    s = brentq(at, GRID[j], GRID[j + 1], xtol=1e-14)
                except (ValueError, *_NUMERIC):  # NaN inside the bracket
                    continue
                yield start + s * direction

    # ---------------------------------------------------------- filters

    def candidate(self, boundary, point, direction, rng=None):
        """``(states, verdicts)`` for a boundary point nudged to either side
        and on it.  With ``rng``, a point where another guard already held is
        moved (by a root search in a random plane through it) onto that
        guard's comparison's boundary as well, up to ``MAX_REFINE`` times."""
        system, directions = [boundary.k], [direction]
        while True:
            states = [self.project(point + nudge * NUDGE * direction) for nudge in (-1, 0, 1)]
            verdicts, blocking = self.verdicts(boundary, states)
            if rng is None or any(v is None for v in verdicts) or not blocking or len(system) > MAX_REFINE:
                return states, verdicts
            for k in blocking[:MAX_REFINE + 1]:
                extra = rng.normal(size=len(direction)) * np.abs(direction).mean()
                moved = self._intersection(system + [k], point, np.array(directions + [extra]))
                if moved is not None:
                    break
            else:
                return states, verdicts
            system.append(k)
            directions.append(extra)
            point = moved

    def _intersection(self, system, point, directions):
        """A point ``point + c·directions`` where every comparison of ``system`` is at its boundary."""
        cm = self.cm

        def residuals(c):
            x, t = self.project(point + c @ directions)
            with np.errstate(all="ignore"):
                sides = cm.sides(x, t)
            return [sides[3 * k] - sides[3 * k + 1] for k in system]

        try:
            with np.errstate(all="ignore"):
                solution = root(residuals, np.zeros(len(system)), method="hybr")
        except _NUMERIC:
            return None
        if not solution.success:
            return None
        found = point + solution.x @ directions
        x, t = self.project(found)
        with np.errstate(all="ignore"):
            sides = cm.sides(x, t)
        if not all(self._at(sides, k) and math.isfinite(sides[3 * k] - sides[3 * k + 1]) for k in system):
            return None
        return found

    def verdicts(self, boundary, states):
        """For the states ``[before, on, after]`` the boundary: ``None`` for
        one the mode can be in at an event, else the reason it cannot; and
        the comparisons (not at their boundary) of the guards that held just
        before the centre."""
        model, cm = self.model, self.cm
        rtol, atol = model.tolerance.rtol, model.tolerance.atol
        if not all(np.all(np.isfinite(x)) for x, _ in states):
            return [NOT_FINITE] * len(states), []
        with np.errstate(all="ignore"):
            all_sides = [cm.sides(x, t) for x, t in states]
        center = all_sides[1]
        # comparisons at their boundary here (the nudged states count as on it): the sampled one, those
        # zero up to boundary_rtol at the centre (the same surface, or one the point was moved onto), and
        # those whose value is not finite
        at_boundary = {boundary.k} | {k for _, k, _, _ in (n for g in cm.guards for n in _walk(g["tree"]))
                                      if self._at(center, k)}
        before, tangent = self._before(states[1], center, at_boundary)
        # a comparison at its boundary that the flow only touches there, though it is not zero all along the
        # sampling line: a grazing (or one the flow cannot cross at all), where no run but a measure-zero set
        # has an event
        for k in sorted(tangent, key=lambda k: k != boundary.k):
            if any(not self._at(all_sides[j], k) for j in (0, 2)):
                return [ALONG if k == boundary.k else GRAZING] * len(states), []
        out, blocking = [], []
        for nudge, ((x, t), sides) in enumerate(zip(states, all_sides)):
            reason = None
            for g in cm.guards:
                if not _false_just_before(g["tree"], sides, rtol, atol, at_boundary, before):
                    reason = HELD
                    if nudge != 1:
                        break
                    blocking += [k for _, k, _, _ in _walk(g["tree"]) if k not in at_boundary and k not in blocking]
            if reason is None and not self.entry.admits(self.mode, x, t):
                reason = ENTRY
            out.append(reason)
        return out, blocking

    def _at(self, sides, k) -> bool:
        """Is comparison ``k`` at its boundary (zero up to ``boundary_rtol``, or not finite) on ``sides``?"""
        left, right, scale = sides[3 * k], sides[3 * k + 1], sides[3 * k + 2]
        if not (math.isfinite(left) and math.isfinite(right)):
            return True
        size = max(abs(left), abs(right), scale if math.isfinite(scale) else 0.0)
        return abs(left - right) <= self.boundary_rtol * size + self.model.tolerance.atol

    def _before(self, state, sides, at_boundary):
        """``(before, tangent)``: the truth just before ``state`` along the
        mode's flow of each comparison at its boundary whose value the flow
        changes (index → truth at ``x − h·f(x)``, ``t − h``; ``h`` moves no
        state by more than ``FLOW_STEP`` of its sampling scale), and the set
        of those the flow leaves unchanged there (tangent).  Both empty when
        the rates cannot be evaluated."""
        cm, model = self.cm, self.model
        x, t = state
        try:
            with np.errstate(all="ignore"):
                rates = np.asarray(cm.rates(x, t), dtype=float)
        except _NUMERIC:
            return {}, set()
        if not np.all(np.isfinite(rates)):
            return {}, set()
        moving = np.abs(rates) > 0
        h = FLOW_STEP * min([self.time_scale, *(self.state_scale[moving] / np.abs(rates[moving]))])
        x_before = x - h * rates
        try:
            with np.errstate(all="ignore"):
                cm.complete(x_before, t - h)
                earlier = cm.sides(x_before, t - h)
        except _NUMERIC:
            return {}, set()
        rtol, atol = model.tolerance.rtol, model.tolerance.atol
        out, tangent = {}, set()
        for _, k, op, _ in (n for g in cm.guards for n in _walk(g["tree"])):
            if k not in at_boundary:
                continue
            now, then = sides[3 * k] - sides[3 * k + 1], earlier[3 * k] - earlier[3 * k + 1]
            if not (math.isfinite(now) and math.isfinite(then)):
                continue
            scale = sides[3 * k + 2] if math.isfinite(sides[3 * k + 2]) else 0.0
            size = max(abs(sides[3 * k]), abs(sides[3 * k + 1]), scale)
            if abs(then - now) >= 10 * max(abs(now), self.boundary_rtol * size + atol):
                out[k] = decide(op, earlier[3 * k], earlier[3 * k + 1], rtol, atol, earlier[3 * k + 2])
            else:
                tangent.add(k)
        return out, tangent


def _walk(tree):
    kind = tree[0]
    if kind == "rel":
        yield tree
    elif kind in ("and", "or"):
        for t in tree[1]:
            yield from _walk(t)
    elif kind == "not":
        yield from _walk(tree[1])


# ------------------------------------------------------------------ filter 3: how a state was entered


class _Comparison:
    """A comparison over states and parameters, decided inclusively (a strict
    one as its inclusive form) with the band ``rtol·max(|lhs|, |rhs|, R) +
    atol``, ``rtol`` the larger of ``ENTRY_RTOL`` and ten times the model's."""

    _INCLUSIVE = {"<": "<=", ">": ">=", "<=": "<=", ">=": ">=", "==": "=="}

    def __init__(self, model, relation):
        args = [list(model.states), model.time, list(model.parameter_symbols)]
        self.model = model
        self.text = str(relation)
        self.op = self._INCLUSIVE[relation.rel_op]
        self.rtol = max(ENTRY_RTOL, 10 * model.tolerance.rtol)
        self.fn = sp.lambdify(args, [relation.lhs, relation.rhs,
                                     sp.Max(roundoff_scale(relation.lhs), roundoff_scale(relation.rhs))], "numpy")

    def holds(self, x, t) -> bool:
        try:
            with np.errstate(all="ignore"):
                left, right, scale = (float(v) for v in self.fn(list(x), t, self.model.parameter_array))
        except _UNEVALUABLE:
            return True
        if not (math.isfinite(left) and math.isfinite(right)):
            return True
        return decide(self.op, left, right, self.rtol, self.model.tolerance.atol, scale)


class _EntryConditions:
    """Filter 3 of the module docstring, derived per automaton state on first use."""

    def __init__(self, model, rng, state_scale, time_scale):
        self.model, self.rng = model, rng
        self.state_scale, self.time_scale = state_scale, time_scale
        self.allowed = set(model.states) | set(model.parameter_symbols)
        self._conditions: dict = {}
        self._invariant: dict = {}

    def conditions(self, index: int, state: str):
        """``None`` (no constraint) or a list of alternatives, each a list of :class:`_Comparison`."""
        key = (index, state)
        if key not in self._conditions:
            self._conditions[key] = self._derive(index, state)
        return self._conditions[key]

    def admits(self, mode, x, t) -> bool:
        for index, state in enumerate(mode.states):
            alternatives = self.conditions(index, state)
            if alternatives is not None and not any(all(c.holds(x, t) for c in kept) for kept in alternatives):
                return False
        return True

    def texts(self, mode) -> dict:
        out = {}
        for index, state in enumerate(mode.states):
            alternatives = self.conditions(index, state)
            if alternatives is not None:
                out[f"{mode.automata[index]}={state}"] = " or ".join(
                    "(" + " and ".join(c.text for c in kept) + ")" if len(kept) > 1 else kept[0].text
                    for kept in alternatives
                )
        return out

    def _derive(self, index, state):
        model = self.model
        automaton = model.automata[index]
        if state == automaton.initial:
            return None
        incoming = [tr for tr in automaton.transitions if tr.target == state]
        if not incoming:
            return None
        alternatives = []
        for tr in incoming:
            condition, _ = model.guard_conditions[(automaton.name, tr)]
            kept = []
            for c in _conjuncts(condition):
                if self._usable(c) and self._kept(c, index, state, tr):
                    try:
                        kept.append(_Comparison(model, c))
                    except _UNEVALUABLE:  # a comparison that cannot be evaluated is not used
                        continue
            if not kept:
                return None
            alternatives.append(kept)
        return alternatives

    def _usable(self, c) -> bool:
        return (isinstance(c, Relational) and c.rel_op in _Comparison._INCLUSIVE
                and bool(c.free_symbols) and c.free_symbols <= self.allowed
                and bool(c.free_symbols & set(self.model.states)))

    def _modes_with(self, index, state):
        """Every mode with automaton ``index`` in ``state`` (``None`` above the cap)."""
        model = self.model
        others = [list(a.states) if k != index else [state] for k, a in enumerate(model.automata)]
        if math.prod(len(o) for o in others) > MAX_ENTRY_MODES:
            return None
        names = tuple(a.name for a in model.automata)
        return [Mode(tuple(states), names) for states in itertools.product(*others)]

    def _kept(self, relation, index, state, tr) -> bool:
        """Is ``lhs − rhs`` unchanged by the flow and the jump of every mode
        with the automaton in ``state`` (and by the jumps of the source state's
        modes, for an a posteriori guard)?"""
        phi = relation.lhs - relation.rhs
        key = (phi, index, state, tr.source if tr.a_posteriori else None)
        if key in self._invariant:
            return self._invariant[key]
        flow_modes = self._modes_with(index, state)
        jump_modes = flow_modes
        if flow_modes is not None and tr.a_posteriori:
            source = self._modes_with(index, tr.source)
            jump_modes = None if source is None else flow_modes + source
        result = flow_modes is not None and jump_modes is not None and self._check(phi, flow_modes, jump_modes)
        self._invariant[key] = result
        return result

    def _check(self, phi, flow_modes, jump_modes) -> bool:
        model = self.model
        states, params = list(model.states), list(model.parameter_symbols)
        args = [states, model.time, params]
        try:
            value = sp.lambdify(args, [phi, roundoff_scale(phi)], "numpy")
            gradient = sp.lambdify(args, [sp.diff(phi, s) for s in states], "numpy")
        except _UNEVALUABLE:
            return False
        p = model.parameter_array
        n = len(states)

        def scalar(fn, x, t):
            return np.array([float(v) for v in fn(list(x), t, p)])

        for mode in dict.fromkeys(flow_modes + jump_modes):
            try:
                cm = model.compiled_mode(mode)
            except HybridBondGraphError:
                continue  # a mode that cannot be derived holds no state
            checked = 0
            for _ in range(INVARIANCE_POINTS):
                x = self.rng.normal(size=n) * self.state_scale
                t = float(self.rng.uniform(0, 2 * self.time_scale[0]))
                try:
                    with np.errstate(all="ignore"):
                        if mode in flow_modes:
                            xp = cm.complete(x.copy(), t)
                            g, f = scalar(gradient, xp, t), np.asarray(cm.rates(xp, t), dtype=float)
                            rate, size = float(g @ f), float(np.abs(g) @ np.abs(f))
                            if not (math.isfinite(rate) and math.isfinite(size)):
                                continue
                            if abs(rate) > INVARIANCE_RTOL * size:
                                return False
                        if mode in jump_modes:
                            (a, ra), (b, rb) = scalar(value, x, t), scalar(value, cm.jump(x, t), t)
                            if not all(math.isfinite(v) for v in (a, b, ra, rb)):
                                continue
                            if abs(a - b) > INVARIANCE_RTOL * (ra + rb):
                                return False
                except _UNEVALUABLE:
                    continue
                checked += 1
            if checked < INVARIANCE_POINTS // 2:
                return False
        return True


def _conjuncts(condition) -> list:
    if isinstance(condition, And):
        return [c for arg in condition.args for c in _conjuncts(arg)]
    return [condition]


# ------------------------------------------------------------------ resolution


def _resolve_and_record(model, mode, x, t, origin, report, loop_index, error_index, frontier, queued):
    boundary, nudge, names = origin

    def sample(outcome):
        record = Sample(mode, boundary.text, boundary.guard, x, t, nudge, outcome, names)
        report.sampled.append(record)
        return record

    try:
        instant = model.resolve(x, mode, t)
    except DivergenceOfTimeError as exc:
        record = sample("divergence of time")
        modes = tuple(step.mode for step in exc.loop)
        key = frozenset(modes)
        if key in loop_index:
            report.loops[loop_index[key]].count += 1
        else:
            loop_index[key] = len(report.loops)
            report.loops.append(Loop(modes, str(exc), record, tuple(exc.loop)))
        return
    except HybridBondGraphError as exc:
        record = sample("error")
        message = str(exc)
        key = (mode, message.splitlines()[0] if message else "")
        if key in error_index:
            report.errors[error_index[key]].count += 1
        else:
            error_index[key] = len(report.errors)
            report.errors.append(SampleError(mode, message, record))
        return
    sample(f"{instant.mode_after.describe()} ({instant.steps[-1].kind})")
    for step in instant.steps:
        if step.kind == "start":
            continue
        report.kinds.setdefault(step.mode, set()).add(step.kind)
        if step.kind in ("continuous", "pinnacle") and step.mode not in queued:
            queued.add(step.mode)
            frontier.append(step.mode)
