"""Reading a SPICE netlist (:func:`read`): its cards sorted into definitions (subcircuits, models,
parameters, ``.tran``, ``.ic``, ``.options``) and elements, the elements flattened out of their
subcircuits with ngspice's names, then the circuit made of them (:mod:`models.spice_assembly`).
See :mod:`models.spice` for the subset read."""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

from .circuits import GROUND, Circuit
from .spice_assembly import Assembler
from .spice_forms import DIODE_RULES, GMIN, NOMINAL_TEMPERATURE, Tran
from .spice_syntax import (
    Card,
    Expression,
    SpiceNetlistError,
    SpiceSyntaxError,
    UnsupportedCardError,
    as_expression,
    card_tokens,
    evaluate,
    exact_number,
    is_word,
    keywords,
    logical_lines,
)
from .spice_writer import write

__all__ = ["read", "SpiceNetlist", "Element", "Scope", "Reader", "MAX_NETLIST_BYTES", "MAX_SUBCIRCUIT_DEPTH"]

#: the largest netlist read [bytes]
MAX_NETLIST_BYTES = 10_000_000
#: the deepest nesting of subcircuit instances
MAX_SUBCIRCUIT_DEPTH = 20


# ---------------------------------------------------------------------------------------------- the netlist read

@dataclass
class SpiceNetlist:
    """A SPICE netlist read (:func:`read`): its :class:`~models.circuits.Circuit`, its ``title``, the
    ``.tran`` (:class:`Tran`, or ``None``), ``notes`` (one line for each choice the reader made:
    how each diode and switch was mapped, a card ignored), ``diodes`` (diode name → the mapping it
    got) and ``source`` (the path, or ``<text>``).

    It is also what ``hbg`` runs (as a shipped model's module): ``DEFAULTS`` (the parameters of the
    built model: each component's number under its name), ``RUN`` (the ``.tran`` as run settings),
    ``SIGNALS`` (the nodes' voltages) and ``build(**parameters)``."""

    circuit: Circuit
    title: str = ""
    tran: Tran | None = None
    notes: list = field(default_factory=list)
    diodes: dict = field(default_factory=dict)
    source: str = "<text>"

    def __post_init__(self):
        self._model = self._defaults = None  # (the model DEFAULTS built, handed to the first build())
        # (hbg's summaries read a module's docstring)
        self.__doc__ = f"{self.title or self.circuit.name} (SPICE netlist {self.source})"

    @property
    def name(self) -> str:
        return self.circuit.name

    @property
    def run(self) -> dict:
        """The run settings of the ``.tran`` card (``t_end``, ``max_step``); empty without one."""
        return self.tran.run if self.tran else {}

    @property
    def RUN(self) -> dict:
        if self.tran is None:
            raise SpiceNetlistError(f"{self.source}: the netlist has no .tran card, so it has no run: add "
                                    "'.tran TSTEP TSTOP' (SPICE's transient analysis) to run it",
                                    source=self.source)
        return dict(self.run)

    @property
    def SIGNALS(self) -> tuple:
        return tuple(f"v_{n}" for n in self.circuit.nodes if n != GROUND)

    @property
    def DEFAULTS(self) -> dict:
        if self._defaults is None:
            self._model = self.circuit.build()
            self._defaults = {s.name: v for s, v in self._model.parameter_values.items()}
        return dict(self._defaults)

    def build(self, **parameters):
        """The circuit's :class:`~switching.HybridModel`, its component values overridden by
        ``parameters`` (``R1=2e3``)."""
        if not parameters and self._model is not None:
            model, self._model = self._model, None
            return model
        return self.circuit.build(parameters=parameters or None)

    def write(self) -> str:
        """The netlist written again (:func:`write`) with its ``.tran``."""
        return write(self.circuit, self.tran, title=self.title or None)


@dataclass
class Model:
    """A ``.model`` card: its name, type (upper case), parameters (lower case → value token) and card."""

    name: str
    kind: str
    parameters: dict
    card: Card


@dataclass
class _Subcircuit:
    """A ``.subckt`` definition: name, ports, default parameters (name → token), body cards, its
    own ``.model`` and ``.param`` cards, and the card that opened it."""

    name: str
    ports: tuple
    defaults: dict
    card: Card
    body: list = field(default_factory=list)
    models: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)


@dataclass
class Element:
    """One element after flattening: its letter, the circuit's name for it, its nodes (the circuit's
    names), the tokens after its nodes, its card and its scope."""

    kind: str
    name: str
    nodes: tuple
    args: tuple
    card: Card
    scope: Scope


#: the nodes each element letter has
_NODE_COUNT = {"R": 2, "C": 2, "L": 2, "V": 2, "I": 2, "D": 2, "B": 2, "S": 4, "W": 2, "K": 0}
#: why an element letter is not read, and what to do
_REFUSED_ELEMENTS = {
    "Q": "a bipolar transistor (Q) is not read: model it as a switch S driven by its base signal",
    "M": "a MOSFET (M) is not read: draw it as a voltage-controlled switch S (RON its R_DS(on)) with its "
         "body diode D from source to drain (Circuit.mosfet is that pair)",
    "J": "a JFET (J) is not read: model it as a switch S",
    "Z": "a MESFET (Z) is not read: model it as a switch S",
    "E": "a controlled source (E) is not read",
    "F": "a controlled source (F) is not read",
    "G": "a controlled source (G) is not read",
    "H": "a controlled source (H) is not read",
    "T": "a transmission line (T) is not read: draw it as L and C sections",
    "O": "a lossy transmission line (O) is not read: draw it as R, L and C sections",
    "U": "a uniform RC line (U) is not read: draw it as R and C sections",
    "A": "an XSPICE code model (A) is not read",
}
#: dot cards that ask for an analysis the toolkit does not run
_ANALYSES = (".ac", ".dc", ".op", ".noise", ".tf", ".disto", ".pz", ".sens", ".four", ".fourier", ".pss",
             ".sp", ".meas", ".measure")
#: dot cards that only ask for output: noted and ignored
_OUTPUT_REQUESTS = (".print", ".plot", ".probe", ".save", ".width")
#: the model types read, and those SPICE has that are not
_MODEL_TYPES = ("D", "SW", "CSW")
_OTHER_MODEL_TYPES = ("NPN", "PNP", "NMOS", "PMOS", "NJF", "PJF", "NMF", "PMF", "R", "C", "L", "URC", "LTRA",
                      "VDMOS", "HFET1", "HFET2", "TRANSLINE")
def _identifier(text: str) -> str:
    """``text`` with every character but letters, digits and ``_`` made ``_`` (a circuit's names)."""
    return re.sub(r"[^A-Za-z0-9_]", "_", text)


class Scope:
    """Where a card is read: the top level, or an instance of a subcircuit (``path``: the instance
    names from the top).  Knows the nodes' names (a port is the node the instance connects it to, an
    inner node is named with the path), the parameters (evaluated when first used, cycles refused),
    and the models."""

    def __init__(self, reader: Reader, parent: Scope | None = None, path: tuple = (), ports=None,
                 params: Mapping | None = None, values: Mapping | None = None, models: Mapping | None = None):
        self.reader, self.parent, self.path = reader, parent, path
        self.ports = dict(ports or {})  # port (lower case) → the circuit's node
        self.raw = dict(params or {})  # name (lower case) → (value token, card)
        self.values = dict(values or {})  # name → its value
        self.models = dict(models or {})  # name (lower case) → Model
        self.busy: set = set()

    def param(self, name: str):
        """The value of parameter ``name`` (lower case), or ``None`` when no scope defines it."""
        if name in self.values:
            return self.values[name]
        if name in self.raw:
            token, card = self.raw[name]
            if name in self.busy:
                raise self.reader.error(SpiceSyntaxError, card, f"parameter {name!r} is defined through "
                                        "itself (a cycle of .param values)")
            self.busy.add(name)
            try:
                self.values[name] = self.value(token, card, f"parameter {name!r}")
            finally:
                self.busy.discard(name)
            return self.values[name]
        return self.parent.param(name) if self.parent else None

    def value(self, token, card: Card, what: str) -> Fraction | float:
        """A value token: a number, a ``{expression}`` or a parameter's name; else an error naming ``what``."""
        try:
            if isinstance(token, Expression):
                return _finite(evaluate(token, self.param))
            exact = exact_number(token) if is_word(token) else None
            if exact is not None:
                return _finite(exact)
            known = self.param(token.lower()) if re.fullmatch(r"[A-Za-z_]\w*", token) else None
            if known is not None:
                return known
        except SpiceNetlistError as error:
            raise self.reader.error(type(error), card, f"{what}: {error}") from None
        raise self.reader.error(SpiceSyntaxError, card, f"{what}: {token!r} is not a number (SPICE numbers: "
                                "2.2k, 10uF, 1e-3), a {expression} or a .param name")

    def node(self, spelled: str, card: Card) -> str:
        """The circuit's name of the node ``spelled`` here."""
        lower = spelled.lower()
        if lower in ("0", "gnd"):
            return GROUND
        if lower in self.ports:
            return self.ports[lower]
        name = "_".join(self.path + (_identifier(spelled),))
        fresh = name.lower() not in self.reader.names["node"]
        name = self.reader.register("node", name, (self.path, lower), card)
        if fresh and _identifier(spelled) != spelled:
            self.reader.note(card, f"node {spelled!r} is named {name!r} (letters, digits and '_')")
        return name

    def element_name(self, spelled: str) -> str:
        """The circuit's name of the element ``spelled`` here: ngspice's ``r.x1.r1`` with ``_``."""
        if not self.path:
            return _identifier(spelled)
        return "_".join((spelled[0].upper(),) + self.path + (_identifier(spelled),))

    def model(self, name: str, card: Card) -> tuple[Model, dict]:
        """The model ``name`` seen from here, with its parameters' values."""
        scope = self
        while scope is not None and name.lower() not in scope.models:
            scope = scope.parent
        if scope is None:
            raise self.reader.error(SpiceSyntaxError, card, f"model {name!r} is not defined: add a .model "
                                    f"{name} card")
        model = scope.models[name.lower()]
        return model, {key: scope.value(token, model.card, f"{key.upper()} of model {model.name}")
                       for key, token in model.parameters.items()}


class Reader:
    """One reading of a netlist: its cards, definitions (subcircuits, models, parameters, ``.tran``,
    ``.ic``, ``.options``), its elements flattened, then the circuit (:class:`Assembler`)."""

    def __init__(self, text: str, source: str, options: dict):
        self.source, self.options = source, options
        self.notes: list[str] = []
        self.names: dict[str, dict] = {"node": {}, "component": {}, "instance": {}}
        self.subcircuits: dict[str, _Subcircuit] = {}
        self.top = Scope(self)
        self.tran: Tran | None = None
        self.ic: list = []
        self.gmin = GMIN  # the diodes' leak [S] and temperature [K] (.options gmin, temp)
        self.temperature = NOMINAL_TEMPERATURE
        self.elements: list[Element] = []
        self.diode_words: dict[str, str] = {}
        title, lines, notes = logical_lines(text, self.error_at)
        self.title = title
        self.notes += notes
        self.cards = [self.card(line, body) for line, body in lines]

    # -- errors and names

    def error_at(self, cls, line, card_text: str, message: str) -> SpiceNetlistError:
        """An error of class ``cls`` at ``line`` (``None``: the whole netlist) of card ``card_text``."""
        where = f"{self.source}, line {line}" if line else self.source
        head = card_text.split(None, 1)[0] if card_text else ""
        return cls(f"{where}: {head + ': ' if head else ''}{message}", line, card_text, self.source)

    def error(self, cls, card: Card, message: str) -> SpiceNetlistError:
        return self.error_at(cls, card.line, card.text, message)

    def card(self, line: int, text: str) -> Card:
        try:
            return Card(line, text, card_tokens(text))
        except SpiceNetlistError as error:
            raise self.error_at(type(error), line, text, str(error)) from None

    def note(self, card: Card | None, text: str) -> None:
        self.notes.append(f"line {card.line}: {text}" if card else text)

    def register(self, what: str, name: str, origin, card: Card) -> str:
        """Claim ``name`` (case-insensitively) for a node or component made at ``origin``: a node
        named twice from one place is one node; anything else named twice is refused."""
        table = self.names[what]
        known = table.get(name.lower())
        if known is not None:
            if what == "node" and known[1] == origin:
                return known[0]
            raise self.error(SpiceSyntaxError, card, f"the {what} name {name!r} is taken (line {known[2].line}: "
                             f"{known[2].text[:60]}); SPICE names are case-insensitive: rename one")
        if not re.fullmatch(r"[A-Za-z0-9_]+", name) or (what == "component" and not name[0].isalpha()):
            raise self.error(SpiceSyntaxError, card, f"{what} name {name!r}: use letters, digits and '_'")
        table[name.lower()] = (name, origin, card)
        return name

    # -- definitions

    def read(self) -> SpiceNetlist:
        top_cards = self.define(self.cards)
        self.flatten(top_cards, self.top)
        if not self.elements:
            raise self.error_at(SpiceSyntaxError, None, "", "the netlist has no elements (its first line is "
                                "the title; the elements follow)")
        circuit = Assembler(self).circuit(_circuit_name(self.options.get("name"), self.title))
        if self.tran is not None and not self.tran.uic:
            self.note(None, "the run starts from the initial conditions (IC=, .ic; 0 elsewhere), as SPICE's "
                      ".tran … UIC: the toolkit does not compute SPICE's DC operating point")
        netlist = SpiceNetlist(circuit, self.title, self.tran, self.notes, {}, self.source)
        netlist.diodes = dict(self.diode_words)
        return netlist

    def define(self, cards) -> list:
        """Sort the cards: subcircuit bodies, models and parameters to their scopes, the control
        cards read; returns the top level's element cards."""
        top, current = [], None
        for card in cards:
            head = card.head.lower()
            if head == ".subckt":
                if current is not None:
                    raise self.error(UnsupportedCardError, card, f"a .subckt inside .subckt {current.name} "
                                     f"(line {current.card.line}): define each subcircuit at the top level")
                current = self.subcircuit(card)
            elif head == ".ends":
                if current is None:
                    raise self.error(SpiceSyntaxError, card, ".ends without its .subckt")
                current = None
            elif head == ".model":
                model = self.model_card(card)
                (current.models if current else self.top.models)[model.name.lower()] = model
            elif head == ".param":
                (current.params if current else self.top.raw).update(self.param_card(card))
            elif head.startswith("."):
                if current is not None:
                    raise self.error(UnsupportedCardError, card, f"inside .subckt {current.name} only elements, "
                                     ".model and .param cards are read")
                self.control(card)
            else:
                (current.body if current else top).append(card)
        if current is not None:
            raise self.error(SpiceSyntaxError, current.card, f".subckt {current.name} has no .ends")
        return top

    def subcircuit(self, card: Card) -> _Subcircuit:
        positional, keys = keywords(card.tokens[1:])
        positional = [p for p in positional if str(p).lower() != "params:"]
        if not positional:
            raise self.error(SpiceSyntaxError, card, "give the subcircuit's name and ports: .subckt NAME n1 n2 …")
        name, ports = positional[0], tuple(str(p) for p in positional[1:])
        if name.lower() in self.subcircuits:
            raise self.error(SpiceSyntaxError, card, f"subcircuit {name} is defined twice (line "
                             f"{self.subcircuits[name.lower()].card.line})")
        defaults = {k: (as_expression(v), card) for k, v in keys.items()}
        self.subcircuits[name.lower()] = _Subcircuit(name, ports, defaults, card)
        return self.subcircuits[name.lower()]

    def model_card(self, card: Card) -> Model:
        positional, keys = keywords(card.tokens[1:])
        if len(positional) != 2:
            raise self.error(SpiceSyntaxError, card, "write a model as .model NAME TYPE(PARAM=value …)")
        name, kind = str(positional[0]), str(positional[1]).upper()
        if kind not in _MODEL_TYPES:
            known = "a SPICE model type that is not read" if kind in _OTHER_MODEL_TYPES else "an unknown model type"
            raise self.error(UnsupportedCardError, card, f"{kind} is {known}: the models read are D (diodes), "
                             "SW (voltage-controlled switches) and CSW (current-controlled switches)")
        return Model(name, kind, keys, card)

    def param_card(self, card: Card) -> dict:
        positional, keys = keywords(card.tokens[1:])
        if positional or not keys:
            raise self.error(SpiceSyntaxError, card, "write parameters as .param name=value (or name={expression})")
        return {k: (as_expression(v), card) for k, v in keys.items()}

    def control(self, card: Card) -> None:
        """A dot card at the top level other than .subckt, .model and .param."""
        head = card.head.lower()
        if head == ".tran":
            self.tran = self.tran_card(card)
        elif head == ".ic":
            self.ic.append(card)
        elif head in (".options", ".option", ".opt"):
            self.options_card(card)
        elif head == ".title":
            self.title = card.text.split(None, 1)[1] if len(card.tokens) > 1 else ""
        elif head in _OUTPUT_REQUESTS:
            self.note(card, f"{head} (an output request) is ignored: the run keeps every signal")
        else:
            raise self.error(UnsupportedCardError, card, _refused_control(head))

    def tran_card(self, card: Card) -> Tran:
        positional, keys = keywords(card.tokens[1:])
        uic = any(str(p).lower() == "uic" for p in positional)
        values = [float(self.top.value(p, card, f".tran's {what}"))
                  for p, what in zip([p for p in positional if str(p).lower() != "uic"],
                                     ("TSTEP", "TSTOP", "TSTART", "TMAX", "fifth value"))]
        if len(values) < 2 or len(values) > 4 or keys:
            raise self.error(SpiceSyntaxError, card, "write the transient analysis as .tran TSTEP TSTOP [TSTART "
                             "[TMAX]] [UIC]")
        step, stop, start, max_step = (values + [0.0, 0.0])[:4]
        if not (step > 0 and stop > 0 and 0 <= start < stop and max_step >= 0):
            raise self.error(SpiceSyntaxError, card, "TSTEP and TSTOP must be positive, 0 ≤ TSTART < TSTOP, TMAX ≥ 0")
        if start:
            self.note(card, f"TSTART = {start:g} s: SPICE records from there; the run starts at 0")
        return Tran(step, stop, start, max_step or None, uic)

    def options_card(self, card: Card) -> None:
        positional, keys = keywords(card.tokens[1:])
        if "gmin" in keys:
            self.gmin = float(self.top.value(keys.pop("gmin"), card, "gmin"))
        if "temp" in keys or "tnom" in keys:
            celsius = [float(self.top.value(keys.pop(k), card, k)) if k in keys else 27.0 for k in ("temp", "tnom")]
            if celsius[0] != celsius[1]:
                raise self.error(UnsupportedCardError, card, f"TEMP = {celsius[0]:g} °C and TNOM = {celsius[1]:g} "
                                 "°C: SPICE would scale the diodes' IS with temperature, which is not read; give "
                                 "TEMP = TNOM (IS is then the value at that temperature)")
            self.temperature = NOMINAL_TEMPERATURE if celsius[0] == 27.0 else celsius[0] + 273.15
        ignored = [str(p) for p in positional] + [f"{k}" for k in keys]
        if ignored:
            self.note(card, f"options {', '.join(ignored)} are ignored (the run's tolerances are its own: "
                      "hbg run --rtol, --atol, --max-step)")

    # -- elements

    def flatten(self, cards, scope: Scope, chain: tuple = ()) -> None:
        """Each element card of ``cards`` read in ``scope``, instances expanded (recursively)."""
        for card in cards:
            letter = card.head[0].upper()
            if letter == "X":
                self.instance(card, scope, chain)
            elif letter in _NODE_COUNT:
                self.elements.append(self.element(card, scope, letter))
            else:
                why = _REFUSED_ELEMENTS.get(letter, f"{letter} is no element letter SPICE reads here")
                raise self.error(UnsupportedCardError, card, f"{why}; the elements read are R, C, L, K, V, I, "
                                 "B, D, S, W and X")

    def element(self, card: Card, scope: Scope, letter: str) -> Element:
        count = _NODE_COUNT[letter]
        nodes = card.tokens[1:1 + count]
        if len(nodes) < count or any(not is_word(n) for n in nodes):
            raise self.error(SpiceSyntaxError, card, f"a {letter} element has {count} nodes after its name")
        name = self.register("component", scope.element_name(card.head), (scope.path, card.head.lower()), card)
        return Element(letter, name, tuple(scope.node(n, card) for n in nodes), card.tokens[1 + count:], card,
                        scope)

    def instance(self, card: Card, scope: Scope, chain: tuple) -> None:
        positional, keys = keywords(card.tokens[1:])
        positional = [p for p in positional if str(p).lower() != "params:"]
        if not positional or any(not is_word(p) for p in positional):
            raise self.error(SpiceSyntaxError, card, "write an instance as Xname node… SUBCKT [param=value …]")
        definition = self.subcircuits.get(str(positional[-1]).lower())
        if definition is None:
            raise self.error(SpiceSyntaxError, card, f"subcircuit {positional[-1]!r} is not defined (.subckt "
                             f"{positional[-1]} … .ends)")
        if definition.name.lower() in chain or len(chain) >= MAX_SUBCIRCUIT_DEPTH:
            raise self.error(SpiceSyntaxError, card, f"subcircuit {definition.name} contains itself (through "
                             f"{' → '.join(chain)}) or nests more than {MAX_SUBCIRCUIT_DEPTH} deep")
        nodes = positional[:-1]
        if len(nodes) != len(definition.ports):
            raise self.error(SpiceSyntaxError, card, f"subcircuit {definition.name} has {len(definition.ports)} "
                             f"ports ({' '.join(definition.ports)}), the instance gives {len(nodes)} nodes")
        path = scope.path + (_identifier(card.head),)
        self.register("instance", "_".join(path), path, card)
        ports = {p.lower(): scope.node(n, card) for p, n in zip(definition.ports, nodes)}
        values = {k: scope.value(v, card, f"parameter {k} of {card.head}") for k, v in keys.items()}
        inner = Scope(self, scope, path, ports, {**definition.defaults, **definition.params}, values,
                       definition.models)
        self.flatten(definition.body, inner, chain + (definition.name.lower(),))


def _finite(value):
    """``value`` if a double holds it, else a :class:`SpiceSyntaxError`."""
    try:
        if math.isfinite(float(value)) and (float(value) != 0 or value == 0):
            return value
    except OverflowError:
        pass
    raise SpiceSyntaxError("the value is beyond a double's range (above 1.8e308, or below 2.2e-308 but not 0)")


def _refused_control(head: str) -> str:
    """Why a dot card is refused, and what to do."""
    if head in _ANALYSES:
        return (f"the analysis {head} is not run: the toolkit runs the transient analysis (.tran TSTEP "
                "TSTOP); remove this card")
    if head in (".include", ".inc", ".lib", ".lib.end", ".endl"):
        return ("a netlist is read alone and never opens other files: paste the models and subcircuits it "
                "needs into the netlist")
    if head == ".temp":
        return "the diodes are at SPICE's nominal 27 °C: remove .temp"
    if head == ".nodeset":
        return ".nodeset guides SPICE's DC operating point, which the run does not compute: give .ic instead"
    return (f"{head} is not read: the cards read are .param, .tran, .ic, .model, .subckt/.ends, .options, "
            ".control/.endc and .end")


def _circuit_name(given: str | None, title: str) -> str:
    """The circuit's name: ``given``, else the title made an identifier (at most 60 characters)."""
    if given:
        return given
    name = re.sub(r"\W+", "_", title, flags=re.ASCII).strip("_")[:60].rstrip("_")
    if not name:
        return "netlist"
    return name if name[0].isalpha() or name[0] == "_" else f"c_{name}"


# ---------------------------------------------------------------------------------------------- reading

def read(source, *, diodes="auto", ideal_edges: float = 1e-3, reference_current: float = 1.0,
         name: str | None = None) -> SpiceNetlist:
    """The :class:`SpiceNetlist` of a SPICE netlist: ``source`` is a path (a ``str`` without a line
    break, or a path object) or the netlist's text.

    ``diodes`` says how each ``D`` is modelled: ``"auto"`` (the default: a model with LTspice's
    ``Vfwd``/``Ron`` is ``"piecewise"``, any other ``"exponential"``), ``"ideal"``, ``"piecewise"`` or
    ``"exponential"`` (see :func:`diode_mapping`) — one word for all, or a mapping from a diode's or a
    model's name to a word (``{"D1": "ideal", "DMOD": "exponential"}``; others ``"auto"``);
    ``netlist.diodes`` says what each got.  ``ideal_edges``: the longest PULSE edge, relative to the
    pulse's shortest level, read as an ideal step (0: every edge given a ramp is one).
    ``reference_current`` [A]: where ``"piecewise"`` takes the exponential's tangent.  ``name``: the
    circuit's (default: the title made an identifier).

    Raises :class:`SpiceNetlistError` (a :class:`SpiceSyntaxError` or :class:`UnsupportedCardError`)
    naming the line, the card and what to do."""
    text, where = _source_text(source)
    if isinstance(diodes, str) and diodes not in DIODE_RULES:
        raise SpiceNetlistError(f"diodes={diodes!r}: give one of {', '.join(DIODE_RULES)} (or a mapping of "
                                "diode or model names to them)")
    options = {"diodes": diodes, "ideal_edges": ideal_edges, "reference_current": reference_current, "name": name}
    return Reader(text, where, options).read()


def _source_text(source) -> tuple[str, str]:
    """``(text, how errors name it)`` of a path or of netlist text."""
    if isinstance(source, os.PathLike) or (isinstance(source, str) and "\n" not in source):
        path = Path(source)
        if path.stat().st_size > MAX_NETLIST_BYTES:
            raise SpiceNetlistError(f"{path}: a netlist of {path.stat().st_size} bytes is more than this reader "
                                    f"takes ({MAX_NETLIST_BYTES})", source=str(path))
        return path.read_text(encoding="utf-8", errors="replace"), str(path)
    if not isinstance(source, str):
        raise TypeError(f"read() takes a path or the netlist's text, got {type(source).__name__}")
    if len(source) > MAX_NETLIST_BYTES:
        raise SpiceNetlistError(f"a netlist of {len(source)} characters is more than this reader takes")
    return source, "<text>"
