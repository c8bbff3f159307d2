"""The shortest period of the sources' sinusoids: a bound on an adaptive step.

An adaptive method's error estimate sees only its own stages.  On a flow whose
source is smooth but whose response is sharp — a rectifier's exponential diode
conducts for about 2 ms of each 20 ms period — a step grown through the
blocking phase can pass over a whole conduction pulse without any stage
landing in it, and no estimate notices: a half-wave rectifier's output read
6.64 V after 0.1 s instead of 8.109 V (ngspice: 8.108 V).  SPICE bounds its
step by ``(t_stop − t_start)/50`` for the same reason.  Here a run whose
``max_step`` is not given steps at most :data:`PERIOD_FRACTION`-th of the
shortest period of a ``sin``, ``cos`` or ``tan`` of time in a source's value
or an expression input (:func:`step_bound`).  A clock that only guards read (a
PWM carrier) has its edges located as instants, but only where a step's
samples see its window: a circuit's PWM switch bounds the step by half its
shortest on or off window (``HybridModel.max_step_hint``, set by
``Circuit.build``) — a synchronous buck's low-side opening at 3.58 periods
was stepped over without it.
"""

from __future__ import annotations

import math

import sympy as sp

from bondgraph.elements import Source
from bondgraph.symbols import t as TIME

__all__ = ["PERIOD_FRACTION", "source_periods", "step_bound"]

#: the steps of an adaptive method per period of the fastest source sinusoid, at least
PERIOD_FRACTION = 16


def _periods(expr: sp.Expr, values: dict) -> list[float]:
    """The periods [s] of the sinusoids of ``t`` in ``expr`` (arguments affine in ``t``, their
    coefficients numbers once ``values`` are substituted)."""
    periods = []
    for function in expr.atoms(sp.sin, sp.cos, sp.tan):
        argument = function.args[0]
        if not argument.has(TIME):
            continue
        rate = sp.diff(argument, TIME).xreplace(values)
        if rate.has(TIME) or not rate.is_number:
            continue
        try:
            omega = abs(float(rate))
        except (TypeError, ValueError):
            continue
        if omega > 0 and math.isfinite(omega):
            periods.append((math.pi if isinstance(function, sp.tan) else 2 * math.pi) / omega)
    return periods


def source_periods(model) -> list[float]:
    """The periods [s] of the sinusoids of time in ``model``'s source values and expression inputs."""
    values = {sp.Symbol(k) if isinstance(k, str) else k: sp.Float(v) for k, v in model.parameter_values.items()}
    periods = []
    for element in model.graph.elements.values():
        if isinstance(element, Source):
            periods += _periods(sp.sympify(element.value), values)
    for function in model.input_signals.functions.values():
        expression = getattr(function, "expression", None)
        if expression is not None:
            parameters = {sp.Symbol(k): sp.Float(v) for k, v in getattr(function, "parameters", {}).items()}
            periods += _periods(sp.sympify(expression), {**values, **parameters})
    return periods


def step_bound(model) -> float:
    """The largest step [s] an adaptive run of ``model`` takes unless given ``max_step``: the shortest
    source period over :data:`PERIOD_FRACTION`, and the model's own hint (``max_step_hint``: half the
    shortest window of a circuit's PWM switches, which a step spanning it would pass unseen); ``inf``
    without either."""
    periods = source_periods(model)
    bound = min(periods) / PERIOD_FRACTION if periods else math.inf
    return min(bound, getattr(model, "max_step_hint", math.inf))
