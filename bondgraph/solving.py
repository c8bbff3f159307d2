"""sympy's solver and simplifier as derivation steps: in a time budget, with
the numbers of a law taken out first.

``sympy.solve`` of ``1e-12*(exp(e/0.025) - 1) = y`` turns the floats into
rationals (``exp(40 e)``, ``1/10¹²``) and then searches for hours; the same
law with symbols ``Is*(exp(e/VT) - 1) = y`` is solved in a fraction of a
second (``e = VT·log(1 + y/Is)``).  So :func:`solve` first replaces every
non-integral float ``c`` of the equations by a symbol ``κ``, solves, and
puts ``c`` back for ``κ``: the solution of the law with symbols, evaluated at
the numbers, is a solution of the law with numbers.  Integral floats
(``x**2.0``) stay: they decide the structure (a square has two roots).
Each call runs in the budget of :mod:`bondgraph.budget`.
"""

from __future__ import annotations

import random

import mpmath
import sympy as sp

from . import budget

__all__ = ["SolveFailure", "solve", "lambert_solution", "simplified", "vanishes", "singular"]


class SolveFailure(Exception):
    """``sympy.solve`` gave up (``NotImplementedError`` or another error of
    its own) or ran out of budget; ``reason`` says which, in words."""

    def __init__(self, reason: str, over_budget: bool = False):
        super().__init__(reason)
        self.reason = reason
        self.over_budget = over_budget


def _floats_as_symbols(expressions) -> tuple[list, dict]:
    """``(expressions', {κ: c})``: every non-integral float ``c`` replaced by a symbol ``κ``."""
    floats = set()
    for expr in expressions:
        floats |= {a for a in expr.atoms(sp.Float) if a != int(a)}
    back = {sp.Dummy(f"c{k}"): c for k, c in enumerate(sorted(floats))}
    forward = {c: k for k, c in back.items()}
    return [expr.xreplace(forward) for expr in expressions], back


def solve(equations, unknowns, step: str, seconds: float | None = None) -> list[dict]:
    """Every solution of ``equations = 0`` for ``unknowns`` (``sympy.solve``
    with ``dict=True``), found with the numbers replaced by symbols (see the
    module docstring), each step in the budget (at most ``seconds`` when
    given).  Raises :class:`SolveFailure`."""
    equations = [sp.sympify(e) for e in equations]
    symbolic, back = _floats_as_symbols(equations)
    try:
        solutions = budget.run_within(seconds, step, sp.solve, symbolic, list(unknowns), dict=True)
    except budget.OverBudget as exc:
        raise SolveFailure(f"sympy found no solution within the budget of {exc.seconds:g} s", True) from None
    except Exception as exc:  # NotImplementedError and sympy's own errors: no closed form
        raise SolveFailure(f"sympy cannot solve it ({type(exc).__name__}: {exc})") from None
    return [{v: value.xreplace(back) for v, value in solution.items()} for solution in solutions]


def lambert_solution(residual: sp.Expr, unknown: sp.Symbol) -> sp.Expr | None:
    """The solution of ``a·v + b + c·exp(d·v + e) = 0`` for ``v = unknown`` (``a, b, c, d, e`` free of it),
    or ``None`` when ``residual`` has another form or the solution is not unique:

        v = −W₀(z)/d − b/a,   z = (d·c/a)·exp(e − d·b/a),

    ``W₀`` the principal branch of Lambert's W.  Unique where ``d·c/a > 0`` (then ``a·v + c·exp(d·v)`` is
    monotonic and ``z > 0``), judged with every symbol positive (a parameter is a resistance, a
    saturation current, a thermal voltage).  An exponential diode in series with a resistance forms
    this loop: ``i = Is·(exp((V − R·i)/VT) − 1)`` gives ``i = (VT/R)·W₀((Is·R/VT)·exp((V + R·Is)/VT)) − Is``
    — sympy's ``solve`` searches for it for minutes when ``V`` holds a source's ``sin(ωt)`` and a
    capacitor's charge.  The code generator writes ``W₀(K·exp(x))`` with the Wright omega function,
    which never overflows (:mod:`codegen.lambert`)."""
    linear, constant, exponential = sp.Integer(0), sp.Integer(0), []
    for term in sp.Add.make_args(sp.expand(residual, power_exp=False, log=False, multinomial=False)):
        if not term.has(unknown):
            constant += term
            continue
        coefficient, rest = term.as_independent(unknown, as_Add=False)
        if rest == unknown:
            linear += coefficient
        elif isinstance(rest, sp.exp):
            exponential.append((coefficient, rest.args[0]))
        else:
            return None
    if len(exponential) != 1 or linear == 0:
        return None
    c, argument = exponential[0]
    d = sp.diff(argument, unknown)
    if d == 0 or d.has(unknown):
        return None
    e = argument.xreplace({unknown: 0})
    a, b = linear, constant
    slope = d * c / a
    positive = {s: sp.Symbol(s.name, positive=True) for s in slope.free_symbols if isinstance(s, sp.Symbol)}
    if slope.xreplace(positive).is_positive is not True:
        return None
    return -sp.LambertW(slope * sp.exp(e - d * b / a)) / d - b / a


def simplified(expr: sp.Expr, step: str, how=sp.simplify) -> sp.Expr:
    """``how(expr)`` (``sympy.simplify`` by default) in the budget; ``expr``
    as it stands when that runs out (simplifying only tidies)."""
    try:
        return budget.run(step, how, expr)
    except budget.OverBudget:
        return expr


def vanishes(expr: sp.Expr, step: str) -> bool:
    """Whether ``expr`` is identically zero, decided at three random points
    of its symbols (rationals between 1 and 2: physical quantities of a
    law are positive): in exact rational arithmetic where ``expr`` is a
    rational function of them, else at 60 digits and within ``1e-40`` of
    zero relative to its top-level terms.  A non-zero value anywhere proves
    ``expr`` non-zero at once; a non-zero analytic function vanishes at a
    random point with probability 0.  (A determinant of a resistive network
    with leaks of 10⁻⁹ S cancels to 15 digits in double precision: floats
    would call it zero.)  Where ``expr`` has no value at such a point,
    ``simplify(expr) == 0`` in the budget decides (``step`` names it)."""
    rng = random.Random(20240601)
    symbols = sorted(expr.free_symbols, key=str)
    terms = sp.Add.make_args(expr)
    for _ in range(3):
        point = {s: sp.Rational(rng.randint(10**6, 2 * 10**6), 10**6 + 3) for s in symbols}
        try:
            value = expr.xreplace(point)
            if value.is_Rational:
                if value != 0:
                    return False
                continue
            value = complex(value.evalf(60))
            scale = max([abs(complex(term.xreplace(point).evalf(60))) for term in terms] + [1.0])
        except (TypeError, ValueError, ArithmeticError):
            break  # no number there: the simplifier decides
        if abs(value) > 1e-40 * scale:
            return False
    else:
        return True
    try:
        return budget.run(step, sp.simplify, expr) == 0
    except budget.OverBudget:
        return False


def singular(matrix: sp.Matrix, step: str) -> bool:
    """Whether the square ``matrix`` (of expressions) is singular for all values of its symbols,
    decided at three random points (rationals between 1 and 2): its determinant there, exactly
    (fraction-free) where the entries become rationals, else at 60 digits and within ``1e-40`` of
    zero relative to Hadamard's bound (the product of the rows' norms).  A non-zero determinant
    anywhere proves the matrix regular at once — no symbolic determinant is formed, whose
    expansion grows as n! terms.  Where an entry has no value at such a point, :func:`vanishes`
    decides on the symbolic determinant."""
    rng = random.Random(20240601)
    symbols = sorted(matrix.free_symbols, key=str)
    for _ in range(3):
        point = {s: sp.Rational(rng.randint(10**6, 2 * 10**6), 10**6 + 3) for s in symbols}
        at = matrix.xreplace(point)
        if all(entry.is_Rational for entry in at):
            if at.det(method="bareiss") != 0:
                return False
            continue
        try:
            with mpmath.workdps(60):
                rows = [[mpmath.mpc(complex(entry.evalf(60))) for entry in at.row(i)] for i in range(at.rows)]
                determinant = abs(mpmath.det(mpmath.matrix(rows)))
                bound = mpmath.fprod(max(mpmath.norm(mpmath.matrix(row)), 1e-300) for row in rows)
        except (TypeError, ValueError, ArithmeticError, ZeroDivisionError):
            break
        if determinant > mpmath.mpf("1e-40") * bound:
            return False
    else:
        return True
    return vanishes(matrix.det(method="berkowitz"), step)
