"""Event detection on one step of a flow: the first time a guard holds.

A guard is a boolean combination of comparisons; each comparison splits into
one-sided *parts* (``==`` into two, ``!=`` into one that holds off the band)
whose *margin* is ``sign·(left − right)`` measured against the tolerance
band.  :class:`GuardScan` tests the guards at the step's end and at sample
points inside it; between points it searches for a guard that holds only
briefly — an extremum of a margin that comes within reach of its threshold
(a parabola through three points, refined by Brent's method,
:mod:`switching.rules.maximize`), or two or more parts of one guard changing truth — and
:meth:`GuardScan.locate` narrows the first time a guard holds down to
adjacent floating-point numbers on the step's interpolant (the ITP method on
the margin of the part that changes truth, :func:`switching.rules.bracket.narrow_next`);
:func:`locate_event` bisects what is left of that bracket (nothing, where
its ends are adjacent numbers already).  The compiled
kernel (:mod:`switching.kernel.events`) ports the same search; the
rules of both are :mod:`switching.rules.bracket` and :mod:`switching.rules.maximize`.
"""

from __future__ import annotations

import functools
import math
import weakref

from codegen.decision import band
from codegen.safety import execute

from ..library.compiled import guard_parts
from ..rules.bracket import (BISECTIONS, halve, narrow_begin, narrow_next, parabola_peak, peak_in_reach,
                             switching_part, worth_refining)
from ..rules.maximize import maximize_begin, maximize_next

__all__ = ["GuardScan", "locate_event"]

_GUARD_FORMS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class _GuardForm:
    """The guards of one compiled mode for event detection, as one generated
    function ``evaluate(sides, rtol, atol) -> (margins, truths, holds)``:

    * ``holds``: a guard holds, decided exactly as
      :func:`codegen.runtime.decide` and :meth:`CompiledMode.holds` do;
    * the *parts* of every comparison, one-sided, in the direction that can
      make its guard hold (a comparison under ``not`` counts reversed; ``==``
      has two parts, one per side of its band; ``!=`` one part, tracked but
      never refined): ``margins`` — ``±(left − right) ± band``, ≥ 0
      (inclusive) or > 0 (strict) exactly where the part holds — and
      ``truths``;

    and ``evaluate_strict`` the same with every part strict (its margin
    ``±(left − right) − band`` > 0): a guard holds there when it holds
    however its comparisons within their band are decided
    (:func:`switching.library.compiled.holds_strictly`)."""

    def __init__(self, cm):
        parts, of_parts, terms, ops = guard_parts([guard["tree"] for guard in cm.guards])
        self.parts = [(k, sign, inclusive) for k, sign, inclusive, _ in parts]  # (relation, sign, inclusive)
        self.by_guard = [[i for i, part in enumerate(parts) if part[3] == g] for g in range(len(cm.guards))]
        # each guard from its parts' truths (for possible(): which guards could hold)
        source = "\n".join(f"def guard_{g}(q):\n    return {expression}" for g, expression in enumerate(of_parts))
        namespace = execute(source, {}, "<hbg guards of their parts>")
        self.guard_of_parts = [namespace[f"guard_{g}"] for g in range(len(of_parts))]
        ops = [ops.get(k) for k in range(cm.n_relations)]
        self.source = self._source("evaluate", ops, False, " or ".join(terms) or "False")
        namespace = execute(self.source, {"band": band}, "<hbg guard parts>", also=frozenset({"band"}))
        self.evaluate = namespace["evaluate"]
        strict = self._source("evaluate_strict", ops, True, " or ".join(of_parts) or "False")
        namespace = execute(strict, {"band": band}, "<hbg strict guard parts>", also=frozenset({"band"}))
        self.evaluate_strict = namespace["evaluate_strict"]
        self.tracked = [i for i, (_, sign, _) in enumerate(self.parts) if sign]
        self.signs = tuple(sign for _, sign, _ in self.parts)

    def _source(self, name: str, ops: list, strict: bool, holds: str) -> str:
        """The source of ``name(s, rtol, atol) -> (margins, truths, holds)``
        (the class docstring); ``strict``: every part strict, and ``holds``
        from the parts' truths ``q``."""
        truth = {"<=": "d{k} <= b{k}", "<": "d{k} < -b{k}", ">=": "d{k} >= -b{k}", ">": "d{k} > b{k}",
                 "==": "abs(d{k}) <= b{k}", "!=": "abs(d{k}) > b{k}"}
        lines = [f"def {name}(s, rtol, atol):"]
        for k, op in enumerate(ops):
            if op is None:
                continue
            # the band of the rule codegen.decision.band, widened by the round-off scale s[3k + 2]
            lines.append(f"    d{k} = s[{3 * k}] - s[{3 * k + 1}]; "
                         f"b{k} = band(s[{3 * k}], s[{3 * k + 1}], s[{3 * k + 2}], rtol, atol)")
            if not strict:
                lines.append(f"    r{k} = " + truth[op].format(k=k))
        margins, truths = [], []
        for i, (k, sign, inclusive) in enumerate(self.parts):
            if sign:
                widened = inclusive and not strict
                lines.append(f"    m{i} = {'' if sign > 0 else '-'}d{k} {'+' if widened else '-'} b{k}")
                margins.append(f"m{i}")
                truths.append(f"m{i} {'>=' if widened else '>'} 0.0")
            else:
                margins.append("None")
                truths.append(f"abs(d{k}) > b{k}")

        def tuple_of(items):
            return f"({', '.join(items)}{',' if len(items) == 1 else ''})"

        if strict:
            lines += [f"    q = {tuple_of(truths)}", f"    return {tuple_of(margins)}, q, {holds}"]
        else:
            lines.append(f"    return {tuple_of(margins)}, {tuple_of(truths)}, {holds}")
        return "\n".join(lines)

    @classmethod
    def of(cls, cm):
        form = _GUARD_FORMS.get(cm)
        if form is None:
            form = _GUARD_FORMS[cm] = cls(cm)
        return form


class _Point:
    """The guards at one time: ``margins`` of the parts, their ``truths``,
    and whether a guard ``holds`` (exactly as :meth:`CompiledMode.holds`)."""

    __slots__ = ("tau", "margins", "truths", "holds")

    def __init__(self, tau, margins, truths, holds):
        self.tau, self.margins, self.truths, self.holds = tau, margins, truths, holds


class GuardScan:
    """Event detection over the steps of one flow.

    Per step the guards are evaluated at ``samples`` interior points and the
    end, as the comparisons' values (the points).  Besides a guard holding at
    a point, two things inside a step are looked for between the points:

    * a comparison's difference with an extremum between points that comes
      within reach of its threshold (a parabola through three points, the
      previous step's last one included, predicts the extremum): the
      extremum is refined (Brent's method on the step's interpolant) and
      becomes a point;
    * two or more comparisons of one guard changing their truth value
      between two points: each change is located by bisection and the guards
      are tested just after each one, so a guard that holds only between
      them is seen.

    ``first_hold`` returns the first pair ``(a, b)`` of times with no guard
    holding at ``a`` and one holding at ``b`` (for :func:`locate_event`).

    ``strict``: a guard counts only where it holds strictly, however its
    comparisons within their band are decided (``_GuardForm.evaluate_strict``)
    — the flow from an instant that rested at a tie, where a guard holds at
    the edge of an inclusive comparison (``v_D >= 0`` at ``v_D = 0``,
    :mod:`switching.rules.instants`): that guard fires once the flow carries
    its comparison beyond the band, as a strict one (``v_D > 0``) would."""

    def __init__(self, cm, sides, stepper, state_at, t0, x0, rtol, atol, samples, strict=False):
        self.cm, self.stepper, self.state_at = cm, stepper, state_at
        self.rtol, self.atol, self.samples = rtol, atol, samples
        self.form = _GuardForm.of(cm)
        self.strict = strict
        self.evaluate = self.form.evaluate_strict if strict else self.form.evaluate
        self.sides = sides  # sides(x, t): the guards' comparison sides, a list of floats
        self.start = self.point(t0, x0)
        self.before = None  # the previous step's last point before its end

    # ------------------------------------------------------------ evaluation

    def state(self, tau):
        return self.state_at(tau, self.stepper.interpolate(tau))

    def point(self, tau, x=None) -> _Point:
        sides = self.sides(self.state(tau) if x is None else x, tau)
        return _Point(tau, *self.evaluate(sides, self.rtol, self.atol))

    def holds(self, x, tau) -> bool:
        """Does a guard hold at ``(tau, x)``: :meth:`CompiledMode.holds`
        itself, or strictly (``strict``)."""
        if self.strict:
            return self.evaluate(self.sides(x, tau), self.rtol, self.atol)[2]
        return self.cm.holds(x, tau, self.rtol, self.atol)

    def margin(self, i, tau) -> float:
        """The margin of part ``i`` at ``tau``."""
        return self.evaluate(self.sides(self.state(tau), tau), self.rtol, self.atol)[0][i]

    # ------------------------------------------------------------ the step

    def first_hold(self, t_prev, t_new, x_new):
        n = self.samples
        h = t_new - t_prev
        points = [self.start]
        for j in range(1, n + 1):
            tau = t_prev + h * j / (n + 1)
            if points[-1].tau < tau < t_new:  # a step of a few ulps has fewer distinct points
                points.append(self.point(tau))
        end = self.point(t_new, x_new)
        points.append(end)
        last = next((i for i in range(1, len(points)) if points[i].holds), None)
        extra = self.extrema(points, last, t_prev, t_new)
        if extra:
            points = sorted(points + extra, key=lambda point: point.tau)
        for i in range(1, len(points)):
            a, b = points[i - 1], points[i]
            if b.holds:  # the first hold in (a, b]; then a hold between the changes before it?
                lo, tau = self.locate(a, b)
                inside = self.pieces(a, lo) if lo is not a else None
                if inside is not None:
                    lo, tau = self.locate(a, inside)
                return self.verified(a, b, lo, tau)
            inside = self.pieces(a, b)
            if inside is not None:
                return self.verified(a, inside, *self.locate(a, inside))
        self.before, self.start = points[-2], end
        return None

    def locate(self, a, b):
        """``(lo, tau)``: ``(a, b]`` (``a`` a point where no guard holds, ``b``
        one where one does) narrowed down to adjacent floating-point numbers
        (the rules :func:`switching.rules.bracket.narrow_begin` and
        ``narrow_next``), ``lo`` the last point seen not holding."""
        lo = a
        signs = self.form.signs
        part = switching_part(a.truths, b.truths, signs, len(signs))

        def guide(point):
            return point.margins[part] if part >= 0 else math.nan

        done, state = narrow_next(narrow_begin(a.tau, b.tau, guide(a)), True, guide(b))
        while not done:
            point = self.point(state[-1])
            if not point.holds:
                lo = point
            done, state = narrow_next(state, point.holds, guide(point))
        return lo, state[1]

    def verified(self, a, b, lo, tau):
        """The bracket ``(lo, tau)`` for :func:`locate_event`, ``tau`` checked with
        ``CompiledMode.holds`` itself (:meth:`holds`; else the plain bracket ``(a, b)``)."""
        if self.holds(self.state(tau), tau):
            return lo.tau, tau
        return a.tau, b.tau

    def extrema(self, points, last, t_prev, t_new) -> list:
        """Points at refined extrema of the parts' margins (see the class)."""
        first = 0 if self.before is None else 1  # the index of t_prev in ``extended``
        extended = ([] if self.before is None else [self.before]) + points[: len(points) if last is None else last + 1]
        count = len(extended)
        if count < 3:
            return []
        taus = [point.tau for point in extended]
        columns = list(zip(*[point.margins for point in extended]))
        found = []
        for i in self.form.tracked:
            m = columns[i]
            top, bottom = max(m), min(m)
            if not worth_refining(top, bottom):
                continue  # holds all along, or far from its threshold all along
            for j in range(first, count):
                if extended[j].truths[i]:
                    continue
                if 0 < j < count - 1:
                    if not (m[j] >= m[j - 1] and m[j] >= m[j + 1]):
                        continue
                    triple, low, high, window = (j - 1, j, j + 1), taus[j - 1], taus[j + 1], None
                elif j == count - 1 and last is None and m[j] > m[j - 1]:  # rising at the step's end
                    triple, low, high = (j - 2, j - 1, j), taus[j - 1], taus[j]
                    window = (taus[j - 1], 2 * taus[j] - taus[j - 1])
                elif j == 0 and m[0] > m[1]:  # falling from the flow's start
                    triple, low, high = (0, 1, 2), taus[0], taus[1]
                    window = (2 * taus[0] - taus[1], taus[1])
                else:
                    continue
                ok, at, value = parabola_peak(*[taus[k] for k in triple], *[m[k] for k in triple])
                if not ok:
                    continue
                reference = max(m[k] for k in triple)
                if window is not None and not window[0] < at < window[1]:
                    continue
                if not peak_in_reach(value, reference):
                    continue
                low, high = max(low, t_prev), min(high, t_new)
                if not high > low:
                    continue
                tau = _peak(functools.partial(self.margin, i), low, high)
                if all(tau != point.tau for point in extended + found):
                    found.append(self.point(tau))
        return found

    def pieces(self, a, b):
        """A point inside ``(a, b)`` where a guard holds although it holds at
        neither end, found from comparisons changing truth in between."""
        if a.truths == b.truths:
            return None
        changed = set()
        for g, mine in enumerate(self.form.by_guard):
            switching = [i for i in mine if a.truths[i] != b.truths[i]]
            if len(switching) >= 2 and self.possible(g, a.truths, switching):
                changed.update(switching)
        if not changed:
            return None
        times = sorted({self.switch(i, a, b) for i in changed})
        for tau in times:
            if tau < b.tau:
                point = self.point(tau)
                if point.holds:
                    return point
        return None

    def possible(self, g, truths, switching) -> bool:
        """Can guard ``g`` hold for some truth values of the ``switching``
        parts, the others as in ``truths``?"""
        guard = self.form.guard_of_parts[g]
        q = list(truths)
        for combination in range(1 << len(switching)):
            for bit, i in enumerate(switching):
                q[i] = bool(combination >> bit & 1)
            if guard(q):
                return True
        return False

    def switch(self, i, a, b) -> float:
        """The first time after which part ``i`` has its truth value at ``b``
        (bisection to adjacent floating-point numbers)."""
        _, sign, inclusive = self.form.parts[i]
        lo, hi, truth_lo = a.tau, b.tau, a.truths[i]
        for _ in range(BISECTIONS):
            more, mid = halve(lo, hi)
            if not more:
                break
            if sign:
                margin = self.margin(i, mid)
                truth = margin >= 0.0 if inclusive and not self.strict else margin > 0.0
            else:
                truth = self.point(mid).truths[i]
            if truth == truth_lo:
                lo = mid
            else:
                hi = mid
        return hi


def _peak(f, a, b) -> float:
    """A maximum of ``f`` on ``[a, b]``, or the first point found where
    ``f ≥ 0`` (the part holds): the rule
    :mod:`switching.rules.maximize` (Brent's method) evaluating ``f``."""
    state = maximize_begin(a, b)
    done = False
    while not done:
        done, state = maximize_next(state, f(state[-1]))
    return state[-1]


def locate_event(holds, stepper, state_at, a, b) -> float:
    """The first time in ``(a, b]`` at which a guard holds on the interpolant
    (``holds(x, t)``: :meth:`GuardScan.holds`; bisection down to adjacent
    floating-point numbers)."""
    for _ in range(BISECTIONS):
        more, mid = halve(a, b)
        if not more:
            break
        if holds(state_at(mid, stepper.interpolate(mid)), mid):
            b = mid
        else:
            a = mid
    return b
