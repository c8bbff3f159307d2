"""Numeric inverses of element laws in generated code: a bracketed Newton iteration per law.

An expression may hold the inverse ``v = ψ⁻¹(y; a…)`` of a monotonic law
that sympy cannot invert in closed form (:class:`bondgraph.inverse.InverseLaw`,
printed as a call of its :attr:`~bondgraph.inverse.InverseLaw.helper`
``_inverse_law_<element>_<digest>(y, a…)``).  For each such law the generated
module defines that helper, a plain function of floats in the subset that
numba compiles and :mod:`codegen.native` translates (:func:`scalar_source`,
printed by :func:`codegen.source.inverse_helpers`);
every name in it is generated (``y``, ``a0``…, ``v``, the law printed by the
code generator), and its name starts with ``_``, which no sanitized user
name does (:func:`codegen.source.sanitize`).  Its loops are the only ones the
Python dialect allows, and only in functions of that prefix
(:func:`codegen.safety.check_code`).

* Python modules (:func:`python_source`) define the iteration as
  ``<helper>_at`` and the helper as ``H.elementwise(<helper>_at, y, a…)``
  (:func:`codegen.runtime.H.elementwise`): the same function on floats, on
  numpy arrays of samples (element by element) and on the impulse-aware
  values of raw code (a pulse inside a law's inverse has no meaning).
  Where Python's :mod:`math` raises (a law past the floating-point range,
  ``sinh(1000)``, which machine code computes as ``inf`` and goes on with),
  the Python helper gives NaN;
* machine-code modules (:func:`compiled_source`) define the helper itself,
  compiled by numba (``@njit``) or translated with the function that calls it.
"""

from __future__ import annotations

import sympy as sp

__all__ = ["HELPER_PREFIX", "compiled_source", "inverse_laws", "python_source", "scalar_source"]

#: the prefix of every helper's name (and of the only generated functions allowed a loop)
HELPER_PREFIX = "_inverse_law_"

#: growths of the bracket: width doubling from at least 2⁻¹⁰⁷⁴ reaches the largest double in ~2100
BRACKET_STEPS = 2100
#: Newton/bisection iterations after the bracket (bisection alone gains a bit each: 200 reach any double);
#: both phases run in one loop of BRACKET_STEPS + NEWTON_STEPS turns, left as soon as the root is found
NEWTON_STEPS = 200


def inverse_laws(kinds) -> list:
    """The :class:`~bondgraph.inverse.InverseLaw` classes among ``kinds`` (classes of expression nodes), by helper name."""
    from bondgraph.inverse import InverseLaw

    found = {k.helper: k for k in kinds if isinstance(k, type) and issubclass(k, InverseLaw) and k is not InverseLaw}
    return [found[name] for name in sorted(found)]


def _arguments(law_class) -> list:
    """The helper's argument names: ``y`` and ``a0``, ``a1``… for the law's other symbols."""
    return ["y", *(f"a{k}" for k in range(len(law_class.others)))]


def scalar_source(law_class, name: str, printed, docstring, decorator: str = "") -> str:
    """The source of ``name(y, a0, …)``: the ``v`` with ``ψ(v; a…) = y``, by
    the iteration its docstring states (see :data:`BRACKET_STEPS`,
    :data:`NEWTON_STEPS`).  ``printed(v)`` gives the law and its slope
    printed with the variable named ``v`` and the other symbols ``a0``, ``a1``…
    (:func:`codegen.source.inverse_helpers`); ``docstring`` makes the
    docstring literal (:func:`codegen.source.docstring`: user text escaped)."""
    arguments = _arguments(law_class)
    (law_a, slope_a), (law_b, _), (law, slope) = (printed(v) for v in ("a", "b", "v"))
    start = repr(float(law_class.start))
    shown = str(law_class.law.xreplace({law_class.variable: sp.Symbol("v")}))
    others = ", ".join(f"a{k} = {s}" for k, s in enumerate(law_class.others))
    doc = docstring([
        f"v with {shown} = y: the inverse of the {law_class.what} law of element {law_class.element!r}"
        + (f" ({others})." if others else "."),
        "",
        f"Bracket: from a = {start}, g(v) = law(v) - y, the root lies above a when g(a) and the slope have opposite",
        "signs; b = a ± w with w = min(2|g(a)/g'(a)|, 1) (1 if that is not a positive number: no far first try",
        "where an exponential law overflows), doubling, the bracket's",
        f"near end moved to b while g keeps its sign (at most {BRACKET_STEPS} times: NaN if g never changes sign or",
        "is not finite). Then, from the bracket's midpoint, Newton's step v - g(v)/g'(v), replaced by the midpoint",
        "of the bracket when it is not",
        "strictly inside it, each iterate replacing the end of its residual's sign; converged when the step is at",
        f"most 2**-51 |v| (full double precision), g(v) = 0, or no double lies between the ends; NaN after "
        f"{NEWTON_STEPS} steps.",
    ])
    lines = [*([decorator] if decorator else []), f"def {name}({', '.join(arguments)}):", doc,
             f"    a = {start}",
             f"    ga = ({law_a}) - y",
             "    if ga == 0.0:",
             "        return a",
             f"    da = {slope_a}",
             f"    sense = {float(law_class.sense)!r}",
             "    if da < 0.0:",
             "        sense = -1.0",
             "    if da > 0.0:",
             "        sense = 1.0",
             "    up = -1.0 if ga * sense > 0.0 else 1.0",
             "    width = 1.0",
             "    if da != 0.0:",
             "        width = 2.0 * abs(ga / da)",
             "    if not isfinite(width) or width == 0.0 or width > 1.0:",
             "        width = 1.0",
             "    b = a",
             "    gb = ga",
             "    lo = a",
             "    hi = a",
             "    v = a",
             "    found = 0",
             "    steps = 0",
             f"    for k in range({BRACKET_STEPS + NEWTON_STEPS}):",
             "        if found == 0:",
             "            b = a + up * width",
             f"            gb = ({law_b}) - y",
             "            if gb == 0.0:",
             "                return b",
             "            if gb != gb:",
             "                return nan",
             "            if (gb < 0.0) != (ga < 0.0):",
             "                found = 1",
             "                lo = a if ga < 0.0 else b",
             "                hi = b if ga < 0.0 else a",
             "                v = 0.5 * (a + b)",
             "            else:",
             f"                if not isfinite(gb) or k >= {BRACKET_STEPS}:",
             "                    return nan",
             "                a = b",
             "                ga = gb",
             "                width = width * 2.0",
             "        else:",
             "            steps = steps + 1",
             f"            if steps > {NEWTON_STEPS}:",
             "                return nan",
             f"            gv = ({law}) - y",
             "            if gv == 0.0:",
             "                return v",
             "            if gv != gv:",
             "                return nan",
             "            if gv < 0.0:",
             "                lo = v",
             "            else:",
             "                hi = v",
             f"            dv = {slope}",
             "            step = nan",
             "            if dv != 0.0 and isfinite(dv):",
             "                step = gv / dv",
             "            nv = v - step",
             "            if not ((nv > lo and nv < hi) or (nv > hi and nv < lo)):",
             "                nv = 0.5 * (lo + hi)",
             "            if abs(nv - v) <= 4.440892098500626e-16 * abs(nv):",
             "                return nv",
             "            v = nv",
             "    return nan"]
    return "\n".join(lines) + "\n"


def python_source(law_class, printed, docstring) -> str:
    """The helper of ``law_class`` for a Python module: the iteration
    ``<helper>_at`` and ``<helper>`` applying it element by element
    (:func:`codegen.runtime.H.elementwise`); ``printed``, ``docstring`` as
    for :func:`scalar_source`."""
    arguments = ", ".join(_arguments(law_class))
    return (scalar_source(law_class, f"{law_class.helper}_at", printed, docstring) + "\n\n"
            f"def {law_class.helper}({arguments}):\n"
            f'    """{law_class.helper}_at on floats, arrays or impulse-aware values."""\n'
            f"    return H.elementwise({law_class.helper}_at, {arguments})\n")


def compiled_source(law_class, printed, docstring) -> str:
    """The helper of ``law_class`` for a machine-code module (numba compiles it: ``@njit``)."""
    return scalar_source(law_class, law_class.helper, printed, docstring, '@njit(error_model="numpy")')
