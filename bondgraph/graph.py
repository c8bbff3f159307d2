"""The bond graph container: elements, bonds, ports, sub-model instances.

A :class:`BondGraph` holds data; the algorithms (causality, equations) are
functions over it, reached through :meth:`BondGraph.causality` and
:meth:`BondGraph.equations`, which cache their results per configuration and
drop the cache whenever the graph changes.

Example — a series RLC circuit driven by a voltage source::

    >>> from bondgraph import BondGraph, Se, R, I, C, One
    >>> g = BondGraph("rlc")
    >>> j = g.add(One("j"))
    >>> for e in (Se("V", "V0"), R("R"), I("L"), C("C")):
    ...     _ = g.connect(e, j) if e.kind == "Se" else g.connect(j, e)
    >>> eq = g.equations()
    >>> eq.rates[g.state("p_L")]
    V0 - R*p_L/L - q_C/C
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import sympy as sp

from .derivation import Derivations
from .elements import Element, Junction, OnePort, OpenPort, Storage, TwoPort
from .errors import (
    DuplicateNameError,
    InvalidGraphError,
    MissingParameterError,
    UnknownNameError,
    UnknownParameterError,
    did_you_mean,
)
from .namespace import graph_namespace
from .symbols import check_name, t

__all__ = ["Bond", "BondGraph", "Instance", "Configuration", "OpenPort"]

#: A configuration: controlled junction name → on (True) / off (False).
Configuration = Mapping[str, bool]


@dataclass(frozen=True)
class Bond:
    """A power bond from ``tail`` to ``head`` (positive power flows tail → head).

    ``effort`` and ``flow`` are the bond's variable symbols ``e_<name>`` and
    ``f_<name>``; modulated sources may use them in their expressions.
    """

    name: str
    tail: str
    head: str

    @functools.cached_property  # built once: derivations ask for them thousands of times
    def effort(self) -> sp.Symbol:
        return sp.Symbol(f"e_{self.name}")

    @functools.cached_property
    def flow(self) -> sp.Symbol:
        return sp.Symbol(f"f_{self.name}")

    def other(self, element: str) -> str:
        """The end of the bond that is not ``element``."""
        return self.head if element == self.tail else self.tail

    def sign_at(self, element: str) -> int:
        """+1 if power flows into ``element`` along this bond, −1 if out of it."""
        return 1 if element == self.head else -1

    def __str__(self) -> str:
        return f"bond {self.name!r} ({self.tail} → {self.head})"


@dataclass(frozen=True)
class Displacement:
    """An integrated displacement: a state ``symbol`` with ``d(symbol)/dt = sign * f_bond``."""

    symbol: sp.Symbol
    bond: str
    sign: int = 1


class Instance:
    """A placed copy of a sub-model: resolves its ports and inner names.

    ``inst.port("p")`` is the name of the element behind port ``p`` (use it
    in :meth:`BondGraph.connect`); ``inst["C"]`` is the full name of inner
    element ``C``; ``inst.state("q_C")`` and ``inst.parameter("k")`` give the
    instance's symbols.
    """

    def __init__(self, graph: "BondGraph", name: str, ports: Mapping[str, str], symbols: Mapping[sp.Symbol, sp.Expr]):
        self.graph = graph
        self.name = name
        self._ports = dict(ports)
        self._symbols = dict(symbols)

    def port(self, port: str) -> str:
        try:
            return self._ports[port]
        except KeyError:
            raise UnknownNameError(
                f"instance {self.name!r} has no port {port!r}; its ports are: {', '.join(self._ports) or '(none)'}",
                port,
            ) from None

    @property
    def ports(self) -> tuple[str, ...]:
        return tuple(self._ports)

    def __getitem__(self, inner_name: str) -> str:
        full = f"{self.name}/{inner_name}"
        if full not in self.graph.elements:
            raise UnknownNameError(f"instance {self.name!r} has no element {inner_name!r}", inner_name)
        return full

    def symbol(self, inner: str) -> sp.Expr:
        """What the sub-model's symbol ``inner`` (state, parameter, input) became in this instance."""
        key = sp.Symbol(inner)
        if key not in self._symbols:
            raise UnknownNameError(f"instance {self.name!r} has no symbol {inner!r}", inner)
        return self._symbols[key]

    state = symbol
    parameter = symbol

    def __repr__(self) -> str:
        return f"Instance({self.name!r}, ports={list(self._ports)})"


class BondGraph:
    """A bond graph: elements joined by power bonds, with named ports.

    Build it with :meth:`add` and :meth:`connect` (``connect(tail, head)``
    draws a bond with positive power from tail to head), declare integrated
    displacements with :meth:`displacement` and inputs with :meth:`input`.
    A bond graph used as a *sub-model* declares ports with :meth:`port` and is
    placed (copied, with hierarchical names ``<instance>/<element>``) into
    another graph with :meth:`add_submodel`, as often as needed.

    The global state vector (DESIGN §4) is :attr:`states`: the state of every
    storage element in the order they were added, then the displacements in
    the order they were declared.
    """

    def __init__(self, name: str = "model"):
        self.name = name
        self.elements: dict[str, Element] = {}
        self.bonds: dict[str, Bond] = {}
        self.displacements: dict[sp.Symbol, Displacement] = {}
        self.inputs: dict[str, sp.Symbol] = {}
        self.ports: dict[str, str] = {}
        #: only in the derivation-time view of a graph with open ports:
        #: port name → (name of its :class:`OpenPort` element, its bond's name)
        self.open_ports: dict[str, tuple[str, str]] = {}
        self._bonds_of: dict[str, list[str]] = {}
        self._version = 0
        #: what is derived from the graph, kept until it changes (:class:`bondgraph.derivation.Derivations`)
        self.derived = Derivations()

    # ------------------------------------------------------------ building

    def _changed(self) -> None:
        self._version += 1
        self.derived.clear()

    def add(self, element: Element) -> Element:
        """Add an element; its name must be new.  Returns the element."""
        if not isinstance(element, Element):
            raise InvalidGraphError(f"expected an element (Se, Sf, C, I, R, TF, GY, Zero, One), got {element!r}")
        if element.name in self.elements:
            raise DuplicateNameError(
                f"graph {self.name!r} already has an element named {element.name!r}; names must be unique",
                element.name,
            )
        self.elements[element.name] = element
        self._bonds_of[element.name] = []
        self._changed()
        return element

    def replace(self, element: Element) -> None:
        """Put ``element`` in place of the element of its name and kind (its bonds stay)."""
        if type(self.elements.get(element.name)) is not type(element):
            raise InvalidGraphError(f"graph {self.name!r} has no {element.kind} named {element.name!r} to replace")
        self.elements[element.name] = element
        self._changed()

    def _resolve(self, ref) -> str:
        name = ref.name if isinstance(ref, Element) else ref
        if isinstance(ref, Element) and name not in self.elements:
            self.add(ref)
        if name not in self.elements:
            raise UnknownNameError(f"graph {self.name!r} has no element {name!r}{self._suggest(name)}", name)
        if isinstance(ref, Element) and self.elements[name] is not ref and self.elements[name] != ref:
            raise DuplicateNameError(f"another element named {name!r} is already in graph {self.name!r}", name)
        return name

    def _suggest(self, name: str) -> str:
        return did_you_mean(name, self.elements)

    def connect(self, tail, head, name: str | None = None) -> Bond:
        """Draw a bond with positive power from ``tail`` to ``head``.

        Either end may be an element (added if new) or an element name.  The
        bond is named ``name``, or after its one-port end, or ``<tail>__<head>`` (``_2``, ``_3``… for parallel bonds).
        """
        tail_name, head_name = self._resolve(tail), self._resolve(head)
        if tail_name == head_name:
            raise InvalidGraphError(f"bond from {tail_name!r} to itself", [tail_name])
        if name is None:
            if isinstance(self.elements[head_name], OnePort):
                name = head_name
            elif isinstance(self.elements[tail_name], OnePort):
                name = tail_name
            else:
                name = f"{tail_name}__{head_name}"
            base, k = name, 2
            while name in self.bonds:
                name, k = f"{base}_{k}", k + 1
        elif name in self.bonds:
            raise DuplicateNameError(f"graph {self.name!r} already has a bond named {name!r}", name)
        bond = Bond(name, tail_name, head_name)
        self.bonds[name] = bond
        self._bonds_of[tail_name].append(name)
        self._bonds_of[head_name].append(name)
        self._changed()
        return bond

    def displacement(self, name: str, of, sign: int = 1) -> sp.Symbol:
        """Declare an integrated displacement state ``name`` with
        ``d(name)/dt = sign * f``, where the flow ``f`` is chosen by ``of``:

        * an **element name** (or :class:`~bondgraph.elements.Element`) of a
          connected one-port (``I``, ``C``, ``R``, a source): the flow *into
          that element* along its bond, whichever way the bond is drawn (an
          ``I`` of mass ``m`` gives ``d(name)/dt = +p/m``);
        * a **1-junction** (element name or object): its common flow, the flow
          variable ``f_b`` that all its bonds share, each bond's flow positive
          in the bond's drawn direction — the flow into every element whose
          bond is drawn *from* the junction, out of every element whose bond is
          drawn *into* it.  To fix the direction by an element instead, name
          that one-port (or pass one of the junction's bonds);
        * a :class:`Bond` object, or a **bond name that is not an element
          name**: that bond's flow in its drawn direction (tail → head).

        A name that is both a bond and an element (:meth:`connect` names a
        bond after its one-port end by default) means the **element**.
        Returns the state symbol (use it in moduli, e.g. ``l*sp.sin(theta)``).
        """
        check_name(name, "displacement name")
        if sign not in (1, -1):
            raise InvalidGraphError(f"displacement {name!r}: sign must be +1 or -1, not {sign!r}")
        symbol = sp.Symbol(name)
        if symbol in self.displacements or any(isinstance(e, Storage) and getattr(e.state, "name", None) == name
                                               and e.state == symbol for e in self.elements.values()):  # (names first)
            raise DuplicateNameError(f"a state named {name!r} already exists", name)
        bond, orientation = self._bond_for_displacement(of, name)
        self.displacements[symbol] = Displacement(symbol, bond, sign * orientation)
        self._changed()
        return symbol

    def _bond_for_displacement(self, of, name: str) -> tuple[str, int]:
        """(bond, ±1): the bond whose flow integrates to the displacement, and
        the sign that turns that bond's flow into the flow meant by ``of``
        (see :meth:`displacement`): an element name wins over a bond name."""
        if isinstance(of, Bond):
            if self.bonds.get(of.name) != of:
                raise UnknownNameError(f"displacement {name!r}: {of} is not a bond of graph {self.name!r}", of.name)
            return of.name, 1
        if isinstance(of, Element):
            if self.elements.get(of.name) is not of and self.elements.get(of.name) != of:
                raise UnknownNameError(
                    f"displacement {name!r}: graph {self.name!r} has no element {of.name!r}{self._suggest(of.name)}",
                    of.name,
                )
            element = of.name
        elif isinstance(of, str) and of in self.elements:
            element = of
        elif isinstance(of, str) and of in self.bonds:
            return of, 1
        else:
            raise UnknownNameError(
                f"displacement {name!r}: graph {self.name!r} has no element or bond {of!r}{self._suggest(str(of))}",
                str(of),
            )
        bonds = self._bonds_of[element]
        if not bonds:
            raise InvalidGraphError(f"displacement {name!r}: element {element!r} has no bond yet; connect it first", [element])
        el = self.elements[element]
        if el.kind == "1":
            return bonds[0], 1
        if isinstance(el, OnePort) and len(bonds) == 1:
            bond = self.bonds[bonds[0]]
            return bond.name, bond.sign_at(element)
        raise InvalidGraphError(
            f"displacement {name!r}: {el.kind}-element {element!r} has no single flow; give a bond, a one-port or a 1-junction",
            [element],
        )

    def input(self, name: str) -> sp.Symbol:
        """Declare an input signal ``name`` (supplied at simulation time); returns its symbol."""
        check_name(name, "input name")
        if name in self.inputs:
            raise DuplicateNameError(f"input {name!r} is already declared", name)
        self.inputs[name] = sp.Symbol(name)
        self._changed()
        return self.inputs[name]

    def port(self, name: str, element) -> None:
        """Expose ``element`` as port ``name`` of this graph used as a sub-model."""
        check_name(name, "port name")
        if name in self.ports:
            raise DuplicateNameError(f"port {name!r} is already declared in {self.name!r}", name)
        self.ports[name] = self._resolve(element)

    def add_submodel(
        self,
        sub: "BondGraph",
        name: str,
        bind: Mapping[str, object] | None = None,
        share: Iterable[str] = (),
    ) -> Instance:
        """Place a copy of ``sub`` called ``name``; returns an :class:`Instance`.

        Every element ``X`` of ``sub`` becomes ``name/X``; its states, bonds,
        displacements, inputs and parameters are renamed the same way, except
        the parameters/inputs listed in ``share`` (kept as they are, shared
        with the rest of the model, e.g. gravity ``g``) and those in ``bind``
        (replaced by the given value: a number, a parameter name or a sympy
        expression).  Sub-models nest: placing a graph that itself holds
        instances gives names like ``rod/body/I_x``.
        """
        from .symbols import as_expr

        check_name(name, "instance name")
        bind = dict(bind or {})
        share = set(share)
        known = {s.name for s in sub.parameters} | set(sub.inputs)
        unknown = (set(bind) | share) - known
        if unknown:
            raise UnknownParameterError(unknown, known)
        clash = [f"{name}/{n}" for n in sub.elements if f"{name}/{n}" in self.elements]
        if clash:
            raise DuplicateNameError(f"placing {sub.name!r} as {name!r} would duplicate {', '.join(clash)}", clash[0])

        mapping: dict[sp.Symbol, sp.Expr] = {}
        for sym in sub.parameters | set(sub.inputs.values()):
            if sym.name in bind:
                mapping[sym] = as_expr(bind[sym.name], f"binding of {sym.name!r}")
            elif sym.name in share:
                mapping[sym] = sym
            else:
                mapping[sym] = sp.Symbol(f"{name}/{sym.name}")
        for disp in sub.displacements:
            mapping[disp] = sp.Symbol(f"{name}/{disp.name}")
        for bond in sub.bonds.values():
            new = Bond(f"{name}/{bond.name}", "", "")
            mapping[bond.effort] = new.effort
            mapping[bond.flow] = new.flow
        for el in sub.elements.values():
            if isinstance(el, Storage) and el.state.name != el.default_state_name():
                mapping[el.state] = sp.Symbol(f"{name}/{el.state.name}")

        symbols = dict(mapping)
        for el in sub.elements.values():
            new = el.renamed(f"{name}/{el.name}", mapping)
            self.add(new)
            if isinstance(el, Storage):
                symbols[el.state] = new.state
        for bond in sub.bonds.values():
            self.connect(f"{name}/{bond.tail}", f"{name}/{bond.head}", name=f"{name}/{bond.name}")
        for disp in sub.displacements.values():
            self.displacements[mapping[disp.symbol]] = Displacement(mapping[disp.symbol], f"{name}/{disp.bond}", disp.sign)
        for inp, sym in sub.inputs.items():
            new_sym = mapping[sym]
            if isinstance(new_sym, sp.Symbol) and new_sym.name not in self.inputs:
                self.inputs[new_sym.name] = new_sym
        self._changed()
        return Instance(self, name, {p: f"{name}/{el}" for p, el in sub.ports.items()}, symbols)

    # ------------------------------------------------------------ queries

    def element(self, name: str) -> Element:
        try:
            return self.elements[name]
        except KeyError:
            raise UnknownNameError(f"graph {self.name!r} has no element {name!r}{self._suggest(name)}", name) from None

    def bond(self, name: str) -> Bond:
        """A bond by name, or the one bond of a one-port element of that name."""
        if name in self.bonds:
            return self.bonds[name]
        if name in self.elements and isinstance(self.elements[name], OnePort) and len(self._bonds_of[name]) == 1:
            return self.bonds[self._bonds_of[name][0]]
        raise UnknownNameError(f"graph {self.name!r} has no bond {name!r}", name)

    def bonds_of(self, element: str) -> tuple[Bond, ...]:
        """The bonds attached to ``element``, in the order they were drawn."""
        self.element(element)
        return tuple(self.bonds[b] for b in self._bonds_of[element])

    def effort(self, ref) -> sp.Symbol:
        """The effort symbol of a bond or of a one-port element's bond."""
        return self.bond(ref.name if isinstance(ref, Element) else ref).effort

    def flow(self, ref) -> sp.Symbol:
        """The flow symbol of a bond or of a one-port element's bond."""
        return self.bond(ref.name if isinstance(ref, Element) else ref).flow

    @property
    def storage(self) -> tuple[Storage, ...]:
        return tuple(e for e in self.elements.values() if isinstance(e, Storage))

    @property
    def states(self) -> tuple[sp.Symbol, ...]:
        """The global state vector: storage states (in order added), then displacements."""
        return tuple(e.state for e in self.storage) + tuple(self.displacements)

    def state(self, name: str) -> sp.Symbol:
        for s in self.states:
            if s.name == name:
                return s
        raise UnknownNameError(
            f"graph {self.name!r} has no state {name!r}; its states are: {', '.join(s.name for s in self.states)}", name
        )

    @property
    def controlled_junctions(self) -> tuple[str, ...]:
        found = self.derived.entries.get("controlled junctions")
        if found is None:
            found = tuple(n for n, e in self.elements.items() if isinstance(e, Junction) and e.controlled)
            self.derived.entries["controlled junctions"] = found
        return found

    def bond_symbols(self) -> set[sp.Symbol]:
        return {s for b in self.bonds.values() for s in (b.effort, b.flow)}

    @property
    def parameters(self) -> set[sp.Symbol]:
        """Every free symbol of the element expressions that is not time, a
        state, an input or a bond variable: the model's parameters."""
        used: set[sp.Symbol] = set()
        for el in self.elements.values():
            for expr in el.expressions():
                used |= expr.free_symbols
        reserved = {t} | set(self.states) | set(self.inputs.values()) | self.bond_symbols()
        return {s for s in used if isinstance(s, sp.Symbol) and not isinstance(s, sp.Dummy)} - reserved

    def check_parameters(self, values: Mapping) -> dict[sp.Symbol, float]:
        """Map parameter names (or symbols) to floats, listing every missing
        parameter at once (:class:`MissingParameterError`) and every unknown
        name (:class:`UnknownParameterError`)."""
        params = {s.name: s for s in self.parameters}
        given = {(k.name if isinstance(k, sp.Symbol) else k): v for k, v in values.items()}
        unknown = set(given) - set(params)
        if unknown:
            raise UnknownParameterError(unknown, params)
        missing = set(params) - set(given)
        if missing:
            raise MissingParameterError(missing)
        out = {}
        for name, v in given.items():
            try:
                out[params[name]] = float(v)
            except (TypeError, ValueError):
                raise InvalidGraphError(f"parameter {name!r} must be a number, got {v!r}") from None
        return out

    # ------------------------------------------------------------ validation

    def validate(self) -> None:
        """Check the structure; raise the first problem found, naming the element.

        Checks: every element has bonds; one-ports have exactly one; TF/GY have
        exactly two, one pointing in and one out; no two symbols (states,
        parameters, inputs, bond variables, ``t``) share a name.
        """
        for name, el in self.elements.items():
            bonds = self._bonds_of[name]
            if not bonds:
                raise InvalidGraphError(f"{el} has no bonds (dangling); connect it or remove it", [name])
            if isinstance(el, OnePort) and len(bonds) != 1:
                raise InvalidGraphError(
                    f"{el} is a one-port but has {len(bonds)} bonds ({', '.join(bonds)}); "
                    "join them through a 0- or 1-junction",
                    [name],
                )
            if isinstance(el, TwoPort):
                if len(bonds) != 2:
                    raise InvalidGraphError(f"{el} needs exactly 2 bonds, has {len(bonds)}", [name])
                ins = [b for b in bonds if self.bonds[b].head == name]
                if len(ins) != 1:
                    raise InvalidGraphError(
                        f"{el} needs one bond pointing in and one out (power passes through it); "
                        f"bonds {', '.join(bonds)} point {'both in' if len(ins) == 2 else 'both out'}",
                        [name],
                    )
        self._check_symbol_names()

    def _check_symbol_names(self) -> None:
        self.namespace()

    def namespace(self):
        """The names this graph owns — ``t``, its states, inputs and bond variables — each with its
        owner (:func:`bondgraph.namespace.graph_namespace`); two quantities of one name are a
        :class:`~bondgraph.errors.NameCollisionError`."""
        return graph_namespace(self)

    def two_port_bonds(self, element: str) -> tuple[Bond, Bond]:
        """(bond in, bond out) of a TF/GY."""
        b1, b2 = self.bonds_of(element)
        return (b1, b2) if b1.head == element else (b2, b1)

    # ------------------------------------------------------------ configurations

    def configuration(self, config: Configuration | None = None, **on: bool) -> dict[str, bool]:
        """Normalise a configuration: every controlled junction → on/off.

        Junctions not mentioned are on.  Unknown or uncontrolled names raise.
        """
        merged = dict(config or {})
        merged.update(on)
        controlled = self.controlled_junctions
        known = self.derived.memo("controlled junction set", lambda: frozenset(controlled))
        for name, value in merged.items():
            if name in known and isinstance(value, (bool, int)):
                continue
            if name not in self.elements:
                raise UnknownNameError(f"configuration names unknown junction {name!r}{self._suggest(name)}", name)
            if name not in known:
                raise InvalidGraphError(
                    f"configuration switches {name!r}, which is not a controlled junction "
                    "(create it with controlled=True)",
                    [name],
                )
            if not isinstance(value, (bool, int)):
                raise InvalidGraphError(f"junction {name!r} must be switched True/False, got {value!r}", [name])
        return {name: bool(merged.get(name, True)) for name in controlled}

    def _cached(self, kind: str, config, compute):
        return self.derived.per_configuration(kind, _normalised(self, config), compute)

    def open_view(self, port_causality: Mapping[str, str] | None = None) -> "BondGraph":
        """The graph as derived on its own: every declared port left **open**.

        Returns ``self`` when the graph has no ports.  Otherwise a copy (the
        user's graph is not changed) in which each port ``A`` on element ``X``
        gets a bond named ``A`` from an :class:`OpenPort` element (the outside
        world) to ``X``: positive power flows *into* the graph through the
        port, and the port's variables are ``e_A`` and ``f_A``.  The one the
        outside imposes is an input of the equations (listed, with the other,
        in the copy's :attr:`inputs`); the other is an output.
        ``port_causality`` maps port names to ``"effort"`` (the outside
        imposes the effort) or ``"flow"``; ports not named follow the
        causality the rest of the graph imposes.

        Ports of sub-model instances are not ports of the graph they are
        placed in, so composition through ports is unaffected.
        """
        port_causality = dict(port_causality or {})
        unknown = set(port_causality) - set(self.ports)
        if unknown:
            name = sorted(unknown)[0]
            raise UnknownNameError(
                f"port_causality names {name!r}, which is not a port of {self.name!r}; "
                f"its ports are: {', '.join(self.ports) or '(none)'}",
                name,
            )
        for name, how in port_causality.items():
            if how not in ("effort", "flow", None):
                raise InvalidGraphError(
                    f"port_causality of port {name!r} must be 'effort' (the outside imposes the effort) "
                    f"or 'flow', not {how!r}",
                    [self.ports[name]],
                )
        if not self.ports:
            return self
        view = BondGraph(self.name)
        view.elements = dict(self.elements)
        view.bonds = dict(self.bonds)
        view.displacements = dict(self.displacements)
        view.inputs = dict(self.inputs)
        view.ports = dict(self.ports)
        view._bonds_of = {k: list(v) for k, v in self._bonds_of.items()}
        for port, element in self.ports.items():
            if port in view.bonds:
                raise DuplicateNameError(
                    f"open port {port!r} of {self.name!r} needs a bond named {port!r} (variables e_{port}, "
                    f"f_{port}), but {view.bonds[port]} already has that name; rename the port or the bond, "
                    "or derive with open_ports=False",
                    port,
                )
            outside = f"port/{port}"
            while outside in view.elements:
                outside = "_" + outside
            view.add(OpenPort(outside, port=port, imposes=port_causality.get(port)))
            bond = view.connect(outside, element, name=port)
            for sym in (bond.effort, bond.flow):
                if sym.name in view.inputs:
                    raise DuplicateNameError(
                        f"open port {port!r} of {self.name!r}: its variable {sym.name!r} is already a declared "
                        "input; rename the port or the input, or derive with open_ports=False",
                        sym.name,
                    )
                view.inputs[sym.name] = sym
            view.open_ports[port] = (outside, bond.name)
        return view

    def _port_key(self, kind: str, port_causality, open_ports: bool) -> str:
        """The cache key of a derivation: one per port setting (all alike without ports)."""
        if not self.ports:
            return kind
        if not open_ports:
            return f"{kind} closed"
        return f"{kind} {sorted((port_causality or {}).items())}" if port_causality else kind

    def causality(self, config: Configuration | None = None, port_causality: Mapping[str, str] | None = None,
                  open_ports: bool = True):
        """The causal assignment for a configuration (cached); see :func:`bondgraph.causality.assign_causality`.

        A graph with ports is assigned with its ports open (see
        :meth:`open_view`, ``port_causality``); ``open_ports=False`` ignores them.
        """
        graph = self.open_view(port_causality) if open_ports else self
        ports = self._port_key("", port_causality, open_ports)
        return self._cached(self._port_key("causality", port_causality, open_ports), config,
                            lambda c: self.derived.causality(graph, c, ports))

    def equations(self, config: Configuration | None = None, port_causality: Mapping[str, str] | None = None,
                  open_ports: bool = True):
        """The symbolic equations of a configuration (cached); see :class:`bondgraph.equations.ConfigurationEquations`.

        A graph with declared ports, derived on its own, has its ports
        **open** (see :meth:`open_view`): for port ``A`` the variable the
        outside imposes (``e_A`` or ``f_A``, by the causality of the rest of
        the graph, or as ``port_causality={"A": "effort" | "flow"}`` fixes
        it) is an input of the equations and the other an output, listed in
        ``eq.port_inputs`` / ``eq.port_outputs`` and in ``eq.efforts["A"]``,
        ``eq.flows["A"]``.  ``open_ports=False`` derives as if the ports were
        not there.
        """
        graph = self.open_view(port_causality) if open_ports else self
        ports = self._port_key("", port_causality, open_ports)
        return self._cached(
            self._port_key("equations", port_causality, open_ports),
            config,
            lambda c: self.derived.equations(graph, c, self.causality(c, port_causality, open_ports), ports),
        )

    def jump_map(self, config: Configuration | None = None, law: str = "conservation"):
        """The jump map into a configuration by a jump ``law`` (cached); see :mod:`bondgraph.jump`."""
        from .jump import derive_jump_map

        # derived on this graph itself: its declared ports closed, as the jump needs the whole graph
        return self._cached(f"jump {law}", config,
                            lambda c: derive_jump_map(self, self.equations(c, open_ports=False), law))

    def island_graph(self, island) -> "BondGraph":
        """The island (:class:`bondgraph.islands.Island`) as a graph of its own:
        its elements (off junctions holding only the island's bonds), bonds and
        displacements in this graph's order; every declared input; the open
        ports whose bond it holds.  Not validated (an off junction may keep a single bond)."""
        sub = BondGraph(self.name)
        held = set(island.bonds)
        sub.elements = {n: self.elements[n] for n in island.elements}
        sub.bonds = {b: self.bonds[b] for b in island.bonds}
        sub._bonds_of = {n: [b for b in self._bonds_of[n] if b in held] for n in island.elements}
        sub.displacements = _island_displacements(self, island.bonds)
        sub.inputs = dict(self.inputs)
        sub.open_ports = {p: (outside, b) for p, (outside, b) in self.open_ports.items() if b in held}
        return sub

    @property
    def version(self) -> int:
        """Increases on every change of the graph (caches keyed on it go stale)."""
        return self._version

    def __repr__(self) -> str:
        return f"BondGraph({self.name!r}, {len(self.elements)} elements, {len(self.bonds)} bonds)"


def _island_displacements(graph: BondGraph, bonds: tuple) -> dict:
    """The displacements of ``graph`` that integrate a flow of ``bonds``, in the graph's order: found by
    bond (an island of a scene, without a walk of every displacement)."""

    def by_bond() -> dict:  # bond → [(place among the displacements, symbol, displacement)]
        found: dict = {}
        for k, (symbol, displacement) in enumerate(graph.displacements.items()):
            found.setdefault(displacement.bond, []).append((k, symbol, displacement))
        return found

    kept = graph.derived.memo("displacements by bond", by_bond)
    return {symbol: d for _, symbol, d in sorted(entry for b in bonds for entry in kept.get(b, ()))}


def _normalised(graph: BondGraph, config) -> dict:
    """:meth:`BondGraph.configuration` of ``config``: a copy where it is normalised already (a dict of every
    controlled junction, in the graph's order, to a bool: a scene's mode asks four times, each of a
    thousand junctions), else normalised now."""
    controlled = graph.controlled_junctions
    if type(config) is dict and len(config) == len(controlled) and list(config) == list(controlled) \
            and all(type(value) is bool for value in config.values()):
        return dict(config)
    return graph.configuration(config)
