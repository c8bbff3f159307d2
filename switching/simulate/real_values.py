"""Laws that leave the real numbers during a run.

A law real for its parameters may still leave the reals at some states:
``sqrt(q)`` of a capacitor whose charge turns negative, ``f**1.5`` of a
flow that reverses.  Python's ``math.sqrt`` then raises a domain error,
Python's ``**`` returns a complex number that no state vector can store,
numpy's gives NaN.  :func:`complex_law_message` finds *which* element law
did it: every element equation ``v = φ(inputs)`` of the mode's causal
assignment is evaluated (in complex arithmetic) at the state, and an
element whose inputs are real but whose output is not (or cannot be
evaluated) is named, with its law, the values it read, the mode and the
time.  :func:`failure_point` recovers the state and time at which a
generated mode function failed from the traceback of the error, so the
diagnosis is made where the value left the reals, not where the flow began.
"""

from __future__ import annotations

import cmath

import numpy as np
import sympy as sp

from ..errors import ComplexValueError

__all__ = ["ComplexValueError", "complex_failure", "complex_laws", "complex_law_message", "failure_point",
           "is_complex_failure"]  # ComplexValueError: defined with the other errors, raised from here

#: an imaginary part counts when it exceeds this fraction of the value's size (and of 1)
_IMAGINARY_TOLERANCE = 1e-12


def is_complex_failure(exc: BaseException) -> bool:
    """Whether an error raised inside a mode function is a value leaving the
    reals: a math domain error, or a complex number stored as a float."""
    text = str(exc)
    return ((isinstance(exc, ValueError) and "math domain error" in text)
            or (isinstance(exc, TypeError) and "complex" in text))


def failure_point(exc: BaseException):
    """``(x, t)`` of the innermost generated mode function (``<hbg mode …>``)
    on the traceback of ``exc``, or ``None``."""
    found = None
    tb = exc.__traceback__
    while tb is not None:
        frame = tb.tb_frame
        if frame.f_code.co_filename.startswith("<hbg mode") and {"x", "t"} <= set(frame.f_locals):
            found = frame.f_locals["x"], frame.f_locals["t"]
        tb = tb.tb_next
    if found is None:
        return None
    try:
        return np.array(found[0], dtype=float), float(found[1])
    except (TypeError, ValueError):
        return None


def _value(expr, values):
    """``expr`` at ``values`` as a Python complex, or ``None`` if it is not a
    number there (a domain error, a pole, a symbol left)."""
    try:
        number = complex(sp.sympify(expr).xreplace(values).evalf())
    except (TypeError, ValueError, ArithmeticError):
        return None
    return number if cmath.isfinite(number) else None


def _is_real(number) -> bool:
    return number is not None and abs(number.imag) <= _IMAGINARY_TOLERANCE * max(1.0, abs(number.real))


def complex_laws(model, mode, x, t: float) -> list[tuple]:
    """``(element, variable, expression, output, inputs)`` for every element
    equation of ``mode`` whose inputs are real at state ``x`` (n,) and time
    ``t`` but whose output is complex or not a number (``output`` ``None``)."""
    me = model.mode_equations(mode)
    eq = me.equations
    values = {**{k: sp.Float(v) for k, v in model.parameter_values_with_inputs(t).items()},
              model.time: sp.Float(t)}
    values.update({s: sp.Float(v) for s, v in zip(model.states, np.asarray(x, dtype=float))})
    values.update({k: sp.sympify(v) for k, v in me.values.items()})
    numbers = dict(values)
    for x_sym, rate in eq.rates.items():
        numbers[eq.rate_symbols[x_sym]] = _value(rate, values)
    for name, bond in eq.graph.bonds.items():
        numbers[bond.effort] = _value(eq.resolve(eq.efforts[name]), values)
        numbers[bond.flow] = _value(eq.resolve(eq.flows[name]), values)
    found = []
    for relation in eq.causality.relations.relations.values():
        reads = {s: numbers.get(s) for s in relation.expr.free_symbols if s not in values}
        if not all(_is_real(v) for v in reads.values()):
            continue  # a value it reads is not real (or not known): the culprit is further up
        output = _value(relation.expr, {**values, **{s: sp.Float(v.real) for s, v in reads.items()}})
        if not _is_real(output):
            shown = {s: float(values[s]) for s in relation.expr.free_symbols if s in values and values[s].is_Float}
            shown.update({s: v.real for s, v in reads.items()})
            found.append((relation.element, relation.var, relation.expr, output, shown))
    return found


def complex_law_message(model, mode, x, t: float) -> str | None:
    """A message naming the element laws that leave the reals at ``(x, t)``
    in ``mode`` (see :func:`complex_laws`), or ``None`` when none does."""
    found = complex_laws(model, mode, x, t)
    if not found:
        return None
    state = ", ".join(f"{s.name} = {v:.6g}" for s, v in zip(model.states, np.asarray(x, dtype=float)))
    lines = [f"an element law leaves the real numbers at t = {t:.12g} s in mode {mode.describe()} "
             f"(state {state}):"]
    for element, var, expr, output, reads in found:
        shown = "no real value (outside its domain)" if output is None else f"{output.real:.6g}{output.imag:+.6g}j"
        read = ", ".join(f"{s.name} = {v:.6g}" for s, v in sorted(reads.items(), key=lambda kv: kv[0].name))
        lines.append(f"  {element!r}: {var} = {expr} gives {shown} for {read}")
        lines.extend(_inverse_hints(expr))
    lines.append("The toolkit computes with real numbers only: keep the law real over the states the run "
                 "reaches (e.g. sqrt(Abs(q)) or sign(q)*sqrt(Abs(q)) for sqrt(q)), or switch modes before the "
                 "state leaves the law's domain.")
    return "\n".join(lines)


def _inverse_hints(expr) -> list:
    """A line for each numeric inverse of a law in ``expr`` (:mod:`bondgraph.inverse`): the value asked
    of it is one the law never takes (or its iteration did not converge there)."""
    from bondgraph.inverse import InverseLaw

    lines = []
    for call in sorted(sp.sympify(expr).atoms(InverseLaw), key=str):
        law = call.law.xreplace({call.variable: sp.Symbol(call.variable.name.lstrip("_"))})
        lines.append(f"    ({call.func.__name__} is the numeric inverse of the {call.what} law {law} of "
                     f"{call.element!r}: the law never takes that value, or its iteration found no bracket "
                     "from the operating point; give the law in the causality the graph needs, or keep the run "
                     "within the law's range)")
    return lines


def complex_failure(model, mode, exc: BaseException) -> dict | None:
    """For an error raised by a mode function during a run in ``mode``: the
    arguments of a :class:`ComplexValueError` (``message``, ``elements``,
    ``x``) and the time ``t`` [s] when a law left the reals at the state it failed at, else ``None``."""
    if not is_complex_failure(exc):
        return None
    point = failure_point(exc)
    if point is None:
        return None
    x, t = point
    try:
        found = complex_laws(model, mode, x, t)
        message = complex_law_message(model, mode, x, t) if found else None
    except Exception:  # the diagnosis must never hide the original error
        return None
    if message is None:
        return None
    return {"message": message, "elements": sorted({f[0] for f in found}), "x": x, "t": float(t)}
