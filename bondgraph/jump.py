"""The jump map ``g`` *into* a configuration, from conservation of state.

Entering a configuration in which some storage elements are dependent, the
state jumps onto that configuration's constraints ``x_d = φ(x_i, t)``.
Impulses flow through the junction structure (moduli are evaluated at the
current positions, which do not jump), so generalized momentum (charge) is
conserved along every direction the constraints leave free.

With the storage co-energies ``y = Φ(x)`` (I: flow, C: effort) and the
constraint written as ``y_d = A y_i + b``, power conservation of the junction
structure gives the impulse balance ``Δx_i = −Aᵀ Δx_d``.  For linear storage
``x = M y`` (``M`` diagonal: masses, inductances, capacitances) this is the
projection of DESIGN §5,

    (M_i + Aᵀ M_d A) y_i⁺ = x_i + Aᵀ x_d − Aᵀ M_d b,     y_d⁺ = A y_i⁺ + b,

which in terms of the constraint ``x_d = K x_i + c`` (``K = ∂φ/∂x_i``,
``A = M_d⁻¹ K M_i``) reads

    (I + M_i Kᵀ M_d⁻¹ K) x_i⁺ = x_i + M_i Kᵀ M_d⁻¹ (x_d − c),   x_d⁺ = K x_i⁺ + c.

Only the independent storage states that appear in a constraint *and* that
the impulses reach through the junction structure take part (their implicit
rates hold a dependent state's rate); a state a constraint reads only through
a modulated source's value stays, the source taking the impulse (an ideal
buffer charging a hold capacitor leaves the capacitor it measures alone).
Every other state (and every displacement) is unchanged.  ``g`` is the
identity on states already on the constraints.  For nonlinear storage the
balance ``x_i⁺ − x_i + Aᵀ(φ(x_i⁺) − x_d) = 0`` is solved numerically
(:meth:`JumpMap.apply`).

**Jump laws.**  The above is the ``"conservation"`` law: impulses pass
through the junction structure only, every source stays finite.  The
``"impulse balance"`` law integrates the configuration's own implicit rates
``ẋ_i = F(x, t, u, ẋ_d)`` over the instant instead.  ``F`` is affine in the
rates of the dependent states, ``B = ∂F/∂ẋ_d`` is evaluated at the positions
(which do not jump), and every independent state whose row of ``B`` is not
zero takes part (set ``J``):

    Δx_J = B Δx_d,    x_d⁺ = φ(x_J⁺)   ⇒   (I − K B) Δx_d = φ(x) − x_d,   K = ∂φ/∂x_J.

Where the only pulses are those of the storage this is the conservation law
(``B = −M_i Kᵀ M_d⁻¹``).  A source *modulated by a constraint effort*
carries a pulse too: a Coulomb friction source ``σ μ N`` driven by the normal
force gives the Newton–Coulomb impact law, a tangential impulse ``−σ μ P_n``
with the normal impulse ``P_n``.  This law needs ``B`` and ``K`` free of the
states that jump (linear storage, linear constraints in them).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import sympy as sp

from .errors import HybridBondGraphError

__all__ = ["JUMP_LAWS", "JumpMap", "derive_jump_map", "JumpMapError"]

JUMP_LAWS = ("conservation", "impulse balance")


class JumpMapError(HybridBondGraphError):
    """The conservation-of-state equations could not be solved (nonlinear
    storage): names the configuration and the state values."""


@dataclass(frozen=True)
class JumpMap:
    """``x⁺ = g(x)`` into one configuration.

    ``expressions`` maps every state to its post-jump value as a sympy
    expression of the pre-jump states (``None`` when the storage is nonlinear
    and the map is numerical only; use :meth:`apply`).  ``participating`` are
    the independent storage states that the constraints couple, ``dependent``
    the dependent ones; all other states are left unchanged.
    """

    states: tuple
    participating: tuple
    dependent: tuple
    expressions: dict | None
    linear: bool
    _numeric: object = field(default=None, repr=False, compare=False)

    @property
    def is_identity(self) -> bool:
        return not self.dependent

    def vector(self) -> sp.Matrix | None:
        """``x⁺`` as an ``n × 1`` matrix in state order (``None`` if numerical only)."""
        if self.expressions is None:
            return None
        return sp.Matrix([self.expressions[x] for x in self.states])

    def substituted(self, values: dict) -> "JumpMap":
        """A copy with symbols replaced by ``values`` (mode-dependent constants)."""
        if not values:
            return self
        expressions = None
        if self.expressions is not None and not self.expressions.keys().isdisjoint(values.keys()):
            expressions = {k: sp.sympify(v).xreplace(values) for k, v in self.expressions.items()}
        elif self.expressions is not None:  # (the states stay themselves: only the others are substituted)
            expressions = dict(self.expressions)
            for k, v in self.expressions.items():
                if v is not k:
                    expressions[k] = sp.sympify(v).xreplace(values)
        numeric = self._numeric
        fixed = {k: float(v) for k, v in values.items() if not sp.sympify(v).free_symbols}
        symbolic = {k: sp.sympify(v) for k, v in values.items() if sp.sympify(v).free_symbols}

        def apply(x, t, parameters):
            merged = dict(parameters)
            merged.update(fixed)
            merged.update({k: float(v.xreplace(parameters)) for k, v in symbolic.items()})
            return numeric(x, t, merged)

        return replace(self, expressions=expressions, _numeric=apply)

    def apply(self, x, t: float, parameters) -> np.ndarray:
        """Numerical ``g(x)`` for state array ``x`` (shape ``(n,)``), time ``t``
        and parameter values (mapping symbol → float)."""
        return self._numeric(np.asarray(x, dtype=float), float(t), parameters)


def _metric(element, x) -> sp.Expr | None:
    """``M = 1/Φ'(x)`` for linear storage; ``None`` if the law is nonlinear."""
    slope = sp.diff(element.law, element.state)
    if slope.has(element.state) or element.law.xreplace({element.state: 0}) != 0:
        return None
    return 1 / slope


def derive_jump_map(graph, equations, law: str = "conservation") -> JumpMap:
    """Derive the jump map into the configuration of ``equations`` by one of
    :data:`JUMP_LAWS` (see the module docstring)."""
    if law not in JUMP_LAWS:
        raise ValueError(f"unknown jump law {law!r}; choose one of {JUMP_LAWS}")
    states = tuple(equations.states)
    dependent = tuple(equations.dependent)
    if not dependent:
        return JumpMap(states, (), (), {x: x for x in states}, True, _numeric=lambda x, t, p: np.array(x, dtype=float))
    if law == "impulse balance":
        return _impulse_balance_jump(equations)

    storage = graph.derived.memo("storage by state", lambda: {el.state: el for el in graph.storage})
    constraints = equations.constraints
    constrained = set().union(*(constraints[d].free_symbols for d in dependent))
    candidates = {x for x in constrained if x in storage}  # (few: a scene's other states are not asked about)
    reached = _reached_by_impulses(equations, graph, candidates)
    # (in the order of the independent states, which is the graph's: a scene's thousand are not looked through)
    places = graph.derived.memo("state places", lambda: {s: k for k, s in enumerate(graph.states)})
    participating = tuple(sorted((x for x in candidates if x in reached), key=places.__getitem__))
    phi = sp.Matrix([constraints[d] for d in dependent])
    K = phi.jacobian(list(participating)) if participating else sp.zeros(len(dependent), 0)
    metrics = {x: _metric(storage[x], x) for x in (*participating, *dependent)}
    linear_storage = all(m is not None for m in metrics.values())
    linear_constraint = all(sp.diff(K[i, j], x) == 0 for i in range(K.rows) for j in range(K.cols) for x in participating)

    if linear_storage and linear_constraint:
        expressions = _linear_jump(_identity(graph, states), participating, dependent, phi, K, metrics)
        numeric = _lambdified(states, expressions)
        return JumpMap(states, participating, dependent, expressions, True, _numeric=numeric)
    return JumpMap(
        states,
        participating,
        dependent,
        None,
        False,
        _numeric=_nonlinear_jump(graph, equations, participating, dependent, phi, storage),
    )


def _identity(graph, states: tuple) -> dict:
    """``{x: x}`` of ``states``, kept with ``graph``'s derivations while they are the same (told apart by
    their objects, not hashed again: a scene's every mode holds all its thousand states)."""
    kept = graph.derived.entries.get("identity map")
    if kept is None or kept[0] != states:
        kept = graph.derived.entries["identity map"] = (states, {x: x for x in states})
    return kept[1]


def _reached_by_impulses(equations, graph=None, among=None) -> set:
    """The independent states whose implicit rate holds a dependent state's rate (``∂F_i/∂ẋ_d ≠ 0``):
    those an impulse into the dependent storage reaches through the junction structure.  A state
    that a constraint reads only through a modulated source's value (a controlled source, a
    sample-and-hold's buffer) is not among them: the source takes the impulse, the state it reads
    stays (its value enters ``c``).  The symbols of each implicit rate are kept with ``graph``'s
    derivations: the configurations of a scene share most of their rates (island by island).  ``among``:
    only these states are asked about (all the independent ones when ``None``)."""
    rates = {equations.rate_symbols[d] for d in equations.dependent}
    implicit = equations.implicit_rates if among is None else equations.implicit_rates_of(among)
    if graph is None:
        return {x for x, rate in implicit.items() if not rates.isdisjoint(rate.atoms(sp.Symbol))}
    memo = graph.derived.memo
    return {x for x, rate in implicit.items()
            if not rates.isdisjoint(memo(("symbols in", rate), lambda rate=rate: rate.atoms(sp.Symbol)))}


def _linear_jump(identity, participating, dependent, phi, K, metrics) -> dict:
    """``x⁺`` of every state (the module docstring's projection): a copy of ``identity`` (state → itself,
    in state order) with the participating and dependent states' values."""
    if len(participating) == 1 and len(dependent) == 1:  # (two point masses meeting: a scene's every pinnacle)
        xi_plus, xd_plus = _scalar_projection(participating[0], dependent[0], phi[0], K[0, 0], metrics)
    else:
        xi_plus, xd_plus = _projection(participating, dependent, phi, K, metrics)
    expressions = dict(identity)
    for k, x in enumerate(participating):
        expressions[x] = _tidy(xi_plus[k])
    for k, x in enumerate(dependent):
        expressions[x] = _tidy(xd_plus[k])
    return expressions


def _projection(participating, dependent, phi, K, metrics) -> tuple:
    """``(x_i⁺, x_d⁺)`` as matrices (the module docstring's projection)."""
    xi = sp.Matrix(participating)
    xd = sp.Matrix(dependent)
    c = phi - K * xi if participating else phi
    Mi = sp.diag(*[metrics[x] for x in participating]) if participating else sp.zeros(0, 0)
    Md_inv = sp.diag(*[1 / metrics[x] for x in dependent])
    if not participating:
        return sp.zeros(0, 1), c
    lhs = sp.eye(len(participating)) + Mi * K.T * Md_inv * K
    rhs = xi + Mi * K.T * Md_inv * (xd - c)
    xi_plus = _solve_small(lhs, rhs)
    return xi_plus, K * xi_plus + c


def _scalar_projection(xi, xd, phi, k, metrics) -> tuple:
    """:func:`_projection` of one participating and one dependent state, each matrix a number: the same
    expressions, built by the same operations in the same order, without sympy's matrices (whose
    arithmetic on 1 × 1 matrices cost more than the map's own algebra)."""
    c = phi - k * xi
    md_inv = 1 / metrics[xd]
    lhs = 1 + metrics[xi] * k * md_inv * k
    rhs = xi + metrics[xi] * k * md_inv * (xd - c)
    xi_plus = rhs / lhs
    return (xi_plus,), (k * xi_plus + c,)


def _impulse_balance_jump(equations) -> JumpMap:
    """``Δx_J = B Δx_d`` with ``B = ∂F/∂ẋ_d`` of the implicit rates, closed
    by the constraints (the module docstring's ``"impulse balance"`` law)."""
    states = tuple(equations.states)
    dependent = tuple(equations.dependent)
    rates = [equations.rate_symbols[d] for d in dependent]
    implicit = equations.implicit_rates
    rows = {x: [sp.diff(implicit[x], r) for r in rates] for x in equations.independent}
    config = equations.configuration
    for x, row in rows.items():
        if any(entry.has(*rates) for entry in row):
            raise JumpMapError(
                f"the impulse-balance jump law into configuration {config} needs the rate of {x} affine in the "
                f"rates of the dependent states {list(dependent)}; it is {implicit[x]}. Use jump_law='conservation'."
            )
    jumping = tuple(x for x, row in rows.items() if any(entry != 0 for entry in row))
    phi = sp.Matrix([equations.constraints[d] for d in dependent])
    B = sp.Matrix([rows[x] for x in jumping]) if jumping else sp.zeros(0, len(dependent))
    K = phi.jacobian(list(jumping)) if jumping else sp.zeros(len(dependent), 0)
    moving = set(jumping) | set(dependent)
    if any(entry.has(*moving) for entry in (*B, *K)):
        raise JumpMapError(
            f"the impulse-balance jump law into configuration {config} needs the impulse coefficients ∂F/∂ẋ_d and "
            f"the constraints' slopes ∂φ/∂x free of the states that jump ({sorted(map(str, moving))}): nonlinear "
            "storage or constraints are not supported by it. Use jump_law='conservation'."
        )
    xd = sp.Matrix(dependent)
    delta = _solve_small(sp.eye(len(dependent)) - K * B, phi - xd)
    expressions = {x: x for x in states}
    increments = B * delta
    for k, x in enumerate(jumping):
        expressions[x] = _tidy(x + increments[k])
    for k, x in enumerate(dependent):
        expressions[x] = _tidy(x + delta[k])
    return JumpMap(states, jumping, dependent, expressions, True, _numeric=_lambdified(states, expressions))


def _solve_small(lhs: sp.Matrix, rhs: sp.Matrix) -> sp.Matrix:
    if lhs.shape == (1, 1):
        return rhs / lhs[0, 0]
    return lhs.LUsolve(rhs)


def _tidy(expr):
    from . import equations  # (looked up at each call: tests replace equations.tidy)

    return equations.tidy(expr)


def _lambdified(states, expressions):
    """``apply(x, t, parameters)`` evaluating the symbolic map; lambdified on
    first use (the generated mode code evaluates ``g`` itself, so most maps
    never need it)."""
    from .symbols import t as time

    compiled = []  # (the function and the parameters it reads, made on first use: a scene's map reads all states)

    def apply(x, t, parameters):
        if not compiled:
            symbols = sorted({s for e in expressions.values() for s in e.free_symbols} - set(states), key=str)
            params = [s for s in symbols if s != time]
            compiled.append((sp.lambdify([list(states), time, params], [expressions[x] for x in states], "numpy",
                                         cse=True), params))
        function, params = compiled[0]
        return np.array(function(x, t, [parameters[s] for s in params]), dtype=float)

    return apply


def _nonlinear_jump(graph, equations, participating, dependent, phi, storage):
    """Newton solve of ``x_i⁺ − x_i + Aᵀ(φ(x_i⁺) − x_d) = 0`` with
    ``A = diag(Φ_d'(x_d)) K diag(1/Φ_i'(x_i))`` evaluated along the way."""
    from scipy.optimize import root

    from .symbols import t as time

    states = list(equations.states)
    K = phi.jacobian(list(participating))
    slope_i = [sp.diff(storage[x].law, x) for x in participating]
    slope_d = [sp.diff(storage[x].law, x).xreplace({x: phi[k]}) for k, x in enumerate(dependent)]
    A = sp.diag(*slope_d) * K * sp.diag(*[1 / s for s in slope_i])
    symbols = set()
    for expr in (*phi, *A):
        symbols |= expr.free_symbols
    params = sorted(symbols - set(states) - {time}, key=str)
    phi_fn = sp.lambdify([states, time, params], list(phi), "numpy")
    A_fn = sp.lambdify([states, time, params], A, "numpy")
    index = {x: k for k, x in enumerate(states)}
    idx_i = [index[x] for x in participating]
    idx_d = [index[x] for x in dependent]
    config = equations.configuration

    def apply(x, t, parameters):
        pvals = [parameters[s] for s in params]
        x = np.array(x, dtype=float)
        x_i, x_d = x[idx_i], x[idx_d]

        def full(xi):
            trial = x.copy()
            trial[idx_i] = xi
            trial[idx_d] = np.asarray(phi_fn(trial, t, pvals), dtype=float).ravel()
            return trial

        def residual(xi):
            trial = full(xi)
            A_val = np.atleast_2d(np.asarray(A_fn(trial, t, pvals), dtype=float))
            return xi - x_i + A_val.T @ (trial[idx_d] - x_d)

        sol = root(residual, x_i, method="hybr", tol=1e-13)
        if not sol.success or not np.all(np.isfinite(sol.x)):
            raise JumpMapError(
                f"conservation of state into configuration {config} did not converge for nonlinear storage "
                f"({sol.message}); state before the jump: "
                + ", ".join(f"{s}={v:.6g}" for s, v in zip(states, x))
                + ". Check the storage laws are invertible near this state, or linearise them."
            )
        return full(sol.x)

    return apply
