"""State-space matrices ``ẋ = A x + B u``, ``y = C x + D u`` of a linear configuration.

See :meth:`bondgraph.ConfigurationEquations.state_space`.  The inputs ``u``
are, in order:

1. one per **source element** (``Se``: its effort, ``Sf``: the flow it pushes
   out of itself), in the order the sources were added, unless its value
   depends on states or bond variables (a feedback-modulated source is part
   of the dynamics, not an input).  The input symbol is the source's value
   when that value is a bare symbol (a parameter or a declared input, e.g.
   ``Se("F", "F0")`` → ``F0``) not shared with another source nor fixed
   by a substituted (mode) constant; otherwise a
   symbol named after the source (``Se("w", -m*g)`` → ``w``; ``u_w`` when
   ``w`` is already a name of the graph).  Constant sources (gravity, a fixed
   voltage) are inputs too: their effect lands in ``B``, never as an offset.
2. every **declared input** (``g.input``) still left in the equations.

With ``inputs=[...]`` the caller picks the input symbols instead (parameters
or declared inputs); sources then keep their values and any term not
proportional to a state or an input is an error.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import sympy as sp

from .errors import DerivationError
from .linear_system import LinearSystem
from .solving import simplified
from .symbols import t

__all__ = ["StateSpace", "state_space"]


@dataclass(frozen=True)
class StateSpace:
    """``ẋ = A x + B u``, ``y = C x + D u`` with the names of ``x``, ``u``, ``y``.

    ``A, B, C, D = ss`` unpacks the four matrices (sympy ``Matrix``);
    ``states``, ``inputs`` are tuples of symbols, ``outputs`` a tuple of names.
    ``constraints``: dependent state → its constraint ``x_d = K x + L u``
    (an expression of the independent states and the inputs), for each state
    that the configuration holds dependent (derivative causality);
    :meth:`reduced` removes those from ``states``."""

    A: sp.Matrix
    B: sp.Matrix
    C: sp.Matrix
    D: sp.Matrix
    states: tuple
    inputs: tuple
    outputs: tuple
    constraints: dict = field(default_factory=dict)

    def __iter__(self):
        return iter((self.A, self.B, self.C, self.D))

    def substituted(self, values: dict) -> "StateSpace":
        """A copy with parameters replaced by ``values`` (numbers or expressions)."""
        values = {sp.Symbol(k) if isinstance(k, str) else k: v for k, v in values.items()}
        return replace(self, A=self.A.xreplace(values), B=self.B.xreplace(values),
                       C=self.C.xreplace(values), D=self.D.xreplace(values),
                       constraints={x: v.xreplace(values) for x, v in self.constraints.items()})

    def reduced(self) -> "StateSpace":
        """The same system over the independent states ``x_i`` alone.

        Each dependent state is ``x_d = K_d x + L_d u`` (:attr:`constraints`;
        ``K_d`` is zero on the dependent states), so ``x = P x_i + Q u`` with
        ``P`` (n × n_i) the identity on the independent rows and ``K_d`` on the
        dependent ones, ``Q`` (n × m) zero and ``L_d``.  Then
        ``ẋ_i = A_i P x_i + (B_i + A_i Q) u`` (``A_i``, ``B_i``: the
        independent rows) and ``y = C P x_i + (D + C Q) u``.  The result
        keeps :attr:`constraints` (their states no longer among ``states``);
        without dependent states among ``states``, ``self``."""
        keep = [k for k, x in enumerate(self.states) if x not in self.constraints]
        if len(keep) == len(self.states):
            return self
        P, Q = self._embedding(keep)
        A_i, B_i = self.A.extract(keep, list(range(self.A.cols))), self.B.extract(keep, list(range(self.B.cols)))
        return StateSpace((A_i * P).applyfunc(sp.simplify), (B_i + A_i * Q).applyfunc(sp.simplify),
                          (self.C * P).applyfunc(sp.simplify), (self.D + self.C * Q).applyfunc(sp.simplify),
                          tuple(self.states[k] for k in keep), self.inputs, self.outputs, dict(self.constraints))

    def _embedding(self, keep: list) -> tuple:
        """``(P, Q)`` of ``x = P x_i + Q u`` (see :meth:`reduced`), ``x_i`` the states at ``keep``."""
        P = sp.zeros(len(self.states), len(keep))
        Q = sp.zeros(len(self.states), len(self.inputs))
        for column, k in enumerate(keep):
            P[k, column] = 1
        for k, x in enumerate(self.states):
            if k in keep:
                continue
            K, L = _linear_row(self.constraints[x], self.states, self.inputs, f"the constraint of {x}")
            if any(K[j] != 0 for j in range(len(self.states)) if j not in keep):
                raise DerivationError(f"the constraint {x} = {self.constraints[x]} names another dependent "
                                      "state; no reduced state-space form", [str(x)])
            for column, j in enumerate(keep):
                P[k, column] = K[j]
            for j, v in enumerate(L):
                Q[k, j] = v
        return P, Q

    def numeric(self, values: dict | None = None, name: str = "") -> LinearSystem:
        """A :class:`~bondgraph.linear_system.LinearSystem` (float arrays,
        continuous time) over the independent states (:meth:`reduced`), with
        ``values`` (symbol or name → number) substituted for the parameters.
        Its ``dependent`` names the states left out, with their constraints.
        A symbol left without a value raises :class:`DerivationError` naming it."""
        system = self.substituted(values or {})
        dependent = {str(x): str(v) for x, v in system.constraints.items()}
        system = system.reduced()
        arrays = []
        for label, matrix in zip("ABCD", system):
            free = sorted(str(s) for s in matrix.free_symbols)
            if free:
                raise DerivationError(f"state-space matrix {label} still holds the symbol(s) {', '.join(free)}: give "
                                      f"their values (numeric(values={{...}})) to make it numerical", free)
            arrays.append(np.array(matrix.evalf(), dtype=float).reshape(matrix.shape))
        return LinearSystem(*arrays, tuple(map(str, system.states)), tuple(map(str, system.inputs)),
                            tuple(map(str, system.outputs)), name=name, dependent=dependent)

    def pretty(self) -> str:
        lines = ["  x = [" + ", ".join(map(str, self.states)) + "]",
                 "  u = [" + ", ".join(map(str, self.inputs)) + "]",
                 "  y = [" + ", ".join(map(str, self.outputs)) + "]"]
        lines += [f"  {x} = {v} (dependent)" for x, v in self.constraints.items()]
        for name, m in zip("ABCD", self):
            lines.append(f"  {name} = " + (sp.pretty(m, use_unicode=True).replace("\n", "\n      ") if m
                                          else f"[] ({m.rows}×{m.cols})"))
        return "\n".join(lines)

    __str__ = pretty


def _source_inputs(eqs, taken: set):
    """Re-derive ``eqs`` with every (non-feedback) source's value replaced by an
    input symbol; returns ``(equations, input symbols)``."""
    from .elements import Se, Source
    from .relations import Relation

    graph = eqs.graph
    rel = eqs.causality.relations
    dynamic = set(graph.states) | graph.bond_symbols() | set(rel.rate_symbols.values())
    sources = [(n, el) for n, el in graph.elements.items()
               if isinstance(el, Source) and not (el.value.free_symbols & dynamic)]
    counts: dict = {}
    for _, el in sources:
        counts[el.value] = counts.get(el.value, 0) + 1
    new = dict(rel.relations)
    symbols = []
    for name, el in sources:
        value = el.value
        if isinstance(value, sp.Symbol) and value != t and counts[value] == 1 and value not in eqs.substitutions:
            u = value
        else:
            label = name if name not in taken else f"u_{name}"
            while label in taken:
                label = "u_" + label
            u = sp.Symbol(label)
        taken.add(u.name)
        symbols.append(u)
        for var, r in rel.relations.items():
            if r.element == name:
                s = graph.bonds_of(name)[0].sign_at(name)
                new[var] = Relation(var, u if isinstance(el, Se) else -s * u, name)
    causality = replace(eqs.causality, relations=replace(rel, relations=new))
    derived = eqs.derived_again(causality)
    for x, phi in derived.constraints.items():
        fixed = sorted(str(u) for u in symbols if phi.has(u))
        if fixed:
            raise DerivationError(
                f"no state-space form: dependent state {x} is fixed by input(s) {', '.join(fixed)} "
                f"({x} = {phi}), so its rate needs their time derivative; pass inputs=[...] to keep those "
                "sources as constant parameters.", [str(x)])
    return derived, symbols


def _linear_row(expr, states, inputs, what):
    """Coefficients of ``expr`` in ``states`` and ``inputs`` (it must be linear in them)."""
    variables = list(states) + list(inputs)
    index = {v: k for k, v in enumerate(variables)}
    row = [sp.S.Zero] * len(variables)
    for term in sp.Add.make_args(sp.expand(expr)):
        if term == 0:
            continue
        coeff, rest = term.as_independent(*variables, as_Add=False)
        if rest in index and not coeff.has(t):
            row[index[rest]] += coeff
            continue
        if rest == 1:
            problem = f"the constant term {term} (not proportional to a state or an input)"
        elif coeff.has(t) or rest.has(t):
            problem = f"the time-varying term {term}"
        else:
            problem = f"the nonlinear term {term}"
        raise DerivationError(
            f"{what} = {expr} is not linear in the states and inputs: {problem}; "
            "no state-space matrices for this configuration.", [what])
    row = [simplified(c, f"simplifying a coefficient of {what}") for c in row]
    return row[:len(states)], row[len(states):]


def _output_list(eqs, outputs, resolve):
    if outputs is None:
        return [(str(x), x) for x in eqs.states]
    if isinstance(outputs, dict):
        return [(str(k), resolve(v)) for k, v in outputs.items()]
    if isinstance(outputs, (str, sp.Basic)):
        outputs = [outputs]
    return [(o if isinstance(o, str) else str(o), resolve(o)) for o in outputs]


def state_space(eqs, outputs=None, inputs=None) -> StateSpace:
    """See :meth:`bondgraph.ConfigurationEquations.state_space`."""
    graph = eqs.graph
    names = {s.name: s for s in (*eqs.states, *graph.inputs.values(), *graph.bond_symbols(), *graph.parameters)}

    def symbol(v):
        if isinstance(v, str):
            if v not in names:
                raise DerivationError(f"unknown output or input {v!r}: give a state, a bond variable (e_<bond>, "
                                      "f_<bond>), an input or a sympy expression", [v])
            return names[v]
        return sp.sympify(v)

    if inputs is None:
        taken = {s.name for s in eqs.parameters | set(eqs.states) | set(eqs.substitutions)} | set(names)
        derived, u = _source_inputs(eqs, taken)
        used = set().union(*(r.free_symbols for r in derived.rates.values())) if derived.rates else set()
        u += [s for s in graph.inputs.values() if s in used and s not in u]
    else:
        derived, u = eqs, [symbol(v) for v in inputs]

    bond_values = {}
    for name, bond in graph.bonds.items():
        bond_values[bond.effort] = derived.efforts[name]
        bond_values[bond.flow] = derived.flows[name]

    def resolve(v):
        expr = symbol(v).xreplace(bond_values)
        return derived.resolve(expr)

    states = eqs.states
    A, B = [], []
    for x in states:
        a, b = _linear_row(derived.rates[x], states, u, f"d{x}/dt")
        A.append(a)
        B.append(b)
    C, D, out_names = [], [], []
    for name, expr in _output_list(eqs, outputs, resolve):
        c, d = _linear_row(expr, states, u, f"output {name}")
        C.append(c)
        D.append(d)
        out_names.append(name)
    n, m, p = len(states), len(u), len(out_names)
    return StateSpace(sp.Matrix(n, n, [v for r in A for v in r]), sp.Matrix(n, m, [v for r in B for v in r]),
                      sp.Matrix(p, n, [v for r in C for v in r]), sp.Matrix(p, m, [v for r in D for v in r]),
                      tuple(states), tuple(u), tuple(out_names), dict(derived.constraints))
