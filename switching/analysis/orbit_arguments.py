"""The arguments of the orbit API checked before anything runs.

:func:`~switching.analysis.orbits.periodic_orbit`,
:func:`~switching.analysis.continuation.continue_orbit` and
:meth:`~switching.analysis.orbits.PeriodicOrbit.small_signal` call these first.
A wrong argument raises :class:`~switching.errors.OrbitArgumentError` (also a
``ValueError``; for ``continue_orbit`` its own arguments raise
:class:`~switching.errors.ContinuationError`) naming the argument, the value
given and what to give.  A number is an ``int``, a ``float`` or a numpy
scalar; ``True``/``False`` are not numbers and text is never read as one.

=================  =====  =====================================================
argument           unit   kind and bounds
=================  =====  =====================================================
``period``         s      number, finite, > 0 (``None`` with a ``section``)
``section``        —      ``"automaton: source -> target"`` or three texts
``crossings``      —      integer ≥ 1
``t0``             s      number, finite
``x0``             state  ``None`` or one finite number per state
``mode``           —      ``None`` or a mode of the model (a label, a mapping)
``method``         —      a method of ``simulate``; a compiled one (``-jit``) or
                          ``"auto"`` is run by its Python equivalent, which
                          integrates the sensitivities
``rtol``, ``tol``  1      number, finite, > 0
``atol``           state  number, finite, > 0
``max_iterations`` —      integer ≥ 0
``max_period``     s      ``None`` or number, finite, > 0
``warmup``         —      integer ≥ 0
``grazing_limit``  1      number > 0 (``inf``: no limit)
``criterion``      —      ``"error"`` or ``"residual"``
=================  =====  =====================================================
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from bondgraph.errors import HybridBondGraphError

from ..errors import ContinuationError, OptionError, OrbitArgumentError
from ..simulate.methods import method_class

__all__ = ["is_number", "checked_number", "checked_section", "checked_x0", "python_method", "checked_orbit_arguments",
           "checked_values", "checked_names", "checked_continuation_arguments", "checked_mode"]


def is_number(value) -> bool:
    """An ``int``, ``float`` or numpy real scalar, not ``True``/``False``."""
    return isinstance(value, (numbers.Real, np.number)) and not isinstance(value, (bool, np.bool_)) \
        and not isinstance(value, np.complexfloating)


def _shown(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def checked_number(where: str, name: str, value, *, low: float | None = None, strict: bool = True,
                   integer: bool = False, finite: bool = True, expected: str = "", error=OrbitArgumentError):
    """``value`` as a float (an int with ``integer``), or ``error`` naming ``where``, ``name``, the value and
    ``expected`` (what to give)."""
    kind = "an integer" if integer else "a number"
    expected = expected or kind

    def refuse(why: str):
        message = f"{where}: {name}={_shown(value)} {why}; give {expected}"
        raise (error(message, name, value) if error is OrbitArgumentError else error(message))

    if not is_number(value) or (integer and not float(value).is_integer()):
        refuse("is text, not a number" if isinstance(value, str) else f"is not {kind}")
    number = float(value)
    if math.isnan(number) or (finite and not math.isfinite(number)):
        refuse("is not finite")
    if low is not None and (number < low or (strict and number == low)):
        refuse(f"is {'at most' if strict else 'below'} {low:g}")
    return int(number) if integer else number


def checked_section(section, model, where: str = "periodic_orbit"):
    """``section`` as ``(automaton, source, target)`` of one of ``model``'s transitions, or ``None``."""
    if section is None:
        return None
    if isinstance(section, str):
        automaton, _, rest = section.partition(":")
        source, _, target = rest.replace("→", "->").partition("->")
        parts = (automaton.strip(), source.strip(), target.strip())
    elif isinstance(section, (tuple, list)) and len(section) == 3 and all(isinstance(p, str) for p in section):
        parts = tuple(p.strip() for p in section)
    else:
        parts = ()
    if len(parts) != 3 or not all(parts):
        raise OrbitArgumentError(
            f"{where}: section={_shown(section)} is not a transition; give 'automaton: source -> target' or "
            "(automaton, source, target), three names (e.g. section='relay: on -> off')", "section", section)
    automata = {a.name: a for a in model.automata}
    if parts[0] not in automata:
        raise OrbitArgumentError(f"{where}: section automaton {parts[0]!r} is not one of the model's "
                                 f"({', '.join(automata)})", "section", section)
    transitions = [(t.source, t.target) for t in automata[parts[0]].transitions]
    if parts[1:] not in transitions:
        raise OrbitArgumentError(f"{where}: automaton {parts[0]!r} has no transition {parts[1]} → {parts[2]}; its "
                                 "transitions: " + ", ".join(f"{s} → {t}" for s, t in transitions), "section", section)
    return parts


def checked_x0(x0, model, where: str = "periodic_orbit") -> np.ndarray:
    """``x0`` (the model's initial state when ``None``) as n finite floats."""
    if x0 is None:
        return np.asarray(model.initial_state(), dtype=float)
    names = [s.name for s in model.states]
    values = np.asarray(x0, dtype=object).ravel() if not isinstance(x0, str) else None
    ok = values is not None and np.ndim(x0) <= 1 and len(values) == len(names) \
        and all(is_number(v) and math.isfinite(float(v)) for v in values)
    if not ok:
        raise OrbitArgumentError(f"{where}: x0={_shown(x0)} is not a state; give {len(names)} finite number(s), "
                                 f"one per state ({', '.join(names)}), or None for the model's initial state",
                                 "x0", x0)
    return values.astype(float)


def checked_mode(mode, model, where: str = "periodic_orbit") -> None:
    """``mode`` (``None``, or any form :meth:`HybridModel.mode` takes) names a mode of ``model``; an unknown
    automaton or state raises the model's own error, naming it."""
    if mode is None:
        return
    try:
        model.mode(mode)
    except HybridBondGraphError:
        raise
    except (TypeError, ValueError, AttributeError, KeyError):
        raise OrbitArgumentError(f"{where}: mode={_shown(mode)} is not a mode; give None (the model's initial mode), "
                                 "a label such as 'on|off' or 'relay=on', or a mapping {automaton: state}",
                                 "mode", mode) from None


def python_method(method, where: str = "periodic_orbit") -> str:
    """The method the shooting runs use: ``method`` itself, or for a compiled one (``-jit``) and ``"auto"``
    its Python equivalent (the runs carry sensitivities, which only the Python methods integrate)."""
    try:
        cls = method_class(method)
    except OptionError as error:  # an unknown method, or not text: the message lists the methods
        raise OrbitArgumentError(f"{where}: method={_shown(method)}: {error}", "method", method) from None
    if getattr(cls, "compiled", False) or getattr(cls, "chooses", False):
        return cls.python.name
    return cls.name


def checked_orbit_arguments(model, period, section, crossings, x0, t0, method, rtol, atol, tol, max_iterations,
                            max_period, warmup, grazing_limit, criterion="error", mode=None) -> dict:
    """Every argument of :func:`~switching.analysis.orbits.periodic_orbit` checked (module docstring), as the
    values the shooting takes."""
    where = "periodic_orbit"
    section = checked_section(section, model, where)
    if section is None and period is None:
        raise OrbitArgumentError(f"{where}: give a positive period=T [s] (got None) for a fixed-period orbit, or "
                                 "section=(automaton, source, target) for an autonomous one", "period", period)
    if period is not None:
        period = checked_number(where, "period", period, low=0.0, expected="the period in seconds, a positive "
                                "number (e.g. period=1/f_sw)")
    if section is not None and period is None and max_period is None:
        raise OrbitArgumentError(f"{where}: an autonomous orbit needs a horizon to look for its return to the "
                                 "section: pass max_period= (seconds) or a guess period= of the period",
                                 "max_period", max_period)
    if max_period is not None:
        max_period = checked_number(where, "max_period", max_period, low=0.0, expected="a positive number of seconds")
    if not isinstance(criterion, str) or criterion not in ("error", "residual"):
        raise OrbitArgumentError(f"{where}: criterion={_shown(criterion)}; give 'error' (the residual and the "
                                 "estimated error of the start within tol, the default) or 'residual' (the "
                                 "residual alone)", "criterion", criterion)
    checked_mode(mode, model, where)
    positive = "a positive number (e.g. 1e-10)"
    return dict(
        period=period, section=section, max_period=max_period, criterion=criterion, x0=checked_x0(x0, model, where),
        crossings=checked_number(where, "crossings", crossings, low=1.0, strict=False, integer=True,
                                 expected="an integer of at least 1 (the section's crossings per period)"),
        t0=checked_number(where, "t0", t0, expected="the start time in seconds, a finite number"),
        method=python_method(method, where),
        rtol=checked_number(where, "rtol", rtol, low=0.0, expected=positive),
        atol=checked_number(where, "atol", atol, low=0.0, expected=positive),
        tol=checked_number(where, "tol", tol, low=0.0, expected="a positive number, the relative error of the "
                           "orbit's start to reach (e.g. 1e-8)"),
        max_iterations=checked_number(where, "max_iterations", max_iterations, low=0.0, strict=False, integer=True,
                                      expected="an integer of at least 0 (Newton steps at most, e.g. 20)"),
        warmup=checked_number(where, "warmup", warmup, low=0.0, strict=False, integer=True,
                              expected="an integer of at least 0 (periods of plain iteration)"),
        grazing_limit=checked_number(where, "grazing_limit", grazing_limit, low=0.0, finite=False,
                                     expected="a positive number (default 1e3; inf for no limit)"))


def checked_values(values, parameter: str, where: str = "continue_orbit") -> list:
    """The continuation's parameter ``values``: one number or a flat sequence of finite numbers (at least one)."""
    if is_number(values):
        flat = [values]
    elif isinstance(values, np.ndarray):
        flat = list(values) if values.ndim == 1 else None
    elif isinstance(values, (list, tuple, range)):
        flat = list(values)
    else:
        flat = None
    if flat is None or not flat or not all(is_number(v) and math.isfinite(float(v)) for v in flat):
        raise ContinuationError(f"{where}: values={_shown(values)}: give one or more finite values of {parameter!r} "
                                "as numbers, a number or a flat list of numbers (e.g. values=[0.3, 0.35, 0.4], or "
                                "numpy.linspace(0.3, 0.5, 9))")
    return [float(v) for v in flat]


def checked_names(where: str, name: str, names, *, unique: bool = True, error=OrbitArgumentError) -> list:
    """``names``: one text or a sequence of texts, each once (with ``unique``)."""
    listed = [names] if isinstance(names, str) else (list(names) if isinstance(names, (list, tuple)) else None)
    if listed is None or not all(isinstance(n, str) and n for n in listed):
        message = f"{where}: {name}={_shown(names)}: give a name or a list of names"
        raise (error(message, name, names) if error is OrbitArgumentError else error(message))
    if unique:
        repeated = sorted({n for n in listed if listed.count(n) > 1})
        if repeated:
            message = (f"{where}: {name}={_shown(names)} names {', '.join(map(repr, repeated))} more than once; give "
                       "each name once")
            raise (error(message, name, names) if error is OrbitArgumentError else error(message))
    return listed


def checked_continuation_arguments(parameter, values, period, section, on_error, parameter_tol, signals, locate,
                                   switch_branch, fixed, warmup) -> tuple:
    """``continue_orbit``'s own arguments checked (a :class:`ContinuationError` naming the argument, the value
    and what to give): ``(values, signals, warmup)``."""
    where = "continue_orbit"
    if not isinstance(parameter, str) or not parameter:
        raise ContinuationError(f"{where}: parameter={_shown(parameter)}: give the name of the parameter (or build "
                                "argument) to follow, as text")
    if not isinstance(on_error, str) or on_error not in ("raise", "stop"):
        raise ContinuationError(f"{where}: on_error={_shown(on_error)}; use 'raise' or 'stop'")
    values = checked_values(values, parameter, where)
    if section is None and period is None:
        raise ContinuationError(f"{where}: give period=T [s] (a number or a callable of the parameter value) for a "
                                "fixed-period orbit, or section=(automaton, source, target)")
    if period is not None and not callable(period):
        checked_number(where, "period", period, low=0.0, error=ContinuationError,
                       expected="the period in seconds, a positive number, or a callable of the parameter value")
    checked_number(where, "parameter_tol", parameter_tol, low=4 * np.finfo(float).eps, strict=False,
                   error=ContinuationError, expected="the bracket's relative width at which a crossing is located, "
                   "a number from 8.9e-16 (4 eps) up (default 1e-9)")
    for name, flag in (("locate", locate), ("switch_branch", switch_branch)):
        if not isinstance(flag, (bool, np.bool_)):
            raise ContinuationError(f"{where}: {name}={_shown(flag)}; give True or False")
    if fixed is not None and not isinstance(fixed, dict):
        raise ContinuationError(f"{where}: fixed={_shown(fixed)}; give a dict of the build function's other "
                                "arguments, name → value")
    signals = checked_names(where, "signals", signals, error=ContinuationError) if signals else []
    warmup = checked_number(where, "warmup", warmup, low=0.0, strict=False, integer=True, error=ContinuationError,
                            expected="an integer of at least 0 (periods of plain iteration before the first point)")
    return values, tuple(signals), warmup
