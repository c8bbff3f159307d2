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
samples see its window: the sinusoids of time in the guards (and in the
signals they name) bound the step the same way — a boost converter run
without ``max_step`` stepped 200 µs over its 50 µs PWM windows and read
74.7 V for 24.0 V — and a circuit's PWM switch bounds it by half its
shortest on or off window (``HybridModel.max_step_hint``, set by
``Circuit.build``) — a synchronous buck's low-side opening at 3.58 periods
was stepped over without it.
"""

from __future__ import annotations

import functools
import math
import weakref

import sympy as sp

from bondgraph.elements import Source
from bondgraph.errors import HybridBondGraphError
from bondgraph.symbols import t as TIME

__all__ = ["PERIOD_FRACTION", "guard_periods", "source_periods", "step_bound"]

#: the steps of an adaptive method per period of the fastest source sinusoid, at least
PERIOD_FRACTION = 16


def _periods(expr: sp.Expr, values: dict) -> list[float]:
    """The periods [s] of the sinusoids of ``t`` in ``expr`` (arguments affine in ``t``, their
    coefficients numbers once ``values`` — symbol → a number as the model holds it — are substituted)."""
    periods = []
    for turn, rate, symbols in _sinusoids(expr):
        period = _period(turn, rate, tuple((s, type(values[s]), values[s]) for s in symbols if s in values))
        if period is not None:
            periods.append(period)
    return periods


@functools.lru_cache(maxsize=1024)
def _sinusoids(expr: sp.Expr) -> tuple:
    """``(turn, rate, symbols)`` of each ``sin``, ``cos`` or ``tan`` of time in ``expr``: its period's
    angle (``2π``, ``π`` for ``tan``), its argument's rate ``dθ/dt`` and the symbols that rate reads
    (derived once per expression: a warm run evaluates them only)."""
    found = []
    for function in expr.atoms(sp.sin, sp.cos, sp.tan):
        argument = function.args[0]
        if argument.has(TIME):
            rate = sp.diff(argument, TIME)
            found.append((math.pi if isinstance(function, sp.tan) else 2 * math.pi, rate,
                          tuple(sorted(rate.atoms(sp.Symbol), key=sp.default_sort_key))))
    return tuple(found)


@functools.lru_cache(maxsize=4096)
def _period(turn: float, rate: sp.Expr, values: tuple) -> float | None:
    """``turn / |rate|`` [s] with ``values`` ``((symbol, type, number), …)`` substituted (as sympy numbers),
    or ``None`` where the rate is no positive finite number (it reads time, or a symbol without a value):
    computed once per rate and values, so that a parameter study pays it only for the values it moves."""
    number = rate.xreplace({symbol: sp.Float(value) for symbol, _, value in values})
    if number.has(TIME) or not number.is_number:
        return None
    try:
        omega = abs(float(number))
    except (TypeError, ValueError):
        return None
    return turn / omega if omega > 0 and math.isfinite(omega) else None


def source_periods(model) -> list[float]:
    """The periods [s] of the sinusoids of time in ``model``'s source values and expression inputs."""
    timed = _timed_sources(model)
    inputs = [(function.expression, getattr(function, "parameters", {}))
              for function in model.input_signals.functions.values()
              if getattr(function, "expression", None) is not None]
    if not timed and not inputs:
        return []
    values = _values(model)
    periods = [period for expression in timed for period in _periods(expression, values)]
    for expression, given in inputs:
        parameters = {sp.Symbol(k): v for k, v in given.items()}
        periods += _periods(sp.sympify(expression), {**values, **parameters})
    return periods


def _values(model) -> dict:
    """Symbol → value of every parameter (made sympy numbers only where a rate reads them: :func:`_period`)."""
    return {sp.Symbol(k) if isinstance(k, str) else k: v for k, v in model.parameter_values.items()}


#: mode space → the sources' values that hold a sinusoid of time (they depend on the structure alone)
_SOURCES: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _timed_sources(model) -> list:
    """The source values of ``model`` with a ``sin``, ``cos`` or ``tan`` of time, once per structure."""
    found = _SOURCES.get(model.mode_space)
    if found is None:
        found = [element.value for element in model.graph.elements.values()
                 if isinstance(element, Source) and element.value.has(TIME)
                 and element.value.has(sp.sin, sp.cos, sp.tan)]
        _SOURCES[model.mode_space] = found
    return found


def guard_periods(model) -> list[float]:
    """The periods [s] of the sinusoids of time in ``model``'s guards and in the signals they name (a
    PWM carrier ``acos(cos(2π·f_sw·t − π·D))/π`` read by ``carrier <= D``)."""
    timed = _timed_guards(model)
    if not timed:
        return []
    values = _values(model)
    return [period for expression in timed for period in _periods(expression, values)]


#: mode space → the expressions of time its guards read (they depend on the structure alone)
_TIMED: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _timed_guards(model) -> list:
    """The guards that read time and the signals of time guards name, once per structure."""
    found = _TIMED.get(model.mode_space)
    if found is not None:
        return found
    names, seen, found = set(model.signal_names), set(), []
    for condition, _ in model.mode_space.guards.values():
        symbols = getattr(condition, "free_symbols", set())
        if TIME in symbols:
            found.append(condition)
        for symbol in symbols - seen:
            seen.add(symbol)
            if symbol != TIME and symbol.name in names:
                try:
                    expression = model.signal_expression(symbol.name)
                except HybridBondGraphError:
                    continue
                if expression.has(TIME):
                    found.append(expression)
    _TIMED[model.mode_space] = found
    return found


def step_bound(model) -> float:
    """The largest step [s] an adaptive run of ``model`` takes unless given ``max_step``: the shortest
    period of a sinusoid of time in its sources over :data:`PERIOD_FRACTION`, and its clocks' bound: the
    model's own hint where it states one (``max_step_hint``: half the shortest window of a circuit's PWM
    switches, which a step spanning it would pass unseen), else the shortest period of a sinusoid of time
    in its guards over :data:`PERIOD_FRACTION` (a clock that only guards read has its edges located only
    where a step's samples see its window: a boost converter's 50 µs PWM windows were stepped over by
    steps of 200 µs); ``inf`` without any."""
    periods = source_periods(model)
    hint = getattr(model, "max_step_hint", None)
    if hint is None:
        periods += guard_periods(model)
    bound = min(periods) / PERIOD_FRACTION if periods else math.inf
    return bound if hint is None else min(bound, hint)
