"""The mode library of a hybrid model: what is derived and generated from its
definition, mode by mode, and kept.

A :class:`~switching.model.hybrid_model.HybridModel` is a definition (graph, automata,
parameters, signals, inputs); its :class:`ModeLibrary` (``model.library``)
holds everything computed from the definition's *structure* — never from
parameter values, initial state or input functions, which every generated
function takes as arguments:

* the symbolic equations of each mode (:meth:`ModeLibrary.mode_equations`),
  derived on first request and kept by mode;
* the generated Python functions of each mode (:meth:`ModeLibrary.compiled_mode`),
  kept by mode, and on disk in :attr:`ModeLibrary.cache` under keys made of the
  :attr:`ModeLibrary.fingerprint` (a hash of the definition's structure);
* the compiled (numba) models of sets of modes (:meth:`ModeLibrary.compiled_model`);
* the memos the code generator shares across modes (printed text, round-off
  scales, guard trees, blocks of guard sides, free symbols).

Two models of the same fingerprint could use one library, but they never do
by accident: each model builds its own, and a sweep shares one only through
:meth:`switching.model.hybrid_model.HybridModel.take_definition` (a model takes another's
definition — its parameter values, initial state, inputs — and keeps its
library), as :func:`switching.sweep.batch.shared_model` does.

Example — the RC circuit of :mod:`switching.model.hybrid_model`::

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
    >>> library = model.library
    >>> me = library.mode_equations("open")
    >>> library.mode_equations("open") is me, [m.label for m in library.derived_modes], library.derivation_count
    (True, ['open'], 1)
    >>> library.visited_modes  # no generated function yet
    ()
"""

from __future__ import annotations

import contextlib
import copy
import re
import time

import sympy as sp

from bondgraph.errors import HybridBondGraphError
from codegen.cache import default_cache, fingerprint
from codegen.source import PrintMemo

from .collection import collection_paused
from .compiled import (BLOCK_CALLS, GUARD_ENTRIES_KEPT, MODE_SOURCE_VERSION, CompiledMode, block_checked,
                       mode_module, shifted_tree)
from .guard_tables import GUARD_TABLES, shifted_entries, table_checked, table_entries
from ..errors import ModelDefinitionError
from .jit_model import CompiledModel, remembered_modes
from ..model.modes import Mode, ModeEquations
from ..model.stepped_inputs import stepped_inputs

__all__ = ["ModeLibrary", "canonical", "definition_fingerprint"]


def canonical(expr) -> str:
    """``srepr`` of ``expr`` with its ``Dummy`` symbols (an element law's
    placeholder argument) renamed by order of first appearance: the same text
    in every process, whatever the dummies' process-wide indices."""
    expr = sp.sympify(expr)
    dummies = []
    for node in sp.preorder_traversal(expr):
        if isinstance(node, sp.Dummy) and node not in dummies:
            dummies.append(node)
    if dummies:
        expr = expr.xreplace({d: sp.Symbol(f"_placeholder{k}_{d.name}") for k, d in enumerate(dummies)})
    return sp.srepr(expr)


#: part of the disk-cache key of everything generated for a model: change it when a derivation changes
#: (2: a closed-form inverse carries its law's range, NaN outside it)
DERIVATION_VERSION = "2"


def definition_fingerprint(model) -> str:
    """A hash of ``model``'s symbolic definition (structure, laws, guards,
    signals, parameter order) and the toolkit version: the disk-cache key of
    everything generated for it.  Parameter values, the initial state and the
    input functions are not part of it, but for the inputs that step, which the
    modes are derived with (:mod:`switching.model.stepped_inputs`)."""
    from bondgraph import __version__

    graph = model.graph
    parts = [__version__, f"derivation {DERIVATION_VERSION}", model.name, f"jump law {model.jump_law}"]
    for el in graph.elements.values():
        parts.append(f"{type(el).__name__} {el.name} " + " ".join(canonical(e) for e in el.expressions()))
        if hasattr(el, "state"):
            parts.append(el.state.name)
        parts.append(str(getattr(el, "controlled", "")))
    parts += [f"{b.name} {b.tail} {b.head}" for b in graph.bonds.values()]
    parts += [f"{d.symbol} {d.bond} {d.sign}" for d in graph.displacements.values()]
    parts += [" ".join(graph.inputs), " ".join(s.name for s in model.parameter_symbols)]
    parts += [f"{u} = {canonical(e)}" for u, e in stepped_inputs(graph, model.input_signals.functions).items()]
    for automaton in model.automata:
        parts.append(f"{automaton.name} {automaton.states!r} {automaton.initial}")
        parts += [f"{k} {sorted((n, canonical(v)) for n, v in t.items())}" for k, t in automaton.values.items()]
        parts += [f"{k} {canonical(v)}" for k, v in automaton.restitution.items()]
    for (name, tr), (condition, _) in model.guard_conditions.items():
        parts.append(f"{name} {tr.source} {tr.target} {tr.when} {canonical(condition)}"
                     + ("" if tr.pulses else " no pulses"))
    parts += [f"{k} {canonical(v)}" for k, v in model.signal_definitions.items()]
    parts += [f"{k} {canonical(v)} {o!r}" for k, (v, o) in model.cross_signals.items()]
    return fingerprint(*parts)


class ModeLibrary:
    """The derived modes, generated functions and code-generation memos of one model.

    Everything here depends on the model's structure only (its
    :attr:`fingerprint`), so a library stays valid when the model's
    parameter values, initial state or inputs change.  Kept, for the
    library's lifetime:

    ``equations``
        mode → :class:`~switching.model.modes.ModeEquations` (sympy f, g, h and guards),
        derived on first request (:meth:`mode_equations`); ``derivation_count`` counts them.
    ``compiled``
        mode → :class:`~switching.library.compiled.CompiledMode`, the generated functions
        of the modes visited so far, in the order of their first visit (:meth:`compiled_mode`).
    ``jit``
        frozenset of modes → :class:`~switching.library.jit_model.CompiledModel` (numba), and
        under ``"visited"`` the model of the visited set with the count it was built at
        (:meth:`compiled_model`).
    ``cache``
        the :class:`codegen.cache.SourceCache` of generated source on disk (keys made
        of :attr:`fingerprint`); assign another to use another directory.
    ``print_memo``
        :class:`codegen.source.PrintMemo`: printed text of expressions, shared by the
        modes' generated functions (``None``: no memo; the same text, slower).
    ``roundoff_memo``
        subexpression → its round-off scale (:mod:`codegen.roundoff`).
    ``scale_memo``
        (left, right) of a guard comparison → its round-off scale
        (:func:`switching.library.compiled.comparison_triples`).
    ``guard_texts``
        guard comparison → its text.
    ``guard_trees``
        guard condition → (its tree, its comparisons) (:meth:`guard_tree`).
    ``guard_entries``, ``guard_entries_by_form``
        a guard's ``META`` entry and comparisons (:func:`~switching.library.compiled._mode_guards`), by its
        transition and condition, and (a bounded number) by its shared guard form.
    ``conjunctions``
        a guard's ``META`` entry → the comparisons of its conjunction (:meth:`CompiledMode.maybe_holding
        <switching.library.compiled.CompiledMode.maybe_holding>`), a bounded number.
    ``guard_blocks``
        (the guard forms of a block of automata, its first comparison) → their ``META`` entries,
        comparisons and triples (:func:`~switching.library.compiled._mode_comparisons`), a bounded number.
    ``guard_forms``
        (automaton, state, its transitions' count) → the :class:`~switching.model.modes.GuardForm` of the
        transitions leaving it, where they are the same in every mode (:meth:`ModeEquations._guard_forms
        <switching.model.modes.ModeEquations._guard_forms>`); and ``last_guard_groups``, those of the mode
        made last, automaton by automaton, from which the next mode's are made.
    ``triple_memo``, ``triple_by_id``
        guard comparison reading no rate → its triple of :func:`~switching.library.compiled.comparison_triples`
        (the same in every mode), by value and (a bounded number) by the object.
    ``side_block_sources``
        (raw?, outputs) of a block of guard sides → (function name, source); also by the outputs' objects.
    ``side_block_functions``
        name of a block of guard sides or rates → its compiled function (shared by the modes).
    ``block_texts``
        name of a block function → its text (:meth:`block_text`), which a mode's module calls
        but does not hold, and of a scene's guard table → its record (:mod:`.guard_tables`): each is
        stored in the disk cache once, under a key of its own.
    ``guard_tables``, ``table_conjunctions``
        (guard table, offset) → its entries with their comparisons numbered from ``offset``
        (:meth:`guards_in`), and the arrays of its conjunctions (:meth:`CompiledMode.maybe_holding
        <switching.library.compiled.CompiledMode.maybe_holding>`), a bounded number each.
    ``symbols_memo``
        expression → (free symbols, whether a law switch's Rate occurs) (:meth:`symbols_of`).
    ``jacobians``
        mode → the generated Jacobian of its flow (:func:`switching.library.jacobian.flow_jacobian`).
    ``gradient_memo``
        (a rate's expression, the independent states) → its gradient
        (:func:`switching.library.jacobian.jacobian_entries`): the modes of a
        scene share most rates (a ball's, where only a far contact switched).
    ``preparation_seconds``
        wall seconds spent making modes' equations and functions (derived,
        generated, or loaded from the disk cache): a run's time less these is
        its integration's (``auto`` prices a Python run by it).
    """

    def __init__(self, model, cache=None):
        #: the model whose definition the modes are derived from
        self.model = model
        self.equations: dict[Mode, ModeEquations] = {}
        #: modes whose derivation failed, with the error (a conflicting mode met at every PWM closing of an
        #: ideal buck is not derived again each period: its error is raised again)
        self.failed: dict[Mode, Exception] = {}
        self.compiled: dict[Mode, CompiledMode] = {}
        self.jit: dict = {}
        self.derivation_count = 0
        self.cache = default_cache() if cache is None else cache
        self.print_memo = PrintMemo()
        self.roundoff_memo: dict = {}
        self.scale_memo: dict = {}
        self.guard_texts: dict = {}
        self.guard_trees: dict = {}
        #: (ids of a guard's transition and condition) → its META entries and comparisons
        #: (:func:`switching.library.compiled._mode_guards`)
        self.guard_entries: dict = {}
        self.guard_entries_by_form: dict = {}
        self.conjunctions: dict = {}
        self.guard_blocks: dict = {}
        #: guard comparison → (left, right, round-off scale) of its finite sides, where they read no rate
        self.triple_memo: dict = {}
        self.triple_by_id: dict = {}
        self.guard_forms: dict = {}
        self.last_guard_groups: tuple | None = None
        self.side_block_sources: dict = {}
        self.side_block_functions: dict = {}
        #: name of a block function (guard sides, rates) → its text; and the names stored in the disk cache
        self.block_texts: dict = {}
        self.stored_blocks: set = set()
        self.guard_tables: dict = {}
        self.table_conjunctions: dict = {}
        #: (the symbols, the argument lists) of the modes' functions (:func:`switching.library.compiled._arguments`)
        self.mode_arguments = None
        self.symbols_memo: dict = {}
        self.jacobians: dict = {}
        self.gradient_memo: dict = {}
        #: (mode, signal names) → the generated signal function (:meth:`signal_function`)
        self.signal_functions: dict = {}
        #: conflicting mode → its guards in the limit of vanishing resistances (:mod:`.conflicts`)
        self.conflicts: dict = {}
        self.preparation_seconds = 0.0
        self._preparing = False
        self._fingerprint = None
        self._rate_symbols = None

    @property
    def fingerprint(self) -> str:
        """:func:`definition_fingerprint` of the model, computed once."""
        if self._fingerprint is None:
            self._fingerprint = definition_fingerprint(self.model)
        return self._fingerprint

    # ------------------------------------------------------------ symbolic

    def mode_equations(self, mode) -> ModeEquations:
        """f, g, h and guards of one mode, derived on first request and kept.
        Asking for a mode never derives any other."""
        mode = self.model.mode(mode)
        found = self.equations.get(mode)
        if found is None:
            if mode in self.failed:
                raise copy.copy(self.failed[mode])
            with self._preparation():
                try:
                    found = self.equations[mode] = ModeEquations(self.model, mode)
                except HybridBondGraphError as error:
                    self.failed[mode] = error
                    raise
            self.derivation_count += 1
        return found

    @contextlib.contextmanager
    def _preparation(self):
        """Count the wall time of the block into :attr:`preparation_seconds` (the outermost block only: a
        mode's functions derive its equations inside theirs).  The cyclic garbage collector waits until
        the block ends (:func:`~switching.library.collection.collection_paused`)."""
        if self._preparing:
            yield
            return
        self._preparing, start = True, time.perf_counter()
        try:
            with collection_paused():
                yield
        finally:
            self._preparing = False
            self.preparation_seconds += time.perf_counter() - start

    @property
    def derived_modes(self) -> tuple:
        """The modes whose equations are derived, in the order of derivation."""
        return tuple(self.equations)

    def symbols_of(self, expr) -> tuple:
        """``(free symbols, whether a law switch's Rate occurs)`` of ``expr``,
        kept: the modes of a large scene ask about the same guard comparisons
        and signals again and again."""
        found = self.symbols_memo.get(expr)
        if found is None:
            from ..model.law_automata import Rate, RateWith

            found = self.symbols_memo[expr] = (frozenset(expr.free_symbols), expr.has(Rate, RateWith))
        return found

    def rate_symbol_set(self, equations) -> frozenset:
        """The symbols ``ẋ`` of the states' rates (those of ``equations``, a mode's: the same in every mode
        of the model), kept."""
        if self._rate_symbols is None:
            self._rate_symbols = frozenset(equations.rate_symbols.values())
        return self._rate_symbols

    def cross_signal(self, mode: Mode, name: str, current=None) -> sp.Expr:
        """The :class:`~switching.model.hybrid_model.InMode` signal ``name`` seen from ``mode``:
        an expression of ``x``, from the equations of the mode it is taken in
        (derived if need be; ``current``: the ModeEquations of ``mode`` while
        it is being built)."""
        model = self.model
        expression, overrides = model.cross_signals[name]
        target = model.mode({**dict(zip(mode.automata, mode.states)), **overrides})
        me = current if (target == mode and current is not None) else self.mode_equations(target)
        g = me.jump.expressions
        if g is None:
            raise ModelDefinitionError(
                f"signal {name!r} is taken in mode {target.describe()}, whose jump map is numerical "
                "(nonlinear storage); such cross-mode signals need a symbolic jump map",
                [name],
            )
        return me.finite(me.to_raw(expression)).xreplace(g)

    # ------------------------------------------------------------ generated

    def compiled_mode(self, mode) -> CompiledMode:
        """The generated numerical functions of a mode: from memory, else from
        the disk cache (key: fingerprint, mode label, source version), else
        derived and generated now (and cached)."""
        known = self.compiled.get(mode) if isinstance(mode, Mode) else None
        if known is not None:
            return known
        mode = self.model.mode(mode)
        if mode not in self.compiled:
            with self._preparation():
                key = fingerprint(self.fingerprint, "mode", MODE_SOURCE_VERSION, mode.label)
                source, meta, chunks = self.cache.load(key, calls=BLOCK_CALLS), None, None
                if source is not None and not all(map(self._block_at_hand, set(re.findall(BLOCK_CALLS, source))
                                                      | set(re.findall(GUARD_TABLES, source)))):
                    source = None  # (a block it calls is gone from the disk cache: made again with the module)
                if source is None:
                    source, meta, chunks = mode_module(self.model, self.mode_equations(mode))
                    self.cache.store(key, source)
                    tables = (name for name, _ in meta.get("guard_blocks", ()))
                    for name in (*(n for f in ("rates", "sides", "sides_raw") for n in chunks["CALLS"][f]),
                                 *tables):
                        if name not in self.stored_blocks:  # (a scene's module calls blocks it does not hold)
                            self.cache.store(self._block_key(name), self.block_texts[name])
                            self.stored_blocks.add(name)
                self.compiled[mode] = CompiledMode(self.model, mode, source, meta, chunks)
        return self.compiled[mode]

    def _block_key(self, name: str) -> str:
        return fingerprint(self.fingerprint, "block", MODE_SOURCE_VERSION, name)

    def _block_at_hand(self, name: str) -> bool:
        """Is the text of block function ``name`` known here, or in the disk cache (then read, checked to be
        the function its name is the hash of)?"""
        if name in self.block_texts:
            return True
        # (not compiled now for the safety check: a block's text is checked when it is compiled to run, if it
        # ever is, and its name is the hash of its text; a scene's module calls a few hundred, most never run)
        text = self.cache.load(self._block_key(name), check=False)
        if text is None or not (block_checked(name, text) or table_checked(name, text)):
            return False
        self.block_texts[name] = text
        self.stored_blocks.add(name)
        return True

    def block_text(self, name: str, mode) -> str:
        """The text of the block function ``name`` that ``mode``'s module calls (made in this process
        or read from the disk cache with the module: :meth:`compiled_mode`)."""
        if not self._block_at_hand(name):
            raise ValueError(f"the generated module of mode {self.model.mode(mode).describe()} calls a block "
                             f"function {name} that is neither made nor in the disk cache")
        return self.block_texts[name]

    def keep_guard_table(self, name: str, offset: int, entries: list) -> None:
        """Keep ``entries``, the guard table ``name`` numbered from ``offset``, for :meth:`guards_in`
        (a mode generated now hands over the entries it was printed from)."""
        if (name, offset) not in self.guard_tables:
            if len(self.guard_tables) >= GUARD_ENTRIES_KEPT:
                self.guard_tables.clear()
            self.guard_tables[(name, offset)] = tuple(entries)

    def guards_in(self, tables, mode) -> tuple:
        """``(guards, sizes)``: the guard entries of ``mode`` whose ``META`` names its guard ``tables``
        (``((name, offset), …)``, :mod:`.guard_tables`), each table's entries numbered from its offset, in
        turn; and how many entries each table holds."""
        guards: list = []
        sizes: list = []
        for name, offset in tables:
            found = self.guard_tables.get((name, offset))
            if found is None:
                try:
                    entries = table_entries(self.block_text(name, mode))
                except ValueError as exc:
                    raise ValueError(f"the generated module of mode {self.model.mode(mode).describe()} names a "
                                     f"guard table {name} that is not one ({exc})") from None
                self.keep_guard_table(name, offset, shifted_entries(entries, offset, shifted_tree))
                found = self.guard_tables[(name, offset)]
            guards += found
            sizes.append(len(found))
        return guards, sizes

    def conflict_guards(self, mode, error):
        """The guards of ``mode``, whose derivation raised the causality conflict ``error``, judged in the
        limit of vanishing resistances (:class:`~switching.library.conflicts.ConflictGuards`; kept).  Raises
        ``error`` when they cannot be judged so."""
        found = self.conflicts.get(mode)
        if found is None:
            from .conflicts import ConflictGuards

            with self._preparation():
                found = self.conflicts[mode] = ConflictGuards(self.model, mode, error)
        return found

    @property
    def visited_modes(self) -> tuple:
        """The modes whose numerical functions exist in this process, in the
        order of their first visit."""
        return tuple(self.compiled)

    def mode_source(self, mode) -> str:
        """The generated Python source of one mode's functions."""
        return self.compiled_mode(mode).source

    def signal_function(self, mode, names):
        """Generated ``fn(x, t, p, u, out)`` giving the finite parts of the
        named signals in one mode (disk cache key: fingerprint, mode label,
        names); ``x`` may be an ``(n, N)`` array of N samples."""
        from codegen.safety import execute
        from codegen.source import Argument, FunctionSpec, function_source, module_namespace

        model = self.model
        mode = model.mode(mode)
        names = tuple(names)
        made = self.signal_functions.get((mode, names))
        if made is not None:
            return made
        key = fingerprint(self.fingerprint, "signals", mode.label, *names)
        source = self.cache.load(key)
        if source is None:
            me = self.mode_equations(mode)
            spec = FunctionSpec(
                "signals",
                (
                    Argument("x", tuple(model.states), doc="state vector"),
                    Argument("t", (model.time,), scalar=True, doc="time [s]"),
                    Argument("p", tuple(model.parameter_symbols), doc="parameters"),
                    Argument("u", tuple(model.input_symbols), doc="inputs"),
                ),
                tuple(me.signal(name).finite for name in names),
                f"Signals {', '.join(names)} in mode {mode.describe()} (finite parts).",
                names,
            )
            source = function_source(spec)
            self.cache.store(key, source)
        namespace = module_namespace(vectorized=True)
        execute(source, namespace, f"<hbg signals {mode.label}>")
        made = self.signal_functions[(mode, names)] = namespace["signals"]
        return made

    def guard_tree(self, condition, relations: list):
        """The tree of a guard condition (:func:`switching.library.compiled.condition_tree`),
        its comparisons appended to ``relations``: kept by condition with the
        comparisons numbered from 0, shifted here to follow ``relations``."""
        from .compiled import condition_tree, shifted_tree

        found = self.guard_trees.get(condition)
        if found is None:
            own: list = []
            found = self.guard_trees[condition] = (condition_tree(condition, own, self.guard_texts), tuple(own))
        tree, own = found
        offset = len(relations)
        relations.extend(own)
        return shifted_tree(tree, offset) if offset else tree

    def compiled_model(self, modes="visited"):
        """The numba module of the model for a set of modes, built once per
        set (see :mod:`switching.library.jit_model`): ``"visited"`` (those with
        generated functions so far, the initial mode, and those remembered in
        the disk cache), ``"reachable"`` (explored from the initial mode by
        :meth:`~switching.model.hybrid_model.HybridModel.verify`), or a list."""
        model = self.model
        if modes == "visited":
            last = self.jit.get("visited")
            if last is not None and last[0] == len(self.compiled):
                return last[1]  # no mode visited since: the same set
            selected = {model.initial_mode, *self.visited_modes, *remembered_modes(model)}
        elif modes == "reachable":
            report = model.verify(samples=5)
            selected = {model.initial_mode, *report.explored, *report.kinds}
        else:
            selected = {model.mode(m) for m in modes}
        key = frozenset(selected)
        if key not in self.jit:
            self.jit[key] = CompiledModel(model, key)
        if modes == "visited":
            self.jit["visited"] = (len(self.compiled), self.jit[key])
        return self.jit[key]

    def export_module(self, path, modes="visited") -> list:
        """Write the generated functions of several modes to one standalone
        Python module (:func:`switching.library.export.export_module`); returns the
        mode labels written."""
        from .export import export_module

        return export_module(self.model, path, modes)

    def __repr__(self) -> str:
        return (f"ModeLibrary({self.model.name!r}, derived modes={len(self.equations)}, "
                f"visited modes={len(self.compiled)})")
