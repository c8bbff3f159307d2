"""Checks before a flow starts: every rate and guard side finite at its first state.

A flow from a state where ``ẋ = f(x)`` or a guard comparison side is NaN or
infinite cannot go anywhere: an adaptive integrator chooses a NaN step and
never reaches its end, a guard whose side is NaN silently never fires.
:func:`nonfinite_at_start` names each such rate or side with the parameters
its expression reads, those that are zero or non-finite first (a zero
inductance ``L`` in ``ẋ = v/L``), and each element law that leaves the real
numbers there (``sqrt`` of a negative charge, which numpy makes NaN), so the
error says what to fix.  The check costs one evaluation of ``f`` and of the
guard sides per flow started.
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from ..library.compiled import condition_tree, decide_tree
from .real_values import complex_law_message

__all__ = ["nonfinite_at_start", "nonfinite_sides_at_start"]


def _comparisons(tree, out: list) -> list:
    """The ``("rel", k, op, text)`` leaves of a guard tree, in order."""
    kind = tree[0]
    if kind in ("and", "or"):
        for branch in tree[1]:
            _comparisons(branch, out)
    elif kind == "not":
        _comparisons(tree[1], out)
    elif kind == "rel":
        out.append(tree)
    return out


def _parameters_read(model, expr) -> str:
    """The parameters an expression reads with their values, the suspicious ones (0, NaN, ±inf) first."""
    values = model.parameter_values
    used = sorted((s for s in expr.free_symbols if s in values), key=lambda s: s.name)
    suspicious = [s for s in used if values[s] == 0 or not np.isfinite(values[s])]
    rest = [s for s in used if s not in suspicious]
    if not used:
        return ""
    text = ", ".join(f"{s.name} = {values[s]:g}" for s in suspicious + rest)
    return f"; it reads {text}"


#: per compiled mode (held weakly: a mode and its model go when they are dropped), the sides' arguments
#: (:func:`_sides_key`) where every side was finite lately: the last kept of each
_FINITE_SIDES: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
_FINITE_SIDES_KEPT = 64


def _sides_key(cm, x, t) -> tuple:
    """Everything ``cm.sides(x, t)`` reads besides its mode: the mode's generated function, the state
    (its type and bits), the time [s], the parameters and the inputs at ``t`` of the mode's model, to
    the bit (``-0.0`` is not ``0.0``).  A loop of runs from the same state with other tolerances, ends or
    outputs (a tolerance study) evaluates the start's sides once."""
    model = cm.model
    inputs = model.input_values(t)
    return (cm._sides, type(x), np.asarray(x, dtype=float).tobytes(), float(t).hex(),
            model.parameter_array.tobytes(), tuple(map(float.hex, map(float, inputs))) if inputs else ())


def nonfinite_sides_at_start(model, cm, x, t, rtol: float, atol: float) -> str | None:
    """Where the compiled kernel starts a run at ``x`` (n,), ``t`` [s] in the mode of ``cm``: unless a guard
    holds there (the kernel then resolves the instant first), :func:`nonfinite_at_start` with
    ``rates=False`` — a guard whose side is not finite would never fire.  The sides are evaluated once,
    and only a side that is not finite asks whether a guard holds (with the guard tolerances ``rtol``,
    ``atol``): where all are finite there is nothing to tell either way."""
    if not cm.n_sides:
        return None
    key, finite = _sides_key(cm, x, t), _FINITE_SIDES.get(cm)
    if finite is not None and key in finite:
        return None
    sides = cm.sides(x, t)
    if all(map(math.isfinite, np.asarray(sides, dtype=float).tolist())):
        if finite is None or len(finite) >= _FINITE_SIDES_KEPT:
            finite = _FINITE_SIDES[cm] = set()
        finite.add(key)
        return None
    if any(decide_tree(g["tree"], sides, rtol, atol) for g in cm.guards):
        return None
    return nonfinite_at_start(model, cm, x, t, rates=False)


def nonfinite_at_start(model, cm, x, t, rates: bool = True) -> str | None:
    """A message naming every non-finite rate ``dx_k/dt`` and guard side of
    the mode of ``cm`` at the state ``x`` (n,) and time ``t`` [s], or ``None``
    when all are finite.  Round-off scales of the sides are not checked (they
    may be infinite where a derivative is, e.g. ``acos`` at ±1).  With
    ``rates=False`` only the guard sides are checked first (the compiled
    kernel tells non-finite rates itself, and its failure then asks for the
    whole message): the rates are evaluated only when a side is not finite."""
    x = np.asarray(x, dtype=float)
    if not rates and cm.n_sides:
        with np.errstate(all="ignore"):
            if np.isfinite(np.asarray(cm.sides(x, t), dtype=float)).all():
                return None
    elif not rates:
        return None
    with np.errstate(all="ignore"):  # numpy's math: inf or NaN where Python floats would raise
        try:
            rates = np.asarray(cm.on_numpy("rates")(x, np.float64(t), model.parameter_array, model.input_values(t),
                                                    np.empty(cm.n)), dtype=float)
        except (ArithmeticError, ValueError) as exc:
            rates = np.full(cm.n, np.nan)
            rates_error = str(exc)
        else:
            rates_error = ""
        sides = np.asarray(cm.sides(x, t), dtype=float) if cm.n_sides else np.zeros(0)
    if np.isfinite(rates).all() and np.isfinite(sides).all():
        return None  # (the common case, at every flow started: no search through the guards)
    bad_rates = np.flatnonzero(~np.isfinite(rates))
    leaves = [(guard, leaf) for guard in cm.guards for leaf in _comparisons(guard["tree"], [])]
    bad_sides = [(guard, leaf, side, sides[3 * leaf[1] + j])
                 for guard, leaf in leaves for j, side in enumerate(("left", "right"))
                 if not np.isfinite(sides[3 * leaf[1] + j])]
    if not len(bad_rates) and not bad_sides:
        return None
    me = model.mode_equations(cm.mode)
    relations: list = []  # every comparison of the mode, in the order of the generated sides
    for guard in me.guards:
        condition_tree(guard.condition, relations)
    infinite_allowed = {s for s in model.parameter_values if s.name in model.allow_infinite}

    def allowed(expr, value) -> bool:  # ±inf read from a parameter the model allows to be infinite
        return np.isinf(value) and bool(expr.free_symbols & infinite_allowed)

    bad_rates = [k for k in bad_rates if not allowed(me.f[model.states[k]], rates[k])]
    bad_sides = [(guard, leaf, side, value) for guard, leaf, side, value in bad_sides
                 if not allowed(me.finite(relations[leaf[1]].lhs if side == "left" else relations[leaf[1]].rhs),
                                value)]
    if not bad_rates and not bad_sides:
        return None
    lines = [f"non-finite values where a flow starts, at t = {t:.12g} s in mode {cm.mode.describe()}:"]
    for k in bad_rates:
        state = model.states[k]
        value = f"cannot be evaluated ({rates_error})" if rates_error else f"= {rates[k]}"
        lines.append(f"  d{state.name}/dt {value}{_parameters_read(model, me.f[state])}")
    for guard, (_, k, op, text), side, value in bad_sides:
        expr = relations[k].lhs if side == "left" else relations[k].rhs
        lines.append(f"  {side} side of {text!r} in guard {guard['text']!r} of automaton {guard['automaton']!r} "
                     f"({guard['source']} → {guard['target']}) = {value}{_parameters_read(model, me.finite(expr))}")
    if bad_rates:
        complex_laws = complex_law_message(model, cm.mode, x, t)  # NaN from numpy where a law left the reals
        if complex_laws:
            lines.append(complex_laws)
    lines.append("Check the values named: storage parameters (capacitance, inductance, mass) and divisors must be "
                 "finite and nonzero, and the initial state inside the model's range.")
    return "\n".join(lines)

