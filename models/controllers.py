"""Closed loops in a netlist: PI/PID controllers, carrier PWM of a signal, hysteresis control.

A controller is a part without terminals (:meth:`Circuit.pid`, :meth:`Circuit.pi`).  With the error
``e = reference − measure`` (``measure`` a text of the netlist's signals, ``reference`` a number, a
parameter name or a text of ``t``: a reference step), its output is the signal named after it::

    u_raw = kp·e + I + D,        u = min(max(u_raw, lo), hi)       (the limits, when given)
    dI/dt = ki·e + (u − u_raw)/T_t                                  (back-calculation anti-windup)
    dz/dt = (e − z)/T_f,  D = kd·(e − z)/T_f                        (a filtered derivative, kd ≠ 0)

``I`` [the output's unit] is the integral term, ``I(0) = initial``; while the output is within its limits
``u = u_raw`` and the integral is the plain ``ki·∫e``: a steady state (or a periodic orbit) with the output
unsaturated has ``e = 0`` (its mean over a period), exactly.  Saturated, the integral tracks the limit
with the time constant ``T_t`` (``tracking`` [s], default ``kp/ki``, Åström and Hägglund's choice for a
PI) instead of winding up.  ``T_f`` (``derivative_filter`` [s], default ``kd/(10·kp)``) bounds the
derivative's gain at high frequency.  Each state is a storage element of unit capacity fed by a flow
source whose value is the state's rate — a signal island of the bond graph, drawn and saved with it:
``I`` is the state ``q_<name>_I``, ``z`` the state ``q_<name>_D``.

A PWM switch whose duty is a controller's name or a text of signals (``PWM(1e-5, "PI1")``,
``PWM(1/f, "0.5 + 0.4*sin(2*pi*50*t)")``) compares the duty with the fixed triangle carrier
``acos(cos(2π(t − delay)/period))/π`` (0 at ``k·period + delay``, 1 half a period later): closed while
``carrier <= duty``, so each pulse is centred on ``k·period + delay`` and both edges are the instants
where the carrier crosses the duty, located as events.

:class:`Hysteresis` is a bang-bang schedule for a switch: closed below ``reference − band/2``, open
above ``reference + band/2`` (or the reverse), the band keeping the switching frequency finite.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import sympy as sp

from bondgraph import C, Se, Sf, Zero
from bondgraph.errors import InvalidGraphError
from bondgraph.symbols import t as TIME
from switching.language.parsing import parse_expression

from ._common import Range
from .netlist import NAME, checked_argument, checked_number
from .sampled_controllers import build_sampled_controller, sample_values

__all__ = ["Hysteresis", "controller_values", "build_controller", "build_controllers", "controller_placeholder",
           "drive_sources", "modulated_duty", "signal_resolver"]


@dataclass(frozen=True)
class Hysteresis:
    """A switch schedule: closed while ``signal < reference − band/2``, open from ``signal >
    reference + band/2`` (``closed_below=False``: the reverse), its state kept inside the band.
    ``signal`` a text of the netlist's signals (``"i_L1"``); ``reference`` and ``band`` numbers or
    parameter names (``band`` > 0, in the signal's unit)."""

    signal: str
    reference: float | str
    band: float | str
    closed_below: bool = True

    def conditions(self) -> tuple[str, str]:
        """``(closing, opening)`` conditions as text."""
        low, high = f"({self.reference}) - ({self.band})/2", f"({self.reference}) + ({self.band})/2"
        below, above = f"({self.signal}) < {low}", f"({self.signal}) > {high}"
        return (below, above) if self.closed_below else (above, below)

    def checked(self, owner: str) -> "Hysteresis":
        if not isinstance(self.signal, str) or not self.signal.strip():
            raise InvalidGraphError(f"the hysteresis of {owner} needs its signal as text (e.g. 'i_L1')", [owner])
        reference = checked_argument(self.reference, f"the hysteresis reference of {owner}")
        band = checked_argument(self.band, f"the hysteresis band of {owner}")
        if not isinstance(band, str) and not band > 0:
            raise InvalidGraphError(f"the hysteresis band of {owner} is {band:g}: give a band > 0 (in the "
                                    "signal's unit; a band of 0 would switch infinitely often)", [owner])
        return Hysteresis(self.signal, reference, band, bool(self.closed_below))


def controller_values(name: str, measure, reference, kp, ki, kd, limits, tracking, derivative_filter,
                      initial, sample_period=None, sample_delay=None) -> dict:
    """A PID controller's arguments checked (the module docstring): gains and times numbers or parameter
    names, ``limits`` ``(lo, hi)`` with ``lo < hi`` (either ``None``), ``measure`` a text; a sampled
    controller's clock (:func:`models.sampled_controllers.sample_values`)."""
    owner = f"controller {name!r}"
    if not isinstance(measure, str) or not measure.strip():
        raise InvalidGraphError(f"{owner}: give what it measures as a text of the signals ('v_out')", [name])
    values = {"measure": measure, "reference": reference if isinstance(reference, str)
              else checked_number(reference, f"the reference of {owner}")}
    for key, value in (("kp", kp), ("ki", ki), ("kd", kd)):
        values[key] = checked_argument(value, f"the gain {key} of {owner}")
    for key, value in (("tracking", tracking), ("derivative_filter", derivative_filter)):
        values[key] = None if value is None else checked_argument(value, f"the {key} time of {owner}")
    values["initial"] = checked_number(initial, f"the initial integral term of {owner}")
    lo, hi = (None, None) if limits is None else limits
    lo, hi = (None if v is None else checked_argument(v, f"the output limit of {owner}") for v in (lo, hi))
    if isinstance(lo, float) and isinstance(hi, float) and not lo < hi:
        raise InvalidGraphError(f"{owner}: its limits ({lo:g}, {hi:g}) leave no range; give (lo, hi) with "
                                "lo < hi", [name])
    values["limits"] = (lo, hi)
    values.update(sample_values(name, sample_period, sample_delay, derivative_filter))
    return values


def signal_resolver(builder, signals: dict):
    """``resolve(text) → expression``: a text of the netlist's signals with every signal replaced by its
    expression of bond variables, states, parameters and ``t`` (a source's value must not name a
    signal: the bond graph reads no signals)."""
    names = {"t": TIME, **builder.graph.inputs}
    parsed: dict = {}

    def expression(name: str) -> sp.Expr:
        if name not in parsed:
            text = signals[name]
            parsed[name] = text if isinstance(text, sp.Basic) else parse_expression(text, names)
        return parsed[name]

    def resolve(text: str) -> sp.Expr:
        found = parse_expression(text, names)
        for _ in range(len(signals) + 1):
            inner = {s: expression(s.name) for s in found.free_symbols if s.name in signals}
            if not inner:
                return found
            found = found.xreplace(inner)
        raise InvalidGraphError(f"the signals in {text!r} define each other in a circle", [text])

    return resolve


def build_controller(builder, part, resolve) -> None:
    """The controller ``part``'s states (signal islands: a unit capacity fed by its rate) and its output
    signal (module docstring), with its gains as parameters ``<name>_kp``, ``<name>_ki``, …"""
    name, v = part.name, part.values
    owner = f"controller {name!r}"

    def parameter(key, what, allowed=None):
        return builder.number_or_parameter(v[key], f"{name}_{key}", f"{what} of {owner}", allowed=allowed)

    kp = parameter("kp", "the proportional gain kp")
    ki = parameter("ki", "the integral gain ki", Range(f"the integral gain of {owner}", 0.0))
    reference = builder.expression_value(v["reference"], f"the reference of {owner}", f"{name}_ref")
    error = reference - resolve(builder.user_text(v["measure"]))
    if v.get("sample_period") is not None:
        _sampled(builder, part, error, kp, ki, parameter)
        return
    derivative = 0
    if v["kd"] != 0:
        kd = parameter("kd", "the derivative gain kd", Range(f"the derivative gain of {owner}", 0.0))
        filter_time = _time(builder, v, "derivative_filter", f"{name}_tf", owner, kd / (10 * kp))
        filtered = C(builder.internal(f"{name}_D"), 1)
        z = filtered.state
        _island(builder, filtered, 0.0, (error - z) / filter_time)
        derivative = kd * (error - z) / filter_time
    storage = C(builder.internal(f"{name}_I"), 1)
    integral = storage.state
    raw = kp * error + integral + derivative
    lo, hi = _limits(builder, v, name, owner)
    output = raw if lo is None else sp.Max(raw, lo)
    output = output if hi is None else sp.Min(output, hi)
    rate = ki * error
    if lo is not None or hi is not None:
        rate += (output - raw) / _time(builder, v, "tracking", f"{name}_tt", owner, kp / ki)
    _island(builder, storage, v["initial"], rate)
    builder.signal(name, output, owner)


def _sampled(builder, part, error, kp, ki, parameter) -> None:
    """The sampled controller ``part`` (:mod:`models.sampled_controllers`) and its output signal."""
    name, v = part.name, part.values
    owner = f"controller {name!r}"
    kd = 0
    if v["kd"] != 0:
        kd = parameter("kd", "the derivative gain kd", Range(f"the derivative gain of {owner}", 0.0))
    lo, hi = _limits(builder, v, name, owner)
    tracking = None
    if lo is not None or hi is not None:
        tracking = _time(builder, v, "tracking", f"{name}_tt", owner, kp / ki)
    output = build_sampled_controller(builder, part, error, {"kp": kp, "ki": ki, "kd": kd}, (lo, hi), tracking)
    builder.signal(name, output, owner)


def _limits(builder, values, name: str, owner: str) -> tuple:
    """The output limits ``(lo, hi)`` as parameters ``<name>_min``, ``<name>_max`` (``None`` where not given)."""
    return tuple(None if value is None else builder.number_or_parameter(
        value, f"{name}_{side}", f"the {side} output limit of {owner}")
        for value, side in zip(values["limits"], ("min", "max")))


def _time(builder, values, key, default_name, owner, default):
    """A time constant [s] of the controller: given, else ``default`` when it is a positive number."""
    if values[key] is not None:
        return builder.number_or_parameter(values[key], default_name, f"the {key} time of {owner}",
                                           allowed=Range(f"the {key} time of {owner}", 0.0, low_open=True))
    known = {sp.Symbol(k): x for k, x in {**builder.defaults, **builder.given}.items() if isinstance(x, (int, float))}
    number = sp.sympify(default).xreplace(known)
    if not (number.is_number and number.is_finite and float(number) > 0):
        raise InvalidGraphError(f"{owner}: give its {key} time in s (its default, {default}, is no positive "
                                "number with these gains)", [owner])
    return builder.number_or_parameter(float(number), default_name, f"the {key} time of {owner}")


def _island(builder, storage, initial: float, rate: sp.Expr) -> None:
    """``storage`` (a unit capacity, state ``q``) fed by a flow source ``<storage>_rate`` of value ``rate``:
    ``dq/dt = rate``, ``q(0) = initial``."""
    name = storage.name
    junction = builder.graph.add(Zero(builder.internal(f"{name}_sum")))
    builder.graph.connect(Sf(builder.internal(f"{name}_rate"), rate), junction, name=builder.bond_name(f"{name}_in"))
    builder.graph.connect(junction, storage, name=builder.bond_name(f"{name}_out"))
    builder.unitless.add(storage.state.name)  # (in the controller's output's unit, which no prefix knows)
    if initial:
        builder.start_unit_state(storage, initial)


def controller_placeholder(builder, value):
    """A source's value that names a controller: its output's placeholder symbol (the output itself is
    put in by :func:`drive_sources` once built); else ``None``."""
    if isinstance(value, str) and value in builder.controllers:
        return sp.Symbol(value)
    return None


def drive_sources(builder, outputs: dict) -> None:
    """Every source whose value holds a controller's placeholder, with the controller's output
    (``outputs``: name → expression) in its place."""
    symbols = {sp.Symbol(name): output for name, output in outputs.items()}
    for element in list(builder.graph.elements.values()):
        if isinstance(element, (Se, Sf)) and element.value.free_symbols & set(symbols):
            builder.graph.replace(dataclasses.replace(element, value=element.value.xreplace(symbols)))


def build_controllers(builder, parts, signals: dict) -> None:
    """Every controller of ``parts`` built (:func:`build_controller`, the signals' texts ``signals``) and
    the sources they drive given their outputs."""
    resolve = signal_resolver(builder, signals)
    outputs = {}
    for part in parts:
        build_controller(builder, part, resolve)
        outputs[part.name] = builder.signals[part.name]
    drive_sources(builder, outputs)


def modulated_duty(builder, rule, controllers) -> str | None:
    """The duty of a PWM ``rule`` as a signal text when it is a controller's name or a text of signals
    (module docstring); ``None`` for a number or a parameter name."""
    duty = rule.duty
    if not isinstance(duty, str):
        return None
    if duty in controllers:
        return duty
    if NAME.fullmatch(duty):
        return None
    return builder.user_text(duty)
