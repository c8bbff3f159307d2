"""Lambert's W in generated code, through the Wright omega function.

sympy writes the inverse of an exponential law in a loop (a diode
``i = Is·(e^{v/VT} − 1)`` in series with a resistor) with the principal
branch of Lambert's W, typically as ``K·exp(c − W(a·e^b))`` with ``a·e^b``
far outside the floating-point range (``2.9·10⁷⁹·e^{−4·10⁷·q}``) and ``K``
as large (``7.2·10⁷⁴``).  Printed as written, it overflows.
:func:`omega_form` rewrites such an expression, exactly, with
``ω(z) = W₀(eᶻ)`` (:class:`WrightOmega`, computed by
:func:`codegen.omega.wrightomega`):

* ``W₀(a·e^b) = ω(log a + b)`` (``a > 0``): from ``W e^W = X`` with
  ``X = eᶻ``, ``W + log W = z``, the equation ``ω`` solves; the argument
  ``z = log X`` is formed from the factors of ``X`` (``log`` of each
  positive factor, the exponent of each ``exp``), never ``X`` itself;
* ``exp(c + k·W₀(X)) = exp(c + k·z)·ω(z)^(−k)``: ``e^W = X/W = eᶻ/ω``, so
  the exponent collects ``c + k·z``, in which the large terms cancel
  symbolically (``−4·10⁷ q`` against ``+4·10⁷ q``; ``log K + c − z`` is
  ``log(VT/R)``): what is left is ``(VT/R)·ω(z)``, which never overflows.

The rewrite is general: any expression holding ``LambertW(X)`` (the
principal branch) is rewritten wherever it occurs, with ``z = log X``
left as a logarithm of the factors whose sign it cannot see (negative
``X``, ``−1/e ≤ X < 0``, where ``W₀`` is real but ``ω`` is not, gives a
NaN at run time then).  ``LambertW(X, k)`` of another branch, and ``W₀``
of an argument known to be negative, raise
:class:`codegen.source.UnprintableExpressionError`.
"""

from __future__ import annotations

import sympy as sp

from .errors import UnprintableExpressionError

__all__ = ["WrightOmega", "omega_form"]


class WrightOmega(sp.Function):
    """``ω(z) = W₀(eᶻ)``, the Wright omega function: the ``w`` with
    ``w + log w = z`` (real and positive for real ``z``).

    ``dω/dz = ω/(1 + ω)`` (from ``(1 + 1/w)·dw = dz``); ``ω(−∞) = 0``,
    ``ω(1) = 1``, ``ω(∞) = ∞``.  Prints as ``wrightomega(z)`` in generated
    code (``H.wrightomega`` in raw code), evaluates with ``evalf``,
    rewrites as ``LambertW(exp(z))``."""

    nargs = 1

    @classmethod
    def eval(cls, z):
        if z is sp.S.NegativeInfinity:
            return sp.S.Zero
        if z is sp.S.Infinity:
            return sp.S.Infinity
        if z == 1:
            return sp.S.One
        return None

    def fdiff(self, argindex=1):
        if argindex != 1:
            raise sp.ArgumentIndexError(self, argindex)
        return self / (1 + self)

    def _eval_is_extended_real(self):
        return self.args[0].is_extended_real

    def _eval_is_positive(self):
        z = self.args[0]
        if z.is_extended_real and z.is_finite:
            return True
        return None

    def _eval_rewrite_as_LambertW(self, z, **kwargs):
        return sp.LambertW(sp.exp(z))

    def _eval_evalf(self, prec):
        import mpmath

        z = self.args[0].evalf(prec)
        if not z.is_Number:
            return None
        with mpmath.workprec(prec + 10):
            value = mpmath.lambertw(mpmath.exp(z._to_mpmath(prec + 10)))
        return sp.Float(value.real, precision=prec) if value.imag == 0 else None

    def _pythoncode(self, printer):
        return f"{printer._module_format('wrightomega')}({printer._print(self.args[0])})"

    def _numpycode(self, printer):
        return f"{printer._module_format('scipy.special.wrightomega')}({printer._print(self.args[0])})"

    _lambdacode = _pythoncode


def omega_form(expressions: list) -> list:
    """``expressions`` with every ``LambertW`` written with :class:`WrightOmega`
    by the two identities of the module docstring (equal expressions
    rewritten once, so what was shared stays shared)."""
    memo: dict = {}
    return [_rewrite(sp.sympify(e), memo) for e in expressions]


def _rewrite(expr, memo: dict):
    if not isinstance(expr, sp.Basic) or expr.is_Atom:
        return expr
    done = memo.get(expr)
    if done is not None:
        return done
    if isinstance(expr, sp.LambertW):
        result = WrightOmega(_log_of(_log_parts(_principal_argument(expr, memo))))
    elif isinstance(expr, sp.exp):
        result = _exp_rule(expr, memo)
    else:
        args = [_rewrite(a, memo) for a in expr.args]
        result = expr.func(*args) if any(a is not b for a, b in zip(args, expr.args)) else expr
    memo[expr] = result
    return result


def _principal_argument(w, memo: dict):
    """The argument of ``W₀`` in ``w`` (rewritten), or the error for another branch."""

    if len(w.args) > 1 and w.args[1] != 0:
        raise UnprintableExpressionError(
            f"the expression {w} has no numerical definition: the code generator computes the principal branch "
            f"of Lambert's W only (W₀, through the Wright omega function), not the branch k = {w.args[1]}")
    return _rewrite(w.args[0], memo)


def _log_parts(x):
    """``log x`` in parts: the exponents ``b`` of the ``exp`` factors of
    ``x`` and ``(base, power)`` pairs, ``log x = Σ b + Σ power·log base``:
    each positive factor its own base, one product of the factors of
    unknown sign (nothing multiplied out: ``x`` itself may be beyond the
    floating-point range)."""

    exponents, powers, unknown, negative = [], [], [], False
    for factor in sp.Mul.make_args(x):
        if isinstance(factor, sp.exp):
            exponents.append(factor.args[0])
        elif factor.is_Number and factor.is_extended_real:
            negative ^= bool(factor < 0)
            if abs(factor) != 1:
                powers.append((abs(factor), sp.S.One))
        elif factor.is_Pow and factor.base.is_positive and factor.exp.is_extended_real:
            powers.append((factor.base, factor.exp))
        elif factor.is_positive:
            powers.append((factor, sp.S.One))
        else:
            unknown.append(factor)
    if negative and not unknown:
        raise UnprintableExpressionError(
            f"the expression LambertW({x}) has no numerical definition here: its argument is negative (W₀ is real "
            "there only between −1/e and 0, which the Wright omega function the code generator computes it with "
            "does not reach)")
    if unknown:
        powers.append((sp.Mul(*unknown) * (-1 if negative else 1), sp.S.One))
    return exponents, powers


def _log_of(parts):
    """``log x`` from :func:`_log_parts`; the ``log`` of a floating-point
    number is left to the generated code (sympy would print its value with
    15 digits: ``182.965613657168``, 5·10⁻¹³ from the double it holds, which
    ``ω`` of a small value turns into the same relative error)."""
    exponents, powers = parts
    return sp.Add(*exponents, *[p * sp.log(base, evaluate=not base.is_Float) for base, p in powers])


def _exp_rule(expr, memo: dict):
    """``exp(c + Σ k·W₀(X))`` as ``exp(c + Σ k·Σb)·Π base^(k·power)·Π ω^(−k)``
    (``c`` and the ``k`` free of W; ``log X = Σb + Σ power·log base`` by
    :func:`_log_parts`: the numbers' powers are formed directly, one
    rounding each, not as ``exp`` of a sum of large logarithms)."""
    kept, exponent, factor = [], [], sp.S.One
    for term in sp.Add.make_args(expr.args[0]):
        k, w = term.as_independent(sp.LambertW, as_Add=False)
        if isinstance(w, sp.LambertW):
            parts = _log_parts(_principal_argument(w, memo))
            if k.is_Float and float(k).is_integer():  # (−1.0 from sympy's solve: ω, not ω**1.0)
                k = sp.Integer(int(k))
            exponent.extend(k * b for b in parts[0])
            for base, power in parts[1]:
                factor *= base ** (k * power)
            factor *= WrightOmega(_log_of(parts)) ** (-k)
        else:
            kept.append(term)
    if not exponent and factor is sp.S.One:
        rewritten = _rewrite(expr.args[0], memo)
        return expr if rewritten is expr.args[0] else sp.exp(rewritten)
    return sp.exp(sp.Add(*[_rewrite(t, memo) for t in kept], *exponent)) * factor
