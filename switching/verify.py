"""Static divergence-of-time check (``HybridModel.verify``).

Starting from the initial mode, explore only the modes that mode resolution
actually reaches: in each explored mode, sample states on the boundary of each
guard comparison (``lhs − rhs = 0``, found by a sign change along a random
line through a random state projected onto the mode's constraints, time
included), nudge them to either side, resolve the instant there and record

* every divergence-of-time loop found (with the modes of the loop),
* the kinds each reached mode was seen with — modes seen only as
  *mythical* can never carry behaviour,
* the real modes reached, which are explored in turn (breadth first, capped).

It is a sampling check: it finds loops, it cannot prove their absence.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import sympy as sp
from scipy.optimize import brentq
from sympy.core.relational import Relational

from bondgraph.errors import HybridBondGraphError

from .errors import DivergenceOfTimeError

__all__ = ["VerificationReport", "verify"]


@dataclass
class VerificationReport:
    """What :func:`verify` found."""

    explored: list = field(default_factory=list)
    kinds: dict = field(default_factory=dict)  # Mode → set of kinds seen
    loops: list = field(default_factory=list)  # (tuple of modes, message)
    errors: list = field(default_factory=list)  # (mode, message) of other failures
    samples: int = 0
    truncated: bool = False

    @property
    def mythical_only(self) -> list:
        return [m for m, kinds in self.kinds.items() if kinds == {"mythical"}]

    @property
    def ok(self) -> bool:
        return not self.loops and not self.errors

    def __str__(self) -> str:
        lines = [
            f"explored {len(self.explored)} mode(s) from {self.samples} boundary sample(s)"
            + (" (stopped at the mode cap)" if self.truncated else "")
        ]
        for mode, kinds in self.kinds.items():
            lines.append(f"  {mode.describe()}: seen as {', '.join(sorted(kinds)) or 'start mode only'}")
        if self.mythical_only:
            lines.append("modes that are only ever mythical: " + "; ".join(m.describe() for m in self.mythical_only))
        if self.loops:
            lines.append(f"{len(self.loops)} divergence-of-time loop(s):")
            for modes, _ in self.loops:
                lines.append("  " + " → ".join(m.describe() for m in modes))
        for mode, message in self.errors:
            lines.append(f"error from {mode.describe()}: {message.splitlines()[0]}")
        if self.ok:
            lines.append("no divergence of time found")
        return "\n".join(lines)


def _relations(condition) -> list:
    if isinstance(condition, Relational):
        return [condition]
    return [r for arg in getattr(condition, "args", ()) for r in _relations(arg)]


def verify(model, samples: int = 20, seed: int = 0, max_modes: int = 200, scale: float | None = None) -> VerificationReport:
    """Sample guard boundaries of every reachable mode and resolve the instant there."""
    rng = np.random.default_rng(seed)
    report = VerificationReport()
    x0 = model._initial_given
    state_scale = np.maximum(np.abs(x0), 1.0) * (scale or 1.0)
    time_scale = max([1.0] + [abs(v) for v in model.parameter_values.values() if np.isfinite(v)])
    frontier = [model.initial_mode]
    queued = {model.initial_mode}
    loop_keys = set()
    params = list(model.parameter_symbols)
    while frontier:
        if len(report.explored) >= max_modes:
            report.truncated = True
            break
        mode = frontier.pop(0)
        report.explored.append(mode)
        me = model.mode_equations(mode)
        report.kinds.setdefault(mode, set())
        for guard in me.guards:
            for relation in _relations(guard.condition):
                expr = me.finite(relation.lhs - relation.rhs)
                fn = sp.lambdify([list(model.states), model.time, params], expr, "numpy")

                def residual(point, fn=fn):
                    x, t = _project(me, point[:-1], point[-1])
                    return float(fn(x, t, model.parameter_array))

                for _ in range(samples):
                    found = _boundary_point(residual, rng, state_scale, time_scale)
                    if found is None:
                        continue
                    point, direction = found
                    for side in (-1e-7, 0.0, 1e-7):
                        x, t = _project(me, (point + side * direction)[:-1], (point + side * direction)[-1])
                        report.samples += 1
                        _resolve_and_record(model, mode, x, t, report, loop_keys, frontier, queued)
    return report


def _project(me, x, t):
    t = abs(float(t))
    x = np.asarray(x, dtype=float)
    if not me.jump.is_identity:
        x = me.jump.apply(x, t, me.model.parameter_values_with_inputs(t))
    return x, t


def _boundary_point(residual, rng, state_scale, time_scale):
    n = len(state_scale)
    start = np.concatenate([rng.normal(size=n) * state_scale, [rng.uniform(0, 2 * time_scale)]])
    direction = np.concatenate([rng.normal(size=n) * state_scale, [rng.normal() * time_scale]])
    s_grid = np.linspace(-10.0, 10.0, 201)
    values = []
    for s in s_grid:
        try:
            values.append(residual(start + s * direction))
        except (ZeroDivisionError, FloatingPointError, HybridBondGraphError, ValueError, OverflowError):
            values.append(np.nan)
    for k in range(len(s_grid) - 1):
        a, b = values[k], values[k + 1]
        if not (np.isfinite(a) and np.isfinite(b)):
            continue
        if a == 0:
            return start + s_grid[k] * direction, direction
        if a * b < 0:
            s = brentq(lambda s: residual(start + s * direction), s_grid[k], s_grid[k + 1], xtol=1e-14)
            return start + s * direction, direction
    return None


def _resolve_and_record(model, mode, x, t, report, loop_keys, frontier, queued):
    try:
        instant = model.resolve(x, mode, t)
    except DivergenceOfTimeError as exc:
        modes = tuple(step.mode for step in exc.loop)
        key = frozenset(modes)
        if key not in loop_keys:
            loop_keys.add(key)
            report.loops.append((modes, str(exc)))
        return
    except HybridBondGraphError as exc:
        report.errors.append((mode, str(exc)))
        return
    for step in instant.steps:
        if step.kind == "start":
            continue
        report.kinds.setdefault(step.mode, set()).add(step.kind)
        if step.kind in ("continuous", "pinnacle") and step.mode not in queued:
            queued.add(step.mode)
            frontier.append(step.mode)
