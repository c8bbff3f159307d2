"""Forward sensitivities of a finished hybrid run through its instants: the
run itself (:func:`simulate_with_sensitivities`; the mathematics are in
:mod:`switching.analysis.sensitivity`, which derives the Jacobians and gradients it
integrates and reads sensitivities of signals from a trajectory)."""

from __future__ import annotations

import math
import time

import numpy as np

from ..errors import SimulationError
from .sensitivity import DEFAULT_ATOL, DEFAULT_RTOL, Parameters, Sensitivities, derivatives, gradients, parse_names
from ..simulate.driver import HybridRun, option_defaults
from ..simulate.methods import METHOD_CLASSES
from ..simulate.run_options import checked_options

__all__ = ["sensitivity_method", "simulate_with_sensitivities"]

_STIFF = ("Radau", "BDF", "LSODA")


def sensitivity_method(method, options) -> str:
    """The method to run with sensitivities (``"auto"`` runs ``"RK45"``), or a clear error."""
    if method == "auto":
        return "RK45"
    if isinstance(method, str) and method.endswith("-jit"):
        python = METHOD_CLASSES[method].python.name if method in METHOD_CLASSES else method[:-4]
        same = "the same steps in Python" if python == method[:-4] else "its Python counterpart"
        raise SimulationError(
            f"sensitivities are not supported on the compiled method {method!r} yet; use {python!r} ({same})")
    if options.get("keep_instants") is False:
        raise SimulationError("sensitivities need the run's instants: drop keep_instants=False")
    return method


def simulate_with_sensitivities(model, t_end, method, names, options, rtol=None, atol=None):
    """``model.simulate(t_end, method, **options)`` and the sensitivities of
    its run with respect to ``names`` (see the module docstring); the
    trajectory returned answers :meth:`~switching.simulate.trajectory.Trajectory.sensitivity`.
    They are integrated along every sample the run recorded (its start, the
    instants' before and after states, the requested times), then read at
    the rows of its sampling (``t_eval``: the requested times only)."""
    method = sensitivity_method(method, options)
    parameters = parse_names(model, names)
    options = dict(options)
    options["keep_instants"] = True
    run = HybridRun(model, checked_options(model, t_end, method, {**option_defaults(), **options}))
    recorded = run.execute(all_rows=True)
    started = time.perf_counter()
    stiff = method in _STIFF
    recorded.sensitivities = _Run(model, recorded, parameters, options, stiff,
                                  DEFAULT_RTOL if rtol is None else float(rtol),
                                  DEFAULT_ATOL if atol is None else float(atol)).compute()
    rows, event_index = run.recorder.rows(complete=recorded.stopped is None)
    trajectory = recorded.take(rows)
    trajectory.event_index = event_index
    trajectory.stats["sensitivities"] = ", ".join(parameters.names)
    trajectory.stats["sensitivity wall time [s]"] = round(time.perf_counter() - started, 6)
    return trajectory


class _Run:
    """The sensitivities of one finished run (see :func:`simulate_with_sensitivities`)."""

    def __init__(self, model, trajectory, parameters: Parameters, options, stiff, rtol, atol):
        self.model = model
        self.trajectory = trajectory
        self.parameters = parameters
        self.options = options
        self.stiff = stiff
        self.rtol, self.atol = rtol, atol
        self.d = derivatives(model, parameters.symbols)
        self.n = len(model.states)
        self.m = len(parameters.names)
        self.columns = np.array(parameters.columns, dtype=int)
        self.p = model.parameter_array
        self.p_list = self.p.tolist()

    # ---------------------------------------------------------------- pieces

    def inputs(self, t):
        return self.model.input_values(t)

    def input_rates(self, t) -> np.ndarray:
        """``du/dt`` by central differences (inputs are functions of time)."""
        if not self.model.input_symbols:
            return np.zeros(0)
        delta = 1e-6 * max(1.0, abs(t))
        return (np.array(self.inputs(t + delta)) - np.array(self.inputs(t - delta))) / (2 * delta)

    def full_p(self, rows: np.ndarray) -> np.ndarray:
        """``(r, m)``: derivatives with respect to the model-parameter columns placed among all columns."""
        out = np.zeros((rows.shape[0], self.m))
        if len(self.columns):
            out[:, self.columns] = rows
        return out

    def gradient_rows(self, generated, name, x, t, rows) -> tuple:
        """``(∂/∂x (rows, n), ∂/∂p (rows, m) over all columns, total ∂/∂t (rows,))`` of a generated gradient."""
        n, mp, k = self.n, len(self.columns), self.d.k
        flat = generated(name, x.tolist(), float(t), self.p_list, self.inputs(t), rows * self.d.width)
        table = np.asarray(flat, dtype=float).reshape(rows, self.d.width)
        dx, dp, dt, du = table[:, :n], table[:, n:n + mp], table[:, n + mp], table[:, n + mp + 1:]
        if k:
            dt = dt + du @ self.input_rates(t)
        return dx, self.full_p(dp), dt

    def rates(self, mode, x, t) -> np.ndarray:
        return np.array(self.model.compiled_mode(mode).rates(np.asarray(x, dtype=float), t), dtype=float)

    # ---------------------------------------------------------------- flow

    def flow(self, mode, t0, x0, S0, t1, times):
        """Integrate ``(x, S)`` from ``t0`` to ``t1`` in ``mode``; returns ``S`` at ``times`` and at ``t1``."""
        from scipy.integrate import solve_ivp

        n, m = self.n, self.m
        if not times.size and t1 <= t0:
            return np.zeros((0, n, m)), S0
        flow = self.d.flow(mode)
        cm = self.model.compiled_mode(mode)
        columns, mp = self.columns, len(self.columns)
        p_list = self.p_list
        inputs = self.inputs

        def rhs(t, y):
            x = y[:n]
            S = y[n:].reshape(n, m)
            u = inputs(t)
            f = cm.rates(x, t)
            table = flow("jac", x.tolist(), t, p_list, u, n * n + n * mp)
            dS = np.asarray(table[:n * n]).reshape(n, n) @ S
            if mp:
                dS[:, columns] += np.asarray(table[n * n:]).reshape(n, mp)
            return np.concatenate([f, dS.ravel()])

        y0 = np.concatenate([np.asarray(x0, dtype=float), S0.ravel()])
        if t1 <= t0:
            return np.repeat(S0[None], times.size, axis=0), S0
        solution = solve_ivp(rhs, (t0, t1), y0, method="Radau" if self.stiff else "DOP853", rtol=self.rtol,
                             atol=self.atol, dense_output=times.size > 0)
        if not solution.success:
            raise SimulationError(
                f"the sensitivity integration failed in mode {mode.describe()} between t = {t0:.12g} and "
                f"{t1:.12g}: {solution.message}", trajectory=self.trajectory, t=t0, mode=mode)
        end = solution.y[n:, -1].reshape(n, m)
        if not times.size:
            return np.zeros((0, n, m)), end
        inside = np.clip(times, t0, t1)
        values = solution.sol(inside)[n:].T.reshape(times.size, n, m)
        values[times <= t0] = S0
        values[times >= t1] = end
        return values, end

    # ---------------------------------------------------------------- instants

    def trigger(self, instant):
        """``(mode, comparison index, ∂h/∂x, ∂h/∂p, ḣ)`` of the comparison whose
        crossing located the instant: among the comparisons of the guards
        fired in the mode that flowed, the one that changed truth most
        recently (smallest ``|h|/|ḣ|``, moving in the direction that makes it
        hold)."""
        step = instant.steps[0]
        mode, x, t = step.mode, step.x_before, instant.t
        cm = self.model.compiled_mode(mode)
        sides = cm.sides(x, t)
        f = self.rates(mode, x, t)
        best = None
        for fired in step.fired:
            guard = next((g for g in cm.guards if (g["automaton"], g["source"], g["target"], g["text"]) ==
                          (fired.automaton, fired.source, fired.target, fired.guard)), None)
            if guard is None:
                continue
            for k, op, flipped in _leaves(guard["tree"]):
                hx, hp, ht = self.gradient_rows(self.d.relation(mode, k), "grad", x, t, 1)
                rate = float(hx[0] @ f + ht[0])
                h = float(sides[3 * k] - sides[3 * k + 1])
                if not (math.isfinite(h) and math.isfinite(rate)):
                    continue
                toward = {"<": -1, "<=": -1, ">": 1, ">=": 1}.get(op, 0) * (-1 if flipped else 1)
                right_way = toward == 0 or toward * rate > 0
                since = abs(h) / abs(rate) if rate != 0 else math.inf
                rank = (not right_way, since)
                if best is None or rank < best[0]:
                    best = (rank, (mode, k, hx[0], hp[0], rate, fired, guard))
        if best is None:
            raise SimulationError(
                f"the instant at t = {t:.12g} has no guard comparison that located it (mode {mode.describe()}); "
                "its event-time sensitivity is not defined", trajectory=self.trajectory, t=t, mode=mode)
        return best[1]

    def instant(self, k, instant, S_minus, initial: bool):
        """``(S⁺, ∂t_k/∂p)`` across one instant."""
        n, m = self.n, self.m
        t = instant.t
        x_minus = instant.x_before
        if initial:
            tau = np.zeros(m)
        else:
            mode, index, hx, hp, rate, fired, _ = self.trigger(instant)
            if rate == 0 or not math.isfinite(rate):
                raise SimulationError(
                    f"the instant at t = {t:.12g} was located where comparison {index} of guard "
                    f"'{fired.guard}' ({fired.automaton}) touches its threshold without crossing it (its rate is "
                    f"{rate}): the event time is not differentiable there", trajectory=self.trajectory, t=t,
                    mode=mode)
            tau = -(hx @ S_minus + hp) / rate
        f_minus = self.rates(instant.steps[0].mode, x_minus, t) if not initial else np.zeros(n)
        D = S_minus + np.outer(f_minus, tau)
        for step in instant.steps:
            if step.kind not in ("pinnacle", "continuous"):
                continue  # the mode the instant began in, and mythical modes: no jump
            cm = self.model.compiled_mode(step.mode)
            if cm.jump_kind == "identity":
                continue
            if cm.jump_kind != "symbolic":
                raise SimulationError(
                    f"the jump into mode {step.mode.describe()} at t = {t:.12g} is numerical (nonlinear storage): "
                    "sensitivities through numerical jump maps are not supported yet",
                    trajectory=self.trajectory, t=t, mode=step.mode)
            gx, gp, gt = self.gradient_rows(self.d.jump(step.mode), "jac", step.x_before, t, n)
            D = gx @ D + gp + np.outer(gt, tau)
        f_plus = self.rates(instant.mode_after, instant.x_after, t) if not initial else np.zeros(n)
        return D - np.outer(f_plus, tau), tau

    def initial(self):
        """``S`` at the run's first sample: unit columns for initial states,
        ``∂x0/∂p`` for a parameter the model's initial state is written with
        (zero for the others), both through the initial mode's projection
        when the model gave the state."""
        n, m = self.n, self.m
        S0 = np.zeros((n, m))
        for j, i in self.parameters.initial.items():
            S0[i, j] = 1.0
        model = self.model
        if self.options.get("x0") is not None:
            return S0
        values = {**model.parameter_values, **model.initial_parameters}
        for state, expr in model.initial_expressions.items():  # x0 written as an expression of parameters
            for j, p in zip(self.columns, self.parameters.symbols):
                if p in expr.free_symbols:
                    S0[model.state_index[state], j] = float(expr.diff(p).xreplace(values))
        mode = model.initial_mode  # model.initial_state() projects the given state with its jump map at t = 0
        cm = model.compiled_mode(mode)
        if cm.jump_kind == "identity":
            return S0
        if cm.jump_kind != "symbolic":
            raise SimulationError(f"the initial projection into mode {mode.describe()} is numerical (nonlinear "
                                  "storage): sensitivities through numerical jump maps are not supported yet")
        x_given = model.given_initial_state
        if model.restitution_of(mode) is None:
            gx, gp, _ = self.gradient_rows(self.d.jump(mode), "jac", x_given, 0.0, n)
            return gx @ S0 + gp
        # (the projection is the jump without the mode's restitution)
        from codegen import vector_function

        base = model.mode_equations(mode).jump.expressions
        rows = gradients([base[s] for s in model.states], model, self.parameters.symbols)
        fn = vector_function(rows, model.states, model.time, model.parameter_symbols, model.input_symbols)
        table = fn(x_given, 0.0, self.p, model.input_values(0.0)).reshape(n, self.d.width)
        mp = len(self.columns)
        return table[:, :n] @ S0 + self.full_p(table[:, n:n + mp])

    def start(self, mode, x, t0, S0):
        """The flow's start without a recorded instant: the resolution at
        ``t0`` still applied the starting mode's jump map (a projection onto
        its constraints, the identity on a consistent state), which moves a
        perturbed initial state; returns the flow's first state and ``S``."""
        cm = self.model.compiled_mode(mode)
        if cm.jump_kind == "identity":
            return x, S0
        x_plus = cm.jump(x, t0)
        if cm.jump_kind != "symbolic":
            if not np.allclose(x_plus, x, rtol=1e-12, atol=0.0):
                raise SimulationError(
                    f"the jump into the starting mode {mode.describe()} is numerical (nonlinear storage): "
                    "sensitivities through numerical jump maps are not supported yet", trajectory=self.trajectory,
                    t=t0, mode=mode)
            return x, S0
        gx, gp, _ = self.gradient_rows(self.d.jump(mode), "jac", x, t0, self.n)
        return x_plus, gx @ S0 + gp

    # ---------------------------------------------------------------- all

    def compute(self) -> Sensitivities:
        tr, n, m = self.trajectory, self.n, self.m
        N = len(tr.t)
        S = np.zeros((N, n, m))
        taus = np.zeros((len(tr.events), m))
        t0 = float(tr.t[0])
        S_now = self.initial()
        start, x_start, t_start, mode = 0, tr.x[0], t0, tr.modes[0]
        if not (tr.events and tr.events[0].t == t0):
            x_start, S_now = self.start(mode, x_start, t0, S_now)
        for k, instant in enumerate(tr.events):
            after = tr.event_index[k]
            before = after - 1
            times = tr.t[start:before + 1]
            values, S_minus = self.flow(mode, t_start, x_start, S_now, instant.t, times)
            S[start:before + 1] = values
            S_now, taus[k] = self.instant(k, instant, S_minus, initial=k == 0 and instant.t == t0)
            S[after] = S_now
            start, x_start, t_start, mode = after + 1, instant.x_after, instant.t, instant.mode_after
        times = tr.t[start:]
        if times.size:
            S[start:], _ = self.flow(mode, t_start, x_start, S_now, float(times[-1]), times)
        return Sensitivities(self.parameters.names, S, taus)


def _leaves(tree, flipped=False):
    """``(index, op, flipped)`` of every comparison of a guard tree (``flipped``: under an odd number of ``not``)."""
    kind = tree[0]
    if kind in ("and", "or"):
        for sub in tree[1]:
            yield from _leaves(sub, flipped)
    elif kind == "not":
        yield from _leaves(tree[1], not flipped)
    elif kind == "rel":
        yield tree[1], tree[2], flipped
