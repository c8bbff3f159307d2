"""A run's set-up, kept for the next run of the same model with the same options.

A parameter study, a fit or a Monte Carlo ensemble calls ``simulate`` on one model thousands of
times, and many of those calls repeat the last one exactly (a tolerance loop's reference run, an
ensemble's baseline, a timing loop).  Before its first step every run checks its options, bounds its
step by the model's clocks (:func:`~switching.model.source_periods.step_bound`), scales each state's
absolute tolerance (:mod:`.state_tolerances`), decides its starting mode and checks that every guard
side is finite where the compiled kernel starts (:func:`.preflight.nonfinite_sides_at_start`).  Each
of those keeps its own memo, and each asks again whether what it was made of has changed: together
some 10 µs of a warm call of the bouncing ball, whose kernel takes 75 µs (issue 46).

The set-up of a run is a function of its options and of a few things of its model, and of nothing
else: a run whose options are those of the model's last run, on a model that is as it was then,
takes that run's set-up whole (:func:`kept_set_up`).  What "as it was" means:

* the options: ``simulate``'s keywords, ``t_end`` and the method, by value and type
  (:func:`~switching.simulate.run_options.options_key`); a run given ``x0``, ``t_eval`` or
  ``samples`` (which the key leaves out) or a progress callback, or run by ``auto`` (which chooses
  its method anew each run), keeps nothing, and a batch's runs (each with its own values:
  :mod:`switching.sweep.kernel_batch`) neither take nor keep one;
* the model's parameter values (the array by identity, and to the bit: a change in place is seen),
  its inputs (by identity), its structure (its mode space), its guard tolerances
  (:class:`~switching.model.hybrid_model.Tolerance`, frozen: by identity) and its ``max_step_hint``;
* its initial state, to the bit, and its projection (:meth:`HybridModel.initial_state`).

A run keeps its set-up when its parameter values are those of the model's run before it (the same
array), so the third of a loop of like runs is the first to take one: a parameter study's runs, each
with new values, only note them (keeping costs ~1 µs a run that such a study would never take back).
A model with inputs still checks its guard sides at every start: they read the inputs at the start
time, which the functions alone do not tell.
"""

from __future__ import annotations

import weakref
from typing import NamedTuple

import numpy as np

__all__ = ["KeptSetUp", "keep_set_up", "kept_set_up"]


class KeptSetUp(NamedTuple):
    """A run's set-up (:mod:`switching.simulate.set_up`): the options it ran with, the starting mode
    ``mode``, the start's generated functions (``start_functions``: a weak reference) and whether the
    guard sides were finite there (``start_checked``), and what it was made of: the options' ``key``, the
    model's parameter values (``parameters``, ``parameter_bits``), inputs (``inputs``: a weak
    reference), mode space, guard tolerances and step hint, the initial state's bits ``x_bits`` and
    its projection ``projected``.  (Nothing in it holds the model: the weak map keeping it lets the
    model go.)"""

    key: tuple
    parameters: np.ndarray
    parameter_bits: bytes
    inputs: weakref.ref
    mode_space: object
    tolerance: object
    hint: object
    options: object
    x_bits: bytes
    projected: object
    mode: object
    start_functions: weakref.ref | None
    start_checked: bool

    def holds_for(self, model) -> bool:
        """Is ``model`` as it was when this set-up was made (its initial state aside)?"""
        p = model.parameter_array
        return p is self.parameters and self.inputs() is model.input_signals and model.mode_space is self.mode_space \
            and model.tolerance is self.tolerance and getattr(model, "max_step_hint", None) == self.hint \
            and p.tobytes() == self.parameter_bits


#: model → [the set-up of its last run that kept one, the parameter values (array) of its last run] (held
#: weakly: it goes with its model; a list, so that a new set-up replaces the last without a new weak
#: reference to the model)
_KEPT: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def kept_set_up(model, key) -> tuple | None:
    """``(the set-up of model's last run, the initial state (n,) of a new run)`` when that run's options
    had ``key`` (:func:`~switching.simulate.run_options.options_key`; ``None``: nothing is kept) and the
    model is as it was then; else ``None``."""
    held = _KEPT.get(model) if key is not None else None
    kept = held[0] if held is not None else None
    if kept is None or not kept.holds_for(model):  # (a parameter study's values: told first)
        return None
    try:
        same = kept.key == key
    except (TypeError, ValueError):  # (a bad option given as an array: checked_options then names it)
        same = False
    if not same:
        return None
    x = model.initial_state()
    if x.tobytes() != kept.x_bits or model.initial_projection is not kept.projected:
        return None
    return kept, x


def keep_set_up(model, key, options, x: np.ndarray, projected, mode, start_functions, start_checked: bool) -> None:
    """Keep the set-up of a run of ``model`` whose options had ``key`` (``None``: nothing kept), if the
    model's last run had the same parameter values (the same array; else note them only): its
    ``options`` (checked, with the step bound and the states' tolerances), its initial state ``x`` (n,)
    and the projection that gave it, its starting ``mode``, the mode's generated functions (``None`` on
    the Python path: then ``start_checked`` is false) and whether the guard sides were found finite there
    (``start_checked``)."""
    if key is None:
        return
    p, held = model.parameter_array, _KEPT.get(model)
    if held is None:
        held = _KEPT[model] = [None, None]
    if held[1] is not p:  # values new since the model's last run (a parameter study's next set): kept once
        held[1] = p       # they run again, so that a study does not pay for keeping what it never takes
        return
    held[0] = KeptSetUp(key, p, p.tobytes(), weakref.ref(model.input_signals), model.mode_space, model.tolerance,
                        getattr(model, "max_step_hint", None), options, x.tobytes(), projected, mode,
                        None if start_functions is None else weakref.ref(start_functions),
                        start_checked and start_functions is not None)
