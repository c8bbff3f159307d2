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


#: Gauss–Legendre nodes and weights on [0, 1] of the quadrature of a law whose energy sympy's closed form cannot
#: be computed in floating point (a closed form with erfi or fresnels, which no numeric module prints, or none)
_NODES, _WEIGHTS = (lambda n, w: ((n + 1) / 2, w / 2))(*np.polynomial.legendre.leggauss(48))


def energy_function(graph, states: Sequence[sp.Symbol], parameters: Mapping[sp.Symbol, float],
                    inputs: Sequence[sp.Symbol] = ()):
    """A numerical evaluator of :func:`stored_energy` for given parameter values.

    Returns ``energy(x, t, u)`` where ``x`` is an ``(N, n)`` array of states in
    ``states`` order (or one state vector), ``t`` the times (``N``) and ``u`` a
    list with one array of values per input symbol; it returns the ``N``
    energies [J] (a float for one state vector).  A law whose energy has no
    closed form that computes in floating point (none in the budget, or one
    with a function no numeric module has: ``erfi``, ``fresnels``) is
    integrated numerically (Gauss–Legendre on ``[0, x]``)."""
    values = {k: sp.Float(v) for k, v in parameters.items()}
    known = set(states) | set(inputs) | {TIME}
    laws = [element.law.xreplace(values) for element in graph.storage]
    unknown = set().union(*(law.free_symbols for law in laws)) - known
    if unknown:
        names = ", ".join(sorted(s.name for s in unknown))
        raise DerivationError(f"the stored energy of graph {graph.name!r} depends on {names}, which have no value",
                              [e.name for e in graph.storage if e.law.free_symbols & unknown])
    args = list(states) + [TIME] + list(inputs)
    terms = [_term(element, law, values, args) for element, law in zip(graph.storage, laws)]
    n = len(states)

    def energy(x, t, u=()):
        x = np.asarray(x, dtype=float)
        single = x.ndim == 1
        x = x.reshape(1 if single else len(x), n)  # (rows given: a graph without storage has n = 0)
        t = np.broadcast_to(np.asarray(t, dtype=float), (len(x),))
        u = [np.broadcast_to(np.asarray(v, dtype=float), (len(x),)) for v in u]
        total = np.zeros(len(x))
        for term in terms:
            total += np.broadcast_to(np.asarray(term(*x.T, t, *u), dtype=float), (len(x),))
        return float(total[0]) if single else total

    return energy


def _term(element: Storage, law: sp.Expr, values: dict, args: list):
    """The evaluator of one element's stored energy (see :func:`energy_function`)."""
    energy = _integrated(element.law, element.state)
    if not energy.has(sp.Integral):
        try:
            fn = sp.lambdify(args, energy.xreplace(values), modules=["numpy", "scipy"])
            with np.errstate(all="ignore"):
                fn(*([0.5] * len(args)))  # a name no module defines (erfi without scipy's) fails here
            return fn
        except Exception:  # a function no module prints (fresnels), or one missing: the quadrature below
            pass
    index = args.index(element.state)
    rate = sp.lambdify(args, law, modules=["numpy", "scipy"])

    def quadrature(*arguments):
        x = np.asarray(arguments[index], dtype=float)
        points = [np.asarray(a, dtype=float)[..., None] for a in arguments]
        points[index] = x[..., None] * _NODES  # (samples, nodes)
        f = np.broadcast_to(np.asarray(rate(*points), dtype=float), points[index].shape)
        return x * (f @ _WEIGHTS)

    return quadrature
