"""Inverses of nonlinear element laws: the real branch, or a numeric inverse.

An element whose law is given in one causality (an R's ``f = ψ(e)``, a C's
``e = Φ(q)``) and used in the other needs ``v = ψ⁻¹(y)``.  Three outcomes,
in this order:

1. **a closed form** from ``sympy.solve`` (in the budget of
   :mod:`bondgraph.budget`): of the solutions it returns (a cubic has three,
   ``sinh`` two), the one that is *the* inverse on the law's real domain is
   kept — free of ``I``, and ``s(ψ(v)) = v`` at the sample points
   :data:`SAMPLES` where ``ψ(v)`` is real (to ``10⁻⁶·(1 + |v|)``, evaluated
   with 30 digits and the law's numbers as exact decimals, so that
   cancellations such as ``10¹²·(10⁻¹²·e^{−80} − 10⁻¹²) + 1`` come out
   right).  It is the branch continuous through the operating point ``v = 0``;
   a branch that covers only part of the line (``∛y`` as sympy writes it is
   complex for ``y < 0``) is not kept, nor, for a monotonic law, one that
   loses its digits in floating point (:func:`computes_accurately`: Cardano's
   formula for ``v + v³``);
2. **a numeric inverse** when sympy finds no such branch, none at all, or
   none in its budget, and the law is *monotonic*: its slope ``ψ′`` is a
   finite real number of one sign (or nought) at the sample points
   :data:`SLOPE_SAMPLES` (``0, ±10⁻³ … ±10³``, the law's other symbols at
   fixed random values in ``[1/2, 2]``; an infinite slope, ``sign(v)·√|v|``
   at 0, is refused: the iteration divides by it).  The inverse
   is :func:`numeric_inverse`'s function ``inverse_law_<element>(y, a…)``
   (``a…`` the law's other symbols), whose derivative sympy takes from the
   implicit function theorem (Jacobians, sensitivities, state-space
   matrices keep working) and which the code generator computes with a
   bracketed Newton iteration (:mod:`codegen.inverse`);
3. otherwise a :class:`~bondgraph.errors.DerivationError` naming the element
   and the law and saying what to do: give the law in the other causality.
"""

from __future__ import annotations

import functools
import hashlib
import math
import random
import re

import sympy as sp

from . import budget

__all__ = ["ACCURACY_SAMPLES", "InverseLaw", "SAMPLES", "SLOPE_SAMPLES", "branch_on_the_line", "computes_accurately",
           "monotonic_sense", "numeric_inverse", "within_range"]

#: where a branch of a closed-form inverse must give back the law's argument (the operating point 0 among them)
SAMPLES = (0, -sp.Rational(1, 1000), sp.Rational(1, 1000), -sp.Rational(1, 10), sp.Rational(1, 10),
           -sp.Rational(1, 2), sp.Rational(1, 2), -1, 1, -2, 2, -5, 5)
#: where the slope of a law must keep one sign for a numeric inverse: 0 and ±10^(k/4), k = −12 … 12
SLOPE_SAMPLES = (0.0,) + tuple(s * 10 ** (k / 4) for k in range(-12, 13) for s in (-1.0, 1.0))


class InverseLaw(sp.Function):
    """``v = ψ⁻¹(y; a…)``: the solution ``v`` of ``ψ(v; a…) = y`` for a
    monotonic law ``ψ`` (one subclass per law, made by :func:`numeric_inverse`).

    Arguments ``(y, a₁, …, a_k)``: the law's value and its other symbols
    (parameters, time, states, other bonds' variables) in the order of
    :attr:`others`.  Derivatives by the implicit function theorem:
    ``∂v/∂y = 1/ψ′(v)``, ``∂v/∂a_j = −(∂ψ/∂a_j)(v)/ψ′(v)``.  Printed in
    generated code as a call of :attr:`helper`, the bracketed Newton
    iteration :mod:`codegen.inverse` writes for the law; ``evalf`` finds the
    root with mpmath (a bracket grown about :attr:`start`, then bisection to
    the working precision)."""

    #: the law ``ψ`` as an expression of :attr:`variable` and :attr:`others`
    law: sp.Expr = None
    #: its slope ``∂ψ/∂v`` (:func:`slope_of`: without the Dirac pulses of ``sign``, nought wherever the
    #: iteration evaluates it)
    slope: sp.Expr = None
    variable: sp.Symbol = None
    others: tuple = ()
    #: the element and the law's role (``"R flow"``, ``"C"``...), for messages
    element: str = ""
    what: str = ""
    #: the name of the generated helper (``_inverse_law_<element>_<digest>``: never a user's name)
    helper: str = ""
    #: where the iteration starts (the operating point, 0 unless the law is not finite there)
    start: float = 0.0
    #: +1 for an increasing law, −1 for a decreasing one (where its slope vanishes, the iteration goes by it)
    sense: int = 1
    #: the arguments of :func:`numeric_inverse` that made the class (to make it again when unpickled)
    _made_from: tuple = ()

    @classmethod
    def _at(cls, value, args):
        """``{v: value, a_j: args[j]}``: the law's symbols at this call's arguments."""
        return {cls.variable: value, **dict(zip(cls.others, args))}

    def fdiff(self, argindex=1):
        if not 1 <= argindex <= len(self.args):
            raise sp.ArgumentIndexError(self, argindex)
        at = self._at(self, self.args[1:])
        slope = self.slope.xreplace(at)
        if argindex == 1:
            return 1 / slope
        return -sp.diff(self.law, self.others[argindex - 2]).xreplace(at) / slope

    def _eval_evalf(self, prec):
        import mpmath

        values = [a.evalf(prec) for a in self.args]
        if not all(v.is_Number for v in values):
            return None
        dps = max(15, int(prec * math.log10(2)) + 5)
        law = sp.lambdify([self.variable, *self.others], self.law, "mpmath")
        with mpmath.workdps(dps):
            y, rest = mpmath.mpf(values[0]), [mpmath.mpf(v) for v in values[1:]]

            def residual(v):
                return law(v, *rest) - y

            low = high = mpmath.mpf(self.start)
            if residual(low) == 0:
                return sp.Float(self.start, precision=prec)
            width = mpmath.mpf(1)
            for _ in range(2200):  # a bracket grown geometrically about the start (on both sides)
                low, high = low - width, high + width
                if residual(low) * residual(high) <= 0:
                    break
                width *= 2
            else:
                return None
            for _ in range(4 * prec + 200):  # bisection until no number of the working precision lies between
                middle = (low + high) / 2
                if middle in (low, high):
                    break
                if residual(low) * residual(middle) <= 0:
                    high = middle
                else:
                    low = middle
            root = (low + high) / 2
        return sp.Float(root, precision=prec)

    def __reduce_ex__(self, protocol):
        """Pickled as the law it inverts and its arguments: the class, made per law, is made again."""
        return _rebuilt, (self._made_from, self.args)

    def _pythoncode(self, printer):
        """The call of the generated helper (the code generator's printer); ``sympy.lambdify`` prints
        the function by its name and calls :func:`_imp_`."""
        return f"{self.helper}({', '.join(printer._print(a) for a in self.args)})"


def _identifier(name: str) -> str:
    return re.sub(r"[^0-9A-Za-z_]", "_", name)


@functools.lru_cache(maxsize=1024)
def numeric_inverse(law: sp.Expr, variable: sp.Symbol, element: str, what: str, sense: int, start: float) -> type:
    """The :class:`InverseLaw` subclass ``inverse_law_<element>`` of ``law``
    (an expression of ``variable``), one per law (cached: the same class for
    every mode that needs it).  Its helper's name carries a digest of the law,
    so two laws of elements of the same name never share one."""
    others = tuple(sorted(law.free_symbols - {variable}, key=lambda s: (s.name, sp.srepr(s))))
    digest = hashlib.blake2b(sp.srepr((law, variable)).encode(), digest_size=4).hexdigest()
    # real (d|v|/dv = sign(v), not a derivative of re and im); "_v" is never a user's name
    real = sp.Symbol("_v", real=True)
    made = type(f"inverse_law_{_identifier(element)}", (InverseLaw,),
                {"law": law.xreplace({variable: real}), "variable": real, "others": others, "element": element,
                 "slope": slope_of(law.xreplace({variable: real}), real),
                 "what": what,
                 "helper": f"_inverse_law_{_identifier(element)}_{digest}", "start": float(start), "sense": sense,
                 "_made_from": (law, variable, element, what, sense, start),
                 "__module__": __name__})
    made._imp_ = _evaluator(made)
    return made


def slope_of(law: sp.Expr, variable: sp.Symbol) -> sp.Expr:
    """``∂law/∂variable`` without its Dirac pulses: ``sign(v)·v²`` has the slope
    ``2|v|`` (its ``2v²·δ(v)`` is nought everywhere the slope is evaluated)."""
    slope = sp.diff(law, variable)
    return slope.replace(lambda e: isinstance(e, sp.DiracDelta), lambda e: sp.S.Zero) \
        if slope.has(sp.DiracDelta) else slope


def _evaluator(law_class) -> staticmethod:
    """The function ``sympy.lambdify`` calls for ``law_class`` (its ``_imp_``): the root at double
    precision by :meth:`InverseLaw._eval_evalf`, element by element over arrays (a jump map of
    nonlinear storage, ``bondgraph.jump``, evaluates it a few times per jump)."""
    import numpy as np

    def one(*values):
        value = law_class(*[sp.Float(float(v)) for v in values]).evalf(17)
        return float(value) if value.is_Number else math.nan

    return staticmethod(np.vectorize(one, otypes=[float]))


def _rebuilt(made_from: tuple, args: tuple) -> InverseLaw:
    """An unpickled :class:`InverseLaw`: its class from :func:`numeric_inverse`, applied to ``args``."""
    return numeric_inverse(*made_from)(*args)


def _exact(expr: sp.Expr) -> sp.Expr:
    """``expr`` with every float replaced by the exact decimal it prints as."""
    floats = expr.atoms(sp.Float)
    return expr.xreplace({c: sp.Rational(repr(float(c))) for c in floats}) if floats else expr


def _sample_values(symbols) -> dict:
    """Fixed random values in ``[1/2, 2]`` (exact rationals) for the law's other symbols."""
    rng = random.Random(28)
    return {s: sp.Rational(rng.randint(500, 2000), 1000) for s in sorted(symbols, key=str)}


def _real(value) -> float | None:
    """``value`` (a sympy or mpmath number) as a float when it is real and
    finite, else ``None``."""
    try:
        number = complex(value)
    except (TypeError, ValueError, OverflowError):
        return None
    if not (math.isfinite(number.real) and math.isfinite(number.imag)):
        return None
    return number.real if abs(number.imag) <= 1e-12 * (1 + abs(number.real)) else None


def _sign(value) -> int | None:
    """The sign (−1, 0, 1) of a real mpmath number, however large; ``None``
    for an infinity, a NaN or a value with an imaginary part."""
    import mpmath

    if isinstance(value, mpmath.mpc):
        if value.imag != 0 and abs(value.imag) > 1e-12 * (1 + abs(value.real)):
            return None
        value = value.real
    try:
        value = mpmath.mpf(value)
    except (TypeError, ValueError):
        return None
    if mpmath.isnan(value) or mpmath.isinf(value):
        return None
    return (value > 0) - (value < 0)


def _gives_back(law, variable, y, branch, values) -> bool:
    """Does ``branch(law(v)) = v`` hold at every sample point where ``law(v)`` is real (and at one at least)?"""
    if branch.has(sp.I):
        return False
    law, branch = _exact(law).xreplace(values), _exact(branch).xreplace(values)
    checked = 0
    for v in SAMPLES:
        value = law.xreplace({variable: v})
        if _real(value.evalf(30)) is None:
            continue  # outside the law's real domain
        back = _real(branch.xreplace({y: value}).evalf(30))
        if back is None or abs(back - float(v)) > 1e-6 * (1 + abs(float(v))):
            return False
        checked += 1
    return checked > 0


def branch_on_the_line(law: sp.Expr, variable: sp.Symbol, y: sp.Symbol, solutions) -> sp.Expr | None:
    """The solution (of ``solutions``, expressions of ``y``) that inverts
    ``law`` at every sample point of its real domain (see the module
    docstring), or ``None``; the check runs in the budget (``None`` when it
    runs out)."""
    values = _sample_values(law.free_symbols - {variable})

    def first():
        return next((s for s in solutions if _gives_back(law, variable, y, s, values)), None)

    try:
        return budget.run(f"checking the branches of the inverse of {law}", first)
    except budget.OverBudget:
        return None


#: where a closed-form inverse is evaluated in floating point against its exact value: y = ψ(±10^(k/2)), k = −6 … 6
#: (from 10⁻³ on: closer to the operating point, ``log(1 + x)`` of a diode's inverse loses digits as ``x → 0``,
#: as any closed form with the identity's first term subtracted out does; what is refused is a closed form
#: that loses them where the law does not flatten, Cardano's cancellation at large y)
ACCURACY_SAMPLES = tuple(s * sp.Integer(10) ** sp.Rational(k, 2) for k in range(-6, 7) for s in (-1, 1))
_EPS = 2.0**-52


def computes_accurately(law: sp.Expr, variable: sp.Symbol, y: sp.Symbol, branch: sp.Expr) -> bool:
    """Does ``branch`` (an inverse of ``law``, an expression of ``y``), evaluated
    in floating point, keep its digits?  At ``y = ψ(v)`` rounded to a double
    for ``v`` in :data:`ACCURACY_SAMPLES` (the law's other symbols at the values
    of :func:`branch_on_the_line`), its value in doubles must be within
    ``10⁻¹⁰`` relative of its exact value at that very double, or within
    ``64·ε·|y·s′(y)|`` — what the rounding of ``y`` alone moves it by, the
    inverse's own conditioning.  Cardano's formula for ``v + v³`` fails this
    (``−27y/2 + √(729y² + 108)/2`` cancels for large ``y``); ``VT·log(1 +
    y/Is)`` of a diode passes (where it cancels, its conditioning is as bad).
    Runs in the budget (``True``: the closed form kept, when it runs out).
    A branch with Lambert's W is kept: the code generator computes it through
    the Wright omega function, which never overflows (:mod:`codegen.lambert`),
    unlike ``W`` of an exponential here."""
    if branch.has(sp.LambertW):
        return True
    values = _sample_values(law.free_symbols - {variable})
    exact_law, exact_branch = _exact(law).xreplace(values), _exact(branch).xreplace(values)
    slope = sp.diff(exact_branch, y)
    try:
        in_doubles = sp.lambdify([y], branch.xreplace({s: float(v) for s, v in values.items()}), "math")
    except Exception:  # noqa: BLE001 - not printable for floats: nothing to compare
        return True

    def check():
        for v in ACCURACY_SAMPLES:
            value = _real(exact_law.xreplace({variable: v}).evalf(30))
            if value is None:
                continue
            at = {y: sp.Rational(value)}
            exact = _real(exact_branch.xreplace(at).evalf(30))
            if exact is None:
                continue
            scale = 64 * _EPS * abs(value) * abs(_real(slope.xreplace(at).evalf(30)) or 0.0)
            if scale >= abs(exact):
                continue  # the rounding of y alone leaves no digit of v here
            try:
                computed = float(in_doubles(value))
            except (ValueError, ArithmeticError, TypeError):
                computed = math.nan
            if not abs(computed - exact) <= 1e-10 * abs(exact) + scale:
                return False
        return True

    try:
        return budget.run(f"checking the digits of the inverse {branch}", check)
    except budget.OverBudget:
        return True


def monotonic_sense(law: sp.Expr, variable: sp.Symbol) -> tuple[int, float] | None:
    """``(sense, start)`` when ``law`` is monotonic at the sample points
    :data:`SLOPE_SAMPLES` (``sense`` +1 increasing, −1 decreasing; ``start``
    the first of 0, 1, −1 where the law and its slope are finite), else
    ``None``.  The check runs in the budget (mpmath's numbers have no range,
    and ``exp(exp(exp(v)))`` at ``v = 1000`` has no end): past it, raises
    :class:`~bondgraph.budget.OverBudget`."""
    values = {s: float(v) for s, v in _sample_values(law.free_symbols - {variable}).items()}
    real = sp.Dummy(variable.name, real=True)
    law = law.xreplace({variable: real, **values})
    try:
        slope = sp.lambdify([real], slope_of(law, real), "mpmath")
        value = sp.lambdify([real], law, "mpmath")
    except Exception:  # noqa: BLE001 - a law lambdify cannot print: not checkable, so not monotonic
        return None
    return budget.run(f"checking that {law} is monotonic", _sense_and_start, slope, value)


def _at_sample(function, v):
    """``function(v)`` (an mpmath number), ``None`` where it is not defined."""
    try:
        return function(v)
    except (TypeError, ValueError, ArithmeticError):
        return None


def _sense_and_start(slope, value) -> tuple[int, float] | None:
    """:func:`monotonic_sense` for the law ``value`` and its ``slope`` (functions of an mpmath number)."""
    signs = set()
    for v in SLOPE_SAMPLES:
        s = _sign(_at_sample(slope, v))
        if s is None:
            return None  # not defined on the whole line: no numeric inverse (its bracket would leave the domain)
        if s != 0:
            signs.add(s)
    if len(signs) != 1:
        return None
    for start in (0.0, 1.0, -1.0):
        if _real(_at_sample(value, start)) is not None and _sign(_at_sample(slope, start)) is not None:
            return signs.pop(), start
    return None


def within_range(law: sp.Expr, variable: sp.Symbol, y: sp.Symbol, branch: sp.Expr) -> sp.Expr:
    """``branch`` (a closed-form inverse of ``law``) carrying the law's range: NaN for a ``y`` the law never
    takes, where the closed form would give a real number that is no answer (``tan(2)`` for ``atan(v) = 2``:
    ``atan`` stays within ``±π/2``); the flow that asks for it then stops with a non-finite state.  The range
    is sympy's over the real line, in the budget; a law onto the whole line, a range sympy does not find, and
    a closed form that leaves the reals by itself outside the range (``log(1 + y/Is)`` of a diode below
    ``−Is``: the law that failed is named there) are kept as they are."""
    def found():
        from sympy.calculus.util import function_range

        return function_range(law, variable, sp.S.Reals)

    try:
        image = budget.run(f"the range of {law}", found)
    except (budget.OverBudget, NotImplementedError, ValueError, TypeError):
        return branch
    if not isinstance(image, sp.Interval) or image == sp.S.Reals or image.free_symbols:
        return branch
    outside = [value for value in (image.inf - 1, image.sup + 1) if value.is_finite]
    if not any(_real(branch.xreplace({y: value}).evalf(30)) is not None for value in outside):
        return branch
    return sp.Piecewise((branch, image.as_relational(y)), (sp.nan, True))
