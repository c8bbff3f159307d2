"""Forward sensitivities of a hybrid run through its instants (issue 18, item 1).

``model.simulate(t_end, method, sensitivities=["e", "x0:y"], ...)`` runs the
ordinary simulation, keeping its instants, and then this module computes
``S = ∂x/∂p`` for each named parameter ``p`` (a model parameter, or
``x0:<state>`` for an initial state) from the run's record:

* **between instants** the augmented system ``x' = f(x)``,
  ``S' = ∂f/∂x·S + ∂f/∂p`` is integrated in the mode that flowed, from the
  recorded state after one instant to the recorded time of the next, with
  tight tolerances (``sensitivity_rtol``, ``sensitivity_atol``);
* **at an instant** at time ``τ`` fired by the comparison ``h = lhs − rhs``
  of the guard whose truth changed during the flow, the event time moves by
  ``τ_p = −(∇h·S⁻ + ∂h/∂p)/ḣ`` (``ḣ = ∇h·f⁻ + ∂h/∂t``), and the state after
  it by the saltation update

      ``S⁺ = G_x (S⁻ + f⁻ τ_p) + G_p + G_t τ_p − f⁺ τ_p``,

  where ``G`` is the composition of the jump maps ``g_β`` (restitution
  included) of every real mode passed at the instant (pinnacles and the
  continuous mode it ends in; mythical modes leave the state unchanged), each
  differentiated at the state it was applied to, and ``f⁻``, ``f⁺`` are the
  rates before and after.  The mode sequence is taken as locally constant:
  ``S`` is the derivative of the run whose modes and instants are those
  recorded.  An instant at the start of the run (the initial mode mythical or
  a pinnacle) has ``τ_p = 0``.

The Jacobians ``∂f/∂x``, ``∂f/∂p``, ``∂g/∂x``, ``∂g/∂p`` and the guard
gradients are derived symbolically from :class:`~switching.modes.ModeEquations`
per mode on first use and turned into generated Python functions
(:mod:`codegen.source`), cached in memory and on disk like the modes' own
functions (a rebuilt model, e.g. a fit's next iterate, derives nothing again).

Sensitivities are with respect to the model's parameters with its initial
state held fixed: an initial state that a ``build`` function computes from
an argument (the colliding balls' momenta ``m·v0``) moves through the
``x0:<state>`` columns, by the chain rule (:func:`switching.fit` does this
for any build argument, :func:`switching.fitting.build_derivatives`).  The
derivative is of the exact flow from the recorded instants: its accuracy
follows the run's (use a tight ``rtol``).  Where a guard or a jump map
reads an input, the input's rate at the instant is taken by central
differences.  Not supported yet: the compiled methods (``*-jit``) and
numerical jump maps (nonlinear storage): both say so
(:class:`~switching.errors.SimulationError`).
"""

from __future__ import annotations

import math
import time
import weakref
from dataclasses import dataclass

import numpy as np
import sympy as sp

from bondgraph.errors import UnknownNameError
from codegen.cache import fingerprint
from codegen.source import Argument, FunctionSpec, function_source, module_namespace

from .compiled import condition_tree
from .errors import SimulationError

__all__ = ["Sensitivities", "INITIAL_PREFIX", "simulate_with_sensitivities", "SENSITIVITY_SOURCE_VERSION"]

#: prefix of an initial state's name in ``sensitivities=`` (``"x0:y"``)
INITIAL_PREFIX = "x0:"
#: part of the disk-cache key of the generated derivative functions
SENSITIVITY_SOURCE_VERSION = "2"
#: tolerances of the augmented integration, unless told (``sensitivity_rtol=``, ``sensitivity_atol=``)
DEFAULT_RTOL, DEFAULT_ATOL = 1e-10, 1e-12
_STIFF = ("Radau", "BDF", "LSODA")
_NUMERIC_ERRORS = (ArithmeticError, ValueError)

_functions: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


@dataclass(eq=False)
class Sensitivities:
    """The sensitivities of one run.

    ``names``: the parameters as requested (``"e"``, ``"x0:y"``);
    ``S``: ``(N, n, m)`` — ``∂x/∂p`` at every sample (at an instant's two
    samples: just before and just after it, at fixed time);
    ``event_times``: ``(K, m)`` — ``∂t_k/∂p`` of every instant."""

    names: tuple
    S: np.ndarray
    event_times: np.ndarray

    def column(self, p: str) -> int:
        if p not in self.names:
            raise UnknownNameError(
                f"no sensitivity with respect to {p!r} was computed; this run has: {', '.join(self.names) or 'none'} "
                "(ask for it with simulate(..., sensitivities=[...]))", p)
        return self.names.index(p)


@dataclass(frozen=True)
class _Parameters:
    """The requested columns: ``names``; the model parameter symbols among
    them (``symbols``, at columns ``columns``); initial states (``initial``:
    column → state index)."""

    names: tuple
    symbols: tuple
    columns: tuple
    initial: dict


def parse_names(model, names) -> _Parameters:
    """Check the requested names: model parameters or ``x0:<state>``."""
    if isinstance(names, str):
        names = [names]
    names = tuple(dict.fromkeys(str(n) for n in names))
    if not names:
        raise SimulationError("sensitivities= names no parameter; give e.g. sensitivities=['e'] or ['x0:y']")
    by_name = {s.name: s for s in model.parameter_symbols}
    symbols, columns, initial = [], [], {}
    for j, name in enumerate(names):
        if name.startswith(INITIAL_PREFIX):
            state = name[len(INITIAL_PREFIX):]
            try:
                symbol = model.state(state)
            except UnknownNameError:
                raise UnknownNameError(
                    f"sensitivity {name!r}: model {model.name!r} has no state {state!r}; states are: "
                    f"{', '.join(s.name for s in model.states)}", name) from None
            initial[j] = model.state_index[symbol]
        elif name in by_name:
            symbols.append(by_name[name])
            columns.append(j)
        else:
            states = [s.name for s in model.states]
            hint = f" (an initial state is named {INITIAL_PREFIX}{name})" if name in states else ""
            raise UnknownNameError(
                f"sensitivity {name!r}: model {model.name!r} has no parameter {name!r}{hint}; parameters are: "
                f"{', '.join(by_name)}; initial states: {', '.join(INITIAL_PREFIX + s for s in states)}", name)
    return _Parameters(names, tuple(symbols), tuple(columns), initial)


# ------------------------------------------------------------------ generated derivative functions


class _Generated:
    """One generated module: its functions on Python floats, and the same on
    numpy's math where those raise (``1/sqrt(0.0)`` gives ``inf``)."""

    def __init__(self, source: str, label: str):
        self.source = source
        self.namespace = module_namespace()
        exec(compile(source, f"<hbg sensitivity {label}>", "exec"), self.namespace)  # our own generated code
        self._numpy = None
        self.label = label

    def __call__(self, name, x, t, p, u, size):
        try:
            return self.namespace[name](x, t, p, u, np.empty(size))
        except _NUMERIC_ERRORS:
            if self._numpy is None:
                self._numpy = module_namespace(vectorized=True)
                exec(compile(self.source, f"<hbg sensitivity {self.label} (numpy)>", "exec"), self._numpy)
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                return self._numpy[name](np.asarray(x, dtype=float), np.float64(t), p, u, np.empty(size))


def _arguments(model):
    return (
        Argument("x", tuple(model.states), doc="state vector"),
        Argument("t", (model.time,), scalar=True, doc="time [s]"),
        Argument("p", tuple(model.parameter_symbols), doc="parameters"),
        Argument("u", tuple(model.input_symbols), doc="inputs"),
    )


def gradient(expression, variables) -> list:
    """``∂e/∂v`` for each of ``variables``, differentiated with every symbol
    taken real (so ``|s|`` gives ``sign(s)``, not complex parts)."""
    e = sp.sympify(expression)
    free = e.free_symbols
    if not free & set(variables):
        return [sp.S.Zero] * len(variables)
    real = {s: sp.Dummy(s.name, real=True) for s in free}
    back = {r: s for s, r in real.items()}
    e = e.xreplace(real)
    return [sp.diff(e, real[v]).xreplace(back) if v in free else sp.S.Zero for v in variables]


def _gradients(expressions, model, symbols):
    """``[∂e/∂x (n), ∂e/∂p (len(symbols)), ∂e/∂t, ∂e/∂u (inputs)]`` of every expression, concatenated."""
    variables = (*model.states, *symbols, model.time, *model.input_symbols)
    out = []
    for e in expressions:
        out += gradient(e, variables)
    return out


class _Derivatives:
    """The generated derivative functions of one model for one set of
    parameter symbols, per mode, built on first use (memory, then disk cache,
    else derived now and stored)."""

    def __init__(self, model, symbols: tuple):
        self._model = weakref.ref(model)  # (kept in a WeakKeyDictionary keyed by the model)
        self.symbols = symbols
        self.n = len(model.states)
        self.m = len(symbols)
        self.k = len(model.input_symbols)
        self.width = self.n + self.m + 1 + self.k  # one gradient row: x, p, t, u
        self._modules: dict = {}

    @property
    def model(self):
        return self._model()

    def _module(self, kind: str, mode, build, label):
        key = (kind, mode)
        module = self._modules.get(key)
        if module is None:
            model = self.model
            cache_key = fingerprint(model.fingerprint, "sensitivity", SENSITIVITY_SOURCE_VERSION, kind, mode.label,
                                    *(s.name for s in self.symbols))
            source = model.cache.load(cache_key)
            if source is None:
                source = build()
                model.cache.store(cache_key, source)
            module = self._modules[key] = _Generated(source, f"{label} {mode.label}")
        return module

    def _source(self, name, outputs, doc, mode):
        return function_source(FunctionSpec(name, _arguments(self.model), tuple(outputs),
                                            f"{doc} in mode {mode.describe()}."))

    def flow(self, mode) -> _Generated:
        """``jac(x, t, p, u, out)``: ``∂f/∂x`` (n×n, row-major) then ``∂f/∂p`` (n×m)."""
        def build():
            model = self.model
            me = model.mode_equations(mode)
            rows = [gradient(me.f[s], (*model.states, *self.symbols)) for s in model.states]
            n = len(model.states)
            outputs = [d for row in rows for d in row[:n]] + [d for row in rows for d in row[n:]]
            return self._source("jac", outputs, "Jacobians df/dx, df/dp", mode)

        return self._module("flow", mode, build, "flow")

    def jump(self, mode) -> _Generated:
        """``jac(x, t, p, u, out)``: per state ``g_i``, its gradient row (x, p, t, u)."""
        def build():
            g = self.model.mode_equations(mode).g
            return self._source("jac", _gradients([g[s] for s in self.model.states], self.model, self.symbols),
                                "Jacobian of the jump map x+ = g(x) (restitution included)", mode)

        return self._module("jump", mode, build, "jump")

    def relation(self, mode, k: int) -> _Generated:
        """``grad(x, t, p, u, out)``: the gradient row (x, p, t, u) of
        ``lhs − rhs`` (finite parts) of comparison ``k`` of the mode, in the
        order of the mode's generated ``sides``."""
        def build():
            me = self.model.mode_equations(mode)
            relations: list = []
            for guard in me.guards:
                condition_tree(guard.condition, relations)
            rel = relations[k]
            h = me.finite(rel.lhs) - me.finite(rel.rhs)
            return self._source("grad", _gradients([h], self.model, self.symbols),
                                f"Gradient of lhs - rhs of comparison {k} ({rel})", mode)

        return self._module(f"relation {k}", mode, build, f"comparison {k}")

    def signal(self, mode, name: str):
        """``grad(x, t, p, u, out)`` of a signal's finite part (rows: x, p),
        as ``(vectorized, on floats)``: the first takes ``(n, N)`` samples
        at once; the second one sample (for expressions with branches,
        e.g. ``sign``, which arrays cannot take)."""
        key = ("signal", mode, name)
        pair = self._modules.get(key)
        if pair is None:
            model = self.model
            cache_key = fingerprint(model.fingerprint, "sensitivity", SENSITIVITY_SOURCE_VERSION, "signal",
                                    mode.label, name, *(s.name for s in self.symbols))
            source = model.cache.load(cache_key)
            if source is None:
                s = model.mode_equations(mode).signal(name).finite
                outputs = gradient(s, (*model.states, *self.symbols))
                source = self._source("grad", outputs, f"Gradient of signal {name!r} (finite part)", mode)
                model.cache.store(cache_key, source)
            code = compile(source, f"<hbg sensitivity signal {name} {mode.label}>", "exec")
            vectorized, scalar = module_namespace(vectorized=True), module_namespace()
            exec(code, vectorized)  # our own generated code
            exec(code, scalar)
            pair = self._modules[key] = (vectorized["grad"], scalar["grad"])
        return pair


def derivatives(model, symbols: tuple) -> _Derivatives:
    """The derivative functions of ``model`` for ``symbols`` (cached per model)."""
    per_model = _functions.get(model)
    if per_model is None:
        per_model = _functions[model] = {}
    found = per_model.get(symbols)
    if found is None:
        found = per_model[symbols] = _Derivatives(model, symbols)
    return found


# ------------------------------------------------------------------ the run


def check_method(method, options) -> str:
    """The method to run with sensitivities (``"auto"`` runs ``"RK45"``), or a clear error."""
    if method == "auto":
        return "RK45"
    if isinstance(method, str) and method.endswith("-jit"):
        raise SimulationError(
            f"sensitivities are not supported on the compiled method {method!r} yet; use {method[:-4]!r} "
            "(the same steps in Python)")
    if options.get("keep_instants") is False:
        raise SimulationError("sensitivities need the run's instants: drop keep_instants=False")
    return method


def simulate_with_sensitivities(model, t_end, method, names, options, rtol=None, atol=None):
    """``model.simulate(t_end, method, **options)`` and the sensitivities of
    its run with respect to ``names`` (see the module docstring); the
    trajectory returned answers :meth:`~switching.trajectory.Trajectory.sensitivity`."""
    from .simulator import simulate

    method = check_method(method, options)
    parameters = parse_names(model, names)
    options = dict(options)
    options["keep_instants"] = True
    trajectory = simulate(model, t_end, method, **options)
    started = time.perf_counter()
    stiff = method in _STIFF
    trajectory.sensitivities = _Run(model, trajectory, parameters, options, stiff,
                                    DEFAULT_RTOL if rtol is None else float(rtol),
                                    DEFAULT_ATOL if atol is None else float(atol)).compute()
    trajectory.stats["sensitivities"] = ", ".join(parameters.names)
    trajectory.stats["sensitivity wall time [s]"] = round(time.perf_counter() - started, 6)
    return trajectory


class _Run:
    """The sensitivities of one finished run (see :func:`simulate_with_sensitivities`)."""

    def __init__(self, model, trajectory, parameters: _Parameters, options, stiff, rtol, atol):
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
        """``S`` at the run's first sample: unit columns for initial states
        (through the initial mode's projection when the model gave the state),
        zero for parameters."""
        n, m = self.n, self.m
        S0 = np.zeros((n, m))
        for j, i in self.parameters.initial.items():
            S0[i, j] = 1.0
        model = self.model
        if self.options.get("x0") is not None:
            return S0
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
        rows = _gradients([base[s] for s in model.states], model, self.parameters.symbols)
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


def signal_sensitivity(trajectory, name: str, p: str) -> np.ndarray:
    """``d s/d p`` of a named signal at every sample: ``∂s/∂x·S + ∂s/∂p``
    (finite part, in each sample's mode)."""
    record = trajectory.sensitivities
    j = record.column(p)
    if name in trajectory.state_names:
        return record.S[:, trajectory.state_names.index(name), j].copy()
    model = trajectory._needs_model()
    if _is_state(model, name):
        index = model.state_index[model.state(name)]
        return record.S[:, index, j].copy()
    model.signal_expression(name)  # an unknown name raises here, listing the signals
    parameters = parse_names(model, record.names)
    d = derivatives(model, parameters.symbols)
    n = len(model.states)
    out = np.empty(len(trajectory.t))
    labels = np.array(trajectory.mode_labels)
    try:
        column = parameters.columns.index(j)
    except ValueError:
        column = None  # an initial state: no explicit dependence
    for mode in dict.fromkeys(trajectory.modes):
        mask = labels == mode.label
        vectorized, scalar = d.signal(mode, name)
        times = trajectory.t[mask]
        inputs = [np.array([model.input_values(tk)[i] for tk in times]) for i in range(len(model.input_symbols))]
        grad = np.empty((n + len(parameters.symbols), int(mask.sum())))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            try:
                vectorized(trajectory.x[mask].T, times, model.parameter_array, inputs, grad)
            except (TypeError, ValueError):  # a branch (sign, Piecewise) on arrays: one sample at a time
                p = model.parameter_array.tolist()
                for i, (x, tk) in enumerate(zip(trajectory.x[mask], times)):
                    grad[:, i] = scalar(x.tolist(), float(tk), p, model.input_values(tk), np.empty(len(grad)))
        values = np.einsum("ik,ki->i", record.S[mask][:, :, j], grad[:n]) if n else np.zeros(int(mask.sum()))
        if column is not None:
            values = values + grad[n + column]
        out[mask] = values
    return out


def _is_state(model, name) -> bool:
    try:
        model.state(name)
    except (UnknownNameError, KeyError):
        return False
    return True
