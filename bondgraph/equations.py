"""Symbolic equations of one junction configuration.

For the global state vector ``x`` (DESIGN §4), split by causality into
independent states ``x_i`` (integral causality, plus displacements) and
dependent states ``x_d`` (derivative causality), the configuration's
equations are

* **constraints**  ``x_d = φ(x_i, t)`` — the dependent states as algebraic
  functions of the independent ones (the system stays on them, no drift);
* **implicit rates** ``dx_i/dt = F(x_i, t, u, dx_d/dt)`` — straight from the
  junction structure, with the rates of dependent states still symbolic;
* **dependent rates** ``dx_d/dt = (∂φ/∂x_i) dx_i/dt + (∂φ/∂u) du/dt + ∂φ/∂t``
  (the chain rule through modulated moduli, and through declared inputs ``u``
  that fix dependent storage — a mass driven by a prescribed velocity: the
  input's derivative enters as the symbol ``du/dt``, listed in
  :attr:`ConfigurationEquations.input_rates`, whose value the simulator
  supplies);
* **rates** ``dx/dt = f(x, t, u)`` for every state — the two above solved
  together (a linear system in ``dx_d/dt``, solved by its sparse structure);
* **efforts / flows** of every bond as expressions of states, inputs,
  parameters, ``t`` and — where derivative causality makes them so — the
  rates ``dx_d/dt`` (the part that carries Dirac pulses when ``x`` jumps).
  :meth:`ConfigurationEquations.resolve` substitutes the rates for a finite
  value during continuous flow.

Shapes: ``x`` has ``n = len(states)`` entries in every configuration;
``rates`` maps each of the ``n`` states to one expression.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import sympy as sp

from . import budget
from .algebra import solve_explicit
from .errors import AlgebraicLoopError, DerivationError
from .floating import floating_part
from .shape_memo import NotKept, ShapeMemo
from .symbols import rate_symbol, t

__all__ = ["ConfigurationEquations", "derive_equations", "tidy"]


@dataclass(frozen=True)
class ConfigurationEquations:
    """The per-configuration equations (see the module docstring for their form).

    Attributes
    ----------
    configuration : dict  controlled junction → on/off
    states : tuple        the global state vector ``x`` (fixed order)
    independent, dependent : tuple   the split of ``states`` by causality
    rate_symbols : dict   state → symbol standing for its time derivative
    constraints : dict    dependent state → ``φ(x_i, t)``
    implicit_rates : dict independent state → ``F(x_i, t, u, dx_d/dt)``
    rates : dict          every state → ``f(x, t, u)``
    efforts, flows : dict bond name → expression (may contain ``dx_d/dt``)
    port_inputs : dict    open port → the symbol the outside imposes (``e_A`` or
                          ``f_A``), when a graph with ports is derived on its own
    port_outputs : dict   open port → ``(symbol, expression)`` of its other variable
                          (``f_A`` or ``e_A``; may contain ``dx_d/dt``)
    input_rates : dict    declared input (or open port input) ``u`` → the symbol
                          ``du/dt`` standing for its time derivative, for every
                          input that fixes a dependent state (empty otherwise)
    """

    graph_name: str
    configuration: dict
    states: tuple
    independent: tuple
    dependent: tuple
    rate_symbols: dict
    constraints: dict
    implicit_rates: dict
    rates: dict
    efforts: dict
    flows: dict
    causality: object = field(repr=False, compare=False)
    _dependent_rates: dict = field(repr=False, compare=False, default_factory=dict)
    graph: object = field(repr=False, compare=False, default=None)
    substitutions: dict = field(repr=False, compare=False, default_factory=dict)
    port_inputs: dict = field(default_factory=dict)
    port_outputs: dict = field(default_factory=dict)
    input_rates: dict = field(default_factory=dict)

    # ---------------------------------------------------------------- access

    def implicit_rates_of(self, states) -> dict:
        """``{x: F_x}`` of :attr:`implicit_rates` for those of ``states`` that are independent, in the
        order of ``states``."""
        implicit = self.implicit_rates
        return {x: implicit[x] for x in states if x in implicit}

    def substituted(self, values: dict) -> "ConfigurationEquations":
        """A copy with symbols replaced by ``values`` (e.g. mode-dependent
        constants set by an automaton state)."""
        if not values:
            return self
        values = {k: sp.sympify(v) for k, v in values.items()}

        def sub(table):
            return {k: sp.sympify(v).xreplace(values) for k, v in table.items()}

        return replace(
            self,
            constraints=sub(self.constraints),
            implicit_rates=sub(self.implicit_rates),
            rates=sub(self.rates),
            efforts=sub(self.efforts),
            flows=sub(self.flows),
            _dependent_rates=sub(self._dependent_rates),
            port_outputs={p: (v, sp.sympify(e).xreplace(values)) for p, (v, e) in self.port_outputs.items()},
            substitutions={**{k: sp.sympify(v).xreplace(values) for k, v in self.substitutions.items()}, **values},
        )

    def derived_again(self, causality) -> "ConfigurationEquations":
        """The equations of this configuration derived anew from ``causality``
        (e.g. with sources' relations replaced by inputs), with this one's substitutions."""
        return derive_equations(self.graph, self.configuration, causality).substituted(self.substitutions)

    def state_space(self, outputs=None, inputs=None):
        """State-space matrices ``ẋ = A x + B u``, ``y = C x + D u`` of this
        (linear) configuration, as a :class:`bondgraph.state_space.StateSpace`
        (``A, B, C, D = eq.state_space()``; also ``.states``, ``.inputs``, ``.outputs``).

        ``x`` is :attr:`states` in order (dependent states included: their
        rows follow the chain rule through the constraints).  The inputs ``u``
        are, by default, **every source element's value** — an ``Se``'s
        effort, an ``Sf``'s flow out of itself — one input per source named by
        its value when that is a bare parameter or declared input
        (``Se("F", "F0")`` → ``F0``) and by the source's name otherwise
        (constant sources such as gravity included, so nothing is left as an
        offset), followed by the **declared inputs** (``g.input``) still in the
        equations; a source whose value depends on states or bond variables
        is feedback, not an input.  ``inputs=[...]`` (symbols or names) uses
        exactly those symbols instead, sources keeping their values.

        ``outputs``: ``None`` (the states: ``C = I``, ``D = 0``), a list of
        expressions or names (states, inputs, bond variables ``e_<bond>`` /
        ``f_<bond>``), or a dict name → expression.

        Raises :class:`~bondgraph.errors.DerivationError` naming the state
        rate or output and the offending term when one is nonlinear,
        time-varying or a constant offset, or when an input fixes a
        dependent state (its rate would need the input's derivative).
        """
        from .state_space import state_space

        return state_space(self, outputs, inputs)

    @property
    def dependent_rate_symbols(self) -> tuple:
        """The symbols ``dx_d/dt`` that signals may contain (impulse carriers)."""
        return tuple(self.rate_symbols[x] for x in self.dependent)

    def resolve(self, expr: sp.Expr) -> sp.Expr:
        """``expr`` with dependent rates replaced by their finite values and
        dependent states by their constraints: valid during continuous flow."""
        expr = sp.sympify(expr)
        expr = expr.xreplace(self._dependent_rates) if self._dependent_rates else expr
        return expr.xreplace(self.constraints) if self.constraints else expr

    def effort(self, bond: str, resolved: bool = False) -> sp.Expr:
        """Effort of ``bond`` (or of a one-port element's bond, by element name)."""
        expr = self.efforts[self._bond_name(bond, self.efforts)]
        return self.resolve(expr) if resolved else expr

    def flow(self, bond: str, resolved: bool = False) -> sp.Expr:
        """Flow of ``bond`` (or of a one-port element's bond, by element name)."""
        expr = self.flows[self._bond_name(bond, self.flows)]
        return self.resolve(expr) if resolved else expr

    def _bond_name(self, bond, table) -> str:
        from .errors import UnknownNameError

        if bond in table:
            return bond
        raise UnknownNameError(f"no bond {bond!r} in {self.graph_name!r}; bonds are: {', '.join(table)}", bond)

    def rate(self, state) -> sp.Expr:
        """``d(state)/dt = f(x, t, u)``; ``state`` is a symbol or its name."""
        if isinstance(state, str):
            state = sp.Symbol(state)
        return self.rates[state]

    @property
    def f(self) -> sp.Matrix:
        """``dx/dt`` as an ``n × 1`` matrix in the order of :attr:`states`."""
        return sp.Matrix([self.rates[x] for x in self.states])

    @property
    def parameters(self) -> set:
        used = set()
        for expr in (*self.rates.values(), *self.efforts.values(), *self.flows.values()):
            used |= expr.free_symbols
        return used - set(self.states) - set(self.rate_symbols.values()) - set(self.input_rates.values()) - {t}

    # ---------------------------------------------------------------- display

    def as_equalities(self, resolved_signals: bool = False) -> list:
        """The equations as ``sympy.Eq`` objects: rates, constraints, then bond variables."""
        out = [sp.Eq(self.rate_symbols[x], self.rates[x]) for x in self.independent]
        out += [sp.Eq(x, self.constraints[x]) for x in self.dependent]
        out += [sp.Eq(self.rate_symbols[x], self.rates[x]) for x in self.dependent]
        return out

    def _config_text(self, words=None) -> str:
        """`` [junctions: S1 on, D1 off]``: the controlled junctions' states, each by its word in ``words``
        (junction → text, as a mode says it: ``S1 closed, D1 conducting``) where it has one."""
        if not self.configuration:
            return ""
        words = words or {}
        return " [junctions: " + ", ".join(f"{k} {words.get(k) or ('on' if v else 'off')}"
                                           for k, v in self.configuration.items()) + "]"

    def pretty(self, signals: bool = False, words=None) -> str:
        """A multi-line human-readable listing (``signals=True`` adds every bond's effort and flow;
        ``words``: controlled junction → the word its state is written with, ``on``/``off`` without:
        a hybrid model's mode gives its automata's states, ``model.mode_space.junction_words(mode)``)."""
        lines = [f"equations of {self.graph_name!r}{self._config_text(words)}"]
        lines.append("  states: " + ", ".join(str(x) for x in self.states))
        if self.dependent:
            lines.append("  dependent (derivative causality): " + ", ".join(str(x) for x in self.dependent))
        lines.append("  dx/dt:")
        for x in self.states:
            lines.append(f"    {self.rate_symbols[x]} = {self.rates[x]}")
        if self.dependent:
            lines.append("  constraints:")
            for x in self.dependent:
                lines.append(f"    {x} = {self.constraints[x]}")
        if signals:
            lines.append("  bonds (effort, flow):")
            for b in self.efforts:
                lines.append(f"    {b}: e = {self.efforts[b]},  f = {self.flows[b]}")
        return "\n".join(lines)

    __str__ = pretty

    def latex(self) -> str:
        """The equations as a LaTeX ``aligned`` block (hierarchical names
        ``rod/theta`` print as an upright prefix before the leaf's symbol)."""
        symbols = set(self.states)
        for expr in (*self.rates.values(), *self.constraints.values()):
            symbols |= expr.free_symbols
        names = latex_names(symbols)

        def tex(expr):
            return sp.latex(expr, symbol_names=names)

        rows = []
        for x in self.states:
            rows.append(rf"\frac{{d}}{{dt}} {tex(x)} &= {tex(self.rates[x])}")
        for x in self.dependent:
            rows.append(rf"{tex(x)} &= {tex(self.constraints[x])}")
        return r"\begin{aligned}" + r" \\ ".join(rows) + r"\end{aligned}"

    def _repr_latex_(self) -> str:
        return f"$${self.latex()}$$"


def latex_names(symbols) -> dict:
    """LaTeX for hierarchical symbol names: ``rod/theta`` → ``{\\mathrm{rod/}\\theta}``."""
    names = {}
    for s in symbols:
        if isinstance(s, sp.Symbol) and "/" in s.name:
            prefix, leaf = s.name.rsplit("/", 1)
            names[s] = rf"{{\mathrm{{{prefix}/}}{sp.latex(sp.Symbol(leaf))}}}"
    return names


#: Expressions produced by eliminating dependent rates are simplified when
#: they have at most this many operations (larger ones are left as they are:
#: ``simplify`` costs grow fast and the numbers are the same).
SIMPLIFY_MAX_OPS = 400


def tidy(expr: sp.Expr) -> sp.Expr:
    """A readable form of a derived expression: a rational function of its
    symbols (a collision of point masses) as one cancelled fraction, which
    ``cancel`` finds at a fraction of ``simplify``'s cost; anything else
    (trigonometry of a rotating body) simplified, when small enough.

    (``cancel`` with ``sin² = 1 − cos²`` and the common factors taken out
    would halve the falling rod's derivation too, but it changes the
    rounding of the rod's rates enough to turn one grazing contact of the
    full grid of ``tests/models/test_model_ranges.py`` into a divergence of time.)

    Each runs in the budget of :mod:`bondgraph.budget`; past it the
    expression is kept as it stands.  An expression of a shape tidied before
    (the same but for its symbols, renamed in order: the contacts of a
    scene) takes that result, renamed (:mod:`bondgraph.shape_memo`)."""
    if sp.count_ops(expr) > SIMPLIFY_MAX_OPS:
        return expr
    return _TIDIED(_tidied, expr)


def _tidied(expr: sp.Expr) -> sp.Expr:
    """``tidy``'s step: ``expr`` as it stands when the budget runs out (not kept for its shape: the next
    expression of the shape tries again)."""
    if expr.is_rational_function():
        how, step = sp.cancel, "cancelling a derived expression"
    else:
        how, step = sp.simplify, "simplifying a derived expression"
    try:
        return budget.run(step, how, expr)
    except budget.OverBudget:
        raise NotKept(expr) from None


_TIDIED = ShapeMemo()


def derive_equations(graph, config: dict, causality) -> ConfigurationEquations:
    """Derive :class:`ConfigurationEquations` for one configuration."""
    rel = causality.relations
    owner = {v: r.element for v, r in rel.relations.items()}

    try:
        bond_values = solve_explicit(
            {v: r.expr for v, r in rel.relations.items()}, owner=lambda v: owner[v], what="algebraic loop"
        )
    except AlgebraicLoopError as error:
        # a singular loop left by a floating part (a causality was found, but it leaves some efforts or a
        # loop flow free: bondgraph.floating) is reported as that part, not as the loop
        floating = floating_part(graph, dict(config), causality.dead)
        if floating is None:
            raise
        raise floating from error

    def bonds_in(expr):
        subs = {s: bond_values[s] for s in expr.free_symbols if s in bond_values}
        return expr.xreplace(subs) if subs else expr

    dependent_rates = {rel.rate_symbols[x] for x in causality.dependent}
    inputs = set(graph.inputs.values())
    dependent_set = set(causality.dependent)
    storage_of = {el.state: el.name for el in graph.storage}

    constraints = {}
    for x in causality.dependent:
        phi = bonds_in(rel.constraints[x])
        if phi.free_symbols & dependent_rates:
            raise DerivationError(
                f"dependent state {x} of {storage_of[x]!r} would depend on the rates of other dependent states "
                f"({phi}); the configuration {config} has a higher-index constraint. Add a small compliance or mass.",
                [storage_of[x]],
            )
        constraints[x] = phi
    input_rates = {u: rate_symbol(u) for u in sorted(set().union(*(phi.free_symbols for phi in constraints.values()))
                                                       & inputs, key=lambda s: s.name)}

    implicit = {x: bonds_in(rel.rates[x]) for x in causality.independent}

    # dx_d/dt = Σ_j ∂φ/∂x_j · dx_j/dt + ∂φ/∂t, with dx_j/dt from the implicit rates
    rate_equations = {}
    for x in causality.dependent:
        phi = constraints[x]
        total = sp.diff(phi, t)
        for s in phi.free_symbols:
            if s in implicit:
                total += sp.diff(phi, s) * implicit[s]
            elif s in dependent_set:
                total += sp.diff(phi, s) * rel.rate_symbols[s]
            elif s in input_rates:
                total += sp.diff(phi, s) * input_rates[s]
        rate_equations[rel.rate_symbols[x]] = total
    rate_values = solve_explicit(
        rate_equations,
        owner=lambda v: storage_of.get(next(x for x in causality.dependent if rel.rate_symbols[x] == v), str(v)),
        what="coupling of dependent storage rates",
    )

    def finite(expr):
        subs = {s: rate_values[s] for s in expr.free_symbols if s in rate_values}
        expr = expr.xreplace(subs) if subs else expr
        expr = expr.xreplace(constraints) if constraints else expr
        return tidy(expr) if subs else expr

    rates = {}
    for x in graph.states:
        if x in implicit:
            rates[x] = finite(implicit[x])
        else:
            rates[x] = finite(rel.rate_symbols[x])

    efforts, flows = {}, {}
    for name, bond in graph.bonds.items():
        # an open port's input has no relation: it stands for itself
        efforts[name] = bond_values.get(bond.effort, bond.effort)
        flows[name] = bond_values.get(bond.flow, bond.flow)

    port_inputs, port_outputs = {}, {}
    for port, (outside, bond_name) in getattr(graph, "open_ports", {}).items():
        bond = graph.bonds[bond_name]
        if causality.effort_by.get(bond_name) == outside:
            port_inputs[port], port_outputs[port] = bond.effort, (bond.flow, flows[bond_name])
        else:
            port_inputs[port], port_outputs[port] = bond.flow, (bond.effort, efforts[bond_name])

    return ConfigurationEquations(
        graph_name=graph.name,
        configuration=dict(config),
        states=tuple(graph.states),
        independent=tuple(causality.independent),
        dependent=tuple(causality.dependent),
        rate_symbols=dict(rel.rate_symbols),
        constraints=constraints,
        implicit_rates=implicit,
        rates=rates,
        efforts=efforts,
        flows=flows,
        causality=causality,
        _dependent_rates=rate_values,
        graph=graph,
        port_inputs=port_inputs,
        port_outputs=port_outputs,
        input_rates=input_rates,
    )
