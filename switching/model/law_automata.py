"""Law switches as local automata: crossings located as events, and sliding modes.

Every discontinuity of an element law (:mod:`bondgraph.law_switches`) with
surface ``s`` and branch symbol ``σ`` becomes a local automaton named after
the switch (``fr_law`` for the friction law of element ``fr``) with three
states that set ``σ``:

==========  =========================  ===================================
state       ``σ``                      leaves, a priori, to
==========  =========================  ===================================
positive    ``+1``                     sliding when ``s ≤ 0`` and ``ṡ < 0``
negative    ``−1``                     sliding when ``s ≥ 0`` and ``ṡ > 0``
sliding     ``σ*`` (below)             positive when ``ṡ₊ > 0``;
                                       negative when ``ṡ₋ < 0``
==========  =========================  ===================================

``ṡ = Σₖ ∂s/∂xₖ·fₖ(x) + ∂s/∂t`` is the rate of ``s`` along the current
mode's flow (:class:`Rate`), ``ṡ₊``/``ṡ₋`` along the flow of the same
configuration with ``σ = +1``/``−1`` (:class:`RateWith`).  Between crossings
the flow therefore sees a smooth right-hand side (the branch is fixed), and a
crossing is an event located like any other.  At a crossing the instant
passes through ``sliding`` (a mythical mode) to the other side when the flow
there leaves the surface too (``ṡ₋ < 0`` coming from ``positive``); when
both sides' flows point into the surface the run *slides* on it (Filippov).

**Sliding dynamics.**  In ``sliding``, ``σ`` takes the value ``σ*(x)`` that
keeps the state on the surface: ``ṡ(x, σ*) = 0``.  With ``ṡ = a(x) + b(x)σ``
affine in ``σ`` (every law that is linear in ``sign``, ``Heaviside`` or a
``Piecewise`` selection), ``σ* = −a/b``, and the flow ``f(x, σ*)`` is exactly
Filippov's convex combination ``α f₊ + (1 − α) f₋`` with
``α = ṡ₋ / (ṡ₋ − ṡ₊)``, ``σ* = 2α − 1``; the laws' outputs (a friction
force) take their equivalent value ``φ(σ*)`` — the static friction force,
bounded by ``μN`` while the block sticks.  Several surfaces sliding at once
solve ``ṡⱼ(x, σ*) = 0`` together (a linear system).  A surface that ``σ``
does not reach (``b ≡ 0``: a sign of a position in a force law) has
``σ* = 0``: its ``sliding`` state is always left at once, except at an
equilibrium on the surface.

**Initial branch.**  A run starts in ``positive`` where ``s > 0``,
``negative`` where ``s < 0`` and ``sliding`` where ``s = 0``
(:func:`branches_at`); the instant at the start then moves it on.

**Words.**  ``positive``, ``negative`` and ``sliding`` are the names of a
law whose meaning is not known (a relay, a bang-bang source).  A dry
friction law (:attr:`bondgraph.law_switches.LawSwitch.friction`: a clutch
with ``T_max``, a damper with a Coulomb law, ``e = μN·sign(f)`` in any R)
names them as engineers say them (:data:`FRICTION`): ``stuck`` is the
sliding (Filippov) state — the surface is the slip speed, held at 0 —, and
``slipping_pos``/``slipping_neg`` slip with the element's own flow positive
or negative (identifiers, as every state name: ``+`` is no name).  The
state names are the automaton's own: modes, run summaries, files and cache
keys show them; the generic names stay readable as input
(:attr:`switching.model.automaton.Automaton.aliases`: ``--mode
clutch_law=sliding`` is ``clutch_law=stuck``).  :func:`law_words` gives a
switch's names.
"""

from __future__ import annotations

from dataclasses import astuple, dataclass

import numpy as np
import sympy as sp

from bondgraph.errors import DerivationError

from .automaton import Automaton

__all__ = ["Rate", "RateWith", "law_automaton", "POSITIVE", "NEGATIVE", "SLIDING", "sliding_values",
           "expand_rates", "branches_at", "LawWords", "GENERIC", "FRICTION", "law_words"]

POSITIVE, NEGATIVE, SLIDING = "positive", "negative", "sliding"


@dataclass(frozen=True)
class LawWords:
    """The names of a law automaton's states: ``positive`` (``σ = +1``, ``s > 0``),
    ``negative`` (``σ = −1``) and ``sliding`` (on the surface, ``σ = σ*``)."""

    positive: str
    negative: str
    sliding: str

    def aliases(self) -> dict:
        """The generic names of the states these words rename (generic name → word)."""
        return {old: new for old, new in zip(astuple(GENERIC), astuple(self)) if old != new}


#: a law whose meaning is not known: the branches by the sign of the surface
GENERIC = LawWords(POSITIVE, NEGATIVE, SLIDING)
#: dry friction whose surface is the element's own flow (the slip speed)
FRICTION = LawWords("slipping_pos", "slipping_neg", "stuck")


def law_words(switch) -> LawWords:
    """The names of the states of ``switch``'s automaton: :data:`FRICTION` for a dry friction law
    (its positive branch ``slipping_neg`` when the surface is minus the slip speed), else :data:`GENERIC`."""
    if switch.friction > 0:
        return FRICTION
    if switch.friction < 0:
        return LawWords(FRICTION.negative, FRICTION.positive, FRICTION.sliding)
    return GENERIC


class Rate(sp.Function):
    """``Rate(s)``: the time derivative of ``s`` along the flow of the mode
    in which it is evaluated (expanded by :func:`expand_rates`)."""

    nargs = 1


class RateWith(sp.Function):
    """``RateWith(s, σ, v)``: the time derivative of ``s`` along the flow of
    the mode's configuration with the branch symbol ``σ`` set to ``v``."""

    nargs = 3


def law_automaton(switch) -> Automaton:
    """The local automaton of a :class:`bondgraph.law_switches.LawSwitch`
    (module docstring), its states named by :func:`law_words` (the generic
    names read as aliases); its initial state is set per run from the state."""
    sigma, s = switch.sigma.name, switch.surface
    w = law_words(switch)
    automaton = Automaton(
        switch.name,
        {w.positive: {}, w.negative: {}, w.sliding: {}},
        w.positive,
        values={w.positive: {sigma: 1}, w.negative: {sigma: -1}, w.sliding: {sigma: 0}},
        aliases=w.aliases(),
    )
    automaton.add_transition(w.positive, w.sliding, sp.And(sp.Le(s, 0), sp.Lt(Rate(s), 0)))
    automaton.add_transition(w.negative, w.sliding, sp.And(sp.Ge(s, 0), sp.Gt(Rate(s), 0)))
    automaton.add_transition(w.sliding, w.positive, sp.Gt(RateWith(s, switch.sigma, 1), 0))
    automaton.add_transition(w.sliding, w.negative, sp.Lt(RateWith(s, switch.sigma, -1), 0))
    return automaton


def _rate(raw_s: sp.Expr, states, rates: dict, time) -> sp.Expr:
    """``Σ ∂s/∂x·f + ∂s/∂t`` of a raw signal ``s`` (no ``ẋ`` allowed in it)."""
    total = sp.diff(raw_s, time)
    for x in states:
        d = sp.diff(raw_s, x)
        if d != 0:
            total += d * rates[x]
    return total


def expand_rates(expr: sp.Basic, me, raw) -> sp.Basic:
    """``expr`` with every :class:`Rate` and :class:`RateWith` replaced by
    its expression in mode ``me`` (``raw``: signal expression → raw form)."""
    if not expr.has(Rate, RateWith):
        return expr

    def rate(s, sigma=None, value=None):
        raw_s = raw(s)
        if set(me.equations.rate_symbols.values()) & raw_s.free_symbols:
            raise DerivationError(
                f"the surface {s} of a law switch depends on a state derivative in mode {me.mode.describe()}; "
                "its rate cannot be formed: write the law in terms of states and bond variables that do not, "
                "or model the switch with an automaton"
            )
        if sigma is None:
            rates = me.f
        else:
            rates = {x: r.xreplace({sigma: value}) for x, r in me.free_rates.items()}
        return _rate(raw_s, me.states, rates, me.model.time)

    expr = expr.replace(RateWith, lambda s, sigma, value: rate(s, sigma, value))
    return expr.replace(Rate, lambda s: rate(s))


def sliding_values(me, sliding: list, raw) -> dict:
    """``{σⱼ: σⱼ*(x)}`` of the law switches ``sliding`` (sliding in mode
    ``me``), solving ``ṡⱼ(x, σ*) = 0`` with the rates ``me.free_rates`` in
    which their ``σ`` are still free."""
    sigmas = [sw.sigma for sw in sliding]
    rows = []
    for sw in sliding:
        raw_s = raw(sw.surface)
        rows.append(sp.expand(_rate(raw_s, me.states, me.free_rates, me.model.time)))
    for sw, row in zip(sliding, rows):
        for sigma in sigmas:
            if sp.diff(row, sigma, 2) != 0:
                raise DerivationError(
                    f"law switch {sw.name!r} ({sw.written} in the law of {sw.element!r}) enters the rate of its "
                    f"surface {sw.surface} nonlinearly in mode {me.mode.describe()}; a sliding motion needs it "
                    "affine in sign/Heaviside (as Coulomb friction, relays and bang-bang sources are): "
                    "rewrite the law, or model the switch with an automaton"
                )
    active = [k for k, row in enumerate(rows) if any(sp.diff(row, sigmas[j]) != 0 for j in range(len(sigmas)))]
    values = {sigmas[k]: sp.S.Zero for k in range(len(sigmas)) if k not in active}
    if active:
        unknowns = [sigmas[k] for k in active]
        system = [rows[k].xreplace(values) for k in active]
        A, b = sp.linear_eq_to_matrix(system, unknowns)
        if A.shape[0] == 1:
            solution = [b[0] / A[0, 0]]
        else:
            try:
                solution = list(A.LUsolve(b))
            except (ValueError, ZeroDivisionError, sp.matrices.common.NonInvertibleMatrixError) as exc:
                names = ", ".join(sliding[k].name for k in active)
                raise DerivationError(
                    f"the law switches {names} slide together in mode {me.mode.describe()}, but their surfaces "
                    f"do not fix their branches ({exc}); model these switches with automata"
                ) from None
        values.update({sigma: value for sigma, value in zip(unknowns, solution)})
    return values


def branches_at(model, mode, x: np.ndarray, t: float):
    """``mode`` with each law automaton set by the sign of its surface at
    ``(x, t)``: positive, negative, or sliding where ``s = 0`` (in the
    switch's words, :func:`law_words`)."""
    if not model.law_switches:
        return mode
    me = model.mode_equations(mode)
    values = {**model.parameter_values_with_inputs(t), model.time: t}
    values.update({s: float(v) for s, v in zip(model.states, x)})
    states = dict(zip(mode.automata, mode.states))
    for switch in model.law_switches.values():
        surface = me.finite(me.to_raw(switch.surface)).xreplace(values)
        try:
            s = float(surface)
        except TypeError:
            raise DerivationError(
                f"the surface {switch.surface} of law switch {switch.name!r} is not a number at t = {t} "
                f"({surface}); it may use only states, bond variables, inputs, parameters and t"
            ) from None
        w = law_words(switch)
        states[switch.name] = w.positive if s > 0 else w.negative if s < 0 else w.sliding
    return model.mode(states)



def starting_mode(model, base, named: set, x, t: float):
    """``base`` with every law switch not in ``named`` set by the sign of its
    surface at ``(x, t)`` (a law discontinuity is decided by the state, not
    chosen); the switches in ``named`` keep their state in ``base``."""
    if not model.law_switches or named >= set(model.law_switches):
        return base
    decided = branches_at(model, base, np.asarray(x, dtype=float), float(t))
    keep = dict(zip(decided.automata, decided.states))
    keep.update({name: base.state_of(name) for name in named if name in model.law_switches})
    return model.mode(keep)
