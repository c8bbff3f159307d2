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

from dataclasses import dataclass, replace

import sympy as sp

from .errors import DerivationError
from .solving import simplified
from .symbols import t

__all__ = ["StateSpace", "state_space"]


@dataclass(frozen=True)
class StateSpace:
    """``ẋ = A x + B u``, ``y = C x + D u`` with the names of ``x``, ``u``, ``y``.

    ``A, B, C, D = ss`` unpacks the four matrices (sympy ``Matrix``);
    ``states``, ``inputs`` are tuples of symbols, ``outputs`` a tuple of names."""

    A: sp.Matrix
    B: sp.Matrix
    C: sp.Matrix
    D: sp.Matrix
    states: tuple
    inputs: tuple
    outputs: tuple

    def __iter__(self):
        return iter((self.A, self.B, self.C, self.D))

    def substituted(self, values: dict) -> "StateSpace":
        """A copy with parameters replaced by ``values`` (numbers or expressions)."""
        values = {sp.Symbol(k) if isinstance(k, str) else k: v for k, v in values.items()}
        return replace(self, A=self.A.xreplace(values), B=self.B.xreplace(values),
                       C=self.C.xreplace(values), D=self.D.xreplace(values))

    def pretty(self) -> str:
        lines = ["  x = [" + ", ".join(map(str, self.states)) + "]",
                 "  u = [" + ", ".join(map(str, self.inputs)) + "]",
                 "  y = [" + ", ".join(map(str, self.outputs)) + "]"]
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
                      tuple(states), tuple(u), tuple(out_names))
