"""Each state's absolute tolerance, so that a default run's error control holds at every scale.

An adaptive step keeps each state's local error below ``atol_i + rtol·|x_i|``.  A single ``atol`` in
the states' own units cannot serve a model's states together: a 10 nF capacitor charged to 10 V
holds 1e-7 C, and an ``atol`` of 1e-9 C lets its voltage err by 0.1 V (1 %, whatever ``rtol``),
while the same number is far below the noise of a 1 kg·m/s momentum.  So ``simulate`` without
``atol`` gives each storage state the tolerance :data:`DEFAULT_ATOL` *in the units of the storage's
output* — the capacitor's voltage, the inductor's current, the mass's velocity, the spring's force —
times the storage's capacity ``c_i = ∂x_i/∂e_i = 1/Φ_i'(x_i)`` at the run's initial state
(``C``, ``L``, ``m``, ``1/k`` for linear storage)::

    atol_i = DEFAULT_ATOL · c_i      [the state's unit: C, V·s, kg·m/s, m]

A state that is no storage's (a displacement), a storage whose law's slope is not a positive finite
number at the initial state, or one whose slope reads inputs or time keeps ``DEFAULT_ATOL`` in its own
units.  An ``atol`` given to ``simulate`` is, as always, in the states' own units, the same for all.
"""

from __future__ import annotations

import math
import weakref
from typing import NamedTuple

import numpy as np
import sympy as sp

__all__ = ["DEFAULT_ATOL", "state_tolerances"]

#: the absolute tolerance [V, A, m/s, N, rad/s, N·m, …: the storage's output] of a run given no ``atol``
DEFAULT_ATOL = 1e-9


def state_tolerances(model, x, atol: float | None = None) -> np.ndarray:
    """``atol_i`` of every state (shape ``(n,)``, in the states' order): ``atol`` for all when given,
    else the capacity-scaled tolerances of the module docstring at the state ``x``.  What they are
    made of the same as the model's last (the states and parameters the slopes read, to the bit), the
    same array is returned (read it, never write it): a loop of runs hands the compiled kernel the
    tolerances its record holds, and a parameter study that moves other values keeps them."""
    n = len(model.states)
    slopes = _slopes(model) if atol is None else None
    if slopes is None:
        made = (n, float(atol))
    else:
        indices, reads = slopes.indices, slopes.reads
        made = (n, np.asarray(x, dtype=float)[indices].tobytes(), model.parameter_array[reads].tobytes())
    kept = _KEPT.get(model)
    if kept is not None and kept[0] is slopes and kept[1] == made:
        return kept[2]
    tolerances = np.full(n, DEFAULT_ATOL if slopes is not None else float(atol))
    for index, slope in slopes.functions if slopes is not None else ():
        try:
            value = float(slope(float(x[index]), model.parameter_array))
        except (TypeError, ValueError, ZeroDivisionError, OverflowError):
            continue
        if math.isfinite(value) and value > 0.0 and math.isfinite(DEFAULT_ATOL / value):
            tolerances[index] = DEFAULT_ATOL / value
    _KEPT[model] = (slopes, made, tolerances)
    return tolerances


#: model → (its slopes, what its last tolerances were made of, those tolerances)
_KEPT: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


class _Slopes(NamedTuple):
    """The storage slopes of a graph: ``functions`` ``[(state index, slope(x_i, parameters) → Φ'(x_i))]``,
    the states they read (``indices``) and the places of the parameters they read (``reads``)."""

    functions: list
    indices: np.ndarray
    reads: np.ndarray


def _slopes(model) -> _Slopes:
    """The slopes of the storage whose law's slope reads only its state and the parameters (compiled
    once per graph and parameter list)."""
    symbols = tuple(model.parameter_symbols)
    key, derived = ("storage slopes", symbols), model.graph.derived
    found = derived.entries.get(key)  # (the memo's own look-up, the key hashed once: its symbols hash in Python)
    return found if found is not None else derived.memo(key, lambda: _compiled_slopes(model, symbols))


def _compiled_slopes(model, symbols) -> _Slopes:
    """:class:`_Slopes` of the model's storage; one function per form of slope (a scene's thousand masses
    of one parameter ``m`` share the slope ``1/m``: one function, not a thousand)."""
    found, reads = [], set()
    known = set(symbols)
    value = sp.Dummy("x")
    functions: dict = {}  # slope with its state as `value` → its function
    for element in model.graph.storage:
        slope = sp.diff(element.law, element.state)
        if not (slope.free_symbols - {element.state}) <= known:
            continue
        form = slope.xreplace({element.state: value})
        function = functions.get(form)
        if function is None:
            function = functions[form] = sp.lambdify((value, symbols), form, "math")
        found.append((model.state_index[element.state], function))
        reads |= {symbols.index(s) for s in slope.free_symbols - {element.state}}
    return _Slopes(found, np.array([index for index, _ in found], dtype=np.int64),
                   np.array(sorted(reads), dtype=np.int64))
