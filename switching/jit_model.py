"""One numba module for a model and a set of its modes (the ``*-jit`` methods).

:class:`CompiledModel` generates one numba module for a set of modes.  Each
mode (numbered ``i`` in label order) is a branch, selected by ``m == i``, of
the dispatchers the kernel of :mod:`codegen.jit` calls; the branches hold the
code generated from the mode's symbolic f, g, h and guards (common
subexpressions eliminated):

``_fy(m, y, t, p, u, out)``    ``dy/dt`` of the independent states ``y = x_i`` (dependent
                               states ``x_d = φ(x_i, t)`` substituted)
``_phi(m, x, t, p, u, out)``   the dependent states ``x_d = φ(x_i, t)``
``_holds(m, y, t, p, u, s, …)``  does a guard hold during flow (finite sides on ``y``)?
``_jump(m, x, t, p, u, out)``  ``x⁺ = g(x)`` with restitution (False: numerical jump map)
``_fire(m, x, xp, t, p, u, d, s, post, …, target, quiet)``  the first holding transition of
                               each automaton at an instant: a priori sides on ``x``, a
                               posteriori ones on ``x⁺ = xp`` with the impulse areas
                               ``Σ_k ∂side/∂ẋ_k · d_k`` of the pulse ``d = x⁺ − x``
                               (sides affine in ``ẋ``; otherwise False when pulsed);
                               ``quiet`` (no pulse): every guard on the flow's own sides
                               at ``x``, as ``_holds`` decides them; False when a
                               transition marked ``pulses=False`` fires (Python resolves)
``_gparts(m, g, q)``           guard ``g`` as a boolean function of its parts' truths ``q``
                               (event detection inside a step, as
                               :class:`switching.events._GuardForm`)

The tables of the guards' one-sided *parts* (as ``_GuardForm.parts``: the
comparison, the sign, inclusive, and the guard of each part, with the numbers
of parts and guards per mode) go with the state-index tables
(:func:`model_tables`: rows 3–6 of ``TABLES``, 3–4 of ``LENGTHS``), which the
generated module holds as constants.

One module with branches rather than a function per mode, so its compile
time hardly grows with the number of modes: about 20–30 s on first use for a
set of modes (the kernel dominates), then about 0.1 s to load in any later
process (numba's disk cache; numba's own set-up on its first use in a
process, about 0.6 s, comes on top for any compiled function).  Each call
passes scalars and reuses its output buffers and workspaces, so a call costs
a few µs besides the integration itself.  Modes are
identified in compiled code by a mixed-radix code of their automaton states,
``code = Σ_a state_a · radix_a``, so the kernel finds the mode a transition
leads to without Python; a mode outside the set sends the instant back to
Python (:func:`switching.resolution.resolve_instant`).

The source is cached like the per-mode sources (key: the model's fingerprint
and the mode labels), so a second process neither derives nor regenerates
anything, and numba's disk cache spares it the compilation.  The module
``jit/hbg_model_<key>.py`` and numba's files of it belong to the same cache
entry as the source ``<key>.py``: the size cap of :mod:`codegen.cache` evicts
them together.  Unreadable numba files are deleted and compiled again, and an
unwritable cache directory sends the module to a private temporary directory
(both with a :class:`codegen.cache.CacheWarning`; :func:`codegen.jit.load_module`).
"""

from __future__ import annotations

import re

import numpy as np
import sympy as sp

from bondgraph.errors import HybridBondGraphError
from codegen.cache import fingerprint
from codegen.jit import (
    COMPARE_SOURCE,
    DISPATCH,
    KERNEL_SOURCE,
    load_module,
    module_header,
    tree_expression,
)
from codegen.source import Argument, FunctionSpec, function_source

from .automaton import A_POSTERIORI
from .compiled import _tree, comparison_triples
from .resolution import Instant, resolve_instant
from .events import guard_parts  # the guards' one-sided parts, as the Python scan

__all__ = ["KINDS", "CompiledInstant", "CompiledModel", "KernelResult"]

KINDS = {"euler-jit": 0, "rk4-jit": 1, "RK45-jit": 2}
_MAX_CODE = 2**62
GENERATOR_VERSION = "13"  # part of the cache key: change it when the generated functions change




def _mode_functions(model, me, i: int) -> tuple[dict, int]:
    """Mode ``i``'s branch (source lines) in each dispatcher, and its number
    of comparison sides."""
    states = list(model.states)
    rate_symbols = [me.equations.rate_symbols[s] for s in states]
    pulses = tuple(sp.Symbol(f"pulse_{k}") for k in range(len(states)))
    base = (
        Argument("x", tuple(states), doc="state vector"),
        Argument("t", (model.time,), scalar=True, doc="time [s]"),
        Argument("p", tuple(model.parameter_symbols), doc="parameters"),
        Argument("u", tuple(model.input_symbols), doc="inputs"),
    )
    label = me.mode.describe()
    dependent = [s for s in states if s in me.equations.dependent]

    relations: list = []
    trees = [(guard, _tree(guard.condition, relations)) for guard in me.guards]
    finite, impulses = comparison_triples(me, relations), []  # (left, right, round-off scale) per comparison
    affine = True
    for rel in relations:
        for raw in (rel.lhs, rel.rhs):
            area = sp.Integer(0)
            for rate, pulse in zip(rate_symbols, pulses):
                if raw.has(rate):
                    coefficient = sp.diff(raw, rate)
                    if any(coefficient.has(r) for r in rate_symbols):
                        affine = False
                    area += coefficient * pulse
            impulses.append(me.finite(area) if affine else sp.Integer(0))
    n_sides = len(finite)

    # the flow and its guard test on the independent states alone (x_d = φ(x_i, t) substituted)
    independent = [s for s in states if s not in me.equations.dependent]
    phi = me.equations.constraints

    def flow_form(expr):
        return sp.sympify(expr).xreplace(phi) if phi else expr

    def body(name, arguments, outputs, out="out"):
        """The statements of a generated function (no def, docstring or return), writing ``out``."""
        lines = function_source(FunctionSpec(name, arguments, tuple(outputs))).splitlines()
        end = next(k for k in range(1, len(lines)) if lines[k].rstrip().endswith('"""') and
                   (k > 1 or lines[k].count('"""') == 2))
        statements = [line[4:] for line in lines[end + 1:] if line.strip() != "return out"]
        return [re.sub(r"\bout\[", f"{out}[", line) for line in statements]

    y_args = (Argument("y", tuple(independent)),) + base[1:]
    xp_args = (Argument("xp", tuple(states)),) + base[1:] + (Argument("d", pulses),)
    branches = {
        "_fy": [f"# mode {label}: dy/dt of the independent states"]
        + body("fy", y_args, [flow_form(me.f[s]) for s in independent]) + ["return"],
        "_phi": [f"# mode {label}: dependent states"]
        + body("phi", base, [phi[s] for s in dependent]) + ["return"],
    }
    holds = [f"# mode {label}: does a guard hold during flow (sides on y)"]
    holds += body("sy", y_args, [flow_form(side) for side in finite], "s")
    holds.append("return " + (" or ".join(tree_expression(tree, "s") for _, tree in trees) or "False"))
    branches["_holds"] = holds

    automaton_index = {a.name: k for k, a in enumerate(model.automata)}
    state_index = {a.name: {s: j for j, s in enumerate(a.states)} for a in model.automata}

    def take(guard, test):
        """Set the automaton's target when ``test`` holds (a transition without pulses: Python resolves)."""
        a = automaton_index[guard.automaton]
        if guard.transition.pulses:
            return [f"if target[{a}] < 0 and {test}:", f"    target[{a}] = {state_index[guard.automaton][guard.transition.target]}"]
        return [f"if target[{a}] < 0 and {test}:", "    return False"]

    fire = [f"# mode {label}: the first holding transition of each automaton at an instant"]
    if trees:  # quiet (no pulse): every guard on the flow's own sides, so a located crossing holds here too
        fire += ["if quiet:"]
        quiet = body("sq", base, [flow_form(side) for side in finite], "s")
        for guard, tree in trees:
            quiet += take(guard, tree_expression(tree, "s"))
        fire += ["    " + line for line in quiet + ["return True"]]
    prior = any(guard.transition.when != A_POSTERIORI for guard, _ in trees)
    posterior = any(guard.transition.when == A_POSTERIORI for guard, _ in trees)
    if (prior or posterior) and n_sides:  # a posteriori guards take the larger round-off scale of x and x⁺
        fire += body("sides", base, finite, "s")
    if posterior:
        if not affine:  # a pulse in a side that is not affine in ẋ: Python decides (or reports it)
            fire += ["for k in range(d.shape[0]):", "    if d[k] != 0.0:", "        return False"]
        fire += body("post", xp_args, finite + impulses, "post")
    for guard, tree in trees:
        test = (tree_expression(tree, "post", "post", n_sides, "s") if guard.transition.when == A_POSTERIORI
                else tree_expression(tree, "s"))
        fire += take(guard, test)
    branches["_fire"] = fire + ["return True"]

    g = me.g
    jump_kind = "identity" if me.jump.is_identity else ("symbolic" if g is not None else "numeric")
    jump = [f"# mode {label}: x⁺ = g(x) ({jump_kind})"]
    if jump_kind == "identity":
        jump += ["for k in range(x.shape[0]):", "    out[k] = x[k]", "return True"]
    elif jump_kind == "symbolic":
        jump += body("jump", base, [g[s] for s in states]) + ["return True"]
    else:
        jump += ["return False"]
    branches["_jump"] = jump

    _, expressions, _, _ = guard_parts([tree for _, tree in trees])
    gparts = [f"# mode {label}: each guard from its parts' truths"]
    for g, expression in enumerate(expressions):
        gparts += [f"if g == {g}:", f"    return {expression}"]
    branches["_gparts"] = gparts + ["return False"]
    return branches, n_sides


_SIGNATURES = {
    "_fy": "y, t, p, u, out",
    "_phi": "x, t, p, u, out",
    "_holds": "y, t, p, u, s, rtol, atol",
    "_jump": "x, t, p, u, out",
    "_fire": "x, xp, t, p, u, d, s, post, rtol, atol, target, quiet",
    "_gparts": "g, q",
}
_DEFAULTS = {"_fy": "return", "_phi": "return", "_holds": "return False", "_jump": "return False",
             "_fire": "return False", "_gparts": "return False"}


def _dispatcher(name: str, bodies: list[list[str]]) -> str:
    """One compiled function over all modes: a branch per mode number ``m``."""
    lines = [DISPATCH, f"def {name}(m, {_SIGNATURES[name]}):"]
    for i, body in enumerate(bodies):
        lines.append(f"    {'if' if i == 0 else 'elif'} m == {i}:")
        lines += ["        " + line for line in body]
    lines.append(f"    {_DEFAULTS[name]}")
    return "\n".join(lines) + "\n"


def model_tables(model, modes: list) -> dict:
    """The integer tables of a compiled module for ``modes`` (numbered in list
    order): ``TABLES[7, modes, w]`` — rows 0–2 the independent, dependent and
    jump-moved state indices, rows 3–6 the guards' one-sided parts (relation,
    sign, inclusive, guard); ``LENGTHS[5, modes]`` — the counts of those
    three index rows, of parts and of guards; ``MSTATES[modes, automata]`` —
    the automaton state numbers; ``RADIX[automata]`` — the mixed radix of the
    mode codes; ``CODES[3, modes]`` — the sorted mode codes, their mode
    numbers, each mode's code (all −1 when the codes would overflow: every
    instant then goes to Python)."""
    n, count = len(model.states), len(modes)
    compiled = [model.compiled_mode(m) for m in modes]
    parts = [guard_parts([g["tree"] for g in cm.guards])[0] for cm in compiled]
    width = max([n, 1] + [len(p) for p in parts])
    tables = np.zeros((7, count, width), dtype=np.int64)
    lengths = np.zeros((5, count), dtype=np.int64)
    for i, cm in enumerate(compiled):
        for row, indices in enumerate((cm.independent, cm.dependent, cm.moved)):
            tables[row, i, : len(indices)] = indices
            lengths[row, i] = len(indices)
        for j, part in enumerate(parts[i]):
            tables[3:7, i, j] = part
        lengths[3, i] = len(parts[i])
        lengths[4, i] = len(cm.guards)
    sizes = [len(a.states) for a in model.automata]
    radix = np.ones(len(sizes), dtype=np.int64)
    total = 1
    for a, size in enumerate(sizes):
        radix[a] = total
        total *= size
    index = [{s: j for j, s in enumerate(a.states)} for a in model.automata]
    mstates = np.array([[index[a][s] for a, s in enumerate(m.states)] for m in modes],
                       dtype=np.int64).reshape(count, len(sizes))
    codes = np.full((3, count), -1, dtype=np.int64)
    if total < _MAX_CODE:
        mode_codes = mstates @ radix
        order = np.argsort(mode_codes, kind="stable")
        codes[0] = mode_codes[order]
        codes[1] = order
        codes[2] = mode_codes
    return {"TABLES": tables, "LENGTHS": lengths, "MSTATES": mstates, "RADIX": radix, "CODES": codes}


def _constant(name: str, array: np.ndarray) -> str:
    """A module-level integer array (numba freezes it into the machine code)."""
    return f"{name} = np.array({array.ravel().tolist()!r}, dtype=np.int64).reshape({array.shape!r})\n"


def generate_model_source(model, modes: list) -> str:
    """The whole compiled module for ``modes`` (numbered in list order)."""
    per_mode, n_sides = [], 0
    for i, mode in enumerate(modes):
        branches, count = _mode_functions(model, model.mode_equations(mode), i)
        per_mode.append(branches)
        n_sides = max(n_sides, count)
    dispatch = [_dispatcher(name, [branches[name] for branches in per_mode]) for name in _SIGNATURES]
    title = f"Compiled hybrid run of model {model.name!r}, modes {', '.join(repr(m.label) for m in modes)}"
    constants = "".join(_constant(name, array) for name, array in model_tables(model, modes).items())
    return (module_header(title) + f"N_SIDES = {n_sides}\n" + constants + "\n" + COMPARE_SOURCE + "\n\n"
            + "\n\n".join(dispatch) + "\n\n" + KERNEL_SOURCE)


class CompiledModel:
    """The compiled module of ``model`` for a set of modes, and a call of its
    kernel (:meth:`run`).  Buffers and workspaces are allocated once and
    reused by every call, so one model is not to be simulated from two
    threads at once (``simulate_many`` runs its workers as processes)."""

    def __init__(self, model, modes):
        self.model = model
        self.modes = sorted(set(modes), key=lambda m: m.label)
        self.ids = {mode: i for i, mode in enumerate(self.modes)}
        labels = [m.label for m in self.modes]
        key = fingerprint(model.fingerprint, "compiled model", GENERATOR_VERSION, COMPARE_SOURCE, KERNEL_SOURCE,
                          *labels)
        source = model.cache.load(key)
        if source is None:
            source = generate_model_source(model, self.modes)
            model.cache.store(key, source)
        directory = model.cache.directory / "jit" if model.cache.directory else None
        self.module = load_module(f"hbg_model_{key}", source, directory)
        self.n = len(model.states)
        self._buffers = {}
        self._workspaces = {}
        self._inputs = np.zeros(0)

    def covers(self, mode) -> bool:
        return mode in self.ids

    def buffers(self, save: bool, capacity: int = 4096, event_capacity: int = 256) -> tuple:
        """Output arrays (reused by every call with the same ``save``):
        ``out_t, out_x, out_m, ev_f, ev_i, info`` (see the kernel's ``run``)."""
        if save not in self._buffers:
            n = self.n
            size = capacity if save else 1
            self._buffers[save] = (np.empty(size), np.empty((size, n)), np.empty(size, dtype=np.int64),
                                   np.empty((event_capacity, 1 + 2 * n)), np.empty((event_capacity, 3), np.int64),
                                   np.zeros(5 + n))
        return self._buffers[save]

    def workspace(self, samples: int, max_instant: int) -> tuple:
        """The kernel's float, integer and boolean workspaces for ``samples``
        guard samples per step and a cap of ``max_instant`` steps per instant."""
        key = (samples, max_instant)
        if key not in self._workspaces:
            floats, ints, bools = self.module.workspace_sizes(self.n, samples, max_instant)
            self._workspaces[key] = (np.empty(floats), np.empty(ints, dtype=np.int64), np.empty(bools, np.bool_))
        return self._workspaces[key]

    def run(self, kind, mode, x, t, t_end, *, dt, rtol, atol, max_step, first_step, samples, save,
            max_steps=10**9, resolve_first=False) -> KernelResult:
        """One kernel call from ``(t, mode, x)`` (``resolve_first``: ``x`` is
        the a priori state of an instant at ``t``, resolved before the flow).
        The result's arrays are views of reused buffers: valid until the next call."""
        model = self.model
        tol = model.tolerance
        max_instant = int(model.max_steps_per_instant)
        save = bool(save)
        buffers = self._buffers.get(save) or self.buffers(save)
        wf, wi, wb = self._workspaces.get((samples, max_instant)) or self.workspace(samples, max_instant)
        out_t, out_x, out_m, ev_f, ev_i, info = buffers
        # scalars of fixed types: numba compiles the kernel anew for every new combination of argument types
        status, n_saved, n_ev, t_stop, m_stop, steps = self.module.run(
            kind, self.ids[mode], int(samples), max_instant, bool(save), int(max_steps), bool(resolve_first),
            float(t), float(t_end), float(dt or 0.0), float(rtol), float(atol), float(max_step),
            float(first_step or 0.0), float(tol.rtol), float(tol.atol), float(tol.jump_rtol), float(tol.jump_atol),
            np.asarray(x, dtype=float), model.parameter_array, self._inputs, out_t, out_x, out_m, ev_f, ev_i, info, wf, wi, wb)
        if status == 7:
            raise RuntimeError(f"compiled model {self.model.name!r}: the kernel's workspace is too small (a bug)")
        return KernelResult(self, status, t_stop, m_stop, steps, n_saved, n_ev, buffers)


class KernelResult:
    """What one kernel call produced: ``n_saved`` samples, ``n_events``
    events (in order, each with the number of samples saved before it), and
    where it stopped (``status``: see :data:`codegen.jit.STATUS`)."""

    def __init__(self, compiled, status, t, mode, steps, n_saved, n_events, buffers):
        self.compiled = compiled
        self.status, self.t, self.steps = status, t, steps
        self.n_saved, self.n_events = n_saved, n_events
        self.mode = compiled.modes[mode]
        self._out_t, self._out_x, self._out_m, self._ev_f, self._ev_i, self.info = buffers

    @property
    def x(self) -> np.ndarray:
        """The state where the call stopped (a copy)."""
        return self.info[5:].copy()

    def samples(self, start: int, stop: int):
        """(t, x, mode) of saved samples ``start:stop`` (copies)."""
        modes = self.compiled.modes
        for j in range(start, stop):
            yield float(self._out_t[j]), self._out_x[j].copy(), modes[self._out_m[j]]

    def events(self):
        """(samples saved before it, t, mode before, x before, mode after, x after) of each event (copies)."""
        modes = self.compiled.modes
        n = self._out_x.shape[1]
        for j in range(self.n_events):
            row = self._ev_f[j]
            mode_before, mode_after, at = self._ev_i[j]
            yield (int(at), float(row[0]), modes[mode_before], row[1:1 + n].copy(), modes[mode_after],
                   row[1 + n:].copy())


class CompiledInstant(Instant):
    """An instant resolved in compiled code.  Its time, modes and states are
    at hand; the steps through mythical modes and pinnacles (with the fired
    guards) are replayed in Python on first access — the resolution is
    deterministic, so the replay passes the same modes."""

    def __init__(self, model, t, mode_before, x_before, mode_after, x_after):
        self.model = model
        self.t = t
        self._before = (mode_before, x_before)
        self._after = (mode_after, x_after)
        self._steps = None

    @property
    def steps(self) -> list:
        if self._steps is None:
            if self.model is None:
                raise HybridBondGraphError(
                    f"the steps of the instant at t = {self.t!r} (resolved in compiled code) are replayed with the "
                    "model, and this record was unpickled without it; its time, modes and states are at hand")
            mode, x = self._before
            self._steps = resolve_instant(self.model, x, mode, self.t, self.model.max_steps_per_instant).steps
        return self._steps

    @property
    def x_before(self) -> np.ndarray:
        return self._before[1]

    @property
    def x_after(self) -> np.ndarray:
        return self._after[1]

    @property
    def mode_before(self):
        return self._before[0]

    @property
    def mode_after(self):
        return self._after[0]
