"""The functions of a flow in one mode: the rates of its independent states
and the full state from them (the dependent ones on their constraints), and
the guards' comparison sides, on Python floats where that is faster, with
the same IEEE results as on arrays."""

from __future__ import annotations

import re
import weakref

import numpy as np

__all__ = ["flow_functions", "sides_function"]

_NUMERIC_ERRORS = (ArithmeticError, TypeError)  # where Python floats raise and numpy scalars give inf/NaN
_READS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _reads(cm, name):
    """The state indices the generated function ``name`` of ``cm`` reads,
    from its source (``local = x[k]`` lines, and those of the block functions
    it calls on ``x``); ``None`` when that cannot be told for sure."""
    known = _READS.setdefault(cm, {})
    if name not in known:
        known[name] = _read_by(cm, cm.function_text(name))
    return known[name]


def _read_by(cm, text):
    """:func:`_reads` of one function's ``text``."""
    body = re.split(r"^def ", text, flags=re.MULTILINE)[1].split('"""')  # (the function, not helpers after it)
    code = body[2] if len(body) == 3 else None
    if code is None:
        return None
    reads = {int(k) for k in re.findall(r"^ +\w+ = x\[(\d+)\]$", code, re.MULTILINE)}
    calls = re.findall(r"^    (_rates_[0-9a-f]{12})\(x, t, p, u, out\[\d+:\d+\]\)$", code, re.MULTILINE)
    if len(re.findall(r"\bx\[", code)) != len(re.findall(r"^ +\w+ = x\[(\d+)\]$", code, re.MULTILINE)) or \
            len(re.findall(r"\bx\b", code)) != len(re.findall(r"\bx\[", code)) + len(calls):
        return None  # (x read otherwise than by unpacking, or handed to something other than a block)
    for block in calls:
        found = _read_by(cm, cm.function_text(block))
        if found is None:
            return None
        reads |= found
    return reads


def _inputs(model):
    """``(inputs, u0)``: the input function, or ``None`` and the constant (empty) inputs."""
    if model.input_symbols:
        return model.input_values, None
    return None, model.input_values(0.0)


def flow_functions(model, cm, x):
    """``(fun, state_at, y0)`` of a flow from ``x`` in the mode of ``cm``:
    ``fun(tau, y)`` the rates of the independent states ``y`` and
    ``state_at(tau, y)`` the full state (a new array), with the values of
    ``cm.rates`` and ``cm.complete``.

    For speed the generated functions run on Python floats (lists): several
    times faster than on numpy scalars, with the same IEEE results; where
    Python floats raise instead of giving inf or NaN (a division by zero, an
    overflowing power) the evaluation is repeated on arrays.  The rates skip
    the dependent states when they do not read them."""
    ind, dep = cm.independent, cm.dependent
    n = cm.n
    template = x.copy()
    if not len(ind):  # nothing flows: step a dummy variable so time guards are still found
        def state_at(tau, y):  # the dependent states follow their constraints (which may hold t or inputs)
            return cm.complete(template.copy(), tau) if len(dep) else template.copy()

        return (lambda tau, y: np.zeros(1)), state_at, np.zeros(1)
    rates, phi, p = cm._rates, cm._phi, model.parameter_array  # the mode's generated functions
    floats = p.tolist()
    inputs, u0 = _inputs(model)
    ind_l, dep_l = ind.tolist(), dep.tolist()
    whole = not dep_l and ind_l == list(range(n))  # y is the whole state
    low, high = ind_l[0], ind_l[0] + len(ind_l)
    contiguous = ind_l == list(range(low, high))
    reads = _reads(cm, "rates")
    with_dependent = bool(dep_l) and (reads is None or not reads.isdisjoint(dep_l))
    base = template.tolist()
    work = np.empty(n)
    dep_out = np.empty(len(dep_l))

    def on_arrays(tau, y, u):  # numpy's math: inf or NaN where Python floats raise
        rates_np, phi_np = cm.on_numpy("rates"), cm.on_numpy("phi")
        tau = np.float64(tau)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if whole:
                return rates_np(np.asarray(y, dtype=float), tau, p, u, np.empty(n))
            z = template.copy()
            z[ind] = y
            if dep_l:
                z[dep] = phi_np(z, tau, p, u, np.empty(len(dep_l)))
            return rates_np(z, tau, p, u, work)[ind]

    def fun(tau, y):
        u = u0 if inputs is None else inputs(tau)
        try:
            if whole:
                return rates(y.tolist(), tau, floats, u, np.empty(n))
            z = base.copy()
            if contiguous:
                z[low:high] = y.tolist()
            else:
                for k, value in zip(ind_l, y.tolist()):
                    z[k] = value
            if with_dependent:
                for k, value in zip(dep_l, phi(z, tau, floats, u, dep_out).tolist()):
                    z[k] = value
            return rates(z, tau, floats, u, work)[ind]
        except _NUMERIC_ERRORS:
            return on_arrays(tau, y, u)

    def fun_list(tau, y):
        """``fun`` on a list, returning a list (for the fixed-step methods)."""
        u = u0 if inputs is None else inputs(tau)
        try:
            if whole:
                return rates(y, tau, floats, u, work).tolist()  # numpy stores: a complex value raises
            z = base.copy()
            if contiguous:
                z[low:high] = y
            else:
                for k, value in zip(ind_l, y):
                    z[k] = value
            if with_dependent:
                for k, value in zip(dep_l, phi(z, tau, floats, u, dep_out).tolist()):
                    z[k] = value
            out = rates(z, tau, floats, u, work)
            return out[low:high].tolist() if contiguous else out[ind].tolist()
        except _NUMERIC_ERRORS:
            return on_arrays(tau, np.array(y), u).tolist()

    if whole:
        def state_at(tau, y):
            return y.copy()
    else:
        def state_at(tau, y):
            s = template.copy()
            s[ind] = y
            if dep_l:
                s[dep] = phi(s, tau, p, u0 if inputs is None else inputs(tau), dep_out)
            return s

    fun.on_lists = fun_list
    return fun, state_at, x[ind]


def sides_function(model, cm):
    """``sides(x, tau)``: the guards' comparison sides as a list of floats
    (computed on Python floats, on arrays where those raise), as ``cm.sides``."""
    generated, p, count = cm._sides, model.parameter_array, cm.n_sides
    floats = p.tolist()
    inputs, u0 = _inputs(model)

    def sides(x, tau):
        u = u0 if inputs is None else inputs(tau)
        try:
            return generated(x.tolist(), float(tau), floats, u, np.empty(count)).tolist()
        except _NUMERIC_ERRORS:
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # a side or scale may be inf
                return cm.on_numpy("sides")(np.asarray(x, dtype=float), np.float64(tau), p, u,
                                            np.empty(count)).tolist()

    return sides
