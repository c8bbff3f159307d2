"""The options of a run, checked before anything runs.

:func:`switching.simulate.driver.simulate` (so ``HybridModel.simulate``,
``simulate_many`` and ``hbg run`` too) calls :func:`check_run` first.  An
option of the wrong kind raises :class:`~switching.errors.OptionTypeError`
(also a ``TypeError``), one out of its bounds
:class:`~switching.errors.OptionValueError` (also a ``ValueError``), and
options that ask for more work or memory than a run may take
:class:`~switching.errors.WorkLimitError` (an ``OptionValueError``): each
names the option, the value given and the value expected.  A number is an
``int``, a ``float`` or a numpy scalar; ``True``/``False`` are not numbers and
text is never read as one.

======================  =========  ==========================================================
option                  unit       kind and bounds
======================  =========  ==========================================================
``t0``, ``t_end``       s          number, finite; ``t_end > t0``
``method``              —          one of :data:`METHODS` or ``"auto"``
``dt``                  s          euler, rk4 (and their ``-jit``) only, and needed there:
                                   number, finite, > 0; at least one ulp of
                                   ``max(|t0|, |t_end|)`` (else ``t + dt == t`` somewhere in
                                   the run: it could not advance); ``(t_end − t0)/dt`` at
                                   most ``max_steps``
``rtol``                1          number, finite, > 0
``atol``                state      number, finite, > 0; ``None`` (default): each state's own,
                                   1e-9 in its storage's output's units (V, A, m/s, N)
                                   times the storage's capacity
                                   (:mod:`switching.simulate.state_tolerances`)
``max_step``            s          number > 0; adaptive methods: at least
                                   10 ulps of ``max(|t0|, |t_end|)`` (their smallest step)
                                   and ``(t_end − t0)/max_step`` at most ``max_steps``; not
                                   given (``inf``): 1/16 of the sources' shortest sinusoid
                                   period and half a PWM switch's shortest window
                                   (:mod:`switching.model.source_periods`), else no limit
``first_step``          s          ``None`` or number, finite, > 0
``x0``                  state      ``None`` or one finite number per state
``t_eval``              s          ``None`` or finite numbers in ``[t0, t_end]``; their
                                   samples (``len(t_eval) × states × 8`` bytes) at most
                                   :data:`MAX_OUTPUT_BYTES` (1 GiB)
``samples``             times      ``None`` or integer ≥ 2 (the times
                                   ``linspace(t0, t_end, samples)``, both ends included);
                                   not with ``t_eval``; ``samples × states × 8`` bytes at
                                   most :data:`MAX_OUTPUT_BYTES`
``max_steps``           steps      integer ≥ 1, default :data:`DEFAULT_MAX_STEPS`
                                   (10 000 000): a bound on the steps the options imply,
                                   checked up front, and on the steps the run takes (beyond
                                   it the run stops with
                                   :class:`~switching.errors.StepLimitError`, its partial
                                   trajectory attached)
``event_samples``       1/step     integer, 0 … :data:`MAX_EVENT_SAMPLES` (1000); the guard
                                   tests the options imply, ``steps × (event_samples + 1)``,
                                   at most ``(DEFAULT_EVENT_SAMPLES + 1) × max_steps``
``max_events``          instants   integer ≥ 1
``zeno_window``         ratios     integer, 2 … :data:`MAX_ZENO_WINDOW` (1000)
``zeno_min_gap``        s          ``None`` (1e-9 of the run) or number ≥ 0, not NaN
``on_zeno``             —          ``"raise"`` or ``"stop"``
``output``              —          ``"steps"`` or ``"events"``
``keep_instants``       —          ``True`` or ``False`` (numpy's too)
``stiffness_check``     —          ``True`` or ``False`` (numpy's too)
``progress``            —          ``None``, ``True`` (a bar) or a callable of the time [s]
``sensitivity_rtol``    1          number, finite, > 0; only with ``sensitivities``
``sensitivity_atol``    state      number, finite, > 0; only with ``sensitivities``
======================  =========  ==========================================================

"Steps" are the integrator's accepted steps: ``(t_end − t0)/dt`` for a fixed
step, at least ``(t_end − t0)/max_step`` for an adaptive one (how many more
it takes depends on the tolerances: the running count bounds those).
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from ..errors import OptionTypeError, OptionValueError, WorkLimitError
from .methods import COMPILED, METHODS, method_class
from .option_groups import RunOptions

__all__ = ["OPTION_CHECKS", "checked_options", "options_key", "check_each", "check_run", "check_work",
           "check_output_size", "check_samples", "check_sensitivity_options", "METHODS", "COMPILED",
           "DEFAULT_MAX_STEPS", "MAX_EVENT_SAMPLES", "MAX_OUTPUT_BYTES", "MAX_ZENO_WINDOW"]

#: steps a run may take unless told (``max_steps=``): no shipped model's run comes near
DEFAULT_MAX_STEPS = 10_000_000
#: guard samples per step unless told (``event_samples=``)
DEFAULT_EVENT_SAMPLES = 3
#: the most guard samples inside one step (``event_samples=``)
MAX_EVENT_SAMPLES = 1000
#: the most event gaps the Zeno watch compares (``zeno_window=``; it scans them at every instant)
MAX_ZENO_WINDOW = 1000
#: the most memory [bytes] the samples at requested times may take (``t_eval``: times × states × 8)
MAX_OUTPUT_BYTES = 2**30


# ------------------------------------------------------------------ kinds of values


def _show(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _is_number(value) -> bool:
    """A real number: int, float or a numpy scalar, not a bool."""
    kind = type(value)
    if kind is float or kind is int:  # the common case, without the abstract classes' slower checks
        return True
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def _of(unit: str) -> str:
    return f" of {unit}" if unit else ""


def _number(option: str, value, expected) -> float:
    """``value`` as a float, or :class:`OptionTypeError` saying ``expected()``
    (a function: the text is made only for the error)."""
    if _is_number(value):
        return float(value)
    hint = ""
    if isinstance(value, (bool, np.bool_)):
        hint = " (True and False are not numbers)"
    elif isinstance(value, (str, bytes)):
        hint = " (text is not read as a number: write the number without quotes)"
    raise OptionTypeError(f"{option} must be {expected()}, got {_show(value)}{hint}", option, value)


def _bounded(option: str, value, expected, accepts) -> float:
    """``value`` as a float if it is a number that ``accepts`` (a predicate), else an error saying ``expected()``."""
    number = _number(option, value, expected)
    if not accepts(number):
        raise OptionValueError(f"{option} must be {expected()}, got {_show(value)}", option, value)
    return number


def positive_finite(option: str, value, unit: str = "") -> float:
    """``value`` [``unit``] as a float if it is a finite number > 0."""
    return _bounded(option, value, lambda: f"a positive finite number{_of(unit)}",
                    lambda number: number > 0 and math.isfinite(number))


def positive(option: str, value, unit: str = "") -> float:
    """``value`` [``unit``] as a float if it is a number > 0 (``inf`` included)."""
    return _bounded(option, value, lambda: f"a positive number{_of(unit)} (inf for no limit)",
                    lambda number: number > 0)


def not_negative(option: str, value, unit: str = "") -> float:
    """``value`` [``unit``] as a float if it is a number ≥ 0 (``inf`` included, not NaN)."""
    return _bounded(option, value, lambda: f"a number ≥ 0{_of(unit)}", lambda number: number >= 0)


def whole(option: str, value, low: int, high: int | None = None, unit: str = "") -> int:
    """``value`` as an int if it is an integer (not a float, not a bool) in ``[low, high]``."""
    if type(value) is int and value >= low and (high is None or value <= high):
        return value  # the common case, at once
    expected = f"a whole number{_of(unit)} ≥ {low}" + ("" if high is None else f" and ≤ {high}")
    if not isinstance(value, numbers.Integral) or isinstance(value, (bool, np.bool_)):
        hint = " (True and False are not numbers)" if isinstance(value, (bool, np.bool_)) else ""
        raise OptionTypeError(f"{option} must be {expected}, got {_show(value)}{hint}", option, value)
    number = int(value)
    if number < low or (high is not None and number > high):
        raise OptionValueError(f"{option} must be {expected}, got {_show(value)}", option, value)
    return number


def flag(option: str, value) -> bool:
    """``value`` if it is ``True`` or ``False`` (numpy's too)."""
    if not isinstance(value, (bool, np.bool_)):
        raise OptionTypeError(f"{option} must be True or False, got {_show(value)}", option, value)
    return bool(value)


def choice(option: str, value, choices: tuple, advice: str = ""):
    """``value`` if it is one of ``choices``."""
    if not isinstance(value, str) or value not in choices:
        cls = OptionValueError if isinstance(value, str) else OptionTypeError
        raise cls(f"{option} must be {' or '.join(map(repr, choices))}, got {_show(value)}{advice}", option, value)
    return value


# ------------------------------------------------------------------ one concern each


def check_method(method, dt) -> None:
    """The method is known, and ``dt`` is given exactly for the fixed-step ones."""
    cls = method_class(method)  # (an unknown one: the error lists the table's names)
    if cls.fixed_step:
        if dt is None:
            raise OptionValueError(f"method {method!r} is fixed-step: give a positive step dt=… [s]", "dt", dt)
    elif dt is not None:
        raise OptionValueError(f"method {method!r} {cls.adaptive_text}: give rtol/atol, not dt (dt is for euler "
                               "and rk4)", "dt", dt)


def _check_progress(progress) -> None:
    if progress is not True and progress is not None and not callable(progress):  # True: switching.simulate.progress
        raise OptionTypeError("progress must be None, True (a progress bar on stderr) or a function of the time "
                              f"[s] (called as progress(t)), got {_show(progress)}", "progress", progress)


#: each option checked alone: the step and tolerance options, those about instants (the Zeno watch's among
#: them), those about what is kept and told (units: times in seconds, atol in the states' units)
OPTION_CHECKS = (
    ("dt", lambda v: v is None or positive_finite("dt", v, "seconds")),
    ("rtol", lambda v: positive_finite("rtol", v)),
    ("atol", lambda v: v is None or positive_finite("atol", v, "the states' units")),
    ("max_step", lambda v: positive("max_step", v, "seconds")),
    ("first_step", lambda v: v is None or positive_finite("first_step", v, "seconds")),
    ("event_samples", lambda v: whole("event_samples", v, 0, MAX_EVENT_SAMPLES, "guard samples per step")),
    ("max_events", lambda v: whole("max_events", v, 1, unit="instants")),
    ("max_steps", lambda v: whole("max_steps", v, 1, unit="steps")),
    ("zeno_window", lambda v: whole("zeno_window", v, 2, MAX_ZENO_WINDOW, "gap ratios")),
    ("zeno_min_gap", lambda v: v is None or not_negative("zeno_min_gap", v, "seconds")),
    ("on_zeno", lambda v: choice("on_zeno", v, ("raise", "stop"))),
    ("output", lambda v: choice("output", v, ("steps", "events"), " (give t_eval=… for chosen times)")),
    ("keep_instants", lambda v: flag("keep_instants", v)),
    ("stiffness_check", lambda v: flag("stiffness_check", v)),
    ("progress", _check_progress),
)


def check_each(o: dict) -> None:
    """Each option of :data:`OPTION_CHECKS` alone."""
    for name, check in OPTION_CHECKS:
        check(o[name])


def check_ends(t0, t_end) -> None:
    """Finite ends [s], ``t_end`` after ``t0``."""
    for name, value in (("t0", t0), ("t_end", t_end)):
        advice = "; a run needs an end: give the time you want to see" if name == "t_end" else ""
        number = _number(name, value, lambda: "a finite number of seconds")
        if not math.isfinite(number):
            raise OptionValueError(f"{name} must be a finite number of seconds, got {_show(value)}{advice}",
                                   name, value)
    if not t_end > t0:
        raise OptionValueError(f"t_end ({t_end}) must be after t0 ({t0})", "t_end", t_end)


def check_x0(model, x0) -> np.ndarray:
    """The initial state as a float array: one finite number per state of ``model``."""
    names = ", ".join(s.name for s in model.states)
    values = np.asarray(x0, dtype=object).ravel() if not isinstance(x0, np.ndarray) or x0.dtype.kind == "O" \
        else x0.ravel()
    if isinstance(values, np.ndarray) and values.dtype.kind != "O":
        if values.dtype.kind not in "iuf":
            raise OptionTypeError(f"x0 must hold numbers, one per state ({names}); got an array of {values.dtype}",
                                  "x0", x0)
    else:
        for k, value in enumerate(values):
            if not _is_number(value):
                raise OptionTypeError(f"x0[{k}] = {_show(value)} is not a number; x0 needs one number per state "
                                      f"({names})", "x0", x0)
    x = np.array(values, dtype=float)
    if len(x) != len(model.states):
        raise OptionValueError(f"x0 has {len(x)} value(s); the model has {len(model.states)} states ({names})",
                               "x0", x0)
    bad = np.flatnonzero(~np.isfinite(x))
    if len(bad):
        raise OptionValueError("x0 is not finite: " + ", ".join(f"{model.states[k].name} = {x[k]}" for k in bad),
                               "x0", x0)
    return x


def _count(t_eval) -> int:
    """How many sample times ``t_eval`` holds (without converting it)."""
    if isinstance(t_eval, np.ndarray):
        return int(t_eval.size)
    if _is_number(t_eval):
        return 1
    try:
        return len(t_eval)
    except TypeError:
        raise OptionTypeError(f"t_eval must be a sequence of times [s], got {_show(t_eval)}", "t_eval",
                              t_eval) from None


def check_t_eval(t_eval, t0, t_end) -> np.ndarray:
    """The requested sample times [s], sorted: finite numbers inside ``[t0, t_end]``."""
    if isinstance(t_eval, np.ndarray) and t_eval.dtype.kind in "iuf":
        times = t_eval.astype(float).ravel()
    else:
        objects = np.asarray(t_eval, dtype=object).ravel()
        for k, value in enumerate(objects):
            if not _is_number(value):
                raise OptionTypeError(f"t_eval[{k}] = {_show(value)} is not a number of seconds", "t_eval", t_eval)
        times = objects.astype(float)
    bad = np.flatnonzero(~np.isfinite(times) | (times < t0) | (times > t_end))
    if len(bad):
        k = int(bad[0])
        raise OptionValueError(
            f"t_eval[{k}] = {float(times[k])!r} is outside the run [{t0}, {t_end}] s ({len(bad)} value(s) are); "
            "give sample times inside the run", "t_eval", t_eval)
    return np.sort(times)


def check_samples(samples, t_eval, states: int) -> int:
    """``samples=N``: a whole number ≥ 2 of uniform times [the start and the
    end at least], not together with ``t_eval``, within
    :data:`MAX_OUTPUT_BYTES` for ``states`` states."""
    if t_eval is not None:
        raise OptionValueError(
            f"samples={_show(samples)} and t_eval are two ways to choose the sample times: give samples=N for N "
            "uniform times and the instants' before/after rows, or t_eval=[...] for exactly those times, not both",
            "samples", samples)
    number = whole("samples", samples, 2, unit="sample times (the start and the end at least)")
    check_output_size(number, states, "samples")
    return number


def _bytes(count: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB"):
        if count < 1024 or unit == "TiB":
            return f"{count:.3g} {unit}"
        count /= 1024
    return f"{count:.3g} TiB"  # (not reached)


def check_output_size(samples: int, states: int, option: str = "t_eval") -> None:
    """Refuse ``samples`` requested sample times of ``states`` states each
    beyond :data:`MAX_OUTPUT_BYTES` of memory (8 bytes a value); ``option`` is
    named (``--samples`` for ``hbg``)."""
    need = samples * max(states, 1) * 8
    if need > MAX_OUTPUT_BYTES:
        raise WorkLimitError(
            f"{option} asks for {samples} sample times × {states} states × 8 bytes = {_bytes(need)} of samples, "
            f"more than the {_bytes(MAX_OUTPUT_BYTES)} a run may hold (switching.simulate.run_options.MAX_OUTPUT_BYTES): "
            "give fewer times, or split the run (t0=, x0= the last state)", option, samples, need, MAX_OUTPUT_BYTES)


def check_work(method: str, t0: float, t_end: float, dt, max_step: float, event_samples: int,
               max_steps: int) -> None:
    """Refuse a step that cannot advance ``t`` in floating point, and options
    implying more than ``max_steps`` steps or more than
    ``(DEFAULT_EVENT_SAMPLES + 1) × max_steps`` guard tests (times [s])."""
    span, reach = t_end - t0, max(abs(t0), abs(t_end))
    if method_class(method).fixed_step:
        option, step, smallest = "dt", dt, math.ulp(reach)
        why = f"one ulp of t there, {smallest:.3g} s): t + dt == t, the run could not advance"
    else:
        option, step, smallest = "max_step", max_step, 10 * math.ulp(reach)
        why = (f"10 ulps of t there, {smallest:.3g} s, the smallest step the adaptive methods take): the step "
               "size would collapse")
    if step < smallest:
        raise WorkLimitError(
            f"{option} = {step!r} s is too small: below the resolution of t near {reach:g} s ({why}; "
            f"give {option} ≥ {smallest:.3g} s"
            + (", or count time from nearer 0 (t0, t_end)" if reach > 100 * span else ""),
            option, step, step, smallest)
    steps = span / step if math.isfinite(step) else 1.0
    if steps > max_steps:
        raise WorkLimitError(
            f"{option} = {step!r} s needs {steps:.3g} steps to cover [{t0:g}, {t_end:g}] s, more than max_steps = "
            f"{max_steps}: give {option} ≥ {span / max_steps:.3g} s, or raise max_steps if a run that long is meant",
            option, step, steps, max_steps)
    tests, limit = steps * (event_samples + 1), (DEFAULT_EVENT_SAMPLES + 1) * max_steps
    if tests > limit:
        raise WorkLimitError(
            f"event_samples = {event_samples} on {steps:.3g} steps means {tests:.3g} guard tests, more than "
            f"(3 + 1) × max_steps = {limit:.3g}: lower event_samples, take a larger {option}, or raise max_steps",
            "event_samples", event_samples, tests, limit)


def check_sensitivity_options(sensitivities, rtol, atol) -> None:
    """``sensitivity_rtol``/``sensitivity_atol`` only with ``sensitivities``, and positive finite numbers."""
    if rtol is None and atol is None:
        return  # (a run without them: nothing to check)
    given = [name for name, value in (("sensitivity_rtol", rtol), ("sensitivity_atol", atol)) if value is not None]
    if sensitivities is None and given:
        raise OptionTypeError(f"{' and '.join(given)} set(s) the tolerances of the sensitivities: give "
                              f"sensitivities=[...] too, or drop {' and '.join(given)}", given[0],
                              rtol if given[0] == "sensitivity_rtol" else atol)
    if rtol is not None:
        positive_finite("sensitivity_rtol", rtol)
    if atol is not None:
        positive_finite("sensitivity_atol", atol, "the states' units")


# ------------------------------------------------------------------ the whole run


def check_run(model, t_end, method, options: dict):
    """Every check of a run of ``model`` up to ``t_end`` [s] with ``method``
    and the keyword ``options`` of ``simulate``, every one (their defaults:
    :func:`switching.simulate.driver.option_defaults`), before anything
    runs; returns ``(t_eval, x0)``: the sample times sorted (with
    ``samples=N``: ``linspace(t0, t_end, N)``) and the initial state as an
    array (``None`` when not given)."""
    o = options
    check_ends(o["t0"], t_end)
    check_each(o)
    check_method(method, o["dt"])
    t0, t_end = float(o["t0"]), float(t_end)
    t_eval = o["t_eval"]
    if t_eval is not None:
        check_output_size(_count(t_eval), len(model.states))
        t_eval = check_t_eval(t_eval, t0, t_end)
    samples = o.get("samples")
    if samples is not None:
        samples = check_samples(samples, o["t_eval"], len(model.states))
        t_eval = np.linspace(t0, t_end, samples)
    x0 = None if o["x0"] is None else check_x0(model, o["x0"])
    check_work(method, t0, t_end, None if o["dt"] is None else float(o["dt"]), float(o["max_step"]),
               int(o["event_samples"]), int(o["max_steps"]))
    return t_eval, x0


#: options checked lately (see checked_options): their key → their RunOptions
_CHECKED: dict = {}
_CHECKED_KEPT = 64


def options_key(t_end, method, keywords: dict):
    """The key of options that no model's size enters (no ``x0``, ``t_eval``
    or ``samples``): the names, the values and their types (``1`` and ``1.0``,
    ``True`` and ``1``, a float and numpy's are told apart: the run sees the
    very values given), else ``None``.  (It may not hash: :func:`_kept_options`.)"""
    if keywords.get("x0") is not None or keywords.get("t_eval") is not None or keywords.get("samples") is not None:
        return None
    values = tuple(keywords.values())
    return method, t_end, type(t_end), tuple(keywords), values, tuple(map(type, values))


def _kept_options(key) -> tuple:
    """``(the options kept under key or None, key)``; the key ``None`` when its values do not all hash."""
    if key is None:
        return None, None
    try:
        return _CHECKED.get(key), key
    except TypeError:  # (a mode given as a dict, an unhashable callback)
        return None, None


_KEY_UNKNOWN = object()  # (checked_options: the options' key not made yet)


def checked_options(model, t_end, method, keywords: dict, key=_KEY_UNKNOWN) -> RunOptions:
    """The options of a run of ``model`` up to ``t_end`` [s] with ``method``,
    grouped (:class:`~switching.simulate.option_groups.RunOptions`) from the
    keywords of ``simulate`` (all of them, ``mode`` included) once
    :func:`check_run` has checked them: ``t_eval`` sorted and ``x0`` as an
    array, every other value as given.

    A loop of runs with the same options (a parameter study, a fit) checks
    them once: options without ``x0``, ``t_eval`` and ``samples`` (which
    depend on the model's size or are arrays) are kept by their values and
    types, frozen, and handed to the next run that gives the same (the last
    64 kept).  ``key``: :func:`options_key` of these, when the caller has made it."""
    found, key = _kept_options(options_key(t_end, method, keywords) if key is _KEY_UNKNOWN else key)
    if found is not None:
        return found
    t_eval, x0 = check_run(model, t_end, method, keywords)
    options = RunOptions.from_keywords(method, t_end, {**keywords, "t_eval": t_eval, "x0": x0})
    if key is not None:
        if len(_CHECKED) >= _CHECKED_KEPT:
            _CHECKED.clear()
        _CHECKED[key] = options
    return options
