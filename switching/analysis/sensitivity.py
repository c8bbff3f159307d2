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
gradients are derived symbolically from :class:`~switching.model.modes.ModeEquations`
per mode on first use and turned into generated Python functions
(:mod:`codegen.source`), cached in memory and on disk like the modes' own
functions (a rebuilt model, e.g. a fit's next iterate, derives nothing again).

Sensitivities are with respect to the model's parameters, the initial
state as the model defines it: an initial value written as an expression of
parameters (``initial_state={"p": "m*v0"}``) moves with them
(``S(t0) ∋ ∂x0/∂p``), a number stays fixed.  An initial state that a
``build`` function computes from an argument as a number moves through the
``x0:<state>`` columns, by the chain rule (:func:`switching.fit` does this
for any build argument, :func:`switching.analysis.fitting.build_derivatives`).  The
derivative is of the exact flow from the recorded instants: its accuracy
follows the run's (use a tight ``rtol``).  Where a guard or a jump map
reads an input, the input's rate at the instant is taken by central
differences.  Not supported yet: the compiled methods (``*-jit``) and
numerical jump maps (nonlinear storage): both say so
(:class:`~switching.errors.SimulationError`).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from bondgraph.errors import UnknownNameError
from codegen.cache import fingerprint
from codegen.safety import compile_checked, execute
from codegen.source import Argument, FunctionSpec, function_source, module_namespace

from ..library.compiled import condition_tree
from ..library.jacobian import real_gradient
from ..errors import SimulationError

__all__ = ["Sensitivities", "INITIAL_PREFIX", "SENSITIVITY_SOURCE_VERSION", "derivatives", "parse_names",
           "signal_sensitivity"]

#: prefix of an initial state's name in ``sensitivities=`` (``"x0:y"``)
INITIAL_PREFIX = "x0:"
#: part of the disk-cache key of the generated derivative functions
SENSITIVITY_SOURCE_VERSION = "3"
#: tolerances of the augmented integration, unless told (``sensitivity_rtol=``, ``sensitivity_atol=``)
DEFAULT_RTOL, DEFAULT_ATOL = 1e-10, 1e-12
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

    def signal(self, trajectory, name: str, p: str) -> np.ndarray:
        """``∂s/∂p`` of a state or named signal of ``trajectory`` (the run these are of), at every sample
        (:func:`signal_sensitivity`)."""
        return signal_sensitivity(trajectory, name, p)

    def take(self, rows) -> "Sensitivities":
        """The sensitivities at the samples ``rows`` (indices) only."""
        return Sensitivities(self.names, self.S[list(rows)], self.event_times)


@dataclass(frozen=True)
class Parameters:
    """The requested columns: ``names``; the model parameter symbols among
    them (``symbols``, at columns ``columns``); initial states (``initial``:
    column → state index)."""

    names: tuple
    symbols: tuple
    columns: tuple
    initial: dict


def parse_names(model, names) -> Parameters:
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
    return Parameters(names, tuple(symbols), tuple(columns), initial)


# ------------------------------------------------------------------ generated derivative functions


class _Generated:
    """One generated module: its functions on Python floats, and the same on
    numpy's math where those raise (``1/sqrt(0.0)`` gives ``inf``)."""

    def __init__(self, source: str, label: str):
        self.source = source
        self.namespace = execute(source, module_namespace(), f"<hbg sensitivity {label}>")
        self._numpy = None
        self.label = label

    def __call__(self, name, x, t, p, u, size):
        try:
            return self.namespace[name](x, t, p, u, np.empty(size))
        except _NUMERIC_ERRORS:
            if self._numpy is None:
                self._numpy = execute(self.source, module_namespace(vectorized=True),
                                      f"<hbg sensitivity {self.label} (numpy)>")
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                return self._numpy[name](np.asarray(x, dtype=float), np.float64(t), p, u, np.empty(size))


def _arguments(model):
    return (
        Argument("x", tuple(model.states), doc="state vector"),
        Argument("t", (model.time,), scalar=True, doc="time [s]"),
        Argument("p", tuple(model.parameter_symbols), doc="parameters"),
        Argument("u", tuple(model.input_symbols), doc="inputs"),
    )


def gradients(expressions, model, symbols):
    """``[∂e/∂x (n), ∂e/∂p (len(symbols)), ∂e/∂t, ∂e/∂u (inputs)]`` of every expression, concatenated."""
    variables = (*model.states, *symbols, model.time, *model.input_symbols)
    out = []
    for e in expressions:
        out += real_gradient(e, variables)
    return out


class Derivatives:
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
            rows = [real_gradient(me.f[s], (*model.states, *self.symbols)) for s in model.states]
            n = len(model.states)
            outputs = [d for row in rows for d in row[:n]] + [d for row in rows for d in row[n:]]
            return self._source("jac", outputs, "Jacobians df/dx, df/dp", mode)

        return self._module("flow", mode, build, "flow")

    def jump(self, mode) -> _Generated:
        """``jac(x, t, p, u, out)``: per state ``g_i``, its gradient row (x, p, t, u)."""
        def build():
            g = self.model.mode_equations(mode).g
            return self._source("jac", gradients([g[s] for s in self.model.states], self.model, self.symbols),
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
            return self._source("grad", gradients([h], self.model, self.symbols),
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
                outputs = real_gradient(s, (*model.states, *self.symbols))
                source = self._source("grad", outputs, f"Gradient of signal {name!r} (finite part)", mode)
                model.cache.store(cache_key, source)
            code = compile_checked(source, f"<hbg sensitivity signal {name} {mode.label}>")
            vectorized, scalar = module_namespace(vectorized=True), module_namespace()
            exec(code, vectorized)  # checked: only what the generator writes
            exec(code, scalar)
            pair = self._modules[key] = (vectorized["grad"], scalar["grad"])
        return pair


def derivatives(model, symbols: tuple) -> Derivatives:
    """The derivative functions of ``model`` for ``symbols`` (cached per model)."""
    per_model = _functions.get(model)
    if per_model is None:
        per_model = _functions[model] = {}
    found = per_model.get(symbols)
    if found is None:
        found = per_model[symbols] = Derivatives(model, symbols)
    return found


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
        mask = labels == mode.describe()
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
