"""A sampled (digital) PID controller: zero-order hold, one sample of computation delay.

:meth:`Circuit.pid`/:meth:`Mechanism.pid` with ``sample_period=T`` build the controller a DSP runs.
Its clock ticks at ``t_k = k·T + delay``, ``k = 0, 1, …`` (``0 ≤ delay < T``; a tick at
``t = 0`` is taken by the run's first instant).  At each tick, with the error ``e_k = reference − measure``
read at ``t_k``::

    u_k     = w_{k−1}                                         (the output applied: computed a sample ago)
    raw_k   = kp·e_k + I_k + kd·(e_k − e_{k−1})/T
    w_k     = min(max(raw_k, lo), hi)                         (the output the next tick applies)
    I_{k+1} = I_k + T·(ki·e_k + (w_k − raw_k)/T_t)           (back-calculation anti-windup)

``u`` is held between ticks: the signal ``<name>`` (the output, piecewise constant), ``w`` the
computed output waiting for the next tick, ``I`` the integral term (``I_0 = initial``, and
``u_0 = w_0 = initial`` until the first tick), ``T_t`` (``tracking``, default ``kp/ki``) the
anti-windup's time, ``e_{−1} = 0``.

**How it is a bond graph.**  Each held value is a storage of unit capacity (state
``q_<name>_<value>``) behind a controlled junction to an effort source whose value is the value's
update — an ideal buffer charging a hold capacitor.  The clock's automaton ``<name>_clock`` closes
them in stages at a tick, each stage a pinnacle mode: its jump is the conservation-of-state jump
onto ``q = update(x)``, which the buffer's impulse makes exactly the update, leaving every state the
update reads where it was (:mod:`bondgraph.jump`).  Each stage reads only values that stage does
not change, so the updates see the values before the tick::

    stage 1:  u ← w                                   (the hold of u)
    stage 2:  w ← clamp(raw(x)),  n ← I + T·(…),  m ← e(x)     (computing; n and m are scratch)
    stage 3:  I ← n,  E ← m                           (the integral's and the last error's update)

(``E`` and ``m``, the last error, only with a derivative: ``kd ≠ 0``.)

A stage is left at once after its jump (its exit guard, ``q == update``, an a priori comparison
within its round-off band, holds on the state after the jump and not before it), so a tick is one
instant: the instants record the three pinnacles.  A stage whose values are already updated
(``q == update`` before its jump) is mythical and leaves the state as it is.  The clock is
``sin(π(t − delay)/T)``, whose zeros are the ticks: the automaton alternates between waiting for it
to turn negative and waiting for it to turn positive (strict comparisons, so a tick located is not
taken twice), with the stages between.
"""

from __future__ import annotations

import sympy as sp

from bondgraph import C, One, Se
from bondgraph.errors import InvalidGraphError
from switching import Automaton

from ._common import Range
from .netlist import checked_number

__all__ = ["sample_values", "build_sampled_controller"]

#: the hold stages at a tick: the held values each closes (module docstring)
STAGES = (("u",), ("w", "n", "m"), ("I", "E"))


def sample_values(name: str, sample_period, sample_delay, derivative_filter) -> dict:
    """The clock of a sampled controller checked: ``{"sample_period": T, "sample_delay": delay}``
    (numbers, ``T > 0``, ``0 ≤ delay < T``), or ``None`` for both when ``sample_period`` is ``None``."""
    owner = f"controller {name!r}"
    if sample_period is None:
        if sample_delay is not None:
            raise InvalidGraphError(f"{owner}: sample_delay is given without sample_period; give the sampling "
                                    "period too (or neither, for a continuous controller)", [name])
        return {"sample_period": None, "sample_delay": None}
    period = checked_number(sample_period, f"the sample period of {owner}")
    delay = checked_number(0.0 if sample_delay is None else sample_delay, f"the sample delay of {owner}")
    if not period > 0:
        raise InvalidGraphError(f"{owner}: its sample period is {period:g} s; give a period > 0", [name])
    if not 0 <= delay < period:
        raise InvalidGraphError(f"{owner}: its sample delay is {delay:g} s; give 0 <= delay < sample_period "
                                f"({period:g} s): the ticks are at k·period + delay", [name])
    if derivative_filter is not None:
        raise InvalidGraphError(f"{owner}: a sampled controller's derivative is the backward difference "
                                "(e_k − e_(k−1))/T; derivative_filter applies to a continuous one only", [name])
    return {"sample_period": period, "sample_delay": delay}


def build_sampled_controller(builder, part, error: sp.Expr, gains: dict, limits: tuple, tracking) -> sp.Expr:
    """The held values, their buffers and the clock of the sampled controller ``part`` (module
    docstring); ``error`` the expression of ``e``, ``gains`` ``{"kp", "ki", "kd"}`` symbols (``kd``
    0 when absent), ``limits`` ``(lo, hi)`` symbols or ``None``, ``tracking`` ``T_t`` or ``None``
    (no limits).  Returns the output's expression (the held ``u``)."""
    name, v = part.name, part.values
    owner = f"controller {name!r}"
    period = builder.number_or_parameter(v["sample_period"], f"{name}_Ts", f"sample period of {owner}",
                                         allowed=Range(f"the sample period of {owner}", 0.0, low_open=True))
    keys = ("u", "w", "I", "n", "E", "m") if gains["kd"] != 0 else ("u", "w", "I", "n")
    holds = {key: C(builder.internal(f"{name}_{key}"), 1) for key in keys}
    q = {key: storage.state for key, storage in holds.items()}
    raw = gains["kp"] * error + q["I"]
    if gains["kd"] != 0:
        raw += gains["kd"] * (error - q["E"]) / period
    computed = raw
    lo, hi = limits
    if lo is not None:
        computed = sp.Max(computed, lo)
    if hi is not None:
        computed = sp.Min(computed, hi)
    rate = gains["ki"] * error
    if tracking is not None:
        rate += (computed - raw) / tracking
    updates = {"u": q["w"], "w": computed, "n": q["I"] + period * rate, "I": q["n"]}
    if "E" in q:
        updates.update({"m": error, "E": q["m"]})
    for key in ("w", "n", "m"):  # the stages' exit guards compare with these signals
        if key in updates:
            builder.signal(f"{name}_next_{key}", updates[key], owner)
    loads = {}
    for key, storage in holds.items():
        load = builder.graph.add(One(builder.internal(f"{name}_{key}_load"), controlled=True))
        builder.graph.connect(Se(builder.internal(f"{name}_{key}_buffer"), updates[key]), load)
        builder.graph.connect(load, storage)
        loads[key] = load.name
        builder.unitless.add(storage.state.name)  # (in the output's unit, which no prefix knows)
        initial = v["initial"] if key in ("u", "w", "I") else 0.0
        if initial:
            builder.start_unit_state(storage, initial)
    builder.automata.append(_clock(name, v["sample_delay"], period, loads, q))
    return q["u"]


def _clock(name: str, delay: float, period: sp.Symbol, loads: dict, q: dict) -> Automaton:
    """The automaton ``<name>_clock``: ``wait_a``/``wait_b`` hold every value (clock positive/negative
    since the last tick), ``stage<j>_a``/``_b`` close stage ``j``'s loads (module docstring); ``q``: the
    held values' states."""
    def setting(closed=()):
        return {load: key in closed for key, load in loads.items()}

    states = {"wait_a": setting(), "wait_b": setting()}
    stages = [tuple(key for key in stage if key in loads) for stage in STAGES]
    for side in ("a", "b"):
        for j, stage in enumerate(stages, 1):
            states[f"stage{j}_{side}"] = setting(stage)
    initial = "stage1_a" if delay == 0 else "wait_b"  # (a tick at t = 0 is taken by the start's instant)
    automaton = Automaton(f"{name}_clock", states, initial=initial)
    clock = f"sin(pi*(t - {delay!r})/{period})"
    for side, other, turns in (("a", "b", f"{clock} < 0"), ("b", "a", f"{clock} > 0")):
        automaton.add_transition(f"wait_{side}", f"stage1_{other}", turns, "a priori")
        for j, stage in enumerate(stages, 1):
            source = f"stage{j}_{other}"
            target = f"stage{j + 1}_{other}" if j < len(stages) else f"wait_{other}"
            done = " and ".join(f"{q[key].name} == {_source_of(name, key, q)}" for key in stage)
            automaton.add_transition(source, target, done, "a priori")
    return automaton


def _source_of(name: str, key: str, q: dict) -> str:
    """The text of the value ``key`` is loaded with: a held state or a ``<name>_next_<key>`` signal."""
    held = {"u": "w", "I": "n", "E": "m"}
    return q[held[key]].name if key in held else f"{name}_next_{key}"
