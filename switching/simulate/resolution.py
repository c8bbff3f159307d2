"""Mode resolution at an instant (the paper's selMode, Eq. 11, Alg. 1–2; DESIGN §6).

From an a priori state ``x`` in mode α:

1. evaluate the guards of the current candidate mode β on ``(x, x⁺)`` with
   ``x⁺ = g_β(x)`` — always from the a priori ``x`` of the last real mode;
   a priori guards see ``x``, a posteriori guards see ``x⁺`` and the impulses
   of the jump ``x → x⁺``;
2. if some hold, every automaton with a holding guard steps (the first of
   its holding transitions, in the order they were added) and β was
   *mythical*; a mode repeating in one mythical chain is a divergence of time;
3. if none holds, β is real: ``x ← x⁺``.  If a guard now holds on the updated
   ``x`` (with ``x⁺ = x``), β was a *pinnacle* and resolution continues;
   otherwise β is *continuous* and the instant ends.  A repeated
   (mode, x) pair among pinnacles, or more steps than the cap, is an error.

A mythical chain that returns to a mode through transitions that all fired
at a *tie* (each guard holding, but not strictly: an inclusive comparison
within its band, ``v_D >= 0`` at ``v_D = 0``) takes none of them: the instant
rests in the mode where the cycle began (the rule of
:mod:`switching.rules.instants`; the cycle's steps are recorded with kind
``"tie"``), and the flow from there counts a guard only once it holds
strictly (:class:`switching.simulate.events.GuardScan`).

A candidate reached only by transitions marked ``pulses=False`` (a jump that
abstracts a continuous approach) judges its a posteriori guards without the
jump's Dirac pulses.  Where no pulse is involved — the mode the instant began
in when its own jump is round-off, and the check after a real jump — guards
are decided on the finite sides exactly as event detection decides them in
flow, so a located crossing holds, and a mode found continuous flows without
a guard holding at once.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from bondgraph.errors import (AlgebraicLoopError, CausalityConflictError, FloatingPartError, HybridBondGraphError,
                              prefixed)
from codegen.runtime import PulseError

from ..model.automaton import A_POSTERIORI
from ..library.collection import collection_paused
from ..library.compiled import decide_tree, holds_strictly
from ..errors import DivergenceOfTimeError, ImpulseError, TooManyStepsError
from ..model.modes import Mode
from ..rules.instants import (CONTINUOUS, DECIDE_AS_FLOW, FIRED, FIRED_AT_TIE, JUMP_AND_DECIDE, JUMP_AT_TIE, NO_ROOM,
                              PINNACLE_REPEATS, REPEATS_IN_CHAIN, decides_as_in_flow, instant_begin, instant_next)

__all__ = ["Instant", "CompiledInstant", "KernelInstants", "Step", "FiredGuard", "instants_made", "resolve_instant",
           "evaluate_guards"]


@dataclass(frozen=True)
class FiredGuard:
    """A transition whose guard held, with the values of its comparisons;
    ``strict``: it holds however its comparisons at their edge are decided
    (:func:`switching.library.compiled.holds_strictly`), else it fired at a tie."""

    automaton: str
    source: str
    target: str
    guard: str
    when: str
    comparisons: tuple  # codegen.runtime.Comparison: text, left, right, result, band, margin
    pulses: bool = True  # False: the transition's jump abstracts a continuous approach (no Dirac pulses)
    strict: bool = True

    @property
    def near_edge(self) -> list:
        """The comparisons decided within :data:`EDGE_ULPS` units in the last
        place of their band's edge: round-off could have flipped them."""
        return [c for c in self.comparisons if c.edge_ulps <= EDGE_ULPS]

    def __str__(self) -> str:
        values = "; ".join(f"{text}: {left} vs {right} → {result}" for text, left, right, result in self.comparisons)
        return f"{self.automaton}: {self.source} → {self.target} [{self.guard}] ({self.when}; {values})"


@dataclass(frozen=True)
class Step:
    """One mode passed at an instant.

    ``kind``: ``"start"`` (the mode the instant began in, left without a
    jump), ``"mythical"``, ``"pinnacle"``, ``"continuous"``, or ``"tie"``
    (a mode of a cycle of ties: its transitions, fired at a tie, were not
    taken).  ``x_before`` /
    ``x_after``: the state on entering and leaving the mode (equal unless it
    was real and jumped); ``fired``: the guards that made it leave.
    """

    mode: Mode
    kind: str
    x_before: np.ndarray = field(repr=False)
    x_after: np.ndarray = field(repr=False)
    fired: tuple = ()

    @property
    def jumped(self) -> bool:
        return not np.array_equal(self.x_before, self.x_after)

    def __str__(self) -> str:
        text = f"{self.mode.describe()} ({self.kind})"
        if self.fired:
            text += " --" + "; ".join(str(f) for f in self.fired) + "-->"
        return text


@dataclass
class Instant:
    """The record of one instant: every mode passed, with kinds and states."""

    t: float
    steps: list
    model: object = field(repr=False, default=None)

    def __getstate__(self):
        state = dict(self.__dict__)
        state["model"] = None  # pickled without the model (generated functions do not pickle)
        return state

    @property
    def x_before(self) -> np.ndarray:
        return self.steps[0].x_before

    @property
    def x_after(self) -> np.ndarray:
        return self.steps[-1].x_after

    @property
    def mode_before(self) -> Mode:
        return self.steps[0].mode

    @property
    def mode_after(self) -> Mode:
        return self.steps[-1].mode

    @property
    def modes(self) -> list:
        return [s.mode for s in self.steps]

    @property
    def kinds(self) -> list:
        return [s.kind for s in self.steps]

    @property
    def mythical(self) -> list:
        return [s.mode for s in self.steps if s.kind == "mythical"]

    @property
    def pinnacles(self) -> list:
        return [s.mode for s in self.steps if s.kind == "pinnacle"]

    @property
    def real_steps(self) -> list:
        return [s for s in self.steps if s.kind in ("pinnacle", "continuous") and s.jumped]

    def impulse(self, signal: str) -> float:
        """Total impulse area of a named signal over the instant's jumps:
        ``Σ a_β(x)ᵀ(x⁺ − x)`` over the real steps (``a = ∂s/∂ẋ`` in the mode jumped into)."""
        total = 0.0
        for step in self.real_steps:
            total += impulse_area(self.model, step.mode, signal, step.x_before, step.x_after, self.t)
        return total

    def __str__(self) -> str:
        lines = [f"instant at t = {self.t:.12g}:"]
        for step in self.steps:
            lines.append(f"  {step.mode.describe()}  [{step.kind}]")
            for fired in step.fired:
                lines.append(f"      fired {fired}")
            if step.jumped:
                changes = ", ".join(
                    f"{s}: {a:.6g} → {b:.6g}"
                    for s, a, b in zip(self.model.states, step.x_before, step.x_after)
                    if a != b
                )
                lines.append(f"      jump {changes}")
        return "\n".join(lines)


# ------------------------------------------------------------------ guards


def evaluate_guards(model, cm, x: np.ndarray, x_plus: np.ndarray, t: float, as_in_flow: bool = False,
                    pulses: bool = True, strict: bool = False, motion: np.ndarray | None = None) -> list:
    """The first holding transition of each automaton in compiled mode ``cm``.

    A priori guards are decided on ``x``; a posteriori guards on ``x_plus``
    with the impulses of the jump ``x → x_plus``.  ``as_in_flow``: every
    guard on the finite sides at ``x``, exactly as event detection tests
    them during flow (for an instant whose jump carries no pulse, so that a
    located event is seen to hold by the same arithmetic that located it).
    ``pulses=False``: a posteriori guards see the finite values only (the
    mode was entered by transitions whose jump abstracts a continuous
    approach, :meth:`Automaton.add_transition`).  ``strict``: only guards
    that hold strictly count (the first of each automaton's).  ``motion``: the
    states' motion within the round-off of ``t`` (:meth:`CompiledMode.motion`), no jump."""
    fired = []
    done = set()
    prior = post = None
    rtol, atol = model.tolerance.rtol, model.tolerance.atol
    maybe = None  # the guards that may hold on the sides at x, all decided at once (CompiledMode.maybe_holding)
    if as_in_flow:
        prior = post = cm.sides(x, t)
        maybe = cm.maybe_holding(prior, rtol, atol)
    guards, following, order = cm.guards, 0, None
    while True:
        if order is None and maybe is not None:  # (from here on only the guards that may hold)
            order = iter(_still_to_decide(cm, maybe, following, as_in_flow))
        if order is None:
            if following == len(guards):
                break
            index, following = following, following + 1
        else:
            index = next(order, None)
            if index is None:
                break
        guard = guards[index]
        if guard["automaton"] in done:
            continue
        if maybe is not None and not maybe[index] and (as_in_flow or guard["when"] != A_POSTERIORI):
            continue  # (fails on the sides at x: decided so by the same arithmetic)
        if guard["when"] == A_POSTERIORI:
            if post is None:
                try:
                    post = cm.sides_impulsive(x, x_plus, t, pulses, motion)
                except PulseError as exc:
                    raise ImpulseError(
                        f"a guard of mode {cm.mode.describe()} at t = {t:.12g} combines pulses wrongly: {exc}"
                    ) from None
            sides = post
        else:
            if prior is None:
                prior = cm.sides(x, t)
                maybe = cm.maybe_holding(prior, rtol, atol)
                if maybe is not None and not maybe[index]:
                    continue
            sides = prior
        if decide_tree(guard["tree"], sides, rtol, atol):
            firm = holds_strictly(guard["tree"], sides, rtol, atol)
            if strict and not firm:
                continue
            comparisons: list = []  # the figures of a guard that fired, for the record (decided alike again)
            decide_tree(guard["tree"], sides, rtol, atol, comparisons)
            done.add(guard["automaton"])
            fired.append(
                FiredGuard(guard["automaton"], guard["source"], guard["target"], guard["text"], guard["when"],
                           tuple(comparisons), guard.get("pulses", True), firm)
            )
    return fired


def _still_to_decide(cm, maybe: np.ndarray, start: int, as_in_flow: bool) -> list:
    """The numbers from ``start`` on of the guards of ``cm`` that may hold on the sides at ``x`` (``maybe``),
    or are decided on other sides (a posteriori, unless ``as_in_flow``), in turn: a scene's thousand
    guards, of which a few may hold, are passed over in one step, not each looked at in Python."""
    wanted = maybe[start:] if as_in_flow else maybe[start:] | cm.a_posteriori[start:]
    return (np.flatnonzero(wanted) + start).tolist()


def impulse_area(model, mode: Mode, signal: str, x: np.ndarray, x_plus: np.ndarray, t: float) -> float:
    """``a(x)ᵀ(x⁺ − x)`` of ``signal`` in ``mode`` (``a = ∂s/∂ẋ``)."""
    from codegen import vector_function

    me = model.mode_equations(mode)
    form = me.signal(signal)
    if not form.impulse:
        return 0.0
    states = list(form.impulse)
    coefficients = vector_function([form.impulse[s] for s in states], model.states, model.time,
                                   model.parameter_symbols, model.input_symbols)
    a = coefficients(x, t, model.parameter_array, model.input_values(t))
    idx = [model.state_index[s] for s in states]
    return float(np.dot(a, (x_plus - x)[idx]))


# ------------------------------------------------------------------ resolution


def _next_mode(model, mode: Mode, fired: list) -> Mode:
    states = list(mode.states)
    names = list(mode.automata)
    for f in fired:
        states[names.index(f.automaton)] = f.target
    return model.mode_space.known_mode(tuple(states))


#: a comparison decided within this many units in the last place of its band's edge is
#: reported as possibly decided by round-off (divergence-of-time messages)
EDGE_ULPS = 64
#: near-edge comparisons listed in a divergence-of-time message
SHOWN_NEAR = 1
#: steps shown at the start and at the end of a long loop in an error message
SHOWN_FIRST, SHOWN_LAST = 3, 3
#: states listed by name and value when a pinnacle repeats a state
SHOWN_STATES = 16

_ADVICE = (
    "Make the guards leave only one mode consistent with each state (e.g. add a threshold such as "
    "a separating-velocity condition or a holding current below the actual one), or model the "
    "fast dynamics continuously."
)


def _step_lines(numbered) -> list:
    """Lines for ``(number, step)`` pairs: all of them if few, else the first
    :data:`SHOWN_FIRST` and last :data:`SHOWN_LAST` with the count left out
    between (the exception's ``loop`` keeps every step)."""
    numbered = list(numbered)
    if len(numbered) > SHOWN_FIRST + SHOWN_LAST + 1:
        left_out = len(numbered) - SHOWN_FIRST - SHOWN_LAST
        shown = numbered[:SHOWN_FIRST] + [None] + numbered[-SHOWN_LAST:]
    else:
        left_out, shown = 0, numbered
    lines = []
    for item in shown:
        if item is None:
            lines.append(f"  … {left_out} more steps …")
            continue
        number, step = item
        lines.append(f"  step {number}: {step.mode.describe()} [{step.kind}]")
        for f in step.fired:
            lines.append(f"      fired {f}")
    return lines


def _state_text(model, x: np.ndarray) -> str:
    """``name = value`` for the states of ``x`` (the first :data:`SHOWN_STATES`)."""
    pairs = [f"{s} = {v:.12g}" for s, v in zip(model.states, x)]
    if len(pairs) > SHOWN_STATES:
        pairs = pairs[:SHOWN_STATES] + [f"… {len(pairs) - SHOWN_STATES} more states"]
    return ", ".join(pairs)


def _roundoff_lines(numbered) -> list:
    """Whether any guard of the loop was decided within :data:`EDGE_ULPS`
    ulps of its band's edge (round-off could have decided it) or all with
    room to spare (the loop is in the guards and the physics)."""
    near = [(number, f, c) for number, step in numbered for f in step.fired for c in f.near_edge]
    if not near:
        return [f"Round-off: none; every comparison in the loop was decided more than {EDGE_ULPS} ulps from the "
                "edge of its band, so the loop is in the model's guards and physics."]
    lines = [f"Round-off: possibly; {len(near)} comparison(s) in the loop were decided within {EDGE_ULPS} ulps of the "
             "edge of their band (a located crossing sits there; otherwise rerun with a wider "
             "Tolerance(rtol=...) to tell), e.g.:"]
    for number, fired, c in near[:SHOWN_NEAR]:
        lines.append(f"      step {number}, {fired.automaton}: {c.text}: {c.left} vs {c.right} "
                     f"(band {c.band:.3g}, {c.edge_ulps:.0f} ulps from its edge)")
    return lines


def _loop_message(t, numbered, kind_text, detail=(), advice=_ADVICE) -> str:
    """The divergence-of-time message: what repeats, the steps (numbered as
    in the instant, long loops shortened), ``detail`` lines, whether
    round-off decided a guard of the loop, ``advice``."""
    numbered = list(numbered)
    lines = [f"divergence of time at t = {t:.12g}: {kind_text}; the loop:"]
    lines += _step_lines(numbered)
    lines += list(detail)
    lines += _roundoff_lines(numbered)
    lines.append(advice)
    return "\n".join(lines)


def _tie_detail(numbered):
    """``(detail lines, advice)`` for a loop that passed some switches only at
    a tie (a guard holding, but not strictly: :attr:`FiredGuard.strict`) and
    some beyond their band — not a cycle of ties, so it diverges — else
    ``None``: name those switches and how to write them so that equality
    does not switch (a capacitor's ideal diode turning off with ``v_D >= 0``
    to turn on: off finds ``v_D = 0``)."""
    ties = [(number, step, f) for number, step in numbered for f in step.fired if not f.strict]
    if not ties:
        return None
    lines = []
    for number, step, f in ties:
        shown = "; ".join(f"{c.text}: {c.left} vs {c.right}" for c in f.comparisons)
        lines.append(f"Step {number} left {step.mode.describe()} only at a tie: {f.automaton}'s guard [{f.guard}] "
                     f"holds only within the tolerance band of a comparison ({shown}), where the mode is consistent "
                     "too; the loop's other switches hold beyond their bands, so this is no cycle of ties (which "
                     "would rest where it began).")
    strict = ", ".join(dict.fromkeys(f"{f.guard.replace('>=', '>').replace('<=', '<')} for {f.guard}"
                                     for _, _, f in ties if ">=" in f.guard or "<=" in f.guard))
    advice = ("Write the guards that switched only at a tie strictly" + (f" ({strict})" if strict else "")
              + ": at equality the mode is then kept, and the flow switches it once the comparison holds beyond its "
              "band (models.circuits' diodes are written so: off → on when v_D > v_f, on → off when i_D < 0). "
              + _ADVICE)
    return lines, advice


def _pinnacle_repeat_message(model, t, steps, first: int, x: np.ndarray) -> str:
    """Pinnacle ``steps[-1]`` came back to the state it had at ``steps[first]``."""
    last = len(steps) - 1
    mode = steps[-1].mode
    numbered = [(k + 1, s) for k, s in enumerate(steps) if s.kind == "pinnacle"]
    cycle = sum(1 for s in steps[first + 1 :] if s.kind == "pinnacle")
    detail = [
        f"Repeating: mode {mode.describe()} at step {last + 1} has the state it had at step {first + 1} "
        f"(equal within a relative 1e-12), so the {cycle} pinnacle(s) of steps {first + 2}–{last + 1} would repeat "
        f"for ever; the state: {_state_text(model, x)}.",
    ]
    return _loop_message(
        t, numbered, f"pinnacle {mode.describe()} repeats with the same state after {len(numbered)} pinnacles",
        detail,
    )


def _too_many_message(model, t, steps, max_steps: int) -> str:
    lines = [
        f"at t = {t:.12g}: more than {max_steps} discrete steps at one instant in model {model.name!r} "
        "(no mode or state repeated, but possibly a divergence of time); the steps:"
    ]
    lines += _step_lines((k + 1, s) for k, s in enumerate(steps))
    x = steps[-1].x_after if steps else None
    if x is not None:
        lines.append(f"The state after step {len(steps)}: {_state_text(model, x)}.")
    raise_it = (
        f"HybridModel(..., max_steps_per_instant={10 * max_steps}) or model.max_steps_per_instant = {10 * max_steps} "
        "before simulating"
    )
    if max_steps != getattr(model, "max_steps_per_instant", max_steps):
        raise_it = f"the max_steps= argument of resolve (the model's own cap is {model.max_steps_per_instant})"
    lines.append(
        f"If the instant is meant to be this long (e.g. a light ball rattling between heavy ones), raise the cap "
        f"(now {max_steps}): {raise_it}. Otherwise " + _ADVICE[0].lower() + _ADVICE[1:]
    )
    return "\n".join(lines)


def resolve_instant(model, x: np.ndarray, mode: Mode, t: float, max_steps: int) -> Instant:
    """Resolve the instant at ``t`` from a priori ``x`` in ``mode`` by the rule
    :mod:`switching.rules.instants` (the passes, the divergences of time, the
    cap on steps), recording every mode passed; see the module docstring.  The
    modes it derives are one block for the cyclic garbage collector
    (:func:`~switching.library.collection.collection_paused`)."""
    with collection_paused():
        return _resolved(model, x, mode, t, max_steps)


def _resolved(model, x: np.ndarray, mode: Mode, t: float, max_steps: int) -> Instant:
    """:func:`resolve_instant`'s passes."""
    x = np.array(x, dtype=float)
    steps: list[Step] = []
    instant = Instant(t, steps, model)
    modes = [mode]  # the rule knows a mode by its place here
    number = {mode: 0}
    chain = np.zeros(max_steps + 1, dtype=np.int64)
    pin_modes, pin_x, pin_steps = np.zeros(16, dtype=np.int64), np.zeros((16, x.shape[0])), []
    chain_start = 0  # index in `steps` where the current mythical chain began
    pulses = True  # False while the candidate was reached only by transitions marked pulses=False
    state = instant_begin(0, chain)
    motion = _motion(model, mode, x, t)
    while True:
        action, current = state[0], modes[state[2]]
        if action == JUMP_AND_DECIDE:
            try:
                cm = model.compiled_mode(current)
            except (CausalityConflictError, AlgebraicLoopError) as error:  # a mode first met here: say when
                fired = _conflict_passed(model, current, error, x, t)
                if not fired:
                    raise prefixed(error, f"at t = {t:.12g}, ") from None
                # passed as mythical (its sources conflict): where it leads, its guards decide
                steps.append(Step(current, "mythical", x, x, tuple(fired)))
                target = _next_mode(model, current, fired)
                if target not in number:
                    number[target] = len(modes)
                    modes.append(target)
                state = instant_next(state, FIRED, number[target], x, max_steps, chain, pin_modes, pin_x)
                pulses = any(f.pulses for f in fired)
                continue
            x_plus = cm.jump(x, t)
            # the mode the instant began in, with no pulse (x on its constraints up to round-off): its
            # guards are decided as during flow, so a located crossing is seen to hold at its band's edge
            quiet = decides_as_in_flow(state, not np.any(cm.pulse(x, x_plus, motion)))
            fired = evaluate_guards(model, cm, x, x_plus, t, as_in_flow=quiet, pulses=pulses, motion=motion)
            if fired:
                steps.append(Step(current, "start" if quiet else "mythical", x, x, tuple(fired)))
        elif action == JUMP_AT_TIE:  # a cycle of ties from chain[state[5]]: none of its switches is taken
            for k in range(chain_start + state[5], len(steps)):
                steps[k] = dataclasses.replace(steps[k], kind="tie")
            cm = model.compiled_mode(current)
            x_before, x = x, cm.jump(x, t)
            fired = evaluate_guards(model, cm, x, x, t, as_in_flow=True, strict=True)
            steps.append(Step(current, "pinnacle" if fired else "continuous", x_before, x, tuple(fired)))
        elif action == DECIDE_AS_FLOW:
            x_before, x = x, x_plus
            if not np.all(np.isfinite(x)):
                raise HybridBondGraphError(
                    f"the jump into mode {current.describe()} at t = {t:.12g} gave a non-finite state: "
                    + ", ".join(f"{s}={v}" for s, v in zip(model.states, x))
                )
            fired = evaluate_guards(model, cm, x, x, t, as_in_flow=True)  # no jump from here: as flow decides
            steps.append(Step(current, "pinnacle" if fired else "continuous", x_before, x, tuple(fired)))
        elif action == CONTINUOUS:
            return instant
        elif action == REPEATS_IN_CHAIN:
            first = state[5]
            loop = steps[chain_start + first:]
            numbered = [(chain_start + first + k + 1, s) for k, s in enumerate(loop)]
            detail, advice = _tie_detail(numbered) or ((), _ADVICE)
            raise DivergenceOfTimeError(
                _loop_message(t, numbered, f"mode {modes[state[2]].describe()} repeats in a chain of mythical modes",
                              detail, advice),
                loop=loop, instant=instant)
        elif action == PINNACLE_REPEATS:
            loop = [s for s in steps if s.kind == "pinnacle"]
            raise DivergenceOfTimeError(_pinnacle_repeat_message(model, t, steps, pin_steps[state[5]], x),
                                        loop=loop, instant=instant)
        else:
            raise TooManyStepsError(_too_many_message(model, t, steps, max_steps), loop=steps[-10:], instant=instant)
        target = _next_mode(model, current, fired) if fired else current
        how = 0  # what fired: nothing, a transition holding strictly, or (passing mythical modes) only ties
        if fired:
            how = FIRED_AT_TIE if action == JUMP_AND_DECIDE and not any(f.strict for f in fired) else FIRED
        if target not in number:
            number[target] = len(modes)
            modes.append(target)
        while True:
            following = instant_next(state, how, number[target], x, max_steps, chain, pin_modes, pin_x)
            if following[0] != NO_ROOM:
                break
            pin_modes = np.concatenate([pin_modes, np.zeros_like(pin_modes)])
            pin_x = np.concatenate([pin_x, np.zeros_like(pin_x)])
        if following[4] > state[4]:  # a pinnacle recorded: its step
            pin_steps.append(len(steps) - 1)
        if fired and following[0] == JUMP_AND_DECIDE:
            pulses = any(f.pulses for f in fired)
            if action != JUMP_AND_DECIDE:  # a pinnacle: a new chain
                chain_start = len(steps)
        state = following


def _motion(model, mode: Mode, x: np.ndarray, t: float) -> np.ndarray:
    """The states' motion within the round-off of ``t`` in ``mode``, the mode that flowed into the instant
    (:mod:`switching.rules.jumps`); zeros where the mode has no equations (it is conflicting)."""
    try:
        return model.compiled_mode(mode).motion(x, t)
    except HybridBondGraphError:
        return np.zeros(x.shape[0])


def _conflict_passed(model, mode: Mode, error, x: np.ndarray, t: float) -> list:
    """The transitions that leave the conflicting candidate ``mode`` (a causality conflict, not a floating
    part) judged in the limit of vanishing resistances (:mod:`switching.library.conflicts`), as
    :class:`FiredGuard` records; empty when it is no conflict or none holds."""
    if not isinstance(error, CausalityConflictError) or isinstance(error, FloatingPartError):
        return []
    try:
        guards = model.library.conflict_guards(mode, error)
    except HybridBondGraphError:
        return []
    return [FiredGuard(automaton, tr.source, tr.target, text, tr.when, comparisons, tr.pulses)
            for automaton, tr, text, comparisons in guards.fired(x, t)]


class CompiledInstant(Instant):
    """An instant resolved in compiled code.  Its time, modes and states are
    at hand; the steps through mythical modes and pinnacles (with the fired
    guards) are replayed in Python on first access — the resolution is
    deterministic, so the replay passes the same modes.

    ``states`` (E, 1 + 2n) holds a kernel call's events a row each, ``(t, x_before, x_after)``, and
    this instant is its row ``row``: ``x_before`` and ``x_after`` are views of that row, made when
    first read (a warm call records its instants without making them)."""

    _steps = None  # (the replayed steps once asked: an instance's own then)

    def __init__(self, model, t, mode_before, mode_after, states: np.ndarray, row: int):
        self.model = model
        self.t = t
        self._modes = (mode_before, mode_after)
        self._row = (states, row)

    def __getstate__(self):
        state = super().__getstate__()
        state.pop("_views", None)
        state["_row"] = (np.array([self._row[0][self._row[1]]]), 0)  # (its own row, not the call's whole block)
        return state

    def _states(self) -> tuple:
        """``(x_before, x_after)``: views of this instant's row, made when first read."""
        found = self.__dict__.get("_views")
        if found is None:
            states, row = self._row
            line = states[row]
            n = (len(line) - 1) // 2
            found = self._views = (line[1:1 + n], line[1 + n:])
        return found

    @property
    def steps(self) -> list:
        if self._steps is None:
            if self.model is None:
                raise HybridBondGraphError(
                    f"the steps of the instant at t = {self.t!r} (resolved in compiled code) are replayed with the "
                    "model, and this record was unpickled without it; its time, modes and states are at hand")
            self._steps = resolve_instant(self.model, self.x_before, self.mode_before, self.t,
                                          self.model.max_steps_per_instant).steps
        return self._steps

    @property
    def x_before(self) -> np.ndarray:
        return self._states()[0]

    @property
    def x_after(self) -> np.ndarray:
        return self._states()[1]

    @property
    def mode_before(self):
        return self._modes[0]

    @property
    def mode_after(self):
        return self._modes[1]


class KernelInstants:
    """The instants of one kernel call, recorded at once: made :class:`CompiledInstant` records when first
    read (:func:`instants_made`; a run whose instants are never read, a parameter study's, makes none).
    Instant ``k`` is at ``times[k]`` [s], from mode number ``before[k]`` to ``after[k]`` (into ``modes``),
    its states the row ``k`` ``(t, x_before, x_after)`` of ``states`` (E, 1 + 2n)."""

    __slots__ = ("model", "modes", "times", "before", "after", "states")

    def __init__(self, model, modes, times: list, before: list, after: list, states: np.ndarray):
        self.model, self.modes, self.times, self.before, self.after, self.states = \
            model, modes, times, before, after, states

    def __len__(self) -> int:
        return len(self.times)

    def made(self) -> list:
        """The records, in time order."""
        model, modes, states = self.model, self.modes, self.states
        return [CompiledInstant(model, t, modes[left], modes[entered], states, row)
                for row, (t, left, entered) in enumerate(zip(self.times, self.before, self.after))]


def instants_made(events: list) -> list:
    """``events`` (instant records, and :class:`KernelInstants` of kernel calls) as a new list of instant
    records in the same order."""
    made = []
    for event in events:
        if type(event) is KernelInstants:
            made += event.made()
        else:
            made.append(event)
    return made
