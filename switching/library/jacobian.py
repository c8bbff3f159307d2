"""The Jacobian of a flow, derived symbolically, for the implicit methods.

In a mode the flow integrates the independent states ``y = x_I`` (``k`` of
the ``n`` states); the dependent ones follow their constraints
``x_D = φ(x_I, t)``.  The rates of the flow are ``ẏ = f_I(x_I, φ(x_I, t), t)``
and its Jacobian, by the chain rule through the constraints,

    J = ∂ẏ/∂y = ∂f_I/∂x_I + ∂f_I/∂x_D · ∂φ/∂x_I          (k × k),

which is what this module derives: ``f_I`` with ``φ`` substituted,
differentiated with every symbol taken real (``|s|`` gives ``sign(s)``), its
structurally nonzero entries generated as one function (checked before it
runs, like every generated module) and kept in the model's cache.  scipy's
``Radau``, ``BDF`` and ``LSODA`` take it as ``jac=`` instead of estimating
``J`` by ``k`` extra evaluations of the rates per Jacobian; large sparse
Jacobians are handed over as sparse matrices (their LU is then sparse too).

The units of ``J[i, j]`` are those of ``ẏ_i / y_j`` (1/s for states of one
kind).
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from bondgraph import budget
from bondgraph.inverse import slope_of
from codegen.cache import fingerprint
from codegen.safety import execute
from codegen.source import Argument, FunctionSpec, function_source, module_namespace

__all__ = ["FlowJacobian", "JACOBIAN_SOURCE_VERSION", "SPARSE_FROM", "flow_jacobian", "flow_rate", "jacobian_entries",
           "real_gradient"]

#: part of the cache key of a generated Jacobian: raise it when the generated text changes
JACOBIAN_SOURCE_VERSION = "2"
#: a Jacobian of at least this many states, at most a quarter of its entries nonzero, is handed to
#: Radau and BDF as a sparse matrix
SPARSE_FROM = 40


def real_gradient(expression, variables) -> list:
    """``∂e/∂v`` for each of ``variables``, every symbol taken real (so
    ``|s|`` gives ``sign(s)``, not complex parts), without Dirac pulses (the
    ``2|s|·δ(s)`` of ``∂(s|s|)/∂s``, the ``s·δ(s)`` of ``∂(s·step(s))/∂s``:
    nought wherever flow evaluates it, :func:`bondgraph.inverse.slope_of`);
    zeros where ``e`` does not contain ``v``."""
    e = sp.sympify(expression)
    free = e.free_symbols
    if not free & set(variables):
        return [sp.S.Zero] * len(variables)
    real = {s: sp.Dummy(s.name, real=True) for s in free}
    back = {r: s for s, r in real.items()}
    e = e.xreplace(real)
    return [slope_of(e, real[v]).xreplace(back) if v in free else sp.S.Zero for v in variables]


def flow_rate(me, state):
    """The rate of the independent ``state`` in the flow of the mode of
    ``me`` (its :class:`ModeEquations`): ``f`` with the dependent states'
    constraints substituted (a function of the independent states, ``t``,
    the parameters and the inputs)."""
    constraints = me.equations.constraints
    rate = me.f[state]
    for _ in range(len(constraints) + 1):  # (a constraint may name another dependent state)
        if not rate.free_symbols & constraints.keys():
            break
        rate = rate.xreplace(constraints)
    return rate


def jacobian_entries(model, mode, independent) -> tuple[list, list, list]:
    """``(rows, cols, entries)``: the structurally nonzero entries of the
    flow's Jacobian in ``mode`` (sympy expressions of the independent states
    ``independent``, indices into the states, of ``t``, the parameters and
    the inputs), row by row."""
    me = model.mode_equations(mode)
    states = [model.states[i] for i in independent]
    memo, variables = model.library.gradient_memo, tuple(states)
    rows, cols, entries = [], [], []
    for i, state in enumerate(states):
        rate = flow_rate(me, state)
        gradient = memo.get((rate, variables))
        if gradient is None:
            gradient = memo[rate, variables] = real_gradient(rate, states)
        for j, derivative in enumerate(gradient):
            if derivative != 0:
                rows.append(i)
                cols.append(j)
                entries.append(derivative)
    return rows, cols, entries


def _source(model, mode, independent) -> str:
    """The generated module: ``META`` (the nonzero entries' rows and
    columns, the size ``k``) and ``jac(x, t, p, u, out)`` writing those
    entries in that order."""
    rows, cols, entries = jacobian_entries(model, mode, independent)
    states = [model.states[i] for i in independent]
    arguments = (
        Argument("x", tuple(model.states), doc="state vector"),
        Argument("t", (model.time,), scalar=True, doc="time [s]"),
        Argument("p", tuple(model.parameter_symbols), doc="parameters"),
        Argument("u", tuple(model.input_symbols), doc="inputs"),
    )
    names = tuple(f"d({model.state_names[independent[i]]})'/d({model.state_names[independent[j]]})"
                  for i, j in zip(rows, cols))
    spec = FunctionSpec("jac", arguments, tuple(entries),
                        f"The nonzero entries of the flow's Jacobian in mode {mode.describe()}.", names)
    meta = {"rows": tuple(rows), "cols": tuple(cols), "size": len(states)}
    return f"META = {meta!r}\n\n\n" + function_source(spec, model.library.print_memo)


class _Generated:
    """A mode's generated Jacobian: its function on Python floats, the same
    on numpy's math when first needed, and its pattern."""

    def __init__(self, source: str, label: str):
        namespace = execute(source, module_namespace(), f"<hbg jacobian {label}>")
        meta = namespace["META"]
        self.source, self.label, self.jac, self.numpy = source, label, namespace["jac"], None
        self.k = meta["size"]
        self.rows = np.array(meta["rows"], dtype=np.int64)
        self.cols = np.array(meta["cols"], dtype=np.int64)

    def on_numpy(self):
        if self.numpy is None:
            self.numpy = execute(self.source, module_namespace(vectorized=True),
                                 f"<hbg jacobian {self.label} (numpy)>")["jac"]
        return self.numpy


class FlowJacobian:
    """``J(t, y)`` of the flow in one mode (see the module docstring):
    :meth:`dense` a ``(k, k)`` array, :meth:`__call__` the form scipy's
    methods take (sparse for large sparse ``J``); :attr:`sparsity` the
    ``(k, k)`` boolean pattern of its structural nonzeros."""

    def __init__(self, model, cm, generated: _Generated, template: np.ndarray):
        self.model, self.cm, self._generated = model, cm, generated
        self.k, self.rows, self.cols = generated.k, generated.rows, generated.cols
        self.sparse = self.k >= SPARSE_FROM and 4 * len(self.rows) <= self.k * self.k
        self._z = template.copy()
        self._values = np.empty(len(self.rows))

    @property
    def sparsity(self) -> np.ndarray:
        pattern = np.zeros((self.k, self.k), dtype=bool)
        pattern[self.rows, self.cols] = True
        return pattern

    def values(self, t, y) -> np.ndarray:
        """The nonzero entries at ``(t, y)``, in the order of :attr:`rows`, :attr:`cols`."""
        model, z = self.model, self._z
        z[self.cm.independent] = y
        u = model.input_values(t)
        try:
            return self._generated.jac(z, t, model.parameter_array, u, self._values)
        except (ArithmeticError, TypeError):  # Python floats raise where numpy gives inf or NaN
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                return self._generated.on_numpy()(z, np.float64(t), model.parameter_array, u, self._values)

    def dense(self, t, y) -> np.ndarray:
        """``J`` at ``(t, y)`` as a ``(k, k)`` array."""
        out = np.zeros((self.k, self.k))
        out[self.rows, self.cols] = self.values(t, y)
        return out

    def __call__(self, t, y):
        """``J`` at ``(t, y)``: a ``(k, k)`` array, or a CSC matrix when :attr:`sparse`.  Where ``J`` is not
        finite (``√q`` at ``q = 0``: an infinite slope) it is 0: the implicit method takes the explicit step it
        can take there (its Newton iteration a plain one), and ``J`` is finite again a step on."""
        values = self.values(t, y)
        if not np.all(np.isfinite(values)):
            values = np.zeros_like(values)
        if self.sparse:
            from scipy.sparse import csc_matrix

            return csc_matrix((values.copy(), (self.rows, self.cols)), shape=(self.k, self.k))
        out = np.zeros((self.k, self.k))
        out[self.rows, self.cols] = values
        return out


def flow_jacobian(model, cm, x) -> FlowJacobian | None:
    """The Jacobian of the flow in the mode of ``cm`` from the state ``x``
    (its dependent states' values are not read), from the model's library,
    its cache, or derived now; ``None`` when the mode has no independent
    state or the derivation runs past the symbolic budget
    (:mod:`bondgraph.budget`: the method then estimates ``J`` by finite
    differences, as it would without)."""
    independent = tuple(int(i) for i in cm.independent)
    if not independent:
        return None
    library = model.library
    generated = library.jacobians.get(cm.mode)
    if generated is None:
        key = fingerprint(library.fingerprint, "flow jacobian", JACOBIAN_SOURCE_VERSION, cm.mode.label)
        source = library.cache.load(key)
        if source is None:
            try:
                source = budget.run(f"the flow's Jacobian in mode {cm.mode.describe()}", _source, model, cm.mode,
                                    independent)
            except budget.OverBudget:
                return None
            library.cache.store(key, source)
        generated = library.jacobians[cm.mode] = _Generated(source, cm.mode.label)
    return FlowJacobian(model, cm, generated, np.asarray(x, dtype=float))
