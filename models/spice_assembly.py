"""The circuit of a netlist's elements (:mod:`models.spice_reader` flattens them): each element
added as its :class:`~models.circuits.Circuit` part — gate sources folded into the switches they drive,
inductors into their couplings, diodes mapped by the reading's rule, ``.ic`` into the capacitors."""

from __future__ import annotations

import re
from fractions import Fraction

from bondgraph import HybridBondGraphError

from .circuits import GROUND, PWM, Circuit
from .spice_forms import (
    DIODE_RULES,
    IDEAL_RESISTANCE,
    MODEL_PARAMETERS,
    DiodeMapping,
    GateControl,
    SpiceText,
    Waveform,
    diode_mapping,
    shifted,
)
from .spice_syntax import (
    Expression,
    SpiceNetlistError,
    SpiceSyntaxError,
    UnsupportedCardError,
    exact_number,
    float_text,
    is_word,
    keywords,
    translate,
)

__all__ = ["Assembler", "MAX_PWL_POINTS", "gate_schedule", "level_rule"]

#: the most points a PWL source may have (its expression stays within the parser's limits)
MAX_PWL_POINTS = 100
#: the transient functions SPICE has that are not read
_OTHER_FUNCTIONS = ("exp", "sffm", "am", "trnoise", "trrandom", "pat", "distof1", "distof2")


class _Devices:
    """The diodes and switches of :class:`Assembler` (its helpers: ``error``, ``note``, ``value``,
    ``local``, ``source_value``; its ``reader``, ``c``, ``gates`` and ``terminals``)."""

    # -- diodes

    def diode(self, e) -> None:
        positional, keys = keywords(e.args)
        if not positional or any(not is_word(p) for p in positional):
            raise self.error(e, "write a diode as Dname anode cathode MODEL [OFF]")
        extra = [str(p) for p in positional[1:] if str(p).lower() != "off"]
        if extra or set(keys) - {"ic"}:
            raise self.error(e, f"{' '.join(extra + [k.upper() for k in keys if k != 'ic'])}: area factors and "
                             "other instance parameters are not read (scale the model's IS and RS instead)",
                             UnsupportedCardError)
        model, params = e.scope.model(positional[0], e.card)
        if model.kind != "D":
            raise self.error(e, f"model {model.name} is a {model.kind} model, not a diode's (D)")
        asked, rule = self.diode_rule(e, model)
        try:
            mapping = diode_mapping(params, rule, self.reader.options["reference_current"], self.reader.gmin,
                                    self.reader.temperature)
        except SpiceNetlistError as error:
            raise self.error(e, f"model {model.name}: {error}") from None
        self.add_diode(e, mapping)
        ignored = sorted(set(params) - set(MODEL_PARAMETERS["D"]))
        words = f"{e.name}: {mapping.words} (model {model.name}, diodes={asked!r})"
        if ignored:
            words += (f"; {', '.join(k.upper() for k in ignored)} ignored (the toolkit's diodes have no charge "
                      "storage, breakdown or off-resistance)")
        self.reader.diode_words[e.name] = words
        self.note(e, words)

    def diode_rule(self, e, model) -> tuple[str, str]:
        """``(asked, taken)``: the mapping asked for this diode — ``diodes`` as a word, or looked up by the
        diode's name (the circuit's or as written) or its model's name; ``"auto"`` where none is given —
        and the one taken (``"auto"`` resolved)."""
        rules = self.reader.options["diodes"]
        if isinstance(rules, str):
            rule = rules
        else:
            lowered = {str(k).lower(): v for k, v in rules.items()}
            rule = next((lowered[k] for k in (e.name.lower(), e.card.head.lower(), model.name.lower())
                         if k in lowered), "auto")
        if rule not in DIODE_RULES:
            raise self.error(e, f"diodes={rule!r}: give one of {', '.join(DIODE_RULES)}", SpiceNetlistError)
        if rule != "auto":
            return rule, rule
        return rule, "piecewise" if {"ron", "vfwd"} & set(model.parameters) else "exponential"

    def add_diode(self, e, mapping: DiodeMapping) -> None:
        anode, cathode = e.nodes
        if mapping.law is None:
            self.c.diode(e.name, anode, cathode, r_on=mapping.r_on, v_f=mapping.v_f)
            return
        if mapping.rs is None:
            self.c.R(e.name, anode, cathode, flow_law=mapping.law)
            return
        inner = self.reader.register("node", f"{e.name}_rs", ("series resistance", e.name), e.card)
        resistor = self.reader.register("component", f"RS_{e.name}", ("series resistance", e.name), e.card)
        self.c.R(e.name, anode, inner, flow_law=mapping.law)
        self.c.R(resistor, inner, cathode, mapping.rs)

    # -- switches

    def find_gates(self) -> None:
        """The gate sources: V sources whose nodes no other element touches, only switches' controls."""
        terminals, by_sources, controls = {}, {}, set()
        for e in self.elements:
            if e.kind == "K":
                continue
            for n in e.nodes[:2]:
                terminals[n] = terminals.get(n, 0) + 1
                by_sources[n] = by_sources.get(n, 0) + (e.kind == "V")
            if e.kind == "S":
                controls.update(e.nodes[2:])
        self.terminals = terminals
        for e in self.elements:
            own = [n for n in e.nodes if n != GROUND]
            if e.kind == "V" and own and all(n in controls and terminals[n] == by_sources[n] for n in own):
                self.gates[e.name.lower()] = e

    def gate_of(self, e):
        """``(gate source, sign)`` of switch ``e`` when a gate source drives its control nodes, else ``None``."""
        plus, minus = e.nodes[2:]
        for n in (plus, minus):
            if n != GROUND and n not in self.terminals:
                raise self.error(e, f"its control node {n!r} is connected to nothing: drive it with a source")
        for gate in self.gates.values():
            if gate.nodes in ((plus, minus), (minus, plus)):
                return gate, 1 if gate.nodes == (plus, minus) else -1
        if any(n in gate.nodes for gate in self.gates.values() for n in (plus, minus) if n != GROUND):
            raise self.error(e, "its control nodes are driven by more than one gate source: give its control "
                             "voltage as one source across its control nodes")
        return None

    def switch(self, e) -> None:
        model, params, state = self.switch_model(e, 1, "SW")
        threshold, hysteresis = params.get("vt", 0), params.get("vh", 0)
        gate = self.gate_of(e)
        if gate is None:
            plus, minus = e.nodes[2:]
            if plus == minus or {plus, minus} == {GROUND}:
                raise self.error(e, "its control nodes are one node")
            control = (f"v_{plus}" if minus == GROUND else f"-v_{minus}" if plus == GROUND
                       else f"v_{plus} - v_{minus}")
            rule = level_rule(control, threshold, hysteresis)
            words = f"closed while {control} > {float(threshold + hysteresis):g} V"
        else:
            source, sign = gate
            rule, words = self.gate_rule(e, source, sign, threshold, hysteresis)
        self.add_switch(e, model, params, state, rule, words)

    def current_switch(self, e) -> None:
        model, params, state = self.switch_model(e, 2, "CSW")
        sense = self.local(e, e.args[0] if e.args else None, "V", "controlling source")
        if sense.name.lower() in self.gates:
            raise self.error(e, f"its controlling source {sense.name} carries no current (only switches' "
                             "controls touch its nodes)")
        threshold, hysteresis = params.get("it", 0), params.get("ih", 0)
        rule = level_rule(f"i_{sense.name}", threshold, hysteresis)
        words = f"closed while i_{sense.name} > {float(threshold + hysteresis):g} A"
        self.add_switch(e, model, params, state, rule, words)

    def switch_model(self, e, at: int, kind: str) -> tuple:
        """The switch's model, its parameters and its ON/OFF word (``None`` without one); the model's
        name is the ``at``-th token after the nodes."""
        positional, keys = keywords(e.args)
        if len(positional) < at or keys or any(not is_word(p) for p in positional):
            raise self.error(e, f"write it as {'Sname n1 n2 nc+ nc-' if kind == 'SW' else 'Wname n1 n2 Vsense'} "
                             "MODEL [ON|OFF]")
        words = [str(p).lower() for p in positional[at:]]
        if any(w not in ("on", "off") for w in words) or len(words) > 1:
            raise self.error(e, f"{' '.join(words)}: only ON or OFF (its state at t = 0) may follow the model")
        model, params = e.scope.model(positional[at - 1], e.card)
        if model.kind != kind:
            raise self.error(e, f"model {model.name} is a {model.kind} model; this switch needs a {kind} model")
        if params.get("vh", 0) < 0 or params.get("ih", 0) < 0:
            raise self.error(e, f"model {model.name}: a negative hysteresis is not read", UnsupportedCardError)
        return model, params, (words[0] == "on") if words else None

    def add_switch(self, e, model, params: dict, state, rule: tuple, words: str) -> None:
        closed_when, open_when, initial = rule
        ron = params.get("ron", 1)
        r_on = None if ron <= IDEAL_RESISTANCE else float(ron)
        self.c.switch(e.name, *e.nodes[:2], closed_when, open_when=open_when,
                      closed=state if state is not None else initial, r_on=r_on)
        ignored = sorted(set(params) - set(MODEL_PARAMETERS[model.kind]))
        self.note(e, f"{e.name}: an ideal switch {words}" + (f", r_on = {float(ron):g} Ω" if r_on else "")
                  + (f"; ROFF = {float(params['roff']):g} Ω is taken as open" if "roff" in params else "")
                  + (f"; {', '.join(k.upper() for k in ignored)} ignored" if ignored else ""))

    def gate_rule(self, e, source, sign: int, threshold, hysteresis) -> tuple:
        """The rule ``(closed_when, open_when, closed at t = 0)`` and its words for a switch driven by the
        gate source ``source`` (its control is ``sign`` times the source's value)."""
        value = self.source_value(source)
        wave = value if isinstance(value, Waveform) else Waveform("DC", (value,))
        control = GateControl(wave, sign, Fraction(threshold), Fraction(hysteresis))
        rule = gate_schedule(control)
        if rule is None:
            shown = wave.text() if sign > 0 else f"-({wave.text()})"
            rule = level_rule(shown, threshold, hysteresis)
            rule = (SpiceText(rule[0], control),) + rule[1:]
        words = (f"on {source.name}'s schedule, {rule[0]}" if isinstance(rule[0], PWM) else
                 f"closed while {str(rule[0])[:120]}")
        self.note(e, f"{source.name} drives only {e.name}'s control: {e.name} follows it and {source.name} is "
                  "not part of the circuit")
        return rule, words


class Assembler(_Devices):
    """The circuit of a reading's elements: gate sources folded into their switches, inductors
    into their couplings, each element added as its :class:`~models.circuits.Circuit` part."""

    def __init__(self, reader):
        self.reader = reader
        self.elements = reader.elements
        self.by_name = {e.name.lower(): e for e in self.elements}
        self.couplings: dict[str, tuple] = {}  # K name (lower) → (L1, L2, k)
        self.coupled: dict = {}  # inductor name (lower) → its K
        self.gates: dict = {}  # gate source name (lower) → the source
        self.ic: dict[str, Fraction] = {}  # node → .ic voltage
        self.c: Circuit | None = None

    def circuit(self, name: str) -> Circuit:
        self.c = Circuit(name)
        self.find_couplings()
        self.find_gates()
        self.read_ic()
        for e in self.elements:
            if e.name.lower() in self.coupled or e.name.lower() in self.gates:
                continue
            try:
                {"R": self.resistor, "C": self.capacitor, "L": self.inductor, "V": self.source, "I": self.source,
                 "B": self.behavioral, "D": self.diode, "S": self.switch, "W": self.current_switch,
                 "K": self.coupling}[e.kind](e)
            except SpiceNetlistError:
                raise
            except HybridBondGraphError as error:
                raise self.reader.error(SpiceNetlistError, e.card, str(error)) from None
        return self.c

    # -- helpers

    def error(self, e, message: str, cls=SpiceSyntaxError) -> SpiceNetlistError:
        return self.reader.error(cls, e.card, message)

    def value(self, e, token, what: str) -> Fraction | float:
        if token is None:
            raise self.error(e, f"its {what} is missing")
        return e.scope.value(token, e.card, f"its {what}")

    def one_value(self, e, what: str, allowed=()) -> tuple[float, dict]:
        """The element's single positional value (its ``what``) and its ``KEY=value`` pairs (only ``allowed``)."""
        positional, keys = keywords(e.args)
        if len(positional) != 1:
            raise self.error(e, f"write it as {e.kind}name n1 n2 {what.upper()}" + "".join(
                f" [{k.upper()}=value]" for k in allowed))
        unknown = sorted(set(keys) - set(allowed))
        if unknown:
            raise self.error(e, f"{', '.join(k.upper() for k in unknown)} is not read here"
                             + (f" (only {', '.join(k.upper() for k in allowed)})" if allowed else ""),
                             UnsupportedCardError)
        return float(self.value(e, positional[0], what)), keys

    def local(self, e, spelled, kinds: str, what: str):
        """The element named ``spelled`` in ``e``'s scope, of one of ``kinds``."""
        found = self.by_name.get(e.scope.element_name(str(spelled)).lower()) if is_word(spelled) else None
        if found is None or found.kind not in kinds:
            raise self.error(e, f"its {what} {spelled!r} is no {' or '.join(kinds)} element of the netlist")
        return found

    def note(self, e, text: str) -> None:
        self.reader.note(e.card, text)

    # -- passive elements

    def resistor(self, e) -> None:
        value, _ = self.one_value(e, "resistance")
        self.c.R(e.name, *e.nodes, value)

    def capacitor(self, e) -> None:
        value, keys = self.one_value(e, "capacitance", ("ic",))
        a, b = e.nodes
        if "ic" in keys:
            v0 = self.value(e, keys["ic"], "initial voltage IC")
        elif a in self.ic or b in self.ic:
            v0 = self.ic.get(a, 0) - self.ic.get(b, 0)
            self.note(e, f"{e.name} starts at {float(v0):g} V (.ic)")
        else:
            v0 = 0
        self.c.C(e.name, a, b, value, v0=float(v0))

    def inductor(self, e) -> None:
        value, keys = self.one_value(e, "inductance", ("ic",))
        i0 = self.value(e, keys["ic"], "initial current IC") if "ic" in keys else 0
        self.c.L(e.name, *e.nodes, value, i0=float(i0))

    def find_couplings(self) -> None:
        for e in self.elements:
            if e.kind != "K":
                continue
            positional, keys = keywords(e.args)
            if len(positional) != 3 or keys:
                raise self.error(e, "write a coupling as Kname L1 L2 k (two inductors and the coupling "
                                 "coefficient; SPICE's K couples pairs here)")
            windings = [self.local(e, p, "L", "inductor") for p in positional[:2]]
            k = self.value(e, positional[2], "coupling coefficient")
            if windings[0] is windings[1]:
                raise self.error(e, "it couples an inductor with itself")
            for winding in windings:
                other = self.coupled.get(winding.name.lower())
                if other is not None:
                    raise self.error(e, f"{winding.name} is coupled by {other.name} already: only pairs of "
                                     "coupled inductors are read", UnsupportedCardError)
                self.coupled[winding.name.lower()] = e
            if not 0 < k <= 1:
                raise self.error(e, f"k = {float(k):g}: give 0 < k ≤ 1 (for a negative k, swap the second "
                                 "inductor's nodes)")
            self.couplings[e.name.lower()] = (windings[0], windings[1], k)

    def coupling(self, e) -> None:
        first, second, k = self.couplings[e.name.lower()]
        values = []
        for winding in (first, second):
            value, keys = self.one_value(winding, "inductance", ("ic",))
            if "ic" in keys and self.value(winding, keys["ic"], "initial current IC") != 0:
                raise self.error(winding, f"coupled by {e.name}, it starts at 0 A in the toolkit: remove its IC")
            values.append(value)
        self.c.coupled_inductors(e.name, *first.nodes, *second.nodes, values[0], values[1], float(k))
        self.note(e, f"{e.name} couples {first.name} and {second.name}: coupled inductors {e.name} "
                  f"(i_{e.name}_p is {first.name}'s current, i_{e.name}_s {second.name}'s; v_{e.name}_p, "
                  f"v_{e.name}_s their voltages)")

    def read_ic(self) -> None:
        for card in self.reader.ic:
            tokens, i = list(card.tokens[1:]), 0
            while i < len(tokens):
                group = tokens[i:i + 6]
                if (len(group) < 6 or str(group[0]).lower() != "v" or group[1] != "(" or group[3] != ")"
                        or group[4] != "=" or not is_word(group[2])):
                    raise self.reader.error(SpiceSyntaxError, card, "write initial voltages as .ic V(node)=value …")
                node = self.reader.top.node(group[2], card) if group[2].lower() in self.reader.names["node"] \
                    or group[2].lower() in ("0", "gnd") else None
                if node is None or node == GROUND:
                    raise self.reader.error(SpiceSyntaxError, card, f"V({group[2]}): no element has node "
                                            f"{group[2]!r} (or it is ground)")
                self.ic[node] = self.reader.top.value(group[5], card, f"V({group[2]})")
                i += 6
        touched = {n for e in self.elements if e.kind == "C" for n in e.nodes}
        for node in sorted(set(self.ic) - touched):
            self.reader.note(None, f".ic V({node}) is not used: no capacitor has node {node!r} (the states are "
                             "the capacitors' charges and the inductors' fluxes)")

    # -- sources

    def source(self, e) -> None:
        value = self.source_value(e)
        if isinstance(value, Waveform):
            value = SpiceText(value.text(), value)
        else:
            value = float(value)
        (self.c.V if e.kind == "V" else self.c.I)(e.name, *e.nodes, value)

    def source_value(self, e):
        """A V or I element's value: its DC value (exact), or its transient function (a :class:`Waveform`)."""
        tokens, i, dc, wave = list(e.args), 0, None, None
        while i < len(tokens):
            word = tokens[i].lower() if is_word(tokens[i]) else ""
            if word == "dc":
                dc = self.value(e, tokens[i + 1] if i + 1 < len(tokens) else None, "DC value")
                i += 2
            elif word == "ac":
                i = self.after_values(tokens, i + 1, 2)
                self.note(e, "its AC specification is ignored (a small-signal analysis's)")
            elif word in ("sin", "pulse", "pwl"):
                values, i = self.function_values(e, tokens, i + 1, word.upper())
                wave = self.waveform(e, word.upper(), values)
            elif word in _OTHER_FUNCTIONS:
                raise self.error(e, f"the transient function {word.upper()} is not read (SIN, PULSE and PWL "
                                 "are)", UnsupportedCardError)
            elif i == 0:
                dc = self.value(e, tokens[0], "value")
                i += 1
            else:
                raise self.error(e, f"{tokens[i]!r} is not read here: write [DC] value, or SIN(…), PULSE(…), PWL(…)")
        if wave is not None and dc not in (None, 0):
            self.note(e, "its DC value is SPICE's operating point's; the run follows its transient function")
        return wave if wave is not None else (dc if dc is not None else 0)

    def after_values(self, tokens, i: int, most: int) -> int:
        """The index after at most ``most`` value tokens from ``i``."""
        for _ in range(most):
            if i < len(tokens) and (isinstance(tokens[i], Expression) or exact_number(str(tokens[i])) is not None):
                i += 1
        return i

    def function_values(self, e, tokens, i: int, kind: str) -> tuple[list, int]:
        """The values of a transient function from ``tokens[i]``: in parentheses, or bare to the end."""
        if i < len(tokens) and tokens[i] == "(":
            end = next((j for j in range(i, len(tokens)) if tokens[j] == ")"), None)
            if end is None:
                raise self.error(e, f"{kind}( has no closing parenthesis")
            inner, after = tokens[i + 1:end], end + 1
        else:
            inner, after = tokens[i:], len(tokens)
        if "=" in inner:
            raise self.error(e, f"{kind} options (r=, td=, …) are not read", UnsupportedCardError)
        return [self.value(e, token, f"{kind} value {k + 1}") for k, token in enumerate(inner)], after

    def waveform(self, e, kind: str, values: list) -> Waveform:
        values = [v if isinstance(v, Fraction) else Fraction(v) for v in values]
        if kind == "SIN":
            if not 2 <= len(values) <= 6:
                raise self.error(e, "write SIN(VO VA [FREQ [TD [THETA [PHASE]]]])")
            defaults = [None, None, lambda: 1 / self.tran_value(e, "stop", "SIN's FREQ"), 0, 0, 0]
            return Waveform("SIN", tuple(self.filled(values, defaults)))
        if kind == "PULSE":
            return self.pulse(e, values)
        if len(values) < 2 or len(values) % 2 or len(values) > 2 * MAX_PWL_POINTS:
            raise self.error(e, f"write PWL(t1 v1 t2 v2 …): pairs of a time and a value, at most "
                             f"{MAX_PWL_POINTS} points (a longer record: an Input of Circuit, in Python)")
        times = values[::2]
        if times[0] < 0 or any(b < a for a, b in zip(times, times[1:])):
            raise self.error(e, "PWL's times must start at 0 or later and never decrease")
        return Waveform("PWL", tuple(values))

    def filled(self, values: list, defaults: list) -> list:
        return values + [d() if callable(d) else d for d in defaults[len(values):]]

    def tran_value(self, e, which: str, what: str) -> Fraction:
        if self.reader.tran is None:
            raise self.error(e, f"{what} is left to its SPICE default, which is the .tran's: give it, or add a "
                             ".tran card")
        return Fraction(repr(getattr(self.reader.tran, which)))  # (the decimal written)

    def pulse(self, e, values: list) -> Waveform:
        if not 2 <= len(values) <= 8:
            raise self.error(e, "write PULSE(V1 V2 [TD [TR [TF [PW [PER [NP]]]]]])")
        step = lambda: self.tran_value(e, "step", "PULSE's TR or TF")
        stop = lambda: self.tran_value(e, "stop", "PULSE's PW or PER")
        v1, v2, td, tr, tf, pw, per, count = self.filled(values, [None, None, 0, step, step, stop, stop, None])
        if tr < 0 or tf < 0 or pw < 0 or per <= 0:
            raise self.error(e, "PULSE needs TR, TF, PW ≥ 0 and PER > 0 (a negative TD shifts the train, as in "
                             "ngspice)")
        if count is not None and (count.denominator != 1 or count < 1):
            raise self.error(e, "PULSE's NP (the number of pulses) must be a whole number ≥ 1")
        off = per - tr - pw - tf
        shortest = min([x for x in (pw, off) if x > 0] or [per])
        ideal = max(tr, tf) <= Fraction(self.reader.options["ideal_edges"]) * shortest
        if not ideal:
            if off < 0:
                raise self.error(e, "PULSE's TR + PW + TF is longer than its PER")
            tr, tf = (x or self.tran_value(e, "step", "a PULSE edge of 0 beside a ramp") for x in (tr, tf))
        return Waveform("PULSE", (v1, v2, td, tr, tf, pw, per, count), ideal)

    def behavioral(self, e) -> None:
        match = re.fullmatch(r"\S+(?:\s+\S+){2}\s+([VvIi])\s*=\s*(.+)", e.card.text)
        if not match:
            raise self.error(e, "write a behavioural source as Bname n+ n- V=expression (or I=expression) of "
                             "time and .param values")
        body = match.group(2).strip()
        if body.startswith("{") and body.endswith("}"):
            body = body[1:-1]
        try:
            text, _ = translate(body, e.scope.param, time=True)
        except SpiceNetlistError as error:
            raise self.error(e, str(error), type(error)) from None
        (self.c.V if match.group(1).lower() == "v" else self.c.I)(e.name, *e.nodes, text)
        if re.search(r"\bu\s*\(", body, re.IGNORECASE):
            self.note(e, "u(x) is read as step(x), which is 1 at x = 0 (ngspice's u is 0 there)")


def level_rule(control: str, threshold, hysteresis) -> tuple:
    """``(closed_when, open_when, None)``: closed when ``control`` exceeds ``threshold + hysteresis``,
    open when it falls below ``threshold − hysteresis`` (SPICE's switch)."""
    high, low = Fraction(threshold) + Fraction(hysteresis), Fraction(threshold) - Fraction(hysteresis)
    return f"{control} > {float_text(high)}", (f"{control} < {float_text(low)}" if hysteresis else None), None


def gate_schedule(control: GateControl):
    """The rule of a switch whose gate is a DC level or a PULSE with ideal edges: a constant, a
    :class:`~models.circuits.PWM` where the pulse train is one (no NP, nothing high before TD), else
    a condition on the pulse's carrier; ``None`` for other waveforms."""
    wave, sign = control.waveform, control.sign
    high = control.threshold + control.hysteresis
    low = control.threshold - control.hysteresis
    if wave.kind == "DC":
        level = sign * wave.values[0]
        constant = "true" if level > high else "false"
        return SpiceText(constant, control), None, level > high
    if wave.kind != "PULSE" or not wave.ideal:
        return None
    v1, v2, td, tr, tf, pw, per, count = wave.values
    first, second = sign * v1, sign * v2
    rise, width = td + tr / 2, pw + (tr + tf) / 2
    on_pulse, off_pulse = second > high and first < low, first > high and second < low
    if not (on_pulse or off_pulse) or width <= 0 or width >= per:
        return None
    high_at_start = rise <= 0 and (-rise) % per < width  # (SPICE's pulse is V1 before TD)
    if count is None and rise + width <= per:
        if on_pulse:
            return PWM(float(per), float(width / per), float(rise)), None, high_at_start
        return PWM(float(per), float(1 - width / per), float(rise + width)), None, not high_at_start
    duty = width / per
    condition = f"acos(cos(2*pi*{shifted(rise)}/{float_text(per)} - pi*{float_text(duty)}))/pi <= {float_text(duty)}"
    if rise - per + width > 0:
        condition += f" and t >= {float_text(rise)}"
    if count is not None:
        condition += f" and t < {float_text(rise + (count - 1) * per + (width + per) / 2)}"
    condition = condition if on_pulse else f"not ({condition})"
    return SpiceText(condition, control), None, on_pulse == high_at_start
