"""Writing a :class:`~models.circuits.Circuit` as a SPICE netlist ngspice runs (:func:`write`,
``Circuit.to_spice()``).  It reads the circuit's parts as data and imports nothing of
:mod:`models.circuits` (a PWM schedule is what has a period, a duty and a delay; an input what has a
name and is no value), so that :mod:`models.circuits` may import it."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from fractions import Fraction

import sympy as sp

from bondgraph import HybridBondGraphError
from bondgraph.symbols import t as TIME
from switching.language.parsing import parse_condition, parse_expression

from .netlist import REFERENCE as GROUND
from .spice_forms import (
    GMIN,
    IDEAL_RESISTANCE,
    NOMINAL_TEMPERATURE,
    OPEN_RESISTANCE,
    THERMAL_VOLTAGE,
    ExponentialDiode,
    GateControl,
    Tran,
    Waveform,
    decimal_text,
)
from .spice_syntax import SpiceExportError, float_text

__all__ = ["write", "WRITTEN_SATURATION_CURRENT", "WRITTEN_KNEE", "WRITTEN_SERIES_RESISTANCE"]


# ---------------------------------------------------------------------------------------------- writing

#: the saturation current [A] of the SPICE diode that stands for the toolkit's ideal diode
WRITTEN_SATURATION_CURRENT = 1e-12
#: the knee [V] given that diode where the ideal diode has no forward drop, and its least series
#: resistance [Ω] (a sharper knee or a smaller RS makes ngspice's Newton iterations fail where an
#: inductor's current is forced into the diode: "timestep too small")
WRITTEN_KNEE = 0.1
WRITTEN_SERIES_RESISTANCE = 1e-3


def write(circuit, run=None, *, parameters: Mapping | None = None, title: str | None = None) -> str:
    """The SPICE netlist of ``circuit`` as ngspice runs it (``Circuit.to_spice()``).

    ``run``: a :class:`Tran`, or run settings (``{"t_end": …, "max_step": …, "tstep": …}``), written as
    ``.tran TSTEP TSTOP 0 TMAX UIC`` (TSTEP ``t_end``/1000 unless given; UIC: SPICE starts from the
    initial conditions, as the toolkit does); none: no ``.tran``.  ``parameters``: the values of the
    parameter names the circuit's values use (written as ``.param`` and ``{name}``).  ``title``: the
    first line (default: the circuit's name).  Each part:

    * R, C (``IC=``), L (``IC=``), V and I with numbers or parameters (``DC``); a source read from a
      SPICE transient function is written as that function; any other expression of ``t`` as a
      behavioural source ``B… V=…`` (ngspice's syntax: ``time``, ``u()`` for ``step``);
    * a resistor with an :class:`ExponentialDiode` law: a ``D`` with its ``.model`` (IS, N; GMIN as
      ``.options gmin``);
    * an ideal diode: SPICE's diode through the same tangent — IS = 1e-12 A, N such that the tangent at
      1 A meets ``i = 0`` at ``v_f`` (at :data:`WRITTEN_KNEE` where there is no ``v_f``), RS the rest
      of ``r_on`` (at least :data:`WRITTEN_SERIES_RESISTANCE`) — with LTspice's ``Vfwd`` and ``Ron`` holding
      ``v_f`` and ``r_on`` (ngspice ignores them; :func:`read` reads the ideal diode back from them);
      a comment says so;
    * a switch: an ``S`` (``RON`` its ``r_on`` or :data:`IDEAL_RESISTANCE`, ``ROFF`` = 1e12 Ω, ON/OFF its
      state at t = 0): a :class:`~models.circuits.PWM` switch driven by a ``PULSE`` gate source with
      ideal edges; a condition ``v_a - v_b > x`` (with ``open_when`` ``v_a - v_b < y``: VT and VH)
      across its nodes; a switch read from a gate source driven by that source again; a condition
      ``i_V > x`` on a voltage source's current is a ``W`` switch.  Any other condition is refused;
    * coupled inductors: two L and a K; a transformer: an E and an F with a 0 V source sensing the
      primary's current; a gyrator (a DC machine): two H with two sensing sources.
      (:func:`read` does not read E, F and H back.)

    A part SPICE cannot express — a law given as a Python function, an :class:`~models.circuits.Input`,
    a switch's condition of another form, a parameter without a value — is refused with a
    :class:`SpiceExportError` naming it."""
    return _Writer(circuit, dict(parameters or {})).netlist(run, title)


def _exact_float(value: float) -> Fraction:
    """A float as the decimal it is written as (its shortest form): what :func:`read` reads back."""
    return Fraction(repr(float(value)))


class _Writer:
    """One writing of a circuit: its element lines, models, parameters and comments."""

    def __init__(self, circuit, parameters: dict):
        self.circuit, self.parameters = circuit, parameters
        # (a Circuit's parts in order: Netlist keeps them in _parts)
        self.parts = list(circuit._parts.values())
        self.lines: list[str] = []
        self.models: list[str] = []
        self.used: dict[str, float] = {}  # parameter names written as .param
        self.taken = {n.lower() for n in circuit.nodes} | {p.name.lower() for p in self.parts}
        self.gmin: set = set()  # the exponential diodes' GMIN [S] and temperatures [K]
        self.temperatures: set = set()

    def netlist(self, run, title: str | None) -> str:
        for part in self.parts:
            {"R": self.resistor, "C": self.storage, "L": self.storage, "V": self.source, "I": self.source,
             "D": self.diode, "S": self.switch, "T": self.transformer, "G": self.gyrator,
             "K": self.coupled}[part.kind](part)
        head = [f"* {title or self.circuit.name}",
                f"* circuit {self.circuit.name!r} written by models.spice.write (hybrid bond graph toolkit)"]
        head += [f".param {name}={float_text(value)}" for name, value in self.used.items()]
        tail = list(self.models)
        for what, values in (("GMIN", self.gmin), ("temperature", self.temperatures)):
            if len(values) > 1:
                raise SpiceExportError(f"the exponential diodes have different {what}s ({sorted(values)}): SPICE "
                                       "has one, give them one")
        if self.gmin - {GMIN}:
            tail.append(f".options gmin={float_text(next(iter(self.gmin)))}")
        if self.temperatures - {NOMINAL_TEMPERATURE}:
            celsius = float_text(next(iter(self.temperatures)) - 273.15)
            tail.append(f".options temp={celsius} tnom={celsius}")
        tail += self.tran(run)
        return "\n".join(head + self.lines + tail + [".end"]) + "\n"

    # -- names and values

    def name(self, letter: str, name: str) -> str:
        """The SPICE name of part ``name`` as a ``letter`` element (the letter put first if need be)."""
        spice = name if name[:1].upper() == letter else f"{letter}{name}"
        if spice != name:
            spice = self.fresh(spice)
        return spice

    def fresh(self, base: str) -> str:
        """A name no node or element has (case-insensitively): ``base``, ``base_2``, …"""
        name, k = base, 2
        while name.lower() in self.taken:
            name, k = f"{base}_{k}", k + 1
        self.taken.add(name.lower())
        return name

    def number(self, value, part, what: str) -> float:
        """A part's value as a number (a parameter name's value from ``parameters``)."""
        if isinstance(value, str):
            if value not in self.parameters:
                raise SpiceExportError(f"{part.kind} {part.name!r}: its {what} is the parameter {value!r}: give its "
                                       f"value, write(..., parameters={{{value!r}: …}})", part.name)
            return float(self.parameters[value])
        if isinstance(value, sp.Expr):
            return float(value.xreplace({sp.Symbol(k): v for k, v in self.parameters.items()}).evalf())
        return float(value)

    def value(self, value, part, what: str) -> str:
        """A part's value as SPICE text: a number, or ``{name}`` with its ``.param`` (``{expression}`` for
        a sympy expression of parameters)."""
        if value is None:
            value = part.name
        if isinstance(value, str):
            self.used[value] = self.number(value, part, what)
            return f"{{{value}}}"
        if isinstance(value, sp.Expr):
            for symbol in value.free_symbols:
                self.used[symbol.name] = self.number(symbol.name, part, what)
            return f"{{{_spice_expression(value, part)}}}"
        return float_text(value)

    # -- parts

    def resistor(self, part) -> None:
        law = part.values.get("law")
        if law is None:
            self.lines.append(f"{self.name('R', part.name)} {' '.join(part.nodes)} "
                              f"{self.value(part.values['value'], part, 'resistance')}")
            return
        if not isinstance(law[1], ExponentialDiode) or law[0] != "flow_law":
            raise SpiceExportError(f"R {part.name!r} has a law given as a Python function: SPICE has no form for "
                                   "it (an ExponentialDiode law is written as a D)", part.name)
        diode = law[1]
        name = self.name("D", part.name)
        self.gmin.add(diode.gmin)
        self.temperatures.add(diode.temperature)
        self.lines.append(f"{name} {' '.join(part.nodes)} m_{name}")
        self.models.append(f".model m_{name} D(IS={float_text(diode.saturation_current)} N={float_text(diode.emission)})")

    def storage(self, part) -> None:
        if part.values.get("law") is not None:
            raise SpiceExportError(f"{part.kind} {part.name!r} has a law given as a Python function: SPICE has no "
                                   "form for it", part.name)
        what = "capacitance" if part.kind == "C" else "inductance"
        initial = part.values.get("initial") or 0.0
        self.lines.append(f"{self.name(part.kind, part.name)} {' '.join(part.nodes)} "
                          f"{self.value(part.values['value'], part, what)}" + (f" IC={float_text(initial)}" if initial else ""))

    def source(self, part) -> None:
        value = part.values["value"]
        if _is_input(value):
            raise SpiceExportError(f"source {part.name!r} is the input {value.name!r}, a Python function: give it "
                                   "as an expression of t to write it", part.name)
        spice = getattr(value, "spice", None)
        if isinstance(spice, Waveform):
            self.lines.append(f"{self.name(part.kind, part.name)} {' '.join(part.nodes)} {spice.card()}")
        elif isinstance(value, str) and not re.fullmatch(r"[A-Za-z_]\w*", value):
            expression = parse_expression(value, {"t": TIME})
            values = {s: self.number(s.name, part, "expression") for s in expression.free_symbols if s != TIME}
            self.lines.append(f"{self.name('B', part.name)} {' '.join(part.nodes)} {'V' if part.kind == 'V' else 'I'}="
                              f"{_spice_expression(expression.xreplace(values), part)}")
        else:
            self.lines.append(f"{self.name(part.kind, part.name)} {' '.join(part.nodes)} DC "
                              f"{self.value(value, part, 'value')}")

    def diode(self, part) -> None:
        r_on, v_f = part.values["r_on"], part.values["v_f"]
        r_on = self.number(r_on, part, "r_on") if r_on is not None else 0.0
        v_f = self.number(v_f, part, "v_f") if v_f is not None else 0.0
        name = self.name("D", part.name)
        knee = THERMAL_VOLTAGE * (math.log(1 / WRITTEN_SATURATION_CURRENT + 1) - 1)
        emission = max(v_f, WRITTEN_KNEE) / knee
        series = max(r_on - emission * THERMAL_VOLTAGE, WRITTEN_SERIES_RESISTANCE)
        self.lines += [f"* {name}: the ideal diode (v_f = {v_f:g} V, r_on = {r_on:g} Ω) as SPICE's diode with the "
                       "tangent at 1 A meeting i = 0 at " + ("v_f" if v_f >= WRITTEN_KNEE else f"{WRITTEN_KNEE} V")
                       + "; Vfwd and Ron (LTspice's, ignored by ngspice) keep v_f and r_on",
                       f"{name} {' '.join(part.nodes)} m_{name}"]
        self.models.append(f".model m_{name} D(IS={float_text(WRITTEN_SATURATION_CURRENT)} N={emission:.6g} "
                           f"RS={series:.6g} Vfwd={float_text(v_f)} Ron={float_text(r_on)})")

    def switch(self, part) -> None:
        rule, r_on = part.values["closed_when"], part.values.get("r_on")
        name = self.name("S", part.name)
        ron = self.number(r_on, part, "r_on") if r_on is not None else IDEAL_RESISTANCE
        state = {True: " ON", False: " OFF", None: ""}[part.values.get("closed")]
        spice = getattr(rule, "spice", None)
        if _is_schedule(rule):
            control, threshold, hysteresis = self.pwm_gate(part, name, rule), Fraction(1, 2), Fraction(0)
        elif isinstance(spice, GateControl):
            gate = self.fresh(f"{part.name}_gate")
            self.lines.append(f"{self.fresh('V' + gate)} {gate} 0 {spice.waveform.card()}")
            control = f"{gate} 0" if spice.sign > 0 else f"0 {gate}"
            threshold, hysteresis = spice.threshold, spice.hysteresis
        else:
            kind, control, threshold, hysteresis = self.level_control(part)
            if kind == "i":
                self.lines.append(f"{self.name('W', part.name)} {' '.join(part.nodes)} {control} m_{name}{state}")
                self.models.append(f".model m_{name} CSW(IT={decimal_text(threshold)} IH={decimal_text(hysteresis)} "
                                   f"RON={float_text(ron)} ROFF={float_text(OPEN_RESISTANCE)})")
                return
        self.lines.append(f"{name} {' '.join(part.nodes)} {control} m_{name}{state}")
        self.models.append(f".model m_{name} SW(VT={decimal_text(threshold)} VH={decimal_text(hysteresis)} RON={float_text(ron)} "
                           f"ROFF={float_text(OPEN_RESISTANCE)})")

    def pwm_gate(self, part, name: str, rule) -> str:
        """Write the PULSE gate source of a PWM switch (closed while the gate is above 0.5 V); returns
        the control nodes.  Its edges last ``ε`` (1e-6 of its shorter level, rounded down to a power of
        ten: ngspice would give an edge of 0 its TSTEP), centred on the schedule's instants, so that
        :func:`~models.spice.read` takes them for ideal steps at exactly those instants; a window that
        would start a period too late for SPICE's first pulse starts a period earlier (a negative TD,
        as ngspice takes it)."""
        period = _exact_float(self.number(rule.period, part, "PWM period"))
        duty = _exact_float(self.number(rule.duty, part, "PWM duty"))
        delay = _exact_float(rule.delay)
        gate = self.fresh(f"{part.name}_gate")
        if duty in (0, 1):
            card = f"DC {int(duty)}"
        else:
            delay -= period * max(0, math.ceil((delay + duty * period - period) / period))
            edge = Fraction(10) ** (math.floor(math.log10(min(duty, 1 - duty) * period)) - 6)
            card = (f"PULSE(0 1 {decimal_text(delay - edge / 2)} {decimal_text(edge)} {decimal_text(edge)} "
                    f"{decimal_text(duty * period - edge)} {decimal_text(period)})")
        self.lines += [(f"* {name}: PWM(period={float(period):g}, duty={float(duty):g}, delay={rule.delay:g}), "
                        "its gate a PULSE whose edges are steps at their midpoints"),
                       f"{self.fresh('V' + gate)} {gate} 0 {card}"]
        return f"{gate} 0"

    def level_control(self, part) -> tuple:
        """``(kind, control, VT, VH)`` of a switch whose condition reads ``v_a - v_b > x`` (``kind``
        ``"v"``, ``control`` the nodes ``a b``) or ``i_V > x`` (``"i"``, the source's SPICE name), with
        ``open_when`` the same control ``< y`` or none; else a :class:`SpiceExportError`."""
        closed_when, open_when = part.values["closed_when"], part.values.get("open_when")
        high = _threshold(closed_when, ">")
        low = _threshold(open_when, "<") if open_when else None
        if high is None or (open_when and (low is None or low[0] != high[0] or low[1] > high[1])):
            raise SpiceExportError(
                f"switch {part.name!r}: its condition {closed_when!r}"
                + (f" (open when {open_when!r})" if open_when else "") + " has no SPICE form: SPICE's switches close "
                "on a voltage across two nodes (v_a - v_b > x, or v_a > x) or a voltage source's current (i_V > x), "
                "with open_when the same control < y; give a PWM, or such a condition", part.name)
        control, level = high
        bottom = low[1] if low else level
        threshold, hysteresis = (level + bottom) / 2, (level - bottom) / 2
        return self.control_of(part, control) + (threshold, hysteresis)

    def control_of(self, part, control: tuple) -> tuple:
        """``(kind, SPICE control)`` of a control read by :func:`_threshold`."""
        nodes = set(self.circuit.nodes)
        sources = {p.name: p for p in self.parts if p.kind == "V"}
        if control[0] == "i":
            source = sources.get(control[1])
            if source is None:
                raise SpiceExportError(f"switch {part.name!r} reads i_{control[1]}, which is no voltage source's "
                                       "current (SPICE's W switch senses a voltage source)", part.name)
            return "i", self.name("V", source.name)
        plus, minus = control[1:]
        for node in (plus, minus):
            if node not in nodes:
                raise SpiceExportError(f"switch {part.name!r} reads v_{node}, which is no node's voltage", part.name)
        return "v", f"{plus} {minus}"

    def transformer(self, part) -> None:
        p1, p2, s1, s2 = part.nodes
        name, ratio = part.name, self.value(part.values["value"], part, "ratio")
        sense, inner = self.fresh(f"V{name}_p"), self.fresh(f"{name}_x")
        self.lines += [(f"* {name}: the ideal transformer (v_p = n·v_s, i_s = n·i_p, n = {ratio}) as E and F, "
                        f"{sense} sensing the primary's current"),
                       f"{sense} {p1} {inner} DC 0",
                       f"{self.fresh('E' + name)} {inner} {p2} {s1} {s2} {ratio}",
                       f"{self.fresh('F' + name)} {s2} {s1} {sense} {ratio}"]

    def gyrator(self, part) -> None:
        p1, p2, s1, s2 = part.nodes
        name, r = part.name, self.value(part.values["value"], part, "ratio")
        sense_p, sense_s = self.fresh(f"V{name}_p"), self.fresh(f"V{name}_s")
        inner_p, inner_s = self.fresh(f"{name}_xp"), self.fresh(f"{name}_xs")
        self.lines += [(f"* {name}: the ideal gyrator (v_p = r·i_s, v_s = r·i_p, r = {r} Ω) as two H, "
                        f"{sense_p} and {sense_s} sensing the ports' currents"),
                       f"{sense_p} {p1} {inner_p} DC 0",
                       f"{self.fresh('H' + name + '_p')} {inner_p} {p2} {sense_s} {r}",
                       f"{sense_s} {inner_s} {s1} DC 0",
                       f"{self.fresh('H' + name + '_s')} {inner_s} {s2} {sense_p} {r}"]

    def coupled(self, part) -> None:
        p1, p2, s1, s2 = part.nodes
        first, second = self.fresh(f"L_{part.name}_p"), self.fresh(f"L_{part.name}_s")
        self.lines += [f"{first} {p1} {p2} {self.value(part.values['L1'], part, 'L1')}",
                       f"{second} {s1} {s2} {self.value(part.values['L2'], part, 'L2')}",
                       f"{self.name('K', part.name)} {first} {second} {self.value(part.values['k'], part, 'k')}"]

    def tran(self, run) -> list:
        if run is None:
            return []
        if isinstance(run, Tran):
            step, stop, max_step = run.step, run.stop, run.max_step
        else:
            stop = float(run["t_end"])
            step, max_step = float(run.get("tstep") or stop / 1000), run.get("max_step")
        return [f".tran {float_text(step)} {float_text(stop)} 0" + (f" {float_text(max_step)}" if max_step else "") + " UIC"]


def _threshold(text, relation: str):
    """``(control, level)`` of a condition ``control > level`` (``relation`` ``">"``; ``"<"``: below):
    ``control`` is ``("v", plus, minus)`` for ``v_a - v_b`` (``"0"`` for ground) or ``("i", V)`` for
    ``i_V``; ``level`` exact.  ``None`` when the condition has another form."""
    try:
        condition = parse_condition(str(text))
    except HybridBondGraphError:
        return None
    kinds = {">": (sp.StrictGreaterThan, sp.GreaterThan), "<": (sp.StrictLessThan, sp.LessThan)}[relation]
    if not isinstance(condition, kinds):
        return None
    difference = sp.expand(condition.lhs - condition.rhs)
    coefficients = {s.name: difference.coeff(s) for s in difference.free_symbols}
    constant = difference.subs({s: 0 for s in difference.free_symbols})
    if not constant.is_number or any(c not in (1, -1) for c in coefficients.values()):
        return None
    level = -_exact_float(float(constant))
    plus = [n for n, c in coefficients.items() if c == 1]
    minus = [n for n, c in coefficients.items() if c == -1]
    if len(plus) == 1 and not minus and plus[0].startswith("i_"):
        return ("i", plus[0][2:]), level
    if len(plus) > 1 or len(minus) > 1 or not (plus or minus) or not all(n.startswith("v_") for n in plus + minus):
        return None
    return ("v", plus[0][2:] if plus else GROUND, minus[0][2:] if minus else GROUND), level


#: sympy's functions as ngspice's expressions write them
_SPICE_FUNCTIONS = {sp.sin: "sin", sp.cos: "cos", sp.tan: "tan", sp.asin: "asin", sp.acos: "acos", sp.atan: "atan",
                    sp.sinh: "sinh", sp.cosh: "cosh", sp.tanh: "tanh", sp.exp: "exp", sp.log: "ln", sp.Abs: "abs",
                    sp.sign: "sgn"}


def _spice_expression(expr, part) -> str:
    """A sympy expression as ngspice writes it (``time`` for ``t``, ``u()`` for ``step``, ``**``)."""
    def show(e) -> str:
        if e == TIME:
            return "time"
        if e is sp.pi:
            return float_text(math.pi)
        if e.is_Number:
            return f"({float_text(e)})" if e < 0 else float_text(e)
        if e.is_Symbol:
            return e.name
        if isinstance(e, sp.Add):
            return "(" + " + ".join(show(a) for a in e.args) + ")"
        if isinstance(e, sp.Mul):
            return "(" + "*".join(show(a) for a in e.args) + ")"
        if isinstance(e, sp.Pow):
            return f"sqrt({show(e.base)})" if e.exp == sp.Rational(1, 2) else f"({show(e.base)})**({show(e.exp)})"
        if isinstance(e, sp.Heaviside):
            return f"u({show(e.args[0])})"
        if isinstance(e, (sp.Min, sp.Max)):
            word, args = ("min" if isinstance(e, sp.Min) else "max"), [show(a) for a in e.args]
            text = args[0]
            for a in args[1:]:
                text = f"{word}({text}, {a})"
            return text
        if type(e) in _SPICE_FUNCTIONS:
            return f"{_SPICE_FUNCTIONS[type(e)]}({show(e.args[0])})"
        raise SpiceExportError(f"{part.kind} {part.name!r}: {e} has no form in ngspice's expressions", part.name)
    return show(expr)


def _is_schedule(rule) -> bool:
    """Is a switch's rule a PWM schedule (``models.circuits.PWM``: a period, a duty and a delay)?"""
    return not isinstance(rule, str) and all(hasattr(rule, a) for a in ("period", "duty", "delay"))


def _is_input(value) -> bool:
    """Is a source's value a declared input (``models.circuits.Input``: a name, no value)?"""
    return not isinstance(value, (str, int, float, sp.Basic)) and hasattr(value, "name")
