"""Trailing-edge PWM: a varying duty compared with a sawtooth carrier, its edges located exactly.

``PWM(period, duty, delay, carrier="sawtooth")`` with a duty that varies (a controller's name or a
text of signals) closes the switch at every tick ``t_k = k·period + delay`` and opens it when the
ramp ``(t − t_k)/period`` — the sawtooth — reaches the duty: a pulse ``[t_k, t_k + d·period)``
whose trailing edge carries the modulation (an analog voltage-mode controller's PWM).

The sawtooth ``(t − delay)/period mod 1`` jumps from 1 to 0 at each tick, so a guard that compared
it with the duty would be decided by round-off at the very instant the pulse begins (1 − ε > duty
opens the switch it just closed).  Instead the ticks are the zeros of the clock
``sin(π(t − delay)/period)`` and the ramp the switch compares is one that is continuous across the
pulse: the automaton ``<switch>_clock`` (no junction) alternates between ``even`` and ``odd``,
counting the ticks' parity, and sets ``<switch>_parity`` to 0 or 1; the signal ``ramp_<switch>`` is

    ramp_even = (θ mod 2π)/π − 1/2,   θ = π(t − delay + period/2)/period      (0 at even ticks)
    ramp_odd  = the same with θ = π(t − delay − period/2)/period               (0 at odd ticks)
    ramp      = (1 − parity)·ramp_even + parity·ramp_odd

each of which runs from −1/2 to 3/2 around its own ticks, wrapping half a period before them and
never within a pulse.  The switch closes when the clock changes sign towards the next parity
(``(1 − 2·parity)·clock < 0``, strict: a tick located is not taken twice) and opens when
``ramp > duty`` (strict).  A duty at or above 1 keeps the switch closed through the tick; at or
below 0 the pulse is an instant long.
"""

from __future__ import annotations

import numbers

import sympy as sp

from bondgraph.errors import InvalidGraphError
from switching import Automaton

__all__ = ["CARRIERS", "sawtooth_pwm"]

#: the carriers a varying duty is compared with
CARRIERS = ("triangle", "sawtooth")


def sawtooth_pwm(builder, part, rule, period: sp.Expr, duty: str) -> tuple[str, str, bool]:
    """``(closing, opening, closed at t = 0)`` of the PWM switch ``part`` comparing ``duty`` (a signal
    text) with the sawtooth (module docstring); its clock's automaton added to the builder's."""
    name, owner = part.name, f"switch {part.name!r}"
    known = {sp.Symbol(k): v for k, v in {**builder.defaults, **builder.given}.items() if isinstance(v, numbers.Real)}
    try:
        period_value = float(period.xreplace(known))
    except (TypeError, ValueError):
        raise InvalidGraphError(f"{owner}: a sawtooth PWM needs its period's value when it is built (give a "
                                "number or a parameter with a value)", [name]) from None
    delay = float(rule.delay) % period_value
    clock = f"sin(pi*(t - {delay!r})/{period})"
    parity = f"{name}_parity"
    ramps = [f"((atan2(-sin({theta}), -cos({theta})) + pi)/pi - 1/2)"
             for theta in (f"pi*(t - {delay!r} + {period}/2)/{period}", f"pi*(t - {delay!r} - {period}/2)/{period}")]
    builder.signal(f"clock_{name}", clock, owner)
    builder.signal(f"ramp_{name}", f"(1 - {parity})*{ramps[0]} + {parity}*{ramps[1]}", owner)
    counter = Automaton(f"{name}_clock", {"even": {}, "odd": {}}, initial="even" if delay == 0 else "odd",
                        values={"even": {parity: 0}, "odd": {parity: 1}})
    counter.add_transition("even", "odd", f"clock_{name} < 0", "a priori")
    counter.add_transition("odd", "even", f"clock_{name} > 0", "a priori")
    builder.automata.append(counter)
    closed = part.values["closed"]
    initial = delay == 0 if closed is None else closed
    return f"(1 - 2*{parity})*clock_{name} < 0", f"ramp_{name} > {duty}", initial
