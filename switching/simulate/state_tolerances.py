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

import numpy as np
import sympy as sp

__all__ = ["DEFAULT_ATOL", "state_tolerances"]

#: the absolute tolerance [V, A, m/s, N, rad/s, N·m, …: the storage's output] of a run given no ``atol``
DEFAULT_ATOL = 1e-9


def state_tolerances(model, x, atol: float | None = None) -> np.ndarray:
    """``atol_i`` of every state (shape ``(n,)``, in the states' order): ``atol`` for all when given,
    else the capacity-scaled tolerances of the module docstring at the state ``x``."""
    n = len(model.states)
    if atol is not None:
        return np.full(n, float(atol))
    tolerances = np.full(n, DEFAULT_ATOL)
    parameters = model.parameter_array
    for index, slope in _slopes(model):
        try:
            value = float(slope(float(x[index]), parameters))
        except (TypeError, ValueError, ZeroDivisionError, OverflowError):
            continue
        if math.isfinite(value) and value > 0.0 and math.isfinite(DEFAULT_ATOL / value):
            tolerances[index] = DEFAULT_ATOL / value
    return tolerances


def _slopes(model) -> list:
    """``[(state index, slope(x_i, parameters) → Φ'(x_i))]`` of the storage whose law's slope reads
    only its state and the parameters (compiled once per graph and parameter list)."""
    symbols = tuple(model.parameter_symbols)
    return model.graph.derived.memo(("storage slopes", symbols), lambda: _compiled_slopes(model, symbols))


def _compiled_slopes(model, symbols) -> list:
    found = []
    known = set(symbols)
    for element in model.graph.storage:
        slope = sp.diff(element.law, element.state)
        if not (slope.free_symbols - {element.state}) <= known:
            continue
        function = sp.lambdify((element.state, symbols), slope, "math")
        found.append((model.state_index[element.state], function))
    return found
