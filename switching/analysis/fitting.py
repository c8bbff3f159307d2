"""Least-squares fits of a hybrid model's parameters to measured signals (issue 18, item 2).

:func:`fit` adjusts build arguments of a model family (``models.<name>.build``)
so that named signals or states match measurements, with
:func:`scipy.optimize.least_squares` and the run's forward sensitivities
through its instants (:mod:`switching.analysis.sensitivity`) as the exact Jacobian —
no finite differences across events that move.

Example — the bouncing ball's restitution from its heights::

    >>> import numpy as np
    >>> from models import bouncing_ball
    >>> from switching import fit
    >>> times = np.linspace(0.05, 1.5, 30)
    >>> truth = bouncing_ball.build(e=0.7).simulate(1.5, "RK45", t_eval=times, rtol=1e-10, atol=1e-12)
    >>> heights = truth.state("y")  # t_eval: one row per time, exactly
    >>> result = fit(bouncing_ball.build, {"y": (times, heights)}, {"e": 0.6})
    >>> round(result.values["e"], 6)
    0.7
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from bondgraph.errors import HybridBondGraphError, ParameterValueError

from ..errors import SimulationError
from .sensitivity import INITIAL_PREFIX

__all__ = ["fit", "FitResult", "FitError", "build_derivatives", "sample_indices"]


class FitError(HybridBondGraphError):
    """A fit that could not be set up or run (bad data, a build argument
    that does not move the model, a run that failed at an iterate:
    ``values`` holds that iterate)."""

    def __init__(self, message: str, values=None):
        super().__init__(message)
        self.values = values


@dataclass(eq=False)
class FitResult:
    """The outcome of :func:`fit`.

    ``values``: fitted value of each parameter; ``standard_errors`` and
    ``covariance`` (in the order of ``names``): the linearized estimate
    ``s²·(JᵀJ)⁻¹`` at the solution, with ``J`` the Jacobian of the weighted
    residuals and ``s² = Σr²/(N − P)`` (or 1 with ``absolute_sigma=True``:
    ``sigma`` then gives the measurements' true standard deviations);
    ``residuals``: model minus data at the solution, per signal, in the data's
    units (unweighted); ``trajectory``: the run at the fitted values (with
    its sensitivities); ``optimizer``: scipy's ``OptimizeResult``."""

    names: tuple
    values: dict
    standard_errors: dict
    covariance: np.ndarray = field(repr=False)
    residuals: dict = field(repr=False)
    cost: float = 0.0
    success: bool = True
    message: str = ""
    runs: int = 0
    trajectory: object = field(repr=False, default=None)
    optimizer: object = field(repr=False, default=None)

    def __str__(self) -> str:
        width = max(len(n) for n in self.names)
        lines = [f"fit: {'converged' if self.success else 'NOT converged'} after {self.runs} runs ({self.message})"]
        for name in self.names:
            lines.append(f"  {name:<{width}} = {self.values[name]:.10g} ± {self.standard_errors[name]:.3g}")
        rms = {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in self.residuals.items()}
        lines.append("  rms residual: " + ", ".join(f"{k} {v:.3g}" for k, v in rms.items()))
        return "\n".join(lines)


def sample_indices(trajectory, times) -> np.ndarray:
    """The row index of each of ``times`` [s] in a run whose rows hold them
    (``t_eval`` covering them, or ``samples=N`` with them among its times):
    the last row at exactly that time that is not one of an instant's two
    rows — at an instant's time, the state after it.  With ``t_eval=times``
    itself the rows are exactly ``times`` and this is ``arange(len(times))``;
    it picks a subset's rows (``fit`` runs on the union of the data's times)."""
    times = np.asarray(times, dtype=float).ravel()
    instant = set(trajectory.event_index) | {k - 1 for k in trajectory.event_index}
    candidates = np.array([k for k in range(len(trajectory.t)) if k not in instant], dtype=int)
    at = trajectory.t[candidates]
    pos = np.searchsorted(at, times, side="right") - 1
    bad = (pos < 0) | (at[np.clip(pos, 0, None)] != times)
    if np.any(bad):
        missing = times[bad]
        raise FitError(f"the run has no sample at t = {missing[0]!r} ({int(bad.sum())} time(s) missing); "
                       "simulate with t_eval covering the data's times")
    return candidates[pos]


def _check_data(data) -> dict:
    if not isinstance(data, Mapping) or not data:
        raise FitError("data must map signal or state names to (times, values) pairs, e.g. {'y': (t, y)}")
    out = {}
    for name, pair in data.items():
        try:
            times, values = pair
        except (TypeError, ValueError):
            raise FitError(f"data[{name!r}] must be a (times, values) pair") from None
        times = np.asarray(times, dtype=float).ravel()
        values = np.asarray(values, dtype=float).ravel()
        if times.shape != values.shape or not times.size:
            raise FitError(f"data[{name!r}]: {times.size} times and {values.size} values; give one value per time")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
            raise FitError(f"data[{name!r}] holds non-finite times or values")
        out[str(name)] = (times, values)
    return out


def _sigmas(sigma, data) -> dict:
    out = {}
    for name, (times, _) in data.items():
        s = sigma.get(name, 1.0) if isinstance(sigma, Mapping) else (1.0 if sigma is None else sigma)
        s = np.broadcast_to(np.asarray(s, dtype=float), times.shape).copy()
        if not np.all((s > 0) & np.isfinite(s)):
            raise FitError(f"sigma of {name!r} must be positive and finite")
        out[name] = s
    return out


def build_derivatives(build, arguments: dict, names, step: float = 1e-4) -> dict:
    """How the built model moves with each fitted build argument: for each
    name, ``{sensitivity name: derivative}`` — model parameters by name and
    initial states as ``x0:<state>`` — from central differences of ``build``
    alone (no simulation; exact for the usual linear dependences such as
    ``p = m·v0``, second order otherwise).  A build argument that changes
    the model's structure (not only its values) cannot be fitted."""
    import warnings

    base = _built(build, arguments)
    out = {}
    for name in names:
        value = float(arguments[name])
        h = step * max(abs(value), 1e-3)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a step just past a physical range (e = 1 + h) is no concern here
            up, down = _built(build, {**arguments, name: value + h}), _built(build, {**arguments, name: value - h})
        if up[0] != base[0] or down[0] != base[0]:
            raise FitError(f"build argument {name!r} changes the model's structure, not only its values: "
                           "it cannot be fitted")
        moved = {}
        for key in base[1]:
            d = (up[1][key] - down[1][key]) / (2 * h)
            if d != 0.0 and math.isfinite(d):
                moved[key] = d
        if not moved:
            raise FitError(f"build argument {name!r} changes neither a parameter nor the initial state of the "
                           "model: it cannot be fitted")
        out[name] = moved
    return out


def _built(build, arguments) -> tuple:
    """``(fingerprint, {model parameter name or x0:<state>: value})`` of ``build(**arguments)``."""
    model = build(**arguments)
    values = {s.name: float(v) for s, v in model.parameter_values.items()}
    values.update({INITIAL_PREFIX + s.name: float(v) for s, v in zip(model.states, model.given_initial_state)})
    return model.fingerprint, values


def fit(build, data, parameters, t_end=None, method="RK45", *, fixed=None, sigma=None, bounds=None,
        absolute_sigma=False, rtol=1e-10, atol=1e-12, simulate_options=None, **least_squares_options):
    """Fit build arguments of a model family to measured signals.

    Parameters
    ----------
    build : callable(**arguments) -> HybridModel
        E.g. ``models.bouncing_ball.build``.  Rebuilt at each iterate; runs
        share one model's derived modes and generated code
        (:func:`switching.sweep.batch.shared_model`), so an iterate costs a build
        and a run.
    data : mapping name → (times, values)
        Measurements of named signals or states (each its own times [s]).
    parameters : mapping name → initial guess
        Build arguments to fit: any that set the model's parameters or its
        initial state (the bouncing ball's ``e``, ``g``, ``y0``; a mass that
        also sets an initial momentum).  How the model depends on each is
        found from ``build`` itself (:func:`build_derivatives`); the
        Jacobian is then the chain rule through the run's sensitivities.
    t_end : float, optional
        End of each run (default: the last measurement time).
    method : str
        A Python simulation method (``"RK45"``, ``"DOP853"``, ``"Radau"``, …).
    fixed : mapping, optional
        Further build arguments, held at these values.
    sigma : float, array or mapping name → float or array, optional
        Standard deviation of the measurements (residuals are divided by it).
    bounds : mapping name → (low, high), optional
    absolute_sigma : bool
        ``True``: ``sigma`` is the measurements' true standard deviation and
        the covariance is not rescaled by the residuals' spread.
    rtol, atol : float
        Tolerances of each run (its sensitivities use ``sensitivity_rtol``,
        ``sensitivity_atol`` of ``simulate_options``, default 1e-10, 1e-12).
    simulate_options : mapping, optional
        Further options of ``simulate`` (``max_step``, ``on_zeno``, …).
    **least_squares_options
        Passed to :func:`scipy.optimize.least_squares` (``xtol``, ``ftol``,
        ``max_nfev``, ``loss``, …).

    Returns a :class:`FitResult`.  A run that fails at an iterate (a Zeno
    sequence the data's window reaches, say) raises :class:`FitError`
    naming the iterate.
    """
    from scipy.optimize import least_squares

    from ..sweep.batch import shared_model

    data = _check_data(data)
    if not isinstance(parameters, Mapping) or not parameters:
        raise FitError("parameters must map the build arguments to fit to their initial guesses, e.g. {'e': 0.5}")
    names = tuple(parameters)
    fixed = dict(fixed or {})
    both = set(names) & set(fixed)
    if both:
        raise FitError(f"{sorted(both)} are both fitted and fixed; name each build argument once")
    sigmas = _sigmas(sigma, data)
    times = np.unique(np.concatenate([t for t, _ in data.values()]))
    if t_end is None:
        t_end = float(times[-1])
    if times[0] < 0 or times[-1] > t_end:
        raise FitError(f"measurement times must lie within the run [0, {t_end}] s")
    x0 = np.array([float(parameters[n]) for n in names])
    low = np.array([(bounds or {}).get(n, (-np.inf, np.inf))[0] for n in names], dtype=float)
    high = np.array([(bounds or {}).get(n, (-np.inf, np.inf))[1] for n in names], dtype=float)
    options = dict(simulate_options or {})
    options.update(rtol=rtol, atol=atol, t_eval=times)
    memo: dict = {}
    runs = [0]

    def run(theta):
        key = tuple(float(v) for v in theta)
        if key in memo:
            return memo[key]
        values = dict(zip(names, key))
        arguments = {**fixed, **values}
        try:
            chain = build_derivatives(build, arguments, names)
            wanted = list(dict.fromkeys(q for moved in chain.values() for q in moved))
            with shared_model(build, arguments) as model:
                trajectory = model.simulate(t_end, method, sensitivities=wanted, **options)
                residuals, jacobian, raw = [], [], {}
                for name, (t, y) in data.items():
                    at = sample_indices(trajectory, t)
                    value = trajectory.signal(name)[at]
                    raw[name] = value - y
                    residuals.append((value - y) / sigmas[name])
                    by_q = {q: trajectory.sensitivity(name, q)[at] for q in wanted}
                    columns = [sum(d * by_q[q] for q, d in chain[n].items()) for n in names]
                    jacobian.append(np.column_stack(columns) / sigmas[name][:, None])
        except (SimulationError, ParameterValueError) as exc:
            raise FitError(f"the run at {values} failed: {exc}", values) from exc
        runs[0] += 1
        memo.clear()  # keep only the last iterate (fun and jac are asked at the same point)
        memo[key] = (np.concatenate(residuals), np.vstack(jacobian), raw, trajectory)
        return memo[key]

    result = least_squares(lambda th: run(th)[0], x0, jac=lambda th: run(th)[1], bounds=(low, high),
                           x_scale="jac", **least_squares_options)
    r, J, raw, trajectory = run(result.x)
    # the run's model is shared with later runs of this family: give the trajectory its own
    trajectory.model = build(**fixed, **dict(zip(names, (float(v) for v in result.x))))
    dof = max(1, r.size - len(names))
    scale = 1.0 if absolute_sigma else float(r @ r) / dof
    covariance = np.linalg.pinv(J.T @ J) * scale
    errors = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    return FitResult(
        names=names,
        values={n: float(v) for n, v in zip(names, result.x)},
        standard_errors={n: float(e) for n, e in zip(names, errors)},
        covariance=covariance,
        residuals=raw,
        cost=float(result.cost),
        success=bool(result.success),
        message=str(result.message),
        runs=runs[0],
        trajectory=trajectory,
        optimizer=result,
    )
