"""Continuation of a periodic orbit in one parameter (:func:`continue_orbit`).

**Natural-parameter continuation.**  For parameter values ``p_0, p_1, …``
(in the order given) the orbit at ``p_k`` is found by Newton shooting
(:func:`switching.analysis.orbits.periodic_orbit`) started from a
*predictor*: the previous orbit's start ``x0(p_{k−1})`` at the second point,
then the secant through the last two,
``x0 ≈ x0(p_{k−1}) + (x0(p_{k−1}) − x0(p_{k−2})) (p_k − p_{k−1})/(p_{k−1} − p_{k−2})``
(and likewise the period's guess of an autonomous orbit), in the start
mode of the previous orbit.  Every point keeps its orbit: period [s],
``x0``, monodromy, Floquet multipliers, stability, mode sequence, and the
range (min, max over one period) of every state and of the ``signals``
asked for.

**How the parameter is changed.**  ``model`` is either

* a :class:`~switching.HybridModel` and ``parameter`` the name of one of its
  parameters: the value is written into the model's parameter values (a new
  ``parameter_values`` dict and ``parameter_array``, which every generated
  function reads at each call — the derived modes and generated code hold
  the parameters as symbols, so nothing is derived again), and the model's
  own values are put back when the continuation ends (also on an error);
* or a build function ``build(**arguments) -> HybridModel`` (a shipped
  model's ``models.<name>.build``, a model file's ``build``) and
  ``parameter`` one of its arguments (which may set several model
  parameters, e.g. a duty cycle that also moves a carrier): each point
  builds ``build(**fixed, parameter=p)`` and moves its values onto the first
  point's model (:meth:`~switching.HybridModel.take_definition`, as sweeps
  do), so the modes are derived once.  The argument must not change the
  model's structure (its fingerprint): that is a :class:`~switching.errors.ContinuationError`.

**Bifurcations** (real crossings only).  With the nontrivial multipliers
``μ_i(p)`` (the trivial one of an autonomous orbit left out), the test
functions ``g_PD(p) = Re ∏_i (μ_i + 1)`` and ``g_F(p) = Re ∏_i (μ_i − 1)``
(for a fixed period ``det(M + I)`` and ``det(M − I)``) change sign exactly
when an odd number of real multipliers passes through −1 (*period
doubling*, a flip) or +1 (*fold*, a saddle-node; for a fixed period also a
transcritical or pitchfork point); a complex pair contributes
``|μ ± 1|² > 0`` and does not.  A sign change between two consecutive
points is located by Brent's bracketing method on ``g(p)`` (each evaluation
an orbit, started from the linear interpolation of the two ends' ``x0``, to
the residual ``tol`` alone: near a fold the orbit's start is determined only
to ``residual / |1 − μ|``, while ``g`` needs its multipliers; each such orbit
carries its ``error``) until the bracket is below ``parameter_tol · max(|p|, |Δp|)``; the
:class:`Bifurcation` records the value, the multiplier nearest ±1 there and
the orbit.  When the two ends flow through different mode sequences the
multipliers may jump across ±1 without crossing it (a border collision):
that is reported with ``kind="border collision"`` and not located.

**Switching to the doubled branch** (``switch_branch=True``).  At a located
period doubling ``p*`` (orbit ``x*``, eigenvector ``v`` of the multiplier −1)
the orbit of twice the period (fixed period ``2T``; autonomous: ``2·crossings``
returns to the section) bifurcates with an amplitude ``∝ sqrt(|p − p*|)`` on
one side — beyond ``p*`` (supercritical: it takes over the stability) or
before it (subcritical: an unstable orbit around the stable one).  At
``p1 = p* ± δ``, ``δ = 10⁻² |bracket|``, beyond first, Newton for the doubled
period starts from ``x* ± s v`` (``v`` scaled to the states' amplitudes,
``s`` from 10⁻³ to 0.3 of them) until it converges to an orbit whose start is
not the period-1 orbit's at ``p1`` (relative difference > 10⁻⁵; the residual
asked of that search is ``10⁻⁶ |μ² − 1|``, ``μ`` the period-1 multiplier
nearest −1 at ``p1``, since ``M² − I`` is nearly singular there); the branch is
then continued from ``p1`` over the given values on that side, outward,
through the distances ``2δ, 4δ, …`` from ``p*`` first (the branch grows as
``sqrt(|p − p*|)``, which a secant through steps doubling in size predicts
within about 12 %); a point without orbit, or one where Newton lands on the
period-1 orbit, ends it (``stopped``).  It is returned in
``Continuation.branches`` (its ``origin`` the bifurcation).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from bondgraph.errors import HybridBondGraphError

from ..errors import ContinuationError, OptionError, OrbitArgumentError, UnknownOptionError
from .orbit_arguments import checked_continuation_arguments, checked_x0
from .orbits import PeriodicOrbit, periodic_orbit

__all__ = ["Bifurcation", "Continuation", "ContinuationPoint", "continue_orbit"]


@dataclass
class ContinuationPoint:
    """One orbit of a :class:`Continuation`: the parameter ``value``, the
    :class:`~switching.analysis.orbits.PeriodicOrbit` found there, and
    ``ranges``: name → (min, max) over one period of every state and of the
    signals asked for (computed with this point's parameter values)."""

    value: float
    orbit: PeriodicOrbit
    ranges: dict = field(default_factory=dict)

    @property
    def period(self) -> float:
        return self.orbit.period

    @property
    def x0(self) -> np.ndarray:
        return self.orbit.x0

    @property
    def multipliers(self) -> np.ndarray:
        return self.orbit.multipliers

    @property
    def stable(self) -> bool:
        return self.orbit.stable


@dataclass
class Bifurcation:
    """A located crossing: ``kind`` is ``"period doubling"`` (a real
    multiplier through −1), ``"fold"`` (through +1) or ``"border
    collision"`` (the multipliers jump across ±1 where the mode sequence
    changes; not located, ``value`` is then the bracket's midpoint);
    ``value`` the parameter value there; ``bracket`` the two continuation
    values it lies between; ``multiplier`` the real multiplier nearest ±1 at
    ``value``; ``eigenvector`` its eigenvector of the monodromy;
    ``orbit`` the orbit at ``value`` (``None`` for a border collision)."""

    kind: str
    value: float
    bracket: tuple
    multiplier: float | None = None
    eigenvector: np.ndarray | None = None
    orbit: PeriodicOrbit | None = None

    def __str__(self) -> str:
        if self.multiplier is None:
            return f"{self.kind} between {self.bracket[0]:.10g} and {self.bracket[1]:.10g}"
        return f"{self.kind} at {self.value:.10g} (multiplier {self.multiplier:.6g})"


@dataclass
class Continuation:
    """The result of :func:`continue_orbit`: ``parameter`` (its name),
    ``points`` (:class:`ContinuationPoint`, in the order computed),
    ``bifurcations`` (:class:`Bifurcation`, in parameter order along the
    path), ``state_names``, ``signals`` (the signal names whose ranges were
    recorded), ``wall_time`` [s]; ``stopped``: ``None``, or the message of
    the error that ended the continuation early (``on_error="stop"``);
    ``branches``: the doubled branches followed from its period doublings
    (each a Continuation whose ``origin`` is the :class:`Bifurcation`)."""

    parameter: str
    points: list
    bifurcations: list
    state_names: tuple
    signals: tuple = ()
    wall_time: float = 0.0
    stopped: str | None = None
    branches: list = field(default_factory=list)
    origin: Bifurcation | None = None

    @property
    def values(self) -> np.ndarray:
        return np.array([p.value for p in self.points])

    def rows(self) -> list:
        """One dict per point: the parameter, ``period`` [s], ``x0:<state>``,
        ``multiplier_1 …`` (largest modulus first; complex when complex),
        ``max_abs_multiplier``, ``stable``, ``iterations``, ``modes``, and
        ``min:<signal>``, ``max:<signal>`` for the signals asked for."""
        rows = []
        for point in self.points:
            orbit = point.orbit
            row = {self.parameter: point.value, "period": orbit.period}
            row.update({f"x0:{s}": float(v) for s, v in zip(self.state_names, orbit.x0)})
            for k, mu in enumerate(orbit.multipliers, 1):
                row[f"multiplier_{k}"] = complex(mu) if np.iscomplexobj(mu) and mu.imag != 0 else float(np.real(mu))
            row["max_abs_multiplier"] = float(np.max(np.abs(orbit.multipliers))) if len(orbit.multipliers) else 0.0
            row["stable"] = orbit.stable
            row["iterations"] = orbit.iterations
            row["modes"] = " → ".join(orbit.mode_names)
            for name in self.signals:
                row[f"min:{name}"], row[f"max:{name}"] = point.ranges[name]
            rows.append(row)
        return rows

    def table(self):
        """The points as a pandas DataFrame (one row each, columns of
        :meth:`rows`) when pandas is importable, else the list of dicts."""
        try:
            import pandas
        except ImportError:
            return self.rows()
        return pandas.DataFrame(self.rows())

    def plot(self, name: str, *, what: str = "range", ax=None):
        """Bifurcation diagram of ``name`` (a state, or a signal passed to
        ``continue_orbit(signals=...)``) against the parameter: ``what="range"``
        draws its min and max over one period, ``"x0"`` (states only) its value
        at the orbit's start.  Stretches between stable points are solid,
        others dashed; bifurcations are marked (o: period doubling, s: fold,
        x: border collision).  Returns the matplotlib axes."""
        from bondgraph.drawing import pyplot

        if name not in self.state_names and name not in self.signals:
            raise ContinuationError(f"Continuation.plot: {name!r} is neither a state ({', '.join(self.state_names)}) "
                                    f"nor a recorded signal ({', '.join(self.signals) or 'none'}); pass "
                                    f"signals=[{name!r}] to continue_orbit")
        if what not in ("range", "x0"):
            raise ContinuationError(f"Continuation.plot: what={what!r}; use 'range' or 'x0'")
        if what == "x0" and name not in self.state_names:
            raise ContinuationError(f"Continuation.plot: what='x0' is for states; {name!r} is a signal")
        if ax is None:
            _, ax = pyplot().subplots(figsize=(6.4, 4.0))
        p, curves = self._curves(name, what, ax, "C0")
        for branch in self.branches:  # doubled branches, in another colour
            branch._curves(name, what, ax, "C1")
        markers = {"period doubling": ("o", "C3"), "fold": ("s", "C2"), "border collision": ("x", "C1")}
        labelled = set()
        for b in self.bifurcations:
            marker, color = markers[b.kind]
            if b.orbit is not None:
                k = self.state_names.index(name) if name in self.state_names else None
                ys = ([b.orbit.x0[k]] if what == "x0" else
                      ([b.orbit.trajectory.x[:, k].min(), b.orbit.trajectory.x[:, k].max()] if k is not None else
                       [np.interp(b.value, p, c) for c in curves]))
            else:
                ys = [np.interp(b.value, p, c) if p[0] < p[-1] else np.interp(b.value, p[::-1], c[::-1])
                      for c in curves]
            ax.plot([b.value] * len(ys), ys, marker, color=color, markersize=7, markerfacecolor="none",
                    label=None if b.kind in labelled else b.kind)
            labelled.add(b.kind)
        notes = getattr(self.points[0].orbit.trajectory.model, "annotations", None) if self.points else None
        label = notes.label if notes is not None else str
        ax.set_xlabel(label(self.parameter))
        ax.set_ylabel(f"{label(name)} at the orbit's start" if what == "x0" else
                      f"{label(name)}: min and max over a period")
        ax.set_title("solid: stable orbit, dashed: unstable" + ("; doubled branches in orange" if self.branches
                                                                else ""), fontsize=9)
        if labelled:
            ax.legend(fontsize=8)
        return ax

    def _curves(self, name, what, ax, color):
        """Draw this continuation's curves of ``name`` on ``ax``; returns ``(values, curves)``."""
        p = self.values
        if what == "x0":
            curves = [np.array([pt.x0[self.state_names.index(name)] for pt in self.points])]
        else:
            curves = [np.array([pt.ranges[name][0] for pt in self.points]),
                      np.array([pt.ranges[name][1] for pt in self.points])]
        stable = [pt.stable for pt in self.points]
        # runs of segments of one kind, each drawn as one line (so a dash pattern shows on short segments)
        runs, start = [], 0
        for k in range(1, len(p)):
            solid = stable[k - 1] and stable[k]
            if k == len(p) - 1 or (stable[k] and stable[k + 1]) != solid:
                runs.append((start, k, solid))
                start = k
        for curve in curves:
            for first, last, solid in runs:
                ax.plot(p[first:last + 1], curve[first:last + 1], color=color, linestyle="-" if solid else "--",
                        linewidth=1.4)
            if len(p) == 1:
                ax.plot(p, curve, "o", color=color, markersize=3)
        return p, curves


class _Family:
    """Sets the continuation parameter: on a model's parameter values, or by a build function."""

    def __init__(self, model, parameter: str, fixed: dict):
        self.parameter, self.fixed = parameter, dict(fixed or {})
        if hasattr(model, "parameter_values") and hasattr(model, "simulate"):
            if self.fixed:
                raise ContinuationError("continue_orbit: fixed= is for a build function; set a model's other "
                                        "parameters when you build it")
            names = {s.name for s in model.parameter_symbols}
            if parameter not in names:
                raise ContinuationError(f"continue_orbit: {parameter!r} is not a parameter of model {model.name!r} "
                                        f"(its parameters: {', '.join(sorted(names))}); to continue in a build "
                                        "argument pass the build function instead of the model")
            self.model, self.build = model, None
            self.saved = dict(model.parameter_values)
        elif callable(model):
            self.model, self.build, self.saved = None, model, None
        else:
            raise ContinuationError(f"continue_orbit: model must be a HybridModel or a build function, got "
                                    f"{type(model).__name__}")

    def set(self, value: float):
        """The model with ``parameter = value``."""
        if self.build is None:
            model = self.model
            values = {s.name: v for s, v in model.parameter_values.items()}
            values[self.parameter] = value
            model.set_parameter_values(values)
            return model
        built = self.build(**{**self.fixed, self.parameter: value})
        if self.model is None:
            self.model = built
        elif built.fingerprint != self.model.fingerprint:
            raise ContinuationError(f"continue_orbit: {self.parameter} = {value:.10g} builds a model of another "
                                    "structure (fingerprint) than the first point: continuation follows one "
                                    "structure; continue in a parameter that changes values only", value=value)
        else:
            self.model.take_definition(built)
        return self.model

    def restore(self) -> None:
        if self.saved is not None:
            self.model.set_parameter_values(self.saved)


def _test_value(multipliers, shift: float) -> float:
    """``Re ∏ (μ_i + shift)`` (1 for no multipliers)."""
    return float(np.real(np.prod(np.asarray(multipliers, dtype=complex) + shift))) if len(multipliers) else 1.0


def _nearest(orbit: PeriodicOrbit, target: float):
    """The real multiplier of ``orbit`` nearest ``target`` and its eigenvector of the monodromy."""
    mu = np.asarray(orbit.multipliers)
    if not len(mu):
        return None, None
    k = int(np.argmin(np.abs(mu - target) + 1e3 * np.abs(np.imag(mu))))
    values, vectors = np.linalg.eig(orbit.monodromy)
    j = int(np.argmin(np.abs(values - mu[k])))
    vector = vectors[:, j]
    return float(np.real(mu[k])), np.real_if_close(vector / np.linalg.norm(vector))


def continue_orbit(model, parameter: str, values, *, period=None, section=None, crossings: int = 1, x0=None,
                   mode=None, fixed=None, signals=(), locate: bool = True, parameter_tol: float = 1e-9,
                   on_error: str = "raise", switch_branch: bool = False, **orbit_options) -> Continuation:
    """Follow a periodic orbit of ``model`` as ``parameter`` runs through
    ``values`` (the mathematics: the module docstring).

    ``model``: a HybridModel (``parameter`` one of its parameters) or a
    build function (``parameter`` one of its arguments, the others from
    ``fixed``).  ``values``: the parameter values in the order followed (at
    least 1).  ``period`` [s]: a number, or a callable of the parameter
    value (a switching period ``1/f_sw`` that moves with ``f_sw``); fixed
    period without ``section``, else the first guess of the autonomous
    period (later guesses: the secant predictor).  ``section``,
    ``crossings``, ``x0`` (the first point's guess; default the model's
    initial state), ``mode`` and ``orbit_options`` (``rtol``, ``tol``,
    ``max_step``, ``warmup`` — the first point only —, …) go to
    :func:`~switching.analysis.orbits.periodic_orbit`.  ``signals``: names
    whose min and max over each orbit are recorded (for :meth:`Continuation.plot`
    and the table; states always are).  ``locate``: locate the crossings
    of ±1 (else only the brackets are reported); ``parameter_tol``: the
    bracket's relative width at which a crossing is located.
    ``on_error``: ``"raise"`` (a :class:`~switching.errors.ContinuationError`
    naming the parameter value, with the points so far in ``.result``) or
    ``"stop"`` (return them, ``.stopped`` the message).
    ``switch_branch``: at each located period doubling, look for the orbit
    of twice the period and follow it (module docstring); the branches
    found are in ``.branches``.

    Its own arguments are checked first (a :class:`~switching.errors.ContinuationError`
    naming the argument, the value and what to give); those of
    :func:`~switching.analysis.orbits.periodic_orbit` raise its
    :class:`~switching.errors.OrbitArgumentError` at the first point.
    """
    values, signals, warmup = checked_continuation_arguments(parameter, values, period, section, on_error,
                                                             parameter_tol, signals, locate, switch_branch, fixed,
                                                             orbit_options.pop("warmup", 0))
    period_of = period if callable(period) else (lambda _value: period)
    family = _Family(model, parameter, fixed)
    started = time.perf_counter()
    result = Continuation(parameter, [], [], (), tuple(signals))

    def solve(value, guess, guess_mode, guess_period, first=False, criterion="error"):
        m = family.set(value)
        T = period_of(value) if (section is None or guess_period is None) else guess_period
        orbit = periodic_orbit(m, T, section=section, crossings=crossings, x0=guess, mode=guess_mode,
                               warmup=warmup if first else 0, criterion=criterion, **orbit_options)
        ranges = {}
        for k, s in enumerate(m.state_names):
            column = orbit.trajectory.x[:, k]
            ranges[s] = (float(column.min()), float(column.max()))
        for name in signals:
            if name not in ranges:
                v = orbit.trajectory.signal(name)
                ranges[name] = (float(np.min(v)), float(np.max(v)))
        return ContinuationPoint(value, orbit, ranges)

    try:
        for k, value in enumerate(values):
            if k == 0:
                m = family.set(value)
                result.state_names = tuple(m.state_names)
                guess = checked_x0(x0, m, "continue_orbit")
                guess_mode, guess_period = mode, None
            else:
                last = result.points[-1]
                guess, guess_mode = last.x0.copy(), last.orbit.modes[0]
                guess_period = last.period if section is not None else None
                if len(result.points) >= 2:
                    before = result.points[-2]
                    ratio = (value - last.value) / (last.value - before.value) if last.value != before.value else 0.0
                    guess = last.x0 + ratio * (last.x0 - before.x0)
                    if section is not None:
                        guess_period = max(last.period + ratio * (last.period - before.period), 0.5 * last.period)
            try:
                point = solve(value, guess, guess_mode, guess_period, first=(k == 0))
            except (OrbitArgumentError, OptionError, UnknownOptionError):  # a request refused (section=5,
                raise  # max_iterations=-1, max_step=-1): not a point's failure
            except HybridBondGraphError as error:  # no orbit (OrbitError), or a run that failed on the way
                previous = (f"; the last orbit found is at {parameter} = {result.points[-1].value:.10g}"
                            if result.points else "")
                message = (f"continue_orbit: no orbit at {parameter} = {value:.10g} (point {k}){previous}: {str(error).rstrip('.')}. "
                           "Try smaller steps of the parameter near this value, stop the range before it, or (first "
                           "point) a better x0= / warmup=; the points found so far are in error.result")
                if on_error == "stop":
                    result.stopped = message
                    break
                raise ContinuationError(message, value=value, result=result) from error
            if result.points:
                _detect(result, result.points[-1], point, solve, locate, parameter_tol)
            result.points.append(point)
        if switch_branch:
            context = dict(period_of=period_of, section=section, crossings=crossings, signals=signals,
                           locate=locate, parameter_tol=parameter_tol, options=orbit_options)
            for bifurcation in list(result.bifurcations):
                if bifurcation.kind == "period doubling" and bifurcation.orbit is not None:
                    branch = _doubled_branch(family, bifurcation, values, result.points, **context)
                    if branch is not None:
                        result.branches.append(branch)
    finally:
        family.restore()
        result.wall_time = time.perf_counter() - started
    return result


def _detect(result: Continuation, a: ContinuationPoint, b: ContinuationPoint, solve, locate, parameter_tol) -> None:
    """Bifurcations between consecutive points ``a`` and ``b`` (appended to ``result.bifurcations``)."""
    for kind, shift in (("period doubling", 1.0), ("fold", -1.0)):
        ga, gb = _test_value(a.multipliers, shift), _test_value(b.multipliers, shift)
        if not (ga * gb < 0 or (gb == 0.0 and ga != 0.0)):
            continue
        bracket = (a.value, b.value)
        if a.orbit.modes != b.orbit.modes:
            result.bifurcations.append(Bifurcation("border collision", 0.5 * (a.value + b.value), bracket))
            continue
        if not locate:
            result.bifurcations.append(Bifurcation(kind, 0.5 * (a.value + b.value), bracket))
            continue
        from scipy.optimize import brentq

        found = {a.value: a.orbit, b.value: b.orbit}

        def g(p):
            if p in found:
                return _test_value(found[p].multipliers, shift)
            w = (p - a.value) / (b.value - a.value)
            guess = (1 - w) * a.x0 + w * b.x0
            period_guess = (1 - w) * a.period + w * b.period
            point = solve(p, guess, a.orbit.modes[0], period_guess, criterion="residual")
            found[p] = point.orbit
            return _test_value(point.orbit.multipliers, shift)

        xtol = parameter_tol * max(abs(a.value), abs(b.value), abs(b.value - a.value))
        try:
            value = brentq(g, a.value, b.value, xtol=xtol, rtol=4 * np.finfo(float).eps, maxiter=200)
            g(value)  # the orbit at the located value (computed once)
        except HybridBondGraphError:  # an orbit inside the bracket not found: report the bracket alone
            result.bifurcations.append(Bifurcation(kind, 0.5 * (a.value + b.value), bracket))
            continue
        orbit = found[value]
        multiplier, vector = _nearest(orbit, -shift)
        result.bifurcations.append(Bifurcation(kind, float(value), bracket, multiplier, vector, orbit))


def _doubled_branch(family, bifurcation: Bifurcation, values, main: list, *, period_of, section, crossings, signals, locate,
                    parameter_tol, options):
    """The branch of twice the period born at ``bifurcation`` (module docstring), or ``None`` if none is found."""
    p_star, (low, high) = bifurcation.value, bifurcation.bracket
    delta = 1e-2 * abs(high - low)
    orbit1 = bifurcation.orbit
    scale = np.maximum(np.max(np.abs(orbit1.trajectory.x), axis=0), float(options.get("atol", 1e-12)))
    v = np.real(np.asarray(bifurcation.eigenvector))
    v = v / np.max(np.abs(v) / scale)
    doubled_crossings = 2 * crossings if section is not None else crossings

    def doubled_period(p):
        return 2.0 * period_of(p) if section is None else 2.0 * orbit1.period

    for end in (high, low):
        direction = 1.0 if end > p_star else -1.0
        p1 = p_star + direction * delta
        model = family.set(p1)
        try:
            single = periodic_orbit(model, period_of(p1) if section is None else orbit1.period, section=section,
                                    crossings=crossings, x0=orbit1.x0, mode=orbit1.modes[0], **options)
        except HybridBondGraphError:
            continue
        # near the flip the doubled map's Jacobian M² − I is nearly singular along v (|μ² − 1| small): a guess
        # off the period-1 orbit by s has a residual of only about |μ² − 1| s, so the candidate must converge to
        # a residual that pins its start to 1e-6 of the states' amplitudes (floored at 10 rtol, the runs' accuracy)
        mu, _ = _nearest(single, -1.0)
        gap = abs(mu * mu - 1.0) if mu is not None else 1.0
        tol = max(min(float(options.get("tol", 1e-8)), 1e-6 * gap), 10.0 * float(options.get("rtol", 1e-10)))
        candidate_options = {**options, "tol": tol}
        found = None
        for size in (1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3):
            for sign in (1.0, -1.0):
                try:
                    orbit = periodic_orbit(model, doubled_period(p1), section=section, crossings=doubled_crossings,
                                           x0=orbit1.x0 + sign * size * v, mode=orbit1.modes[0],
                                           **candidate_options)
                except HybridBondGraphError:
                    continue
                if np.max(np.abs(orbit.x0 - single.x0) / scale) > 1e-5:
                    found = orbit
                    break
            if found is not None:
                break
        if found is None:
            continue
        outward = sorted((p for p in values if (p - p_star) * direction > delta), key=lambda p: abs(p - p_star))
        # the branch grows as sqrt(|p − p*|): distances from p* doubling (δ, 2δ, 4δ, … up to the first given
        # value) keep the secant predictor within about 12 % of the amplitude's growth
        reach = abs(outward[0] - p_star) if outward else delta
        ladder = [p_star + direction * delta * 2.0**k for k in range(1, 64) if delta * 2.0**k < reach]
        outward = ladder + outward
        source = family.build if family.build is not None else family.model
        branch = continue_orbit(source, family.parameter, [p1, *outward], period=doubled_period,
                                section=section, crossings=doubled_crossings, x0=found.x0, mode=found.modes[0],
                                fixed=family.fixed if family.build is not None else None, signals=signals,
                                locate=locate, parameter_tol=parameter_tol, on_error="stop", **options)
        branch.origin = bifurcation
        # a point whose start is the period-1 orbit's at the same value: the branch has ended (Newton for the
        # doubled period also converges to the period-1 orbit, a fixed point of the twice-iterated map)
        single_at = {point.value: point.x0 for point in main}
        for k, point in enumerate(branch.points[1:], 1):
            if point.value in single_at and np.max(np.abs(point.x0 - single_at[point.value]) / scale) <= 1e-5:
                branch.stopped = (f"the doubled branch meets the period-1 orbit at {family.parameter} = "
                                  f"{point.value:.10g}: it ends between {branch.points[k - 1].value:.10g} and there "
                                  "(or leaves the region where its mode sequence holds); smaller steps show where")
                branch.points = branch.points[:k]
                kept = {p.value for p in branch.points}
                branch.bifurcations = [b for b in branch.bifurcations if set(b.bracket) <= kept]
                break
        return branch
    return None
