"""Stored energy of a bond graph, from the storage elements' laws.

For a C with ``e = Φ(q)`` the stored energy is ``E = ∫₀^q Φ(s) ds``; for an I
with ``f = Φ(p)`` it is ``E = ∫₀^p Φ(s) ds`` (linear laws give ``q²/2C`` and
``p²/2m``).  Each law is integrated once by sympy and cached.  Displacements
(integrated positions) store nothing: a potential such as gravity enters the
graph as a source, not as stored energy.

Example::

    >>> import sympy as sp
    >>> from bondgraph import C
    >>> from bondgraph.energy import storage_energy
    >>> storage_energy(C("spring", effort_law=lambda q: q**3 / sp.Symbol("C3")))
    q_spring**4/(4*C3)
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence

import numpy as np
import sympy as sp

from . import budget
from .elements import Storage
from .errors import DerivationError
from .solving import simplified
from .symbols import t as TIME

__all__ = ["storage_energy", "stored_energy", "energy_function"]


@functools.lru_cache(maxsize=4096)
def _integrated(law: sp.Expr, state: sp.Symbol) -> sp.Expr:
    slope = sp.diff(law, state)
    if not slope.has(state) and law.xreplace({state: 0}) == 0:  # linear: no integrator needed
        return law * state / 2
    s = sp.Dummy("s")
    try:
        energy = budget.run(f"integrating {law} over {state}", sp.integrate, law.xreplace({state: s}), (s, 0, state))
    except Exception:  # over budget, or sympy's NotImplementedError: refused below, as its own unevaluated one
        return sp.Integral(law.xreplace({state: s}), (s, 0, state))
    return simplified(energy, "simplifying a stored energy") if energy.has(sp.Piecewise) else energy


def storage_energy(element: Storage) -> sp.Expr:
    """The energy stored in one C or I element as a sympy expression of its
    state: ``∫₀^x Φ(s) ds`` with ``Φ`` the element's law (cached per law)."""
    if not isinstance(element, Storage):
        raise TypeError(f"{element} stores no energy: only C and I elements do")
    energy = _integrated(element.law, element.state)
    if energy.has(sp.Integral):
        raise DerivationError(
            f"cannot integrate the law of {element} ({element.law} in {element.state}) symbolically, "
            f"within the budget of {budget.budget_seconds()} s, so its stored energy is unknown; give a law sympy "
            "can integrate (its numbers as parameters help sympy)",
            [element.name],
        )
    return energy


def stored_energy(graph) -> sp.Expr:
    """The total energy stored in a :class:`~bondgraph.BondGraph`: the sum of
    :func:`storage_energy` over its C and I elements, an expression of the
    states (and of the parameters of the laws)."""
    return sp.Add(*(storage_energy(element) for element in graph.storage))


def energy_function(graph, states: Sequence[sp.Symbol], parameters: Mapping[sp.Symbol, float],
                    inputs: Sequence[sp.Symbol] = ()):
    """A numerical evaluator of :func:`stored_energy` for given parameter values.

    Returns ``energy(x, t, u)`` where ``x`` is an ``(N, n)`` array of states in
    ``states`` order (or one state vector), ``t`` the times (``N``) and ``u`` a
    list with one array of values per input symbol; it returns the ``N``
    energies [J] (a float for one state vector)."""
    expr = stored_energy(graph).xreplace({k: sp.Float(v) for k, v in parameters.items()})
    known = set(states) | set(inputs) | {TIME}
    unknown = expr.free_symbols - known
    if unknown:
        names = ", ".join(sorted(s.name for s in unknown))
        raise DerivationError(f"the stored energy of graph {graph.name!r} depends on {names}, which have no value",
                              [e.name for e in graph.storage if e.law.free_symbols & unknown])
    args = list(states) + [TIME] + list(inputs)
    fn = sp.lambdify(args, expr, modules="numpy")
    n = len(states)

    def energy(x, t, u=()):
        x = np.asarray(x, dtype=float)
        single = x.ndim == 1
        x = x.reshape(1 if single else len(x), n)  # (rows given: a graph without storage has n = 0)
        t = np.broadcast_to(np.asarray(t, dtype=float), (len(x),))
        u = [np.broadcast_to(np.asarray(v, dtype=float), (len(x),)) for v in u]
        values = np.broadcast_to(np.asarray(fn(*x.T, t, *u), dtype=float), (len(x),)).copy()
        return float(values[0]) if single else values

    return energy
