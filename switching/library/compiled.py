"""Per-mode numerical functions, generated from a mode's symbolic f, g, h
and guards, compiled on the mode's first visit and cached (in memory, and on
disk keyed by a fingerprint of the model's symbolic definition, the mode and
the toolkit version — so a second process pays no symbolic derivation).

Generated functions of one mode (arrays: ``x`` states, ``p`` parameters,
``u`` inputs, ``xdot`` state derivatives as :class:`codegen.runtime.Hyper`):

``phi(x, t, p, u, out)``       dependent states from the independent ones
``rates(x, t, p, u, out)``     ``dx/dt`` of every state
``jump(x, t, p, u, out)``      ``x⁺ = g(x)`` with restitution (symbolic jumps only)
``sides(x, t, p, u, out)``     for every guard comparison ``k``: its finite left and
                               right sides and their round-off scale
                               ``max(R(left), R(right))`` (:mod:`codegen.roundoff`) at
                               ``out[3k], out[3k + 1], out[3k + 2]``
``sides_raw(x, t, p, u, xdot)``  the left and right sides on raw signals,
                               impulse-aware (``[2k], [2k + 1]``)

In a mode of many automata (more than ``2·SIDE_BLOCK_AUTOMATA``: a scene) ``sides``
and ``sides_raw`` call one function per block of automata
(``_sides_<hash>``, ``_sides_raw_<hash>``, named by a hash of their text),
which every mode holding those automata in the same states shares, and
``rates`` one per block of ``STATE_BLOCK`` states (``_rates_<hash>``);
:func:`flat_sides` writes such a ``sides`` and ``rates`` out as one function.
A scene's module does not hold the blocks it calls (each is generated, stored
in the disk cache and compiled once for all the modes that call it:
:meth:`switching.library.mode_library.ModeLibrary.block_text`), and its
functions' docstrings state the arrays' shapes, not every entry, and its ``META``
names the automata off their initial states (``changed``) and the *guard tables*
of its blocks of automata (``guard_blocks``, :mod:`.guard_tables`), each stored
once like a block, instead of every guard's entry, every automaton's state and
every independent state (the complement of ``dependent``): the module's size
so grows with the number of blocks, not with the states and guards.
:attr:`CompiledMode.source` writes the whole ``META`` out.

A comparison is decided with the band ``rtol·max(|left|, |right|, R) + atol``
(:func:`codegen.runtime.decide`): a difference that is zero up to the
round-off of the terms that formed it compares as zero, whatever the units.

The metadata ``META`` (independent / dependent indices, the guards as trees
of comparisons) is part of the same source, so a module loaded from disk
needs nothing else.
"""

from __future__ import annotations

import ast
import re
from itertools import compress, count, filterfalse
from operator import is_not

import numpy as np
import sympy as sp
from sympy.core.relational import Relational
from sympy.logic.boolalg import And, BooleanFalse, BooleanTrue, Not, Or

from codegen import decision
from codegen.roundoff import larger, roundoff_scale
from codegen.runtime import Comparison, Hyper, decide, hyper
from codegen.composed import composed_function
from codegen.safety import execute
from codegen.source import Argument, FunctionSpec, composed_source, docstring, function_source, module_namespace

from ..model.automaton import A_POSTERIORI
from ..rules.jumps import MOTION_ULPS, jump_pulse
from .guard_tables import guard_table_record, table_name

__all__ = ["BLOCK_CALLS", "CompiledMode", "MODE_SOURCE_VERSION", "block_checked", "block_name", "called_blocks", "comparison_triples",
           "condition_tree", "generate_mode_source", "decide_tree", "guard_parts", "holds_strictly", "mode_module", "mode_source_and_meta", "shifted_tree"]

#: part of the disk-cache key of a mode's source: change it when the generated functions change
MODE_SOURCE_VERSION = "14"

_OPS = {sp.Lt: "<", sp.Le: "<=", sp.Gt: ">", sp.Ge: ">=", sp.Eq: "==", sp.Ne: "!="}


def _op(relation) -> str:
    for cls, op in _OPS.items():
        if isinstance(relation, cls):
            return op
    raise TypeError(f"unsupported comparison {relation}")


def condition_tree(condition, relations: list, texts: dict | None = None):
    """A guard condition as nested plain tuples; comparisons are collected in
    ``relations``; ``texts`` memoizes the text of each comparison."""
    if isinstance(condition, BooleanTrue):
        return ("const", True)
    if isinstance(condition, BooleanFalse):
        return ("const", False)
    if isinstance(condition, And):
        return ("and", tuple(condition_tree(c, relations, texts) for c in condition.args))
    if isinstance(condition, Or):
        return ("or", tuple(condition_tree(c, relations, texts) for c in condition.args))
    if isinstance(condition, Not):
        return ("not", condition_tree(condition.args[0], relations, texts))
    if isinstance(condition, Relational):
        relations.append(condition)
        text = texts.get(condition) if texts is not None else None
        if text is None:
            # the terms in sympy's own order: sorting them costs more than the rest of a large mode's source
            text = sp.sstr(condition, order="none")
            if texts is not None:
                texts[condition] = text
        return ("rel", len(relations) - 1, _op(condition), text)
    raise TypeError(f"cannot compile {condition} as a guard")


def shifted_tree(tree, offset: int):
    """A guard tree with its comparison indices moved by ``offset``."""
    kind = tree[0]
    if kind == "rel":
        return ("rel", tree[1] + offset, tree[2], tree[3])
    if kind in ("and", "or"):
        return (kind, tuple(shifted_tree(t, offset) for t in tree[1]))
    if kind == "not":
        return ("not", shifted_tree(tree[1], offset))
    return tree


def _leaf_texts(trees, count: int) -> list:
    """The text of every comparison, by index, from the leaves of guard trees."""
    texts = [""] * count
    todo = list(trees)
    while todo:
        tree = todo.pop()
        if tree[0] in ("and", "or"):
            todo.extend(tree[1])
        elif tree[0] == "not":
            todo.append(tree[1])
        elif tree[0] == "rel":
            texts[tree[1]] = tree[3]
    return texts


def decide_tree(tree, sides, rtol, atol, record=None, fixed=None) -> bool:
    """Evaluate a guard tree on the comparison triples ``sides`` (left, right,
    round-off scale of comparison ``k`` at ``[3k], [3k + 1], [3k + 2]``).
    ``record`` collects a :class:`codegen.runtime.Comparison` per comparison
    evaluated; ``fixed`` (comparison index → truth) overrides comparisons."""
    kind = tree[0]
    if kind == "const":
        return tree[1]
    if kind == "rel":
        _, k, op, text = tree
    elif kind == "and":  # (loops, not all() of a generator: a scene decides a thousand guards an instant)
        for sub in tree[1]:
            if not decide_tree(sub, sides, rtol, atol, record, fixed):
                return False
        return True
    elif kind == "or":
        for sub in tree[1]:
            if decide_tree(sub, sides, rtol, atol, record, fixed):
                return True
        return False
    else:
        return not decide_tree(tree[1], sides, rtol, atol, record, fixed)
    if fixed and k in fixed:
        return fixed[k]
    left, right, scale = sides[3 * k], sides[3 * k + 1], sides[3 * k + 2]
    if record is None:
        return decide(op, left, right, rtol, atol, scale)
    comparison = Comparison.of(text, op, left, right, rtol, atol, scale)
    record.append(comparison)
    return comparison.result


#: a guard with more comparisons at their edge than this is taken to hold strictly (2**n decisions to try)
EDGE_COMPARISONS_TRIED = 10


def _at_edge(tree, sides, rtol, atol, found) -> None:
    """The comparisons of ``tree`` at their edge into ``found``: no impulse
    decides them and their finite sides differ by no more than their band."""
    kind = tree[0]
    if kind in ("and", "or"):
        for sub in tree[1]:
            _at_edge(sub, sides, rtol, atol, found)
    elif kind == "not":
        _at_edge(tree[1], sides, rtol, atol, found)
    elif kind != "const":
        k = tree[1]
        left, right, scale = hyper(sides[3 * k]), hyper(sides[3 * k + 1]), sides[3 * k + 2]
        if decision.pulse_decides(left.impulse, right.impulse):
            return
        width = decision.band(left.finite, right.finite, scale, rtol, atol)
        if abs(left.finite - right.finite) <= width:
            found.add(k)


def holds_strictly(tree, sides, rtol, atol) -> bool:
    """Does the guard ``tree`` hold however its comparisons at their edge are
    decided?  A comparison is at its edge when no impulse decides it and its
    finite sides differ by no more than its band (:func:`codegen.decision.band`:
    equality up to round-off); a guard that holds, but not strictly, holds at
    a *tie* (``v_D >= 0`` at ``v_D = 0``; :mod:`switching.rules.instants`).
    Every decision of the comparisons at their edge is tried (a guard with
    more than :data:`EDGE_COMPARISONS_TRIED` of them counts as holding
    strictly: no tie is claimed that was not checked)."""
    edge: set = set()
    _at_edge(tree, sides, rtol, atol, edge)
    if not edge:
        return decide_tree(tree, sides, rtol, atol)
    if len(edge) > EDGE_COMPARISONS_TRIED:
        return decide_tree(tree, sides, rtol, atol)
    edge = sorted(edge)
    for bits in range(1 << len(edge)):
        if not decide_tree(tree, sides, rtol, atol, fixed={k: bool(bits >> i & 1) for i, k in enumerate(edge)}):
            return False
    return True


def comparison_triples(me, relations) -> list:
    """``[left, right, max(R(left), R(right))]`` of every comparison, finite
    parts (``ẋ = f(x)`` substituted), concatenated: the outputs of ``sides``.

    A comparison on the time alone (a clock: its sides depend on ``t`` and
    the parameters, on no state and no input) gets the round-off scale 0, so
    its band is ``rtol·max(|left|, |right|) + atol``.  Its sides' round-off
    at a float ``t`` (``≈ ε·R``) only moves the computed crossing by a few
    units in the last place of ``t``; widening the band by ``rtol·R``
    (``rtol ≫ ε``) would move every crossing by ``rtol·R/|d(left − right)/dt|``
    instead — and the scale of a periodic clock grows with its phase: the
    edges of a PWM carrier ``acos(cos(2·pi·f·t − pi·D))/pi`` (``R ≈ 12·f·t``,
    slope ``2·f``) would lag ``6·rtol·t``, 6e-12 s after 1e5 periods of
    10 kHz instead of the round-off of ``k/f``."""
    return _triples(me, relations)[0]


def _triples(me, relations) -> tuple:
    """``(triples, plain)``: :func:`comparison_triples` of ``relations``, and whether every triple is the
    same in every mode (it reads no rate)."""
    triples, plain = [], True
    model = me.model
    memo, scales = model.library.roundoff_memo, model.library.scale_memo
    kept = model.library.triple_memo  # comparison → its triple, where it reads no rate (the same in every mode)
    clock = None
    by_id = model.library.triple_by_id  # (the same, by the object held with it: a scene's thousand not hashed)
    for rel in relations:
        found = _found_by_id(by_id, rel)
        if found is not None:
            triples += found
            continue
        found = kept.get(rel)
        if found is not None:
            _keep_by_id(by_id, rel, found)
            triples += found
            continue
        left, right = me.finite(rel.lhs), me.finite(rel.rhs)
        scale = scales.get((left, right))
        if scale is None:
            clock = clock or {model.time, *model.parameter_symbols}
            free = left.free_symbols | right.free_symbols
            if model.time in free and free <= clock:
                scale = sp.Integer(0)
            else:
                scale = larger(roundoff_scale(left, memo), roundoff_scale(right, memo))
            scales[(left, right)] = scale
        if left is rel.lhs and right is rel.rhs:  # (no rate substituted: the mode did not enter)
            kept[rel] = (left, right, scale)
            _keep_by_id(by_id, rel, kept[rel])
        else:
            plain = False
        triples += [left, right, scale]
    return triples, plain


def _found_by_id(by_id: dict, obj):
    """What ``by_id`` keeps for the object ``obj`` (:func:`_keep_by_id`), or ``None``."""
    found = by_id.get(id(obj))
    return found[1] if found is not None and found[0] is obj else None


def _keep_by_id(by_id: dict, obj, value):
    """``value`` kept for the object ``obj`` (held, so that its id stays its own; found again without
    hashing it: a scene's thousands of expressions and entries), at most :data:`GUARD_ENTRIES_KEPT` of
    them (an object made anew in every mode, a comparison reading a bond, is never met again); returns
    ``value``."""
    if len(by_id) >= GUARD_ENTRIES_KEPT:
        by_id.clear()
    by_id[id(obj)] = (obj, value)
    return value


def generate_mode_source(model, me) -> str:
    """The generated module (source text) of one mode from its ModeEquations."""
    return mode_source_and_meta(model, me)[0]


def mode_source_and_meta(model, me) -> tuple[str, dict]:
    """The generated module of one mode and its ``META`` (the value the
    module's ``META = …`` line holds, which a :class:`CompiledMode` made now
    need not parse back: ~10 ms a mode for a scene of 200 contacts)."""
    return mode_module(model, me)[:2]


#: a guard's entries for at most this many offsets of its comparisons are kept (:func:`_mode_guards`)
GUARD_OFFSETS_KEPT = 8
#: guards whose entries a library keeps: where a guard's condition reads a bond of the mode it is a new object in
#: every mode, and its entry would never be met again (the kept entries are dropped at this many)
GUARD_ENTRIES_KEPT = 20_000


def _mode_guards(model, me) -> tuple:
    """``(guards, their reprs, comparisons, raw sides, spans)`` of a mode: each guard's ``META`` entry
    (its comparisons numbered after those of the guards before it), the comparisons in order, their
    left and right sides, and per guard (the block of its automaton, its first comparison, the
    comparison after its last).

    A guard's entry, its text and its comparisons are kept by the library per guard (its transition
    and condition, the same objects in every mode where the condition reads no bond of the mode) and
    offset of its comparisons: a scene's modes repeat nearly all their thousand guards, and printing
    and building them again was a fifth of a mode's generation."""
    return _guards_at(model, me.guards, 0)


def _guards_at(model, forms: list, offset: int) -> tuple:
    """:func:`_mode_guards` of the guard ``forms`` whose first comparison is number ``offset``."""
    library = model.library
    kept, automaton_index, by_form = library.guard_entries, model.automaton_index, library.guard_entries_by_form
    guards, texts, relations, raw_sides, spans = [], [], [], [], []
    for guard in forms:
        found = _found_by_id(by_form, guard)  # (a guard form shared by the modes: ModeEquations._guard_forms)
        if found is None:
            found = _keep_by_id(by_form, guard, _guard_entry(library, kept, automaton_index, guard))
        start = offset + len(relations)
        shifted = found[6].get(start)
        if shifted is None:
            entry = found[3] if not start else {**found[3], "tree": shifted_tree(found[3]["tree"], start)}
            shifted = (entry, repr(entry))
            if len(found[6]) < GUARD_OFFSETS_KEPT:
                found[6][start] = shifted
        guards.append(shifted[0])
        texts.append(shifted[1])
        relations.extend(found[4])
        raw_sides.extend(found[5])
        spans.append((found[7], start, offset + len(relations)))
    return guards, texts, relations, raw_sides, spans


def _mode_comparisons(model, me, tables: bool = False) -> tuple:
    """``(guards, their reprs, comparisons, raw sides, spans, finite sides, guard tables, side blocks)``:
    :func:`_mode_guards` and :func:`comparison_triples` of a mode, a block of :data:`SIDE_BLOCK_AUTOMATA`
    automata at a time.  A block's guard forms shared by the modes (``me.guard_starts``: where each
    automaton's forms begin) at the same first comparison give the same results, kept by the library (a
    bounded number) where their triples read no rate: a mode of a scene looks at each block once, not at
    each of its thousand guards.  With ``tables``, the last item is ``((name, offset), …)`` of the
    blocks' guard tables (:mod:`.guard_tables`), else ``None`` (also where the mode has no blocks); the
    side blocks are :func:`_side_blocks` of the spans, known here block by block (``None`` without blocks)."""
    starts = getattr(me, "guard_starts", None)
    if starts is None:
        guards, texts, relations, raw_sides, spans = _mode_guards(model, me)
        return guards, texts, relations, raw_sides, spans, comparison_triples(me, relations), None, None
    memo, count, library = model.library.guard_blocks, len(starts) - 1, model.library
    results: tuple = ([], [], [], [], [], [])
    named = [] if tables else None
    side_blocks = []  # (first comparison, end) of each block that has comparisons: _side_blocks of the spans
    for first in range(0, count, SIDE_BLOCK_AUTOMATA):
        low, high = starts[first], starts[min(first + SIDE_BLOCK_AUTOMATA, count)]
        if low == high:
            continue
        forms, offset = me.guards[low:high], len(results[2])
        # (by the first and last form's objects, then by all of theirs; the forms compared by identity at once)
        quick = (id(forms[0]), id(forms[-1]), len(forms), offset)
        found = memo.get(quick)
        if found is None or found[0] != forms:
            key = (tuple(map(id, forms)), offset)
            found = memo.get(key)
            if found is None or found[0] != forms:
                block = _guards_at(model, forms, offset)
                triples, plain = _triples(me, block[2])
                found = (forms, (*block, triples), [None])
                if plain:
                    if len(memo) >= GUARD_ENTRIES_KEPT:
                        memo.clear()
                    memo[key] = found  # (the forms held: their ids stay theirs)
            if key in memo:  # (kept: also under the quick key)
                memo[quick] = found
        for whole, part in zip(results, found[1]):
            whole += part
        if len(results[2]) > offset:
            side_blocks.append((offset, len(results[2])))
        if named is not None:
            if found[2][0] is None:
                found[2][0] = _guard_table(model, forms)
            named.append((found[2][0], offset))
            library.keep_guard_table(found[2][0], offset, found[1][0])
    return (*results, None if named is None else tuple(named), side_blocks)


def _guard_table(model, forms: list) -> str:
    """The name of the guard table of a block's guard ``forms`` (:mod:`.guard_tables`: their entries
    numbered from the block's first comparison), its text put in the library's ``block_texts``."""
    record = guard_table_record(_guards_at(model, forms, 0)[1])
    name = table_name(record)
    model.library.block_texts.setdefault(name, record)
    return name


def _guard_entry(library, kept: dict, automaton_index: dict, guard) -> tuple:
    """The library's entry of ``guard`` (:func:`_mode_guards`), kept by its transition and condition:
    ``(transition, condition, (automaton, text), META entry, comparisons, their sides, entries by offset,
    the block of its automaton)``."""
    tr, condition = guard.transition, guard.condition
    found = kept.get((id(tr), id(condition)))
    if found is None or found[0] is not tr or found[1] is not condition or found[2] != (guard.automaton,
                                                                                      guard.text):
        own: list = []
        tree = library.guard_tree(condition, own)
        entry = {"automaton": guard.automaton, "source": tr.source, "target": tr.target, "when": tr.when,
                 "pulses": tr.pulses, "text": guard.text, "tree": tree}
        sides = tuple(side for rel in own for side in (rel.lhs, rel.rhs))
        found = (tr, condition, (guard.automaton, guard.text), entry, tuple(own), sides, {},
                 automaton_index[guard.automaton] // SIDE_BLOCK_AUTOMATA)
        if len(kept) >= GUARD_ENTRIES_KEPT:
            kept.clear()
        kept[(id(tr), id(condition))] = found  # (the transition and condition held: their ids stay theirs)
    return found


def _in_order(values: dict, states: list) -> tuple:
    """``values[s]`` of each of ``states`` in turn: the dictionary's own order where it is theirs (the same
    objects, compared at once: a scene's thousand states not hashed again)."""
    if len(values) == len(states) and list(values) == states:
        return tuple(values.values())
    return tuple(values[s] for s in states)


def _conjunction(tree) -> tuple:
    """``(comparisons, operators)`` of a guard tree that is one comparison or a conjunction of comparisons
    (the numbers of its comparisons, :data:`codegen.decision.OPS` of their operators), else ``((), ())``."""
    leaves = (tree,) if tree[0] == "rel" else tree[1] if tree[0] == "and" else ()
    if not (leaves and all(leaf[0] == "rel" for leaf in leaves)):
        return (), ()
    return tuple(leaf[1] for leaf in leaves), tuple(decision.OPS[leaf[2]] for leaf in leaves)


def _tuple_text(items: list) -> str:
    """``repr`` of a tuple of items whose reprs are ``items``."""
    return "(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")"


def _arguments(model, states, rates, params, inputs) -> tuple:
    """The argument lists of a mode's functions and of its raw ones: the same tuples for every mode of a model
    (kept by its library) while they hold the same symbols, so that the print memo finds its table by them at
    once (:meth:`codegen.source.PrintMemo.table`)."""
    kept = model.library.mode_arguments
    symbols = (tuple(states), tuple(rates), tuple(params), tuple(inputs), model.time)
    if kept is not None and kept[0] == symbols:
        return kept[1]
    base_args = (
        Argument("x", symbols[0], doc="state vector"),
        Argument("t", (model.time,), scalar=True, doc="time [s]"),
        Argument("p", symbols[2], doc="parameters"),
        Argument("u", symbols[3], doc="inputs"),
    )
    raw_args = base_args + (Argument("xdot", symbols[1], doc="state derivatives (Hyper: impulse, finite)"),)
    model.library.mode_arguments = (symbols, (base_args, raw_args))
    return base_args, raw_args


def mode_module(model, me) -> tuple[str, dict, dict]:
    """:func:`mode_source_and_meta` and the module's parts as
    :func:`_function_chunks` reads them off the text, known here as the text
    is assembled (a :class:`CompiledMode` made now need not search the text
    for them: ~7 ms a mode for a scene of 500 contacts), and under ``CALLS``
    the block functions each of ``rates``, ``sides`` and ``sides_raw`` calls."""
    states = list(model.states)
    rates = list(map(me.equations.rate_symbols.__getitem__, states))
    params = list(model.parameter_symbols)
    inputs = list(model.input_symbols)
    # (by place in x: a scene's thousand states are not each hashed or compared again)
    dependent_at = sorted(model.state_index[s] for s in me.equations.dependent)
    held = frozenset(dependent_at)
    independent_at = tuple(filterfalse(held.__contains__, range(len(states))))
    dependent = [states[k] for k in dependent_at]
    label = me.mode.describe()
    base_args, raw_args = _arguments(model, states, rates, params, inputs)

    large = len(model.automata) > 2 * SIDE_BLOCK_AUTOMATA  # a scene: no per-entry lists, rates in blocks
    guards, guard_texts, relations, raw_sides, spans, finite_sides, tables, side_blocks = \
        _mode_comparisons(model, me, large)
    if large:  # (the docstrings state the arrays' shapes; the module's docstring names the mode)
        side_names = triple_names = ()
        where, shaped = "this mode", (lambda output_doc: {"entries": False, "output_doc": output_doc})
    else:
        texts = _leaf_texts([g["tree"] for g in guards], len(relations))  # printed once, by condition_tree
        side_names = tuple(f"{side} of {text}" for text in texts for side in ("left", "right"))
        triple_names = tuple(f"{side} of {text}" for text in texts for side in ("left", "right", "round-off scale"))
        where, shaped = f"mode {label}", (lambda output_doc: {})

    g = me.g
    jump_kind = "identity" if me.jump.is_identity else ("symbolic" if g is not None else "numeric")
    specs = [
        FunctionSpec("phi", base_args, tuple(me.equations.constraints[s] for s in dependent),
                     f"Dependent states of {where} (x_d = phi(x_i, t)).",
                     tuple(model.state_names[model.state_index[s]] for s in dependent),
                     **shaped("x_d, the states at x[k] for k in META['dependent'], in that order")),
        FunctionSpec("rates", base_args, _in_order(me.f, states), f"dx/dt in {where}.",
                     model.state_names, **shaped("dx/dt of every state, in the order of x")),
        FunctionSpec("sides", base_args, tuple(finite_sides),
                     f"Guard comparison sides in {where} (finite) with their round-off scales.", triple_names,
                     **shaped("left side, right side and round-off scale of guard comparison k (numbered as "
                              "in META's guard trees) at [3k], [3k + 1], [3k + 2]")),
        FunctionSpec("sides_raw", raw_args, tuple(raw_sides),
                     f"Guard comparison sides in {where} on raw signals (impulse-aware).", side_names, raw=True,
                     **shaped("left and right side of guard comparison k at [2k], [2k + 1]")),
    ]
    if jump_kind == "symbolic":
        outputs = _in_order(g, states)  # (the states a jump moves are not its states themselves: a scene's few)
        specs.append(FunctionSpec("jump", base_args, outputs, f"x+ = g(x) into {where}.", model.state_names,
                                  copy_of="x", differs=tuple(compress(count(), map(is_not, outputs, states))),
                                  **shaped("x+, in the order of x")))
    blocks = (_side_blocks(spans) if side_blocks is None else side_blocks) if large else None
    state_blocks = [(k, min(k + STATE_BLOCK, len(states))) for k in range(0, len(states), STATE_BLOCK)] \
        if large else None
    meta = {
        "mode": tuple(me.mode.states),
        "automata": tuple(me.mode.automata),
        "independent": independent_at,
        "dependent": tuple(dependent_at),
        "moved": tuple(model.state_index[s] for s in (*me.jump.participating, *me.jump.dependent)),
        "jump": jump_kind,
        "guards": tuple(guards),
        "n_states": len(states),
    }
    if large:  # (named by the automata off their initial states)
        initial = {a.name: a.initial for a in model.automata}
        changed = tuple((a, s) for a, s in zip(me.mode.automata, me.mode.states) if s != initial[a])
        label = ", ".join(f"{a}={s}" for a, s in changed) + " (every other automaton in its initial state)" \
            if changed else "with every automaton in its initial state"
    if tables is not None:  # a scene (large): of a size that does not grow with its automata and states
        meta = {"changed": changed, **{k: meta[k] for k in ("dependent", "moved", "jump", "n_states")},
                "guard_blocks": tables, "comparisons": len(relations)}
    header = docstring([f"Generated functions of mode {label} of model {model.name!r} (do not edit)."], "") + "\n\n"
    pieces = []  # (function name, its text) in the module's order
    calls = {name: [] for name in ("rates", "sides", "sides_raw")}  # (the block functions each calls)
    for spec in specs:
        if blocks and spec.name in ("sides", "sides_raw"):
            *piece, calls[spec.name] = _blocked_piece(model, spec, blocks, 3 if spec.name == "sides" else 2)
        elif state_blocks and spec.name == "rates":
            *piece, calls[spec.name] = _blocked_piece(model, spec, state_blocks, 1)
        else:
            piece = (spec.name, function_source(spec, model.library.print_memo))
        pieces.append(tuple(piece))
    meta_text = "{" + ", ".join(f"{k!r}: {v!r}" if k != "guards" else f"{k!r}: {_tuple_text(guard_texts)}"
                                for k, v in meta.items()) + "}"  # (repr(meta), the guards' texts kept)
    head = header + f"META = {meta_text}\n\n\n"
    source = head + "\n\n".join(text for _, text in pieces)
    chunks = {"META": meta_text, "CALLS": calls}
    start, line = len(head), 1 + head.count("\n")
    for k, (name, text) in enumerate(pieces):
        text = text if k + 1 == len(pieces) else text + "\n\n"  # (a chunk runs to the next one's start)
        chunks[name] = (line, text)
        start, line = start + len(text), line + text.count("\n")
    return source, meta, chunks


#: the guard comparisons of a mode of more than twice this many automata are
#: printed in blocks of this many automata: a function of its own per block,
#: shared by every mode in which those automata are in the same states (a new
#: mode of a 200-contact chain prints and compiles one block, not the sides of
#: 200 contacts).  ``sides`` calls them in turn, each on its slice of ``out``;
#: the price is a few per cent per call (the parameters and the subexpressions
#: shared across a block's edge are computed once per block).
SIDE_BLOCK_AUTOMATA = 16

#: the rates of such a mode are printed in blocks of this many states, shared alike (a
#: ball's rates read the same in every mode where its contacts are as they were)
STATE_BLOCK = 32

_BLOCK_NAME = r"_(?:sides|sides_raw|rates)_[0-9a-f]{12}"
#: the names of block functions in a module's text, which its functions may call (checked: :mod:`codegen.safety`)
BLOCK_CALLS = rf"\b{_BLOCK_NAME}\b"


def _side_blocks(spans) -> list | None:
    """``[(first comparison, end)]`` of each block of automata that has
    comparisons, from the guards' ``spans`` (``None`` if the guards are not
    in the automata's order)."""
    blocks: list = []
    current = None
    for block, start, end in spans:
        if end == start:
            continue
        if current is None or block > current:
            blocks.append((start, end))
            current = block
        elif block == current and blocks[-1][1] == start:
            blocks[-1] = (blocks[-1][0], end)
        else:
            return None
    return blocks


def block_name(kind: str, text: str) -> str:
    """The name of a block function of ``kind`` (``sides``, ``sides_raw``, ``rates``) whose text,
    defined as ``_block_``, is ``text``: a hash of it."""
    import hashlib

    return f"_{kind}_" + hashlib.sha1(text.encode()).hexdigest()[:12]


def _blocked_piece(model, spec: FunctionSpec, blocks: list, per_item: int) -> tuple:
    """``spec`` (``sides``, ``sides_raw`` or ``rates``) as calls of one block
    function per block of items (comparisons, states; ``per_item`` outputs
    each): ``(name, text, the blocks it calls)`` of the caller.  A block is named by a hash of its
    text, so one block is one function for every mode that holds it, in this
    process and in the disk cache; its text is kept for the model by its
    outputs (the print memo makes the rest) and by its name in the library's
    ``block_texts``, which the caller's module does not hold (the library
    stores each block in the disk cache once, under its own key)."""
    memo, named = model.library.side_block_sources, model.library.block_texts
    calls = []
    kind = "raw signals (impulse-aware)" if spec.raw else "their round-off scales"
    for start, end in blocks:
        outputs = spec.outputs[per_item * start:per_item * end]
        # (by the outputs' objects first, which a scene's modes share: its thousands of expressions not hashed;
        # the first and last name the block, the comparison below makes sure)
        quick = ("by id", spec.name, spec.raw, id(outputs[0]), id(outputs[-1]), len(outputs))
        held = memo.get(quick)
        if held is not None and held[0] == outputs:  # (the same objects: compared by identity at once)
            calls.append((held[1][0], len(outputs)))
            continue
        key = (spec.name, spec.raw, outputs)
        found = memo.get(key)
        if found is None:
            doc = ("A block of state rates dx/dt." if spec.name == "rates"
                   else f"A block of guard comparison sides with {kind}.")
            block = FunctionSpec("_block_", spec.arguments, outputs, doc, raw=spec.raw, brief=True)
            text = function_source(block, model.library.print_memo)
            name = block_name(spec.name, text)
            found = memo[key] = (name, text.replace("def _block_(", f"def {name}(", 1))
            named[name] = found[1]
        memo[quick] = (outputs, found)  # (the outputs held: their ids stay theirs)
        calls.append((found[0], len(outputs)))
    return spec.name, composed_source(spec, calls, model.library.print_memo), list(dict.fromkeys(n for n, _ in calls))


def called_blocks(text: str) -> list:
    """The block functions a generated caller's ``text`` calls, in order, each once."""
    body = text[text.rindex('"""') + 3:] if '"""' in text else text  # (after the docstring)
    return list(dict.fromkeys(re.findall(rf"\b({_BLOCK_NAME})\(", body)))


def block_checked(name: str, text: str) -> bool:
    """Is ``text`` the block function ``name`` (its name the hash of its text)?"""
    kind = re.fullmatch(r"_(sides|sides_raw|rates)_[0-9a-f]{12}", name)
    head = f"def {name}("
    return bool(kind) and text.startswith(head) and block_name(kind.group(1), "def _block_(" + text[len(head):]) \
        == name


def flat_sides(source: str) -> str:
    """A generated mode module with a ``sides`` (and ``rates``) made of
    blocks written out as one function — each block's statements in turn, its
    outputs at their places — and the blocks' definitions dropped: the same
    numbers, for any ``out`` (a standalone export may be handed a list, whose
    slices are copies, not views).  Other modules are returned as they are."""
    for function in ("sides", "rates"):
        source = _flat(source, function)
    return source


def _flat(source: str, function: str) -> str:
    """:func:`flat_sides` of one function."""
    chunks = _function_chunks(source)
    if function not in chunks:
        return source
    caller = chunks[function][1]
    calls = re.findall(rf"^    ({_BLOCK_NAME})\(x, t, p, u, out\[(\d+):\d+\]\)$", caller, re.MULTILINE)
    if not calls:
        return source
    lines = caller.rstrip("\n").split("\n")
    end_of_doc = next(k for k in range(1, len(lines)) if lines[k] == '    """') + 1
    flat = lines[:end_of_doc]
    for name, start in calls:
        body = chunks[name][1].rstrip("\n").split("\n")[2:]  # (after the def line and the one-line docstring)
        for line in body:
            output = re.match(r"    out\[(\d+)\] = ", line)
            if output:
                flat.append(f"    out[{int(start) + int(output.group(1))}] = " + line[output.end():])
            elif line != "    return out":
                flat.append(line)
    flat.append("    return out")
    source = source.replace(caller, "\n".join(flat) + caller[len(caller.rstrip("\n")):])
    for name in dict.fromkeys(name for name, _ in calls):
        source = source.replace(chunks[name][1], "")
    return source


def _function_chunks(source: str) -> dict:
    """The parts of a generated mode module: ``META`` (the text of its
    value) and each function by name as ``(first line, text)``."""
    chunks = {}
    starts = list(re.finditer(rf"^(?:def (phi|rates|sides|sides_raw|jump|{_BLOCK_NAME})\(x, t, p, u(?:, xdot)?"
                              r"(?:, out)?\):$|META = )", source, re.MULTILINE))
    line, counted = 1, 0
    for k, match in enumerate(starts):
        end = starts[k + 1].start() if k + 1 < len(starts) else len(source)
        text = source[match.start():end]
        line += source.count("\n", counted, match.start())
        counted = match.start()
        if match.group(1) is None:
            chunks["META"] = text[len("META = "):].strip()
        else:
            chunks[match.group(1)] = (line, text)
    return chunks


class _Generated:
    """A generated function of a :class:`CompiledMode`, compiled on first use
    (:meth:`CompiledMode._function`); assigning one replaces it."""

    def __init__(self, name: str):
        self.name = name

    def __get__(self, mode, owner=None):
        return self if mode is None else mode._function(self.name)

    def __set__(self, mode, function) -> None:
        mode._namespace[self.name] = function


class CompiledMode:
    """Executable functions and metadata of one mode (see the module docstring)."""

    def __init__(self, model, mode, source: str, meta: dict | None = None, chunks: dict | None = None):
        self.model = model
        self.mode = mode
        #: the mode's module as generated and stored: a scene's calls block functions it does not hold
        #: (:attr:`source` is the module with them)
        self.module = source
        self._where = f"<hbg mode {mode.label}>"
        self._namespace = module_namespace()
        # (given: the parts the text was assembled from, :func:`mode_module`)
        self._chunks = _function_chunks(source) if chunks is None else dict(chunks)
        missing = {"META", "phi", "rates", "sides", "sides_raw"} - set(self._chunks)
        if missing:  # not a module generate_mode_source wrote
            raise ValueError(f"the generated source of mode {mode.describe()} lacks {', '.join(sorted(missing))}")
        meta_text = self._chunks.pop("META")
        meta = ast.literal_eval(meta_text) if meta is None else meta  # (given: the value the text was printed from)
        self.meta = meta
        #: the block functions the module's callers call, by caller
        calls = self._chunks.pop("CALLS", None)  # (given with the parts: read off the text otherwise)
        self._blocks = calls if calls is not None else \
            {name: called_blocks(self._chunks[name][1]) for name in ("rates", "sides", "sides_raw")}
        # (each compiled apart, checked to call only these)
        self._functions = frozenset(self._chunks).union(*self._blocks.values())
        if "independent" in meta:
            self.independent = np.array(meta["independent"], dtype=int)
        else:  # (a scene's module: every state not dependent)
            self.independent = np.delete(np.arange(meta["n_states"]), np.array(meta["dependent"], dtype=int))
        self.dependent = np.array(meta["dependent"], dtype=int)
        self.moved = np.array(meta["moved"], dtype=int)
        self.jump_kind = meta["jump"]
        #: every guard's entry (:func:`mode_module`), written out or in a scene's tables (:mod:`.guard_tables`)
        if "guards" in meta:
            self.guards = meta["guards"]
        else:  # (and how many guards each table holds)
            self.guards, self._table_sizes = model.library.guards_in(meta["guard_blocks"], mode)
        self._on_numpy = None  # the same functions on numpy's math (see on_numpy), compiled when first needed
        self._conjunctions = self._a_posteriori = None  # (see maybe_holding, a_posteriori)
        self.n = meta["n_states"]
        self.n_relations = meta["comparisons"] if "comparisons" in meta else \
            sum(_count_rel(g["tree"]) for g in self.guards)
        self.n_sides = 3 * self.n_relations  # (left, right, round-off scale) per comparison

    @property
    def source(self) -> str:
        """The mode's whole module: :attr:`module` with its ``META``'s guards written out (a scene's are in
        tables, :mod:`.guard_tables`) and the block functions it calls that it does not hold."""
        module = self.module
        if "guards" not in self.meta:
            meta = self.meta
            whole = {"mode": tuple(self.mode.states), "automata": tuple(self.mode.automata),
                     "independent": tuple(int(k) for k in self.independent), "dependent": meta["dependent"],
                     "moved": meta["moved"], "jump": meta["jump"], "guards": tuple(self.guards),
                     "n_states": meta["n_states"]}
            module = re.sub(r"^META = .*$", lambda _: f"META = {whole!r}", module, count=1, flags=re.MULTILINE)
        missing = [name for names in self._blocks.values() for name in names if name not in self._chunks]
        if not missing:
            return module
        texts = [self.function_text(name) for name in dict.fromkeys(missing)]
        return module.rstrip("\n") + "\n\n\n" + "\n\n".join(text.rstrip("\n") + "\n" for text in texts)

    def function_text(self, name: str) -> str:
        """The text of generated function ``name``: the module's, or a block function it calls
        (:meth:`~switching.library.mode_library.ModeLibrary.block_text`)."""
        if name in self._chunks:
            return self._chunks[name][1]
        return self.model.library.block_text(name, self.mode)

    def _function(self, name: str):
        """Generated function ``name``, compiled when first asked for (a mode
        passed through at instants never needs its rates, say).  Its line
        numbers are those of :attr:`module` (a block's, its own)."""
        found = self._namespace.get(name)
        if found is None and name in self._chunks:
            first_line, text = self._chunks[name]
            blocks = self._blocks.get(name, ())
            self._place_blocks(blocks)
            # (a caller of blocks is read, not compiled: codegen.composed)
            found = composed_function(text, {block: self._namespace[block] for block in blocks}, self._where,
                                      first_line) if blocks else None
            if found is None:
                execute(text, self._namespace, self._where, first_line=first_line, also=self._functions)
                found = self._namespace[name]
            else:
                self._namespace[name] = found
        return found

    def _place_blocks(self, blocks) -> None:
        """Put the block functions ``blocks`` into this mode's namespace: the
        model's, compiled by the first mode that needed them (a block's name is
        a hash of its text, so equal names are equal functions), else compiled
        now from its text (:meth:`function_text`)."""
        shared = self.model.library.side_block_functions
        for block in blocks:
            if block in self._namespace:
                continue
            function = shared.get(block)
            if function is None:
                if block in self._chunks:
                    function = self._function(block)
                else:
                    namespace = execute(self.function_text(block), module_namespace(), f"<hbg block {block}>")
                    function = namespace[block]
                shared[block] = function
            self._namespace[block] = function

    _phi = _Generated("phi")
    _rates = _Generated("rates")
    _sides = _Generated("sides")
    _sides_raw = _Generated("sides_raw")
    _jump = _Generated("jump")

    def on_numpy(self, name: str):
        """Generated function ``name`` run with numpy's math functions, whose
        results are numpy scalars: where the ``math`` version raises (a
        division by ``sqrt(0.0)``, an overflow) this one gives ``inf`` or
        ``NaN`` (under ``np.errstate``) — the values the guard band and the
        non-finite checks know how to handle."""
        if self._on_numpy is None:
            namespace = module_namespace(vectorized=True)
            execute(self.source, namespace, self._where)
            self._on_numpy = namespace
        return self._on_numpy[name]

    # ----------------------------------------------------------- evaluation

    def complete(self, x: np.ndarray, t: float) -> np.ndarray:
        """Set the dependent entries of ``x`` (in place) from the independent ones."""
        if len(self.dependent):
            model = self.model
            out = np.empty(len(self.dependent))
            self._phi(x, t, model.parameter_array, model.input_values(t), out)
            x[self.dependent] = out
        return x

    def rates(self, x: np.ndarray, t: float, out: np.ndarray | None = None) -> np.ndarray:
        model = self.model
        out = np.empty(self.n) if out is None else out
        return self._rates(x, t, model.parameter_array, model.input_values(t), out)

    def complete_at(self, xs: np.ndarray, times: np.ndarray) -> np.ndarray:
        """:meth:`complete` of many states at once: ``xs`` (N, n), ``times`` (N,) → a copy (N, n) with
        the dependent entries of each row set from its independent ones."""
        out = np.array(xs, dtype=float)
        if not len(self.dependent):
            return out
        values = self._vectorized("phi", out, times, len(self.dependent))
        if values is None:
            for j, t in enumerate(times):
                self.complete(out[j], float(t))
        else:
            out[:, self.dependent] = values
        return out

    def _vectorized(self, name: str, xs: np.ndarray, times: np.ndarray, size: int) -> np.ndarray | None:
        """Generated function ``name`` on N rows at once (N, size), or None where its code does not take
        arrays (it branches on values)."""
        model, times = self.model, np.asarray(times, dtype=float)
        out = np.empty((size, len(times)))
        with np.errstate(all="ignore"):
            try:
                self.on_numpy(name)(np.asarray(xs, dtype=float).T, times, model.parameter_array,
                                    model.input_signals.columns(times), out)
            except (ArithmeticError, ValueError, TypeError, IndexError):
                return None
        return out.T.copy()

    def rates_at(self, xs: np.ndarray, times: np.ndarray) -> np.ndarray:
        """``f(x_j, t_j)`` of many states at once [states' units per s]: ``xs`` (N, n), ``times`` (N,) →
        (N, n); one call of the generated function on numpy arrays where it takes them, else row by row
        (a function whose code branches on values).  NaN where the flow cannot be evaluated."""
        found = self._vectorized("rates", xs, times, self.n)
        if found is not None:
            return found
        rows = np.full((len(times), self.n), np.nan)
        with np.errstate(all="ignore"):
            for j, t in enumerate(times):
                try:
                    rows[j] = self.rates(np.array(xs[j], dtype=float), float(t))
                except (ArithmeticError, ValueError):
                    pass
        return rows

    def jump(self, x: np.ndarray, t: float) -> np.ndarray:
        """``x⁺ = g(x)`` (restitution included), exactly as the jump map gives it."""
        x = np.asarray(x, dtype=float)
        if self.jump_kind == "identity":
            return x.copy()
        if self.jump_kind == "symbolic":
            return self._jump(x, t, self.model.parameter_array, self.model.input_values(t), np.empty(self.n))
        return np.asarray(self.model.mode_equations(self.mode).numeric_jump(x, t), dtype=float)

    def pulse(self, x: np.ndarray, x_plus: np.ndarray, motion: np.ndarray | None = None) -> np.ndarray:
        """The jump ``x⁺ − x`` with round-off removed: components within
        ``jump_rtol·(largest moved state) + jump_atol`` (and within ``motion``,
        :meth:`motion` of the mode that flowed into the instant) are no jump and
        carry no Dirac pulse (the state itself still takes the exact ``x⁺``): the
        rule :func:`switching.rules.jumps.jump_pulse`."""
        x = np.asarray(x, dtype=float)
        x_plus = np.asarray(x_plus, dtype=float)
        n, moved = x.shape[0], self.moved
        tol = self.model.tolerance
        motion = np.zeros(n) if motion is None else motion
        if 0 < len(moved) < n:
            elsewhere = x_plus != x  # (NaN differs from itself: the rule on all states then)
            elsewhere[moved] = False
            if not elsewhere.any():  # (a scene's jump moves a few of its thousands of states)
                # the rule on the moved states alone: the others' pulse is 0 exactly, as the rule would make it
                moved_pulse = np.empty(len(moved))
                jump_pulse(x[moved], x_plus[moved], np.arange(len(moved)), len(moved), tol.jump_rtol,
                           tol.jump_atol, motion[moved], moved_pulse)
                delta = np.zeros(n)
                delta[moved] = moved_pulse
                return delta
        delta = np.empty(n)
        jump_pulse(x, x_plus, moved, len(moved), tol.jump_rtol, tol.jump_atol, motion, delta)
        return delta

    def motion(self, x: np.ndarray, t: float) -> np.ndarray:
        """``MOTION_ULPS·ulp(t)·|ẋ_i|`` of this mode's independent states at ``(x, t)`` (0 for the others
        and where a rate is not finite): how far each moves within the round-off of an instant's time
        (:mod:`switching.rules.jumps`)."""
        motion = np.zeros(self.n)
        if len(self.independent):
            with np.errstate(all="ignore"):
                rates = np.abs(self.rates(np.asarray(x, dtype=float), t)[self.independent])
            motion[self.independent] = np.where(np.isfinite(rates), MOTION_ULPS * np.spacing(abs(t)) * rates, 0.0)
        return motion

    def sides(self, x, t) -> np.ndarray:
        """The comparison triples at ``x`` (a round-off scale may be ``inf``
        where a derivative is, e.g. ``acos`` at ±1: the band then falls back
        to the sides' own size, :func:`codegen.runtime.decide`)."""
        model = self.model
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            try:
                return self._sides(x, t, model.parameter_array, model.input_values(t), np.empty(self.n_sides))
            except ArithmeticError:
                return self.on_numpy("sides")(np.asarray(x, dtype=float), np.float64(t), model.parameter_array,
                                              model.input_values(t), np.empty(self.n_sides))

    def sides_impulsive(self, x, x_plus, t, pulses: bool = True, motion: np.ndarray | None = None) -> list:
        """Comparison triples a posteriori: the sides on ``x_plus`` with the
        pulses of ``x → x_plus`` (none with ``pulses=False``: a jump that
        abstracts a continuous approach); as round-off scale the larger of
        the scales on ``x`` and on ``x_plus`` (the jump's own round-off is of
        the size of the terms it started from); ``motion`` as for :meth:`pulse`."""
        model = self.model
        finite = self.rates(x_plus, t)
        delta = self.pulse(x, x_plus, motion) if pulses else np.zeros(self.n)
        xdot = [Hyper(delta[k], finite[k]) for k in range(self.n)]
        raw = self._sides_raw(x_plus, t, model.parameter_array, model.input_values(t), xdot)
        before, after = self.sides(x, t), self.sides(x_plus, t)
        triples = []
        for k in range(self.n_relations):
            scale = decision.larger(before[3 * k + 2], after[3 * k + 2])
            triples += [raw[2 * k], raw[2 * k + 1], scale]
        return triples

    @property
    def a_posteriori(self) -> np.ndarray:
        """Which guards are decided a posteriori (on the state after the jump), as a mask of the guards."""
        if self._a_posteriori is None:
            self._a_posteriori = np.array([g["when"] == A_POSTERIORI for g in self.guards], dtype=bool)
        return self._a_posteriori

    def maybe_holding(self, sides, rtol, atol) -> np.ndarray | None:
        """Which guards may hold on the comparison triples ``sides`` (an array of floats, :meth:`sides`): a
        mask that is ``False`` only where :func:`decide_tree` decides ``False`` — a guard that is one
        comparison or a conjunction of comparisons one of which fails — computed for all of them at once,
        with the arithmetic of :func:`codegen.runtime.decide` on arrays (:func:`codegen.decision.band`,
        :func:`codegen.decision.finite_holds`: the same IEEE operations, so the same decisions).  A scene
        decides a thousand guards at each pinnacle, of which a few hold; ``None`` where ``sides`` is no
        array of floats (Hyper values: a posteriori sides)."""
        if not isinstance(sides, np.ndarray) or sides.dtype != np.float64:
            return None
        if self._conjunctions is None:
            self._conjunctions = self._conjunction_arrays()
        start, ops, owners = self._conjunctions
        maybe = np.ones(len(self.guards), dtype=bool)
        if not len(start):
            return maybe
        lf, rf, sc = sides[start], sides[start + 1], sides[start + 2]
        with np.errstate(all="ignore"):
            left, right = np.abs(lf), np.abs(rf)
            scale = np.where(right > left, right, left)
            scale = np.where(np.isfinite(sc) & (sc > scale), sc, scale)
            width = np.where(np.isfinite(np.where(right > left, right, left)), rtol * scale + atol, 0.0)
            diff = lf - rf
            size = np.abs(diff)
            holds = np.select([ops == 0, ops == 1, ops == 2, ops == 3, ops == 4],
                              [diff < -width, diff <= width, diff > width, diff >= -width, size <= width],
                              size > width)
        maybe[owners[~holds]] = False
        return maybe

    def _conjunction_arrays(self) -> tuple:
        """``(3k, operators, guards)`` of every comparison ``k`` of the guards that are conjunctions
        (:meth:`maybe_holding`): a scene's made a guard table at a time (:mod:`.guard_tables`), each
        table's kept by the library for the modes that hold it at the same offset."""
        library = self.model.library
        if "guard_blocks" not in self.meta:
            return _conjunctions_of(library, self.guards)
        pieces, first = [], 0
        kept = library.table_conjunctions
        for (name, offset), size in zip(self.meta["guard_blocks"], self._table_sizes):
            found = kept.get((name, offset))
            if found is None:
                if len(kept) >= GUARD_ENTRIES_KEPT:
                    kept.clear()
                found = kept[(name, offset)] = _conjunctions_of(library, self.guards[first:first + size])
            pieces.append((found[0], found[1], found[2] + first))
            first += size
        return tuple(np.concatenate([piece[j] for piece in pieces]) if pieces else np.zeros(0, dtype=np.intp)
                     for j in range(3))

    def holds(self, x, t, rtol, atol) -> bool:
        """Does any guard hold during flow at ``x`` (no jump)?"""
        if not self.guards:
            return False
        sides = self.sides(x, t)
        maybe = self.maybe_holding(sides, rtol, atol)
        if maybe is None:
            return any(decide_tree(g["tree"], sides, rtol, atol) for g in self.guards)
        return any(decide_tree(self.guards[g]["tree"], sides, rtol, atol) for g in np.flatnonzero(maybe))


def _conjunctions_of(library, guards) -> tuple:
    """``(3k, operators, guard numbers)`` of the comparisons of ``guards`` that are conjunctions
    (:meth:`CompiledMode.maybe_holding`)."""
    comparisons, ops, owners = [], [], []
    kept = library.conjunctions  # (a guard's entry is shared by a scene's modes)
    for g, guard in enumerate(guards):
        found = _found_by_id(kept, guard)
        if found is None:
            found = _keep_by_id(kept, guard, _conjunction(guard["tree"]))
        if found[0]:
            comparisons += found[0]
            ops += found[1]
            owners += [g] * len(found[0])
    return 3 * np.array(comparisons, dtype=np.intp), np.array(ops, dtype=np.intp), np.array(owners, dtype=np.intp)


def _count_rel(tree) -> int:
    kind = tree[0]
    if kind == "rel":
        return 1
    if kind in ("and", "or"):
        return sum(_count_rel(t) for t in tree[1])
    if kind == "not":
        return _count_rel(tree[1])
    return 0


FLIPPED = {">=": "<", ">": "<=", "<=": ">", "<": ">=", "==": "!=", "!=": "=="}
# one-sided parts of an (effective) comparison: (sign, inclusive); the part holds when
# sign·(left − right) + (band if inclusive else −band) is ≥ 0 (inclusive) or > 0 (strict)
PARTS = {">=": ((1, True),), ">": ((1, False),), "<=": ((-1, True),), "<": ((-1, False),),
          "==": ((1, True), (-1, True)), "!=": ((0, False),)}


def guard_parts(trees) -> tuple[list, list, list, dict]:
    """The guards' one-sided *parts* for event detection (the Python scan's :class:`switching.simulate.events.GuardScan`, the kernel's tables).

    Returns ``parts`` — ``(relation, sign, inclusive, guard)`` for every part,
    a comparison under ``not`` counting reversed — each guard as an expression
    of its parts' truths ``q[i]`` and as one of its comparisons' truths
    ``r<k>``, and the operator of each comparison ``k``."""
    parts, of_parts, of_relations, ops = [], [], [], {}

    def walk(tree, positive, g):
        kind = tree[0]
        if kind in ("and", "or"):
            pairs = [walk(sub, positive, g) for sub in tree[1]]
            return tuple("(" + f" {kind} ".join(p[j] for p in pairs) + ")" for j in (0, 1))
        if kind == "not":
            q, r = walk(tree[1], not positive, g)
            return f"(not {q})", f"(not {r})"
        if kind == "const":
            return repr(bool(tree[1])), repr(bool(tree[1]))
        _, k, op, _text = tree
        ops[k] = op
        first = len(parts)
        for sign, inclusive in PARTS[op if positive else FLIPPED[op]]:
            parts.append((k, sign, inclusive, g))
        mine = " and ".join(f"q[{i}]" for i in range(first, len(parts)))
        return (f"({mine})" if positive else f"(not ({mine}))"), f"r{k}"

    for g, tree in enumerate(trees):
        q, r = walk(tree, True, g)
        of_parts.append(q)
        of_relations.append(r)
    return parts, of_parts, of_relations, ops
