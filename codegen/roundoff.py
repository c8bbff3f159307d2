"""Round-off scales of expressions: how large the terms were that formed a value.

A quantity computed as ``p_y/m − l·p_J·cos θ/J`` from terms of size 3 that
cancel carries a round-off error of about ``ε·3`` (``ε`` the machine
epsilon), however small the result: comparing the result with a band
relative to itself (``rtol·|value|``) lets round-off decide.  The
*round-off scale* ``R(e) ≥ |e|`` is a first-order bound of the sizes that
enter ``e``'s floating-point evaluation; the computed value has an error of
a modest multiple of ``ε·R(e)`` (one multiple per operation on the longest
path), so a band ``rtol·R(e)`` with ``rtol ≫ ε`` covers it.

Rules (``a, b`` subexpressions, ``n`` a number)::

    R(number or symbol)  = |value|                 (a stored value: relative error ≤ ε)
    R(a₁ + … + a_k)      = R(a₁) + … + R(a_k)
    R(a₁ · … · a_k)      = Σ_i R(a_i) Π_{j≠i} |a_j| + (k − 1)·|a₁ ⋯ a_k|   (first order; the k − 1
                                                                          roundings of the products)
    R(c · a)             = |c|·R(a) + |c·a|  (c a number; R(−a) = R(a): a sign is exact)
    R(a**n)              = |n|·|a|**(n−1)·R(a) + |a**n|
    R(f(a₁, …))          = Σ_i |∂f/∂a_i|·R(a_i) + |f|   (elementary functions)
    R(|a|)               = R(a);   R(min/max(a, b, …)) = max(R(a), R(b), …)   (:class:`larger`)
    anything else        = |e|

Units: ``R(e)`` has the units of ``e``.  Because every rule is homogeneous
(a model rescaled to other units rescales ``R`` like the value), a band
``rtol·R`` decides the same way in metres, millimetres or kilometres.
"""

from __future__ import annotations

import sympy as sp

__all__ = ["roundoff_scale", "larger"]

_PASS_THROUGH = (sp.Abs,)
_EXTREMA = (sp.Min, sp.Max)


class larger(sp.Function):
    """``max(a, b, …)`` of round-off scales, left unevaluated.

    sympy's own ``Max`` compares its arguments symbolically whenever it is
    rebuilt (common-subexpression elimination rebuilds every node), which
    costs more than the rest of a large mode's code generation; scales only
    need the number.  Prints as ``max(...)`` in Python code, evaluates with
    ``evalf``, rewrites as ``Max``."""

    @classmethod
    def eval(cls, *args):
        if len(args) == 1:
            return args[0]
        return None

    def _eval_evalf(self, prec):
        values = [a.evalf(prec) for a in self.args]
        if all(v.is_Number for v in values):
            return max(values)
        return None

    def _eval_rewrite_as_Max(self, *args, **kwargs):
        return sp.Max(*args)

    def _pythoncode(self, printer):
        return "max(" + ", ".join(printer._print(a) for a in self.args) + ")"

    def _numpycode(self, printer):
        text = printer._print(self.args[0])
        for a in self.args[1:]:
            text = f"{printer._module_format('numpy.maximum')}({text}, {printer._print(a)})"
        return text

    _lambdacode = _pythoncode


def _abs(e: sp.Basic) -> sp.Expr:
    """``|e|`` left as written (sympy's own ``Abs`` would rewrite ``|exp(x)|``
    into ``exp(re(x))`` for symbols not declared real)."""
    if e.is_Number:
        return abs(e)
    if e.is_nonnegative:
        return e
    return sp.Abs(e, evaluate=False)


def roundoff_scale(expr, memo: dict | None = None) -> sp.Expr:
    """``R(expr)`` by the rules of the module docstring (a sympy expression
    in the same symbols, ``≥ |expr|`` wherever both are finite).  ``memo``
    (subexpression → scale) may be shared between calls: ``R`` depends on the
    expression alone, so the modes of one model share their guards' scales."""
    return _scale(sp.sympify(expr), {} if memo is None else memo)


def _scale(e: sp.Basic, memo: dict) -> sp.Expr:
    cached = memo.get(e)
    if cached is not None:
        return cached
    result = _rule(e, memo)
    memo[e] = result
    return result


def _rule(e: sp.Basic, memo: dict) -> sp.Expr:
    if e.is_Number or e.is_Symbol or e.is_NumberSymbol or not e.args:
        return _abs(e)
    if e.is_Add:
        return sp.Add(*[_scale(a, memo) for a in e.args])
    if e.is_Mul:
        # first order: relative errors of the factors add (a product of R's would compound them, 2^k-fold)
        coefficient, factors = e.as_coeff_mul()
        if len(factors) == 1:
            rest = _scale(factors[0], memo)
        else:
            sizes = [_abs(a) for a in factors]
            terms = [_scale(a, memo) * sp.Mul(*(sizes[:i] + sizes[i + 1:])) for i, a in enumerate(factors)]
            rest = sp.Add(*terms) + (len(factors) - 1) * sp.Mul(*sizes)
        if abs(coefficient) == 1:  # a sign: exact
            return rest
        return abs(coefficient) * rest + _abs(e)  # one more rounding for a numeric coefficient
    if e.is_Pow:
        base, exponent = e.args
        if exponent.is_Number:
            if exponent == 1:
                return _scale(base, memo)
            return (_abs(exponent) * _abs(base) ** (exponent - 1) * _scale(base, memo) + _abs(e))
        return _function_rule(e, (base, exponent), memo)
    if isinstance(e, _PASS_THROUGH):
        return _scale(e.args[0], memo)
    if isinstance(e, _EXTREMA) or isinstance(e, larger):
        return larger(*[_scale(a, memo) for a in e.args])
    if isinstance(e, sp.Function) and not isinstance(e, sp.Piecewise) and all(a.is_commutative for a in e.args):
        return _function_rule(e, e.args, memo)
    return _abs(e)


def _function_rule(e: sp.Basic, arguments: tuple, memo: dict) -> sp.Expr:
    """``Σ |∂e/∂a_i|·R(a_i) + |e|`` over the arguments that are not plain numbers."""
    total = _abs(e)
    dummies = [sp.Dummy(f"a{k}") for k in range(len(arguments))]
    try:
        template = e.func(*dummies) if not e.is_Pow else dummies[0] ** dummies[1]
    except (TypeError, ValueError):
        return _abs(e)
    for k, argument in enumerate(arguments):
        if argument.is_Number:
            continue
        try:
            derivative = sp.diff(template, dummies[k])
        except (TypeError, ValueError, NotImplementedError):
            return _abs(e)
        if derivative.has(sp.Derivative, sp.Subs) or derivative.has(sp.DiracDelta):
            return _abs(e)  # no closed-form derivative (or a step's pulse): the value's own size
        derivative = derivative.xreplace(dict(zip(dummies, arguments)))
        total += _abs(derivative) * _scale(argument, memo)
    return total
