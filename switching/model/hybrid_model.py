"""The hybrid model: a bond graph, local automata, parameters and an initial state.

Example — an RC circuit whose switch opens when the capacitor is charged::

    >>> from bondgraph import BondGraph, Se, R, C, One
    >>> from switching import Automaton, HybridModel
    >>> g = BondGraph("rc")
    >>> sw = g.add(One("sw", controlled=True))
    >>> _ = g.connect(Se("V", "V0"), sw)
    >>> _ = g.connect(sw, R("R", "R"))
    >>> _ = g.connect(sw, C("C", "C"))
    >>> switch = Automaton("switch", {"closed": {"sw": True}, "open": {"sw": False}}, "closed")
    >>> _ = switch.add_transition("closed", "open", "q_C >= 0.5*C*V0")
    >>> model = HybridModel(g, [switch], {"V0": 1, "R": 1, "C": 1e-3})
    >>> model.mode_equations("open").f[model.state("q_C")]
    0
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from types import MappingProxyType
from collections.abc import Callable, Iterable, Mapping, Sequence

import numpy as np
import sympy as sp

from bondgraph import BondGraph, t as TIME
from bondgraph.errors import UnknownNameError
from bondgraph.jump import JUMP_LAWS
from bondgraph.law_switches import law_switches
from bondgraph.symbols import rate_symbol

from .annotations import annotations
from .automaton import Automaton
from ..errors import ModelDefinitionError
from . import definition
from .definition import InMode
from .drawn import ShownAsBondGraph
from .modes import Mode, ModeEquations
from .initial_state import InitialStateProjected
from . import initial_state
from .inputs import InputValues
from .law_automata import branches_at, law_automaton, starting_mode
from .mode_space import ModeSpace
from .stepped_inputs import with_stepped_inputs
from .services import SERVICES
from .simulate_doc import SIMULATE_DOC

__all__ = ["HybridModel", "InitialStateProjected", "Tolerance", "InMode"]


@dataclass(frozen=True)
class Tolerance:
    """Tolerances at an instant.

    Guard comparisons use the band ``rtol·max(|lhs|, |rhs|, R) + atol``
    (``<=`` includes it, ``<`` excludes it), where ``R = max(R(lhs), R(rhs))`` is
    the comparison's round-off scale: the size of the terms that formed its
    sides (:mod:`codegen.roundoff`; at an instant, a posteriori, the larger
    of its values before and after the jump).  A difference that is zero up
    to the round-off of those terms thus compares as zero, in any units,
    while a small quantity of a small-scale model still counts.  A
    comparison on the time alone (a clock, no state) has ``R = 0``: its
    crossing is located to the round-off of ``t``, not ``rtol·R`` away
    (:func:`switching.library.compiled.comparison_triples`).  A state
    change at a jump smaller than ``jump_rtol·(largest moved state) +
    jump_atol`` is round-off: it is no jump and carries no Dirac pulse.
    ``atol`` and ``jump_atol`` are absolute, in the quantities' own units, and
    0 by default: with the round-off scale no absolute part is needed, and one
    would make decisions depend on the units (a current of 1e-15 A is 'zero'
    in amperes and not in kiloamperes).  Set them only for a model whose
    quantities of interest are all of one known size."""

    rtol: float = 1e-13
    atol: float = 0.0
    jump_rtol: float = 1e-12
    jump_atol: float = 0.0


class HybridModel(ShownAsBondGraph):
    """A bond graph with controlled junctions driven by local automata.

    The model is the definition (graph, automata, parameters, signals,
    inputs) and its validation; what is derived and generated from it mode by
    mode — equations, code, memos, the fingerprint — lives in its mode library,
    :attr:`library` (:mod:`switching.library.mode_library`), which the model's
    own methods (:meth:`mode_equations`, :meth:`compiled_mode`, ...) call.

    Parameters
    ----------
    graph : BondGraph
    automata : sequence of Automaton
        Every controlled junction is driven by exactly one automaton.
    parameters : mapping name → number
        A value for every parameter of the graph, the guards, the signals and
        the restitution coefficients (all missing ones are listed at once).
        Every value must be finite (NaN never is): :class:`~bondgraph.errors.ParameterValueError`
        names the culprit otherwise.
    initial_state : mapping name → number or expression, optional
        Initial values by state name; states not given start at 0.  A value
        may be an expression of parameters (sympy, or text parsed without
        executing code: ``"l*sin(theta0)"``); a parameter only the initial
        state uses (``theta0``) is given in ``parameters`` like the others
        and kept in :attr:`initial_parameters`, out of the generated code.
    signals : mapping name → expression, optional
        Named signals (sympy expressions, or text parsed without executing
        code) over states, bond variables (``e_<bond>``, ``f_<bond>``),
        parameters, ``t`` and earlier signals; states and bond variables are
        signals by their own names too.  One name, one owner (:attr:`namespace`).
    inputs : mapping name → callable(t), optional
        Values of the graph's declared inputs.
    tolerance : Tolerance, optional
        Band for guard comparisons at an instant.
    max_steps_per_instant : int
        Cap on discrete steps in one instant (divergence of time otherwise).
    jump_law : ``"conservation"`` (default) or ``"impulse balance"``
        How the jump map ``g`` into a mode is derived (:mod:`bondgraph.jump`):
        by conservation of state through the junction structure, every
        source finite (the paper's law); or by integrating the mode's own
        equations over the instant, so that a source modulated by a
        constraint effort carries a pulse too — a Coulomb friction source
        driven by the normal force then gives the Newton–Coulomb impact law
        (tangential impulse ``−σ μ P_n``).  Both agree wherever no source
        is modulated by a pulsed effort.
    allow_infinite : iterable of parameter names, optional
        Parameters that may be ``±inf`` where that is physical (a threshold
        never reached, an open circuit's resistance).
    units, descriptions : mapping name → text, optional
        The unit (``"V"``, ``"rad/s"``) and a one-line description of
        parameters, states, signals and inputs, shown on plots' axes and kept
        in model files (:mod:`switching.model.annotations`).
    """

    def __init__(
        self,
        graph: BondGraph,
        automata: Sequence[Automaton],
        parameters: Mapping | None = None,
        initial_state: Mapping | None = None,
        signals: Mapping | None = None,
        inputs: Mapping[str, Callable[[float], float]] | None = None,
        name: str | None = None,
        tolerance: Tolerance | None = None,
        max_steps_per_instant: int = 1000,
        jump_law: str = "conservation",
        allow_infinite: Iterable[str] = (),
        units: Mapping[str, str] | None = None,
        descriptions: Mapping[str, str] | None = None,
    ):
        if jump_law not in JUMP_LAWS:
            raise ModelDefinitionError(f"unknown jump_law {jump_law!r}; choose one of: {', '.join(JUMP_LAWS)}")
        self.jump_law = jump_law
        graph.validate()
        self.graph = graph
        self.name = name or graph.name
        self._inputs = definition.check_inputs(graph, inputs or {})
        #: the graph the modes are derived from: ``graph`` with stepping inputs read into its laws
        #: (:mod:`.stepped_inputs`), each discontinuity of a law a branch symbol (:mod:`bondgraph.law_switches`)
        self.derivation_graph, switches = law_switches(with_stepped_inputs(graph, self._inputs))
        #: law switch name → :class:`bondgraph.law_switches.LawSwitch`; each drives the automaton of that name
        self.law_switches = {sw.name: sw for sw in switches}
        definition.check_law_switch_names(graph, self.law_switches, automata)
        self.automata = tuple(automata) + tuple(law_automaton(sw) for sw in switches)
        self._initial_branches_set = not switches
        self._initial_mode = Mode(tuple(a.initial for a in self.automata), tuple(a.name for a in self.automata))
        self.tolerance = tolerance or Tolerance()
        self.max_steps_per_instant = int(max_steps_per_instant)
        self.time = TIME
        definition.check_automata(graph, self.automata)
        self.states = tuple(graph.states)
        self.state_index = {s: k for k, s in enumerate(self.states)}
        self.rate_symbols = {s: sp.Symbol(f"d{s.name}/dt") for s in self.states}
        self._names = definition.base_names(graph, self.states)
        #: name → owner of each name of the model, one owner a name (:mod:`bondgraph.namespace`)
        self.namespace = definition.model_namespace(self)
        self._signals, self._cross = definition.parse_signals(self._names, signals or {}, self.namespace)
        self._guards = definition.parse_guards(self.automata, {**self._names, **self._signals}, self._signals)
        #: the modes of :attr:`automata`, named, configured and left by their guards
        self.mode_space = ModeSpace(self.automata, self._guards)
        self.input_signals = InputValues(tuple(graph.inputs), self._inputs)
        self.parameter_symbols = definition.collect_parameters(self)
        self.allow_infinite = frozenset(allow_infinite)
        #: state symbol → its initial value as given: a number, or an expression of parameters
        self.initial_expressions = definition.initial_expressions(self.states, initial_state or {})
        only = definition.initial_only_names(self.initial_expressions, self.parameter_symbols)
        given = {(k.name if isinstance(k, sp.Symbol) else str(k)): v for k, v in (parameters or {}).items()}
        self.set_parameter_values({k: v for k, v in given.items() if k not in only},
                                  {k: v for k, v in given.items() if k in only})
        #: units and descriptions by name (:mod:`switching.model.annotations`)
        self.annotations = annotations(self, units, descriptions)
        #: the derived modes, generated functions and code-generation memos (:mod:`switching.library.mode_library`)
        self.library = SERVICES.library(self)

    # ------------------------------------------------------------ names and values

    @property
    def input_symbols(self) -> tuple:
        """The declared inputs ``u``, then their rates ``du/dt`` (an input
        that fixes dependent storage — a prescribed velocity driving a mass —
        enters the equations with its derivative; see :meth:`input_values`)."""
        inputs = tuple(self.graph.inputs.values())
        return inputs + tuple(rate_symbol(u) for u in inputs)

    def input_values(self, t: float) -> list:
        """Values of :attr:`input_symbols` at ``t``: each input, then its
        derivative (:class:`switching.model.inputs.InputValues`)."""
        return self.input_signals.values(t)

    def parameter_values_with_inputs(self, t: float) -> dict:
        values = dict(self.parameter_values)
        values.update(zip(self.input_symbols, self.input_values(t)))
        return values

    def state(self, name: str) -> sp.Symbol:
        return self.graph.state(name)

    @property
    def signal_names(self) -> tuple:
        """User signals, then states by name."""
        return tuple(self._signals) + tuple(s.name for s in self.states)

    @property
    def signal_definitions(self) -> Mapping:
        """User signal name → its parsed expression, in the order given (a signal taken in another mode
        stands here as its own symbol; its definition is in :attr:`cross_signals`)."""
        return MappingProxyType(self._signals)

    @property
    def cross_signals(self) -> Mapping:
        """:class:`InMode` signal name → (its parsed expression, automaton → state it is taken in)."""
        return MappingProxyType(self._cross)

    @property
    def guard_conditions(self) -> Mapping:
        """(automaton name, transition) → (its parsed condition, its text), for every transition."""
        return MappingProxyType(self._guards)

    def signal_expression(self, name: str) -> sp.Expr:
        """The defining expression of a named signal (state, bond variable or user signal)."""
        if name in self._signals:
            return self._signals[name]
        if name in self._names and name != "t" and self._names[name] not in self.parameter_symbols:
            return self._names[name]
        raise UnknownNameError(
            f"model {self.name!r} has no signal {name!r}; signals are: {', '.join(self.signal_names)} "
            "and every bond's e_<bond>, f_<bond>",
            name,
        )

    # ------------------------------------------------------------ modes

    @property
    def initial_mode(self) -> Mode:
        """The automata's initial states; law switches (:mod:`switching.model.law_automata`)
        on the side of their surface where the given initial state lies."""
        if not self._initial_branches_set:
            self._initial_branches_set = True
            self._initial_mode = branches_at(self, self._initial_mode, self._initial_given, 0.0)
        return self._initial_mode

    def starting_mode(self, x, t: float, mode=None) -> Mode:
        """The mode a run from ``(x, t)`` starts in: ``mode`` (default: the
        initial mode) with its law switches decided by the state
        (:func:`switching.model.law_automata.starting_mode`); a mode given as
        a mapping or label that names a law switch keeps that switch's state."""
        named = set()
        if mode is None:
            base = self.initial_mode
        else:
            base = self.mode(mode)
            if isinstance(mode, Mapping):
                named = set(mode)
            elif isinstance(mode, (str, tuple, Mode)):
                named = set(self.law_switches)
        return starting_mode(self, base, named, x, t)

    def mode(self, spec) -> Mode:
        """A mode from a :class:`Mode`, a tuple of states, a label ``"s1|s2"``
        or a mapping {automaton: state} (automata not named keep their initial state)."""
        return self.mode_space.mode(spec)

    def configuration_of(self, mode: Mode) -> dict:
        """Controlled junction name → on or off in ``mode``."""
        return self.mode_space.configuration_of(mode)

    def mode_values(self, mode: Mode) -> dict:
        """Mode-dependent constants set by the automaton states of ``mode`` (symbol → value)."""
        return self.mode_space.mode_values(mode)

    def restitution_of(self, mode: Mode):
        """The restitution coefficient of the mode (``None`` if no state carries one)."""
        return self.mode_space.restitution_of(mode)

    @functools.cached_property
    def state_names(self) -> tuple:
        """The names of :attr:`states`, in order."""
        return tuple(s.name for s in self.states)

    @functools.cached_property
    def automaton_index(self) -> dict:
        """Automaton name → its position in :attr:`automata` (and in a mode's states)."""
        return {automaton.name: k for k, automaton in enumerate(self.automata)}

    def guards_from(self, mode: Mode) -> list:
        """(automaton, transition, condition, text) of every transition leaving ``mode``."""
        return self.mode_space.guards_from(mode)

    # ------------------------------------------------------------ the mode library (switching.library.mode_library)

    def mode_equations(self, mode) -> ModeEquations:
        """f, g, h and guards of one mode, derived on first request and cached
        (:meth:`ModeLibrary.mode_equations`).  Asking for a mode never derives any other."""
        return self.library.mode_equations(mode)

    @property
    def derived_modes(self) -> tuple:
        return self.library.derived_modes

    @property
    def derivation_count(self) -> int:
        """How many modes' equations the library has derived."""
        return self.library.derivation_count

    @property
    def fingerprint(self) -> str:
        """A hash of the model's symbolic definition (structure, laws, guards,
        signals, parameter order) and the toolkit version: the disk-cache key
        (:func:`switching.library.mode_library.definition_fingerprint`)."""
        return self.library.fingerprint

    @property
    def cache(self):
        """The disk cache of generated source (:class:`codegen.cache.SourceCache`) of the library."""
        return self.library.cache

    @cache.setter
    def cache(self, cache) -> None:
        self.library.cache = cache

    def compiled_mode(self, mode):
        """The generated numerical functions of a mode: from memory, else from
        the disk cache, else derived and generated now (and cached)."""
        return self.library.compiled_mode(mode)

    def signal_function(self, mode, names):
        """Generated ``fn(x, t, p, u, out)`` giving the finite parts of the
        named signals in one mode; ``x`` may be an ``(n, N)`` array of N
        samples (numpy functions are used)."""
        return self.library.signal_function(mode, names)

    def export_module(self, path, modes="visited") -> list:
        """Write the generated functions of several modes to one standalone
        Python module that needs neither sympy nor this toolkit.

        ``modes``: ``"visited"`` (those compiled so far), ``"reachable"``
        (explored from the initial mode by :meth:`verify`), or a list.
        Returns the mode labels written."""
        return self.library.export_module(path, modes)

    @property
    def visited_modes(self) -> tuple:
        """The modes whose numerical functions exist in this process (visited
        by a simulation, resolution or verification so far)."""
        return self.library.visited_modes

    def compiled_model(self, modes="visited"):
        """The numba module of this model for a set of modes, built once per
        set (see :mod:`switching.library.jit_model`): ``"visited"`` (those with
        generated functions so far, and the initial mode), ``"reachable"``
        (explored from the initial mode by :meth:`verify`), or a list.  The
        ``*-jit`` methods start from the visited set, which includes the
        modes compiled before by any process sharing the disk cache
        (remembered there; the set only grows); a mode first reached during
        a run is resolved in Python at that instant, compiled, and run by the
        kernel from its next call."""
        return self.library.compiled_model(modes)

    def mode_source(self, mode) -> str:
        """The generated Python source of one mode's functions."""
        return self.library.mode_source(mode)

    def take_definition(self, other: HybridModel) -> None:
        """Take ``other``'s definition — parameter values, initial state,
        inputs, tolerances, every attribute — and keep this model's
        :attr:`library` (its derived modes, generated code and memos, all of
        which depend on the structure alone).  This is how a sweep shares one
        library between the runs of one structure
        (:func:`switching.sweep.batch.shared_model`); ``other`` must be of the same
        type and fingerprint (:class:`ModelDefinitionError` otherwise).  This
        model stays the same object: what refers to it (its compiled modes and
        kernels) reads the new values."""
        if type(other) is not type(self) or other.fingerprint != self.fingerprint:
            raise ModelDefinitionError(
                f"model {other.name!r} cannot take the place of {self.name!r} on its mode library: "
                "a library is shared only by models of one type and fingerprint (one structure)", [other.name])
        if other is self:
            return
        library = self.library
        vars(self).clear()
        vars(self).update(vars(other))
        self.library = library

    def set_parameter_values(self, values: Mapping, initial: Mapping | None = None) -> None:
        """Give every parameter its value (name → number), in place: the structure, and so the derived
        modes and generated code (which read the values at every call), stay.  ``initial``: the values of
        the parameters only the initial state uses (``theta0``; default: as before).  The given initial
        state is evaluated anew from :attr:`initial_expressions` and projected again when next asked."""
        self.parameter_values = definition.parameter_values(self, values)
        self.parameter_array = np.array([self.parameter_values[s] for s in self.parameter_symbols], dtype=float)
        if initial is not None:
            #: symbol → value of each parameter used only by the initial state
            self.initial_parameters = definition.initial_parameter_values(self, initial)
        self._initial_given = definition.initial_state(self.states, self.initial_expressions,
                                                       {**self.parameter_values, **self.initial_parameters})
        self._initial = None

    # ------------------------------------------------------------ initial state

    @property
    def given_initial_state(self) -> np.ndarray:
        """The initial state as given (``initial_state=`` of the model, zeros
        elsewhere), before any projection onto the initial mode's constraints."""
        return self._initial_given.copy()

    def initial_state(self) -> np.ndarray:
        """The initial state vector, projected onto the initial mode's
        constraints with its jump map (an :class:`InitialStateProjected`
        warning says so when that changes it; :attr:`initial_projection` is then
        ``(given, projected)``, else ``None``)."""
        if self._initial is None:
            self._initial, self.initial_projection = initial_state.initial_state(self, self._initial_given)
        return self._initial.copy()

    # ------------------------------------------------------------ instants

    def resolve(self, x, mode=None, t: float = 0.0, max_steps: int | None = None):
        """Resolve the instant at time ``t`` from the a priori state ``x`` in
        ``mode`` (default: the initial mode); returns an
        :class:`~switching.simulate.resolution.Instant`.  See DESIGN §6."""
        mode = self.initial_mode if mode is None else self.mode(mode)
        return SERVICES.resolve_instant(self, np.asarray(x, dtype=float), mode, float(t), max_steps or self.max_steps_per_instant)

    def simulate(self, t_end: float, method: str = "RK45", **options):
        SERVICES.check_option_names(options)
        sensitivities = options.pop("sensitivities", None)
        rtol, atol = options.pop("sensitivity_rtol", None), options.pop("sensitivity_atol", None)
        SERVICES.check_sensitivity_options(sensitivities, rtol, atol)
        if sensitivities is not None:
            return SERVICES.simulate_with_sensitivities(self, t_end, method, sensitivities, options, rtol, atol)
        return SERVICES.simulate(self, t_end, method, **options)

    simulate.__doc__ = SIMULATE_DOC

    def verify(self, samples: int = 20, seed: int = 0, max_modes: int = 200, scale: float | None = None):
        """Static divergence-of-time check from sampled states on each
        reachable mode's guard boundaries; see :func:`switching.analysis.verify.verify`."""
        return SERVICES.verify(self, samples=samples, seed=seed, max_modes=max_modes, scale=scale)

    def periodic_orbit(self, period: float | None = None, **options):
        """A periodic orbit by Newton shooting on the period map (fixed
        ``period`` [s], or autonomous with ``section=(automaton, source,
        target)``); see :func:`switching.analysis.orbits.periodic_orbit`."""
        return SERVICES.periodic_orbit(self, period, **options)

    def state_space(self, mode=None, outputs=None, inputs=None, numeric: bool = True):
        """The linear state-space matrices of one mode (default the initial one), over its independent
        states, parameter values substituted; see :func:`switching.analysis.linear.state_space`."""
        return SERVICES.state_space(self, mode, outputs, inputs, numeric)

    def save(self, path, *, run: dict | None = None, description: str | None = None) -> None:
        """Write the model to the model file ``path``, checked to read back to
        the same model; see :func:`switching.files.modelfile.save_model`."""
        SERVICES.save(self, path, run=run, description=description)

    def __repr__(self) -> str:
        return (
            f"HybridModel({self.name!r}, {len(self.states)} states, "
            f"automata={[a.name for a in self.automata]}, derived modes={len(self.library.equations)})"
        )
