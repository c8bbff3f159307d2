"""Modes and their equations.

A :class:`Mode` is the tuple of the current states of all local automata; it
fixes the configuration of every controlled junction.  Its
:class:`ModeEquations` bundle (derived lazily, once, on first request):

* **f** — ``dx/dt = f(x, t)`` of the configuration (every state, dependent
  ones by the chain rule);
* **g** — the jump map into the mode, from conservation of state; with a
  restitution coefficient ``e`` carried by one of the mode's automaton states,
  ``x⁺ = x + (1 + e)(g(x) − x)``;
* **h** — named signals, each as a *raw* expression of the states, ``t``,
  parameters and state derivatives ``ẋ`` (:meth:`ModeEquations.signal`): its
  finite part substitutes ``ẋ = f(x)``; its impulse at a jump ``x → x⁺`` is
  ``a(x)ᵀ (x⁺ − x)`` with ``a = ∂s/∂ẋ``;
* **guards** — the transitions leaving the mode's automaton states, with their
  conditions in terms of raw signals.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from itertools import accumulate, chain, compress
from operator import attrgetter, ne, not_, or_

import numpy as np
import sympy as sp

from bondgraph.elements import C, I
from bondgraph.errors import (AlgebraicLoopError, CausalityConflictError, FloatingPartError, HybridBondGraphError,
                              prefixed)
from bondgraph import budget
from bondgraph.regularize import floating_limit

from .law_automata import expand_rates, law_words, sliding_values

__all__ = ["Mode", "ModeEquations", "SignalForm", "GuardForm"]


@dataclass(frozen=True)
class Mode:
    """The states of all automata, in the model's automaton order."""

    states: tuple
    automata: tuple = field(compare=False, hash=False)

    def __hash__(self) -> int:
        # the states' hash, kept: a mode is a key of many maps, and a scene's mode holds a thousand states
        found = self.__dict__.get("_hash")
        if found is None:
            found = hash(self.states)
            object.__setattr__(self, "_hash", found)
        return found

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state.pop("_hash", None)  # (strings hash differently in another process)
        return state

    @property
    def label(self) -> str:
        """The compact key of the mode in code (cache keys, tables of
        exported modules): its automata's states joined by ``|``, ``"free|stuck"``."""
        return "|".join(self.states)

    def describe(self) -> str:
        """The mode as every output shows it (run summaries, CSV and NPZ files,
        plots, errors) and every input accepts (``--mode``, :meth:`HybridModel.mode`):
        ``automaton=state`` for each automaton, ``", "`` between them —
        ``"contact=free, friction=stuck"``."""
        return ", ".join(f"{a}={s}" for a, s in zip(self.automata, self.states))

    def state_of(self, automaton: str) -> str:
        return self.states[self.automata.index(automaton)]

    def __str__(self) -> str:
        return self.label


@dataclass(frozen=True)
class SignalForm:
    """A signal in one mode: ``raw`` (may contain ``ẋ`` symbols), ``finite``
    (``ẋ = f(x)`` substituted) and ``impulse`` coefficients ``a_k = ∂raw/∂ẋ_k``
    (state → expression; only non-zero ones are kept)."""

    name: str
    raw: sp.Expr
    finite: sp.Expr
    impulse: dict

    @property
    def can_pulse(self) -> bool:
        return bool(self.impulse)


@dataclass(frozen=True)
class GuardForm:
    """A transition leaving the mode, with its condition in raw signals."""

    automaton: str
    transition: object
    condition: sp.Basic
    text: str


def _storage_values(graph, mode_values: dict) -> dict:
    """Bond symbol → the co-energy of the storage element on it, from its own state (an I's signed
    flow, a C's effort), with the values a mode's automaton states set substituted: kept with the
    graph's derivations for each set of values (every mode of a scene of many contacts asks for the
    same thousand expressions)."""

    def derive():
        values = {}
        for el in graph.storage:
            (bond,) = graph.bonds_of(el.name)
            s = bond.sign_at(el.name)
            if isinstance(el, I):
                values[bond.flow] = s * el.output(el.state).xreplace(mode_values)
            elif isinstance(el, C):
                values[bond.effort] = el.output(el.state).xreplace(mode_values)
        return values

    # (the values by their full form: 1, 1.0 and Integer(1) are equal keys but different substitutions)
    key = tuple((symbol, sp.srepr(value)) for symbol, value in mode_values.items())
    return graph.derived.memo(("storage co-energies", key), derive)


class ModeEquations:
    """Everything derived for one mode (see the module docstring).

    Attributes: ``mode``, ``configuration``, ``equations``
    (:class:`bondgraph.ConfigurationEquations`), ``jump``
    (:class:`bondgraph.JumpMap`), ``restitution`` (expression or ``None``),
    ``guards`` (list of :class:`GuardForm`).
    """

    def __init__(self, model, mode: Mode):
        self.model = model
        self.mode = mode
        self.configuration = model.configuration_of(mode)
        graph = model.derivation_graph
        self.values = model.mode_values(mode)
        # a hybrid model is closed: declared ports are for composing it, not inputs of its modes
        try:
            equations = graph.equations(self.configuration, open_ports=False)
            jump = graph.jump_map(self.configuration, model.jump_law)
        except FloatingPartError as error:  # under-determined: the limit of vanishing leaks (DESIGN.md §6b)
            try:
                equations, jump = budget.run(f"the limit of vanishing leaks of mode {mode.describe()}",
                                             floating_limit, graph, self.configuration, model.jump_law)
            except (HybridBondGraphError, ValueError, sp.PolynomialError) as why:  # no limit, or none in the budget
                reason = str(why).splitlines()[0] if str(why) else type(why).__name__
                raise prefixed(error, f"mode {mode.describe()}: ",
                               f" (The limit of vanishing leaks gives this mode no equations: {reason}.)") from None
        except (CausalityConflictError, AlgebraicLoopError) as error:  # name the mode, which the user wrote
            # a model built from a netlist says a conflict in its words too (models.circuits: a loop of sources)
            in_words = getattr(model, "conflict_words", None)
            words = in_words(self.configuration) if in_words and isinstance(error, CausalityConflictError) else ""
            raise prefixed(error, f"mode {mode.describe()}: ", words) from None
        self.jump = jump.substituted(self.values)
        self.restitution = model.restitution_of(mode)
        sliding = [sw for sw in model.law_switches.values() if mode.state_of(sw.name) == law_words(sw).sliding]
        if sliding:  # σ of each sliding law switch from ṡ = 0 (switching.model.law_automata)
            free = {sw.sigma for sw in sliding}
            self.equations = equations.substituted({k: v for k, v in self.values.items() if k not in free})
            self.states = self.equations.states
            self._bond_values = self._raw_bond_values(graph)
            self.free_rates = self.equations.rates
            self.values.update(sliding_values(self, sliding, self.to_raw))
        else:
            self.free_rates = None
        self.equations = equations.substituted(self.values)
        self.states = self.equations.states
        self.__dict__.pop("_bond_values", None)  # (made again from these equations when first needed)
        #: ``dx/dt`` with the branches of sliding law switches still free (``f`` in other modes)
        self.free_rates = self.free_rates or self.equations.rates
        self.guards = self._guard_forms()
        self._signals: dict[str, SignalForm] = {}
        self._numeric_f = None

    # ------------------------------------------------------------ symbolic

    def _guard_forms(self) -> list:
        """A :class:`GuardForm` of every transition leaving the mode.  The forms of an automaton state
        whose conditions read no bond, rate or signal taken in another mode are the same in every mode
        whose automaton states set none of their symbols: kept by the library and shared (a scene's
        modes hold a thousand contacts' guards).  A mode that sets no constants starts from the groups of
        forms of the mode made before it (``library.last_guard_groups``) and makes again only those of
        the automata in another state, or whose forms were its own."""
        space, library, values = self.model.mode_space, self.model.library, self.values
        states = self.mode.states
        transitions = sum(map(len, map(attrgetter("transitions"), space.automata)))  # (they may be added to)
        last = None if values else library.last_guard_groups
        if last is not None and last[0] is space and last[1] == transitions and len(last[2]) == len(states):
            groups, shared = list(last[3]), list(last[4])
            again = compress(range(len(states)), map(or_, map(ne, last[2], states), map(not_, shared)))
        else:
            groups, shared, again = [None] * len(states), [False] * len(states), range(len(states))
        for k in again:
            groups[k], shared[k] = self._automaton_forms(space, space.automata[k], states[k])
        if not values:
            library.last_guard_groups = (space, transitions, states, groups, shared)
        #: where each automaton's forms begin in :attr:`guards` (and the end): the generated module takes
        #: them a block of automata at a time
        self.guard_starts = list(accumulate(map(len, groups), initial=0))
        return list(chain.from_iterable(groups))

    def _automaton_forms(self, space, automaton, state: str) -> tuple:
        """``(forms, shared)``: the guard forms of the transitions leaving ``state`` of ``automaton`` in this
        mode, and whether they are the library's, the same in every mode that sets no constants."""
        kept, values = self.model.library.guard_forms, self.values
        key, entries = space.leaving(automaton, state)
        found = kept.get(key)
        if found is not None and found[0] is entries and (not values or values.keys().isdisjoint(found[2])):
            return found[1], True
        group = [GuardForm(auto, tr, self.to_raw(cond), text) for auto, tr, cond, text in entries]
        if all(self._as_written(cond) for _, _, cond, _ in entries):
            free = frozenset().union(*(self.model.library.symbols_of(cond)[0] for _, _, cond, _ in entries))
            if not values or values.keys().isdisjoint(free):  # (as written here too: the forms of every such mode)
                kept[key] = (entries, group, free)  # (the entries held: the same list while they are kept)
                return group, True
        return group, False

    def _as_written(self, expr) -> bool:
        """Does :meth:`to_raw` leave ``expr`` as it is in every mode whose automaton states set none of its
        symbols (it reads no bond, no law switch's rate, no signal taken in another mode)?"""
        free, has_rates = self.model.library.symbols_of(expr)
        return not (has_rates or self.model.cross_signals) and self._bond_symbols().isdisjoint(free)

    @functools.cached_property
    def _bond_values(self) -> dict:
        """Bond symbol → raw expression in this mode (:meth:`_raw_bond_values`), made when an expression
        first reads a bond: a scene's guards read states and parameters only, and its modes have
        thousands of bonds."""
        return self._raw_bond_values(self.model.derivation_graph)

    def _bond_symbols(self) -> frozenset:
        """The keys of :attr:`_bond_values` (every bond's effort and flow: the same in every mode), kept
        with the graph's derivations."""
        graph = self.model.derivation_graph
        return graph.derived.memo("bond symbols", lambda: frozenset(
            symbol for bond in graph.bonds.values() for symbol in (bond.effort, bond.flow)))

    def _raw_bond_values(self, graph) -> dict:
        """Bond symbol → raw expression in this mode.  A storage element's own
        co-energy (I: flow, C: effort) is taken from its own state, so signals
        evaluated a priori on a state off this mode's constraints see the
        physical value (e.g. the velocity of each mass)."""
        eq = self.equations
        values = {}
        efforts, flows = eq.efforts, eq.flows
        for name, bond in graph.bonds.items():
            values[bond.effort] = efforts[name]
            values[bond.flow] = flows[name]
        values.update(_storage_values(graph, self.values))
        return values

    def to_raw(self, expr: sp.Basic) -> sp.Basic:
        """Replace bond variables in ``expr`` by this mode's raw expressions
        (and signals taken in another mode by their expressions of ``x``)."""
        free, has_rates = self.model.library.symbols_of(expr)
        values, taken = self.values, self.model.cross_signals
        if not (has_rates or taken or not self._bond_symbols().isdisjoint(free) or not values.keys().isdisjoint(free)):
            return expr  # (a guard on states and parameters: every contact of a ball chain)
        if taken:
            cross = {s: self.model.library.cross_signal(self.mode, s.name, self) for s in free
                     if s.name in taken and isinstance(s, sp.Symbol)}
            if cross:
                expr = expr.xreplace(cross)
                free = expr.free_symbols
        subs = {s: self._bond_values[s] for s in free if s in self._bond_values}
        if subs:
            expr = expr.xreplace(subs)
        expr = expand_rates(expr, self, self.to_raw)  # branch symbols still free in the rates it forms
        if not self.values:
            return expr
        values = {s: self.values[s] for s in expr.free_symbols if s in self.values}
        return expr.xreplace(values) if values else expr

    @property
    def f(self) -> dict:
        """``dx/dt`` for every state (the configuration's rates)."""
        return self.equations.rates

    @property
    def g(self) -> dict | None:
        """``x⁺`` for every state as expressions of ``x``, restitution
        included; ``None`` when the storage is nonlinear (numerical jump)."""
        base = self.jump.expressions
        if base is None:
            return None
        if self.restitution is None:
            return dict(base)
        e = self.restitution
        out = dict(base)  # (the states that stay are not looked up one by one: a scene has thousands)
        for x, value in base.items():
            if value is not x:
                out[x] = x + (1 + e) * (value - x)
        return out

    def finite(self, raw: sp.Expr) -> sp.Expr:
        """``raw`` with every ``ẋ`` replaced by ``f(x)``."""
        free = self.model.library.symbols_of(raw)[0]
        if self.model.library.rate_symbol_set(self.equations).isdisjoint(free):
            return raw  # (no rate read: the guard comparisons of a scene, on states and parameters)
        rates = self._rates_by_symbol
        subs = {s: rates[s] for s in free if s in rates}
        return raw.xreplace(subs) if subs else raw

    @functools.cached_property
    def _rates_by_symbol(self) -> dict:
        """``ẋ`` symbol → ``f(x)``, built once per mode."""
        return {self.equations.rate_symbols[x]: self.f[x] for x in self.states}

    def signal(self, name: str) -> SignalForm:
        """The form of a named signal in this mode (derived on first request)."""
        if name not in self._signals:
            raw = self.to_raw(self.model.signal_expression(name))
            impulse = {}
            for x in self.states:
                rate = self.equations.rate_symbols[x]
                if raw.has(rate):
                    impulse[x] = sp.diff(raw, rate)
            self._signals[name] = SignalForm(name, raw, self.finite(raw), impulse)
        return self._signals[name]

    def state_space(self, outputs=None, inputs=None):
        """``A, B, C, D`` of this mode (with its constants substituted), as
        :meth:`bondgraph.ConfigurationEquations.state_space`; outputs may also
        name the model's signals."""
        if outputs is not None and not isinstance(outputs, dict):
            outputs = [outputs] if isinstance(outputs, (str, sp.Basic)) else outputs
            outputs = {str(o): self.model.signal_expression(o) if isinstance(o, str) else o for o in outputs}
        elif isinstance(outputs, dict):
            outputs = {k: self.model.signal_expression(v) if isinstance(v, str) else v for k, v in outputs.items()}
        return self.equations.state_space(outputs, inputs)

    @property
    def h(self) -> dict:
        """Every named signal of the model in this mode."""
        return {name: self.signal(name) for name in self.model.signal_names}

    # ------------------------------------------------------------ numerical

    def rates(self, x: np.ndarray, t: float) -> np.ndarray:
        """Numerical ``f(x, t)``."""
        if self._numeric_f is None:
            from codegen import vector_function

            model = self.model
            self._numeric_f = vector_function(
                [self.f[s] for s in self.states], self.states, model.time, model.parameter_symbols, model.input_symbols
            )
        return self._numeric_f(x, t, self.model.parameter_array, self.model.input_values(t))

    def apply_jump(self, x: np.ndarray, t: float) -> np.ndarray:
        """Numerical ``x⁺ = g(x)`` into this mode, restitution included (the
        symbolic-free path for nonlinear storage; generated code does the rest)."""
        x = np.asarray(x, dtype=float)
        if self.jump.is_identity:
            return x.copy()
        values = self.model.parameter_values_with_inputs(t)
        plus = self.jump.apply(x, t, values)
        if self.restitution is not None:
            e = float(self.restitution.xreplace(values)) if self.restitution.free_symbols else float(self.restitution)
            plus = x + (1.0 + e) * (plus - x)
        return plus

    numeric_jump = apply_jump

    def __repr__(self) -> str:
        return f"ModeEquations({self.mode.describe()})"

    def pretty(self) -> str:
        """A text listing of f, g (when symbolic), the guards and the constraints."""
        words = self.model.mode_space.junction_words(self.mode)  # the junctions as the mode says them
        lines = [f"mode {self.mode.describe()}", self.equations.pretty(words=words)]
        g = self.g
        if self.jump.is_identity:
            lines.append("  g: identity (no dependent storage)")
        elif g is None:
            lines.append("  g: numerical (nonlinear storage)")
        else:
            lines.append("  g (x⁺ =):" + (f"  [restitution e = {self.restitution}]" if self.restitution is not None else ""))
            for x in self.states:
                if g[x] != x:
                    lines.append(f"    {x}⁺ = {g[x]}")
        if self.guards:
            lines.append("  guards:")
            for guard in self.guards:
                tr = guard.transition
                lines.append(f"    {guard.automaton}: {tr.source} → {tr.target} when {guard.text} ({tr.when})")
        return "\n".join(lines)

    __str__ = pretty
