"""Discontinuous element laws as switching surfaces (law switches).

Users write Coulomb friction, relays and bang-bang sources straight into
element laws: ``e = μN·sign(f)``, ``e = 2·Heaviside(1 − q)``, a
``Piecewise`` with a jump.  Integrated as they stand, such a right-hand side
jumps inside a step: fixed-step methods see a false stiffness and adaptive
ones chatter through millions of steps.  This module finds those
discontinuities and rewrites each law in terms of a *branch* symbol ``σ``:

=================================  =====================================
written in the law                 rewritten (surface ``s``)
=================================  =====================================
``sign(a)``                        ``σ`` (``s = a``)
``Heaviside(a)``                   ``(1 + σ)/2`` (``s = a``)
``Piecewise((u, c), (v, True))``   ``u·(1 + σ)/2 + v·(1 − σ)/2``
                                   (``c`` a comparison; ``s > 0 ⇔ c``)
=================================  =====================================

with more ``Piecewise`` pieces nested the same way.  ``σ = +1`` where
``s > 0`` and ``−1`` where ``s < 0``: between crossings of ``s = 0`` the
law is smooth.  On the surface itself ``σ`` may take any value in
``[−1, 1]`` (Filippov's convex hull), which is what a sliding motion (a
block held by friction) needs.  :mod:`switching.model.law_automata` turns every
:class:`LawSwitch` into a local automaton (``positive``, ``negative``,
``sliding``; a friction law's ``slipping_pos``, ``slipping_neg``, ``stuck``)
whose states set ``σ``.

Only discontinuities are rewritten.  A law that stays continuous across the
surface (``sqrt(abs(e))·sign(e)`` of an orifice, a saturation written with
``Min``/``Max``, ``Abs``) is left as written: integrators step over a kink,
and locating every crossing of a non-Lipschitz law's equilibrium (the
orifice's ``e = 0``, reached in finite time) would only add instants.

The surface ``s`` of a switch is an expression of the graph's bond
variables, states, inputs, parameters and ``t`` (an R element's own flow
``f`` becomes its bond's flow with the sign of the bond's direction), so
that it can be evaluated in every configuration like any signal.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import sympy as sp
from sympy.core.relational import Relational

from .elements import LAW_EFFORT, LAW_FLOW, R, copy_with
from .errors import DerivationError
from .solving import SolveFailure, simplified, solve

__all__ = ["LawSwitch", "law_switches", "DISCONTINUOUS"]

#: sympy functions whose value jumps where their argument (or condition) changes sign
DISCONTINUOUS = (sp.sign, sp.Heaviside, sp.Piecewise)


@dataclass(frozen=True)
class LawSwitch:
    """One switching surface of an element law.

    ``name``: unique, ``<element>_law`` (``_law2``, … for more in one
    element); ``element``: the element whose law has it; ``written``: the
    function as the user wrote it (text); ``sigma``: the branch symbol that
    replaces it in the rewritten law; ``surface``: ``s``, an expression of
    bond variables, states, inputs, parameters and ``t`` with ``σ = +1``
    where ``s > 0``; ``friction``: ``+1`` when the law is dry (Coulomb)
    friction — an R element's effort that jumps where its own flow (a slip
    speed) changes sign — and ``s`` is that flow, ``−1`` when ``s`` is minus
    it, ``0`` for any other law (a relay, a bang-bang source): what the
    branches mean, so that they can be named as engineers say them
    (:mod:`switching.model.law_automata`: stuck, slipping)."""

    name: str
    element: str
    written: str
    sigma: sp.Symbol
    surface: sp.Expr
    friction: int = 0


def _oriented(condition, element: str) -> sp.Expr:
    """``s`` with ``s > 0`` where the comparison ``condition`` holds."""
    if not isinstance(condition, Relational) or condition.rel_op not in (">", ">=", "<", "<="):
        raise DerivationError(
            f"the law of {element!r} has a Piecewise condition {condition} that is not one comparison "
            "(<, <=, >, >=); write nested Piecewise pieces with one comparison each, e.g. "
            "Piecewise((a, x > 0), (Piecewise((b, y > 0), (c, True)), True))"
        )
    return condition.lhs - condition.rhs if condition.rel_op in (">", ">=") else condition.rhs - condition.lhs


def _surfaces_of(atom, element: str) -> list:
    """The surfaces ``s`` an atom switches on, in the order of its pieces."""
    if isinstance(atom, sp.Piecewise):
        pieces = atom.args
        if pieces[-1].cond != sp.true:
            raise DerivationError(
                f"the law of {element!r} has a Piecewise without a default piece ({atom}); "
                "end it with (value, True)"
            )
        return [_oriented(piece.cond, element) for piece in pieces[:-1]]
    return [atom.args[0]]


def _rewrite(atom, sigmas: list) -> sp.Expr:
    """``atom`` in terms of the branch values ``sigmas`` of its surfaces."""
    if isinstance(atom, sp.sign):
        return sigmas[0]
    if isinstance(atom, sp.Heaviside):
        return (1 + sigmas[0]) / 2
    value = atom.args[-1].expr
    for piece, sigma in reversed(list(zip(atom.args[:-1], sigmas))):
        value = piece.expr * (1 + sigma) / 2 + value * (1 - sigma) / 2
    return value


def _local_variables(graph, element) -> dict:
    """An element's own placeholders → graph variables (R: ``LAW_FLOW`` → the
    flow into the element, ``LAW_EFFORT`` → its bond's effort)."""
    if not isinstance(element, R):
        return {}
    (bond,) = graph.bonds_of(element.name)
    return {LAW_FLOW: bond.sign_at(element.name) * bond.flow, LAW_EFFORT: bond.effort}


def _is_continuous(law: sp.Expr, sigma: sp.Symbol, surface: sp.Expr) -> bool:
    """Whether ``law`` (with ``sigma`` in it) takes the same value on both
    sides of ``surface = 0``: ``law(σ=1) − law(σ=−1)`` vanishes there."""
    jump = law.xreplace({sigma: sp.S.One}) - law.xreplace({sigma: sp.S.NegativeOne})
    if jump == 0:
        return True
    for symbol in sorted(surface.free_symbols, key=lambda s: s.name):
        if sp.diff(surface, symbol, 2) != 0 or sp.diff(surface, symbol) == 0:
            continue
        try:
            roots = solve([surface], [symbol], f"solving the switching surface {surface} = 0 for {symbol}")
        except SolveFailure:  # undecided: a switch where the law may be continuous costs only events
            return False
        if len(roots) == 1 and symbol in roots[0]:
            on_surface = jump.xreplace({symbol: roots[0][symbol]})
            on_surface = on_surface.replace(sp.Abs, lambda a: sp.sqrt(a**2))
            return simplified(on_surface, "deciding whether a law is continuous on its switching surface") == 0
    return False


def _friction(graph, element, field_name: str, surface: sp.Expr) -> int:
    """``±1`` when a switch of ``element``'s ``field_name`` on ``surface`` is dry friction (an R's effort
    law switching on ``±`` its own flow: :attr:`LawSwitch.friction`), else 0."""
    if not isinstance(element, R) or field_name != "effort_law":
        return 0
    (bond,) = graph.bonds_of(element.name)
    flow = bond.sign_at(element.name) * bond.flow
    return 1 if surface == flow else -1 if surface == -flow else 0


def _law_fields(element) -> list:
    """The names of the element's fields that hold laws or values."""
    return [f.name for f in fields(element)
            if isinstance(getattr(element, f.name), sp.Basic) and f.name != "state"
            and getattr(element, f.name).has(*DISCONTINUOUS)]


def _element_switches(graph, element, taken: set) -> tuple[dict, list]:
    """The rewritten law fields of one element and its switches."""
    changes, switches = {}, []
    local = _local_variables(graph, element)
    for field_name in _law_fields(element):
        law = getattr(element, field_name)
        kept = set()  # continuous atoms, left as written
        while True:
            atoms = [a for a in law.atoms(*DISCONTINUOUS) if a not in kept]
            outer = [a for a in atoms if not any(b != a and b.has(a) for b in atoms)]
            if not outer:
                break
            atom = min(outer, key=sp.default_sort_key)
            surfaces = _surfaces_of(atom, element.name)
            for s in surfaces:
                if s.has(*DISCONTINUOUS):
                    raise DerivationError(
                        f"the law of {element.name!r} switches on {s}, itself discontinuous; "
                        "write the nested switch as one Piecewise on two comparisons, or model it with an automaton"
                    )
            own = [sp.Symbol(f"_{element.name}_branch{k}") for k in range(len(surfaces))]
            trial = law.xreplace({atom: _rewrite(atom, own)})
            if all(_is_continuous(trial, sigma, s) for sigma, s in zip(own, surfaces)):
                kept.add(atom)
                continue
            sigmas = []
            for s in surfaces:
                k = len(taken) + 1
                name = f"{element.name}_law" + ("" if f"{element.name}_law" not in taken else str(k))
                while name in taken:
                    k += 1
                    name = f"{element.name}_law{k}"
                taken.add(name)
                sigma = sp.Symbol(f"{name}_sigma")
                sigmas.append(sigma)
                surface = s.xreplace(local) if local else s
                switches.append(LawSwitch(name, element.name, str(atom.xreplace(local)), sigma, surface,
                                          _friction(graph, element, field_name, surface)))
            law = law.xreplace({atom: _rewrite(atom, sigmas)})
        changes[field_name] = law
    return changes, switches


def law_switches(graph):
    """``(graph', switches)``: a copy of ``graph`` whose element laws have every
    discontinuity replaced by branch symbols, and the :class:`LawSwitch` of
    each (``graph`` itself and ``()`` when no law has one).  The user's graph
    is not changed."""
    from .graph import BondGraph

    elements, switches, taken = {}, [], set()
    for name, element in graph.elements.items():
        if not _law_fields(element):
            continue
        changes, found = _element_switches(graph, element, taken)
        if found:
            elements[name] = copy_with(element, **changes)
            switches += found
    if not switches:
        return graph, ()
    copy = BondGraph(graph.name)
    copy.elements = {name: elements.get(name, element) for name, element in graph.elements.items()}
    copy.bonds = dict(graph.bonds)
    copy.displacements = dict(graph.displacements)
    copy.inputs = dict(graph.inputs)
    copy.ports = dict(graph.ports)
    copy._bonds_of = {k: list(v) for k, v in graph._bonds_of.items()}
    return copy, tuple(switches)
