"""Brent's maximisation of a function on an interval, as reverse communication.

Event detection (:class:`switching.simulate.events.GuardScan` and its compiled
translation in :mod:`switching.kernel.loop`) refines a sampled extremum of a guard
part's margin ``m(τ)`` on ``[a, b]``: does the margin reach 0 (the part
holds) somewhere between the samples?  The search is Brent's minimisation
(R. P. Brent, *Algorithms for Minimization without Derivatives*, 1973, ch. 5;
the ``fminbound`` of scipy) of ``φ = −m``:

* golden-section steps ``x + c·(b − x)`` or ``x + c·(a − x)``, ``c = (3 − √5)/2``,
  into the larger part of the bracket;
* a parabolic step instead — the minimum of the parabola through the three
  best points ``x, w, v`` — when it falls inside the bracket and moves less
  than half the step before last (otherwise golden section);
* no evaluation closer than ``tol₁ = 4·10⁻¹⁶·|x| + 10⁻¹⁰·(b₀ − a₀)`` to ``x``
  or ``2·tol₁`` to an end;
* stop when the bracket around ``x`` is within ``2·tol₁`` (``|x − (a + b)/2|
  ≤ 2·tol₁ − (b − a)/2``), after :data:`MAX_EVALUATIONS` evaluations past the
  first, or at the first point where ``m ≥ 0`` (that point is the answer: the
  part holds there).

The answer is the best point ``x`` found (largest margin), or the first point
at which the margin is ≥ 0.

The caller evaluates the margin: :func:`maximize_begin` returns the search's
state, a tuple of floats whose last entry is the first point to evaluate;
:func:`maximize_next` takes the state and the margin at that point and
returns ``(done, state)``: the next point to evaluate is ``state[-1]``, or,
when ``done``, the answer is.  In Python::

    state = maximize_begin(a, b)
    done = False
    while not done:
        done, state = maximize_next(state, margin(state[-1]))
    tau = state[-1]

(the compiled kernel runs the same loop with its own ``margin``).
"""

from __future__ import annotations

__all__ = ["GOLDEN", "MAX_EVALUATIONS", "RULES", "maximize_begin", "maximize_next"]

RULES = ("maximize_begin", "maximize_next")

GOLDEN = 0.3819660112501051  # (3 − √5)/2: the golden section of a bracket
MAX_EVALUATIONS = 60  # evaluations after the first


def maximize_begin(a, b):
    """The state of a search for a maximum on ``[a, b]``; its first point to
    evaluate, ``state[-1]``, is the golden section ``a + GOLDEN·(b − a)``.

    The state is the tuple ``(a, b, x, w, v, φx, φw, φv, d, e, xtol, count,
    point)`` of floats: the bracket, the best three points and their values
    of ``φ = −margin``, the last two steps, the absolute tolerance
    ``10⁻¹⁰·(b − a)``, the evaluations after the first, the point to
    evaluate next (or the answer)."""
    x = a + GOLDEN * (b - a)
    return (a, b, x, x, x, 0.0, 0.0, 0.0, 0.0, 0.0, 1e-10 * (b - a), -1.0, x)


def maximize_next(state, margin):
    """One step of the search: ``margin`` is the margin at ``state[-1]``.
    Returns ``(done, state)`` with ``state[-1]`` the next point to evaluate,
    or the answer when ``done`` (see the module)."""
    a, b, x, w, v, fx, fw, fv, d, e, xtol, count, u = state
    fu = -margin
    if count < 0.0:  # the first point, x itself
        fx = fu
        fw = fu
        fv = fu
        if fx <= 0.0:
            return True, (a, b, x, w, v, fx, fw, fv, d, e, xtol, 0.0, x)
        count = 0.0
    else:
        if fu <= 0.0:
            return True, (a, b, x, w, v, fx, fw, fv, d, e, xtol, count, u)
        if fu <= fx:
            if u < x:
                b = x
            else:
                a = x
            v = w
            fv = fw
            w = x
            fw = fx
            x = u
            fx = fu
        else:
            if u < x:
                a = u
            else:
                b = u
            if fu <= fw or w == x:
                v = w
                fv = fw
                w = u
                fw = fu
            elif fu <= fv or v == x or v == w:
                v = u
                fv = fu
        if count >= MAX_EVALUATIONS:
            return True, (a, b, x, w, v, fx, fw, fv, d, e, xtol, count, x)
    middle = 0.5 * (a + b)
    tol1 = 4e-16 * abs(x) + xtol
    tol2 = 2.0 * tol1
    if abs(x - middle) <= tol2 - 0.5 * (b - a):
        return True, (a, b, x, w, v, fx, fw, fv, d, e, xtol, count, x)
    use_golden = True
    if abs(e) > tol1:  # a parabolic step through x, w, v
        r = (x - w) * (fx - fv)
        q = (x - v) * (fx - fw)
        p = (x - v) * q - (x - w) * r
        q = 2.0 * (q - r)
        if q > 0.0:
            p = -p
        q = abs(q)
        previous = e
        e = d
        if abs(p) < abs(0.5 * q * previous) and q * (a - x) < p and p < q * (b - x):
            d = p / q
            u = x + d
            if u - a < tol2 or b - u < tol2:
                d = tol1 if x < middle else -tol1
            use_golden = False
    if use_golden:
        e = (b - x) if x < middle else (a - x)
        d = GOLDEN * e
    u = x + (d if abs(d) >= tol1 else (tol1 if d > 0 else -tol1))
    return False, (a, b, x, w, v, fx, fw, fv, d, e, xtol, count + 1.0, u)
