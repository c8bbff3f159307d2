"""A time budget for one symbolic step of a derivation.

sympy cannot be interrupted cooperatively: ``solve`` of a law with floats in
it (a diode ``Is*(exp(e/VT) - 1)`` with ``Is = 1e-12``) may run for hours.
:func:`run` calls a step and stops it once it has run for longer than the
budget, raising :class:`OverBudget`; the caller then falls back (the
unsimplified form, a conservative answer) or raises an error of the
hierarchy that names the element and the law.

How a step is stopped:

* in the main thread of a Unix process, by ``SIGALRM`` from an interval
  timer (``setitimer``).  Any handler and timer already set (``pytest-timeout``,
  the user's own alarm) are put back afterwards, the timer with what was left
  of it; an outer alarm due before the budget ends is left to fire itself.
* in any other thread (a Dask worker thread, a GUI's worker), by a watchdog
  thread that raises the stop in the step's thread
  (``PyThreadState_SetAsyncExc``), and raises it again every
  :data:`_REPEAT` seconds until the step has stopped: Python ignores an
  exception raised inside a weakref callback, a ``__del__`` or a generator the
  garbage collector closes, and the step would run on after a single stop.
  A stop that lands inside the thread's trace or profile function (a
  debugger, coverage) makes Python remove it: it is put back afterwards.

Either way the stop is an exception (a ``BaseException``, so sympy's own
``except Exception`` clauses do not swallow it) raised inside the step.  In
the main thread it comes even from inside C-level arithmetic on huge
integers (which checks for signals; sympy gets there when it raises
``10¹²`` to a large power).  Off the main thread it comes at the next
bytecode the interpreter runs: a single C-level operation runs to its end
there, which is why :mod:`bondgraph.solving` takes the numbers out of a law
before solving.  A bare ``except:`` inside sympy that swallowed one stop
meets the next.

The budget, in seconds per step: :data:`SECONDS` when set (``None`` by
default), else the environment variable ``HBG_SYMBOLIC_BUDGET``, else
:data:`DEFAULT_SECONDS`.  ``0``, ``off`` or ``none`` turns the budget off.
"""

from __future__ import annotations

import ctypes
import math
import os
import signal
import sys
import threading
import time
from collections.abc import Callable

from .errors import DerivationError

__all__ = ["DEFAULT_SECONDS", "ENVIRONMENT_VARIABLE", "SECONDS", "OverBudget", "budget_seconds", "run", "run_within"]

#: the budget of one symbolic step when neither :data:`SECONDS` nor the environment sets it
DEFAULT_SECONDS = 5.0
#: the environment variable that sets the budget (seconds; ``0``/``off``/``none`` for none)
ENVIRONMENT_VARIABLE = "HBG_SYMBOLIC_BUDGET"
#: the budget set in code (seconds, ``0`` for none); ``None``: the environment or the default
SECONDS: float | None = None

#: after the budget, the alarm repeats at this interval until the step has stopped
#: (in case a bare ``except:`` inside sympy swallowed the first one)
_REPEAT = 0.05


class OverBudget(DerivationError):
    """A symbolic step ran past its time budget.  ``step`` says which and
    ``seconds`` what the budget was; callers turn it into a fallback or a
    :class:`~bondgraph.errors.DerivationError` naming the element."""

    def __init__(self, step: str, seconds: float):
        shown = f"{seconds:g}" if isinstance(seconds, (int, float)) else seconds
        super().__init__(
            f"{step} took longer than its budget of {shown} s and was stopped "
            f"(set {ENVIRONMENT_VARIABLE} or bondgraph.budget.SECONDS for a larger budget)"
        )
        self.step = step
        self.seconds = seconds


class _Expired(BaseException):
    """Raised inside the step by the alarm; ``args[0]`` is the budget's token."""


def budget_seconds() -> float | None:
    """The budget of one step in seconds, ``None`` when it is off."""
    value = SECONDS
    if value is None:
        text = os.environ.get(ENVIRONMENT_VARIABLE, "").strip().lower()
        if not text:
            value = DEFAULT_SECONDS
        elif text in ("off", "none"):
            return None
        else:
            try:
                value = float(text)
            except ValueError:
                raise DerivationError(
                    f"{ENVIRONMENT_VARIABLE}={os.environ[ENVIRONMENT_VARIABLE]!r} is not a number of seconds; "
                    "give e.g. 5, or 0 (or off) for no budget"
                ) from None
    value = float(value)
    if math.isnan(value) or value <= 0 or math.isinf(value):
        return None
    return value


def run(step: str, function: Callable, *args, **kwargs):
    """``function(*args, **kwargs)`` stopped after the budget: raises
    :class:`OverBudget` (naming ``step``) if it has not returned by then."""
    return run_within(budget_seconds(), step, function, *args, **kwargs)


def run_within(limit: float | None, step: str, function: Callable, *args, **kwargs):
    """:func:`run` with the budget at most ``limit`` seconds (``None``: the
    budget as set): a step with a cheaper fallback (a numeric inverse)
    need not wait for the whole budget."""
    seconds = budget_seconds()
    if limit is not None and seconds is not None:
        seconds = min(seconds, limit)
    if seconds is None:
        return function(*args, **kwargs)
    token = object()
    _quiet_ignored_stops()
    if _can_alarm():
        outcome = _with_alarm(token, seconds, function, args, kwargs)
    else:
        outcome = _with_watchdog(token, seconds, function, args, kwargs)
    if outcome is token:
        raise OverBudget(step, seconds)
    return outcome


#: the hook that ``_drop_stops`` hands every other unraisable exception to
_next_unraisable_hook = sys.__unraisablehook__


def _quiet_ignored_stops() -> None:
    """Install :func:`_drop_stops` as ``sys.unraisablehook`` (in front of the
    hook set now) unless it is there."""
    global _next_unraisable_hook
    if sys.unraisablehook is not _drop_stops:
        _next_unraisable_hook = sys.unraisablehook
        sys.unraisablehook = _drop_stops


def _drop_stops(unraisable) -> None:
    """A stop that lands where Python ignores exceptions (a weakref callback,
    a ``__del__``) is sent again; it is not an error to print ("Exception
    ignored in ...").  Anything else goes on to the hook that was there."""
    if not isinstance(unraisable.exc_value, _Expired):
        _next_unraisable_hook(unraisable)


def _can_alarm() -> bool:
    """Whether this thread can use ``SIGALRM`` (main thread, Unix, a handler
    that Python can put back)."""
    return (hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread()
            and signal.getsignal(signal.SIGALRM) is not None)


def _with_alarm(token, seconds, function, args, kwargs):
    """The step under an interval timer; ``token`` if it ran out of time."""
    previous_delay, previous_interval = signal.getitimer(signal.ITIMER_REAL)
    if 0 < previous_delay <= seconds:  # an outer alarm comes first: it stops the step itself
        return function(*args, **kwargs)
    active = [True]

    def alarm(signum, frame):
        if active[0]:
            raise _Expired(token)

    start = time.monotonic()
    previous_handler = signal.signal(signal.SIGALRM, alarm)
    outcome = token
    try:
        signal.setitimer(signal.ITIMER_REAL, seconds, _REPEAT)  # armed inside: it may fire at once
        outcome = function(*args, **kwargs)
        active[0] = False  # from here on the alarm is a no-op (no check of signals before this store)
    except _Expired as stop:
        active[0] = False
        if stop.args[0] is not token:
            raise
    finally:
        active[0] = False
        signal.setitimer(signal.ITIMER_REAL, 0)
        _let_pending_signals_run()  # a SIGALRM of ours still pending meets the no-op handler, not the previous one
        signal.signal(signal.SIGALRM, previous_handler)
        if previous_delay > 0:
            left = previous_delay - (time.monotonic() - start)
            signal.setitimer(signal.ITIMER_REAL, max(left, 1e-6), previous_interval)
    return outcome


def _let_pending_signals_run() -> None:
    """Python runs pending signal handlers on entering a function: this one."""


def _with_watchdog(token, seconds, function, args, kwargs):
    """The step in this thread, stopped by a watchdog thread once ``seconds``
    have passed; ``token`` if it ran out of time."""

    class Stop(_Expired):
        """This step's own stop: a stop pending for another step is not this one."""

    thread = threading.get_ident()
    lock = threading.Lock()
    finished = threading.Event()

    def watchdog():
        if finished.wait(seconds):
            return
        while True:
            with lock:
                if finished.is_set():
                    return
                _raise_in_thread(thread, Stop)
            if finished.wait(_REPEAT):
                return

    trace, profile = sys.gettrace(), sys.getprofile()  # a stop inside either removes it: put back after
    threading.Thread(target=watchdog, name="hbg-symbolic-budget", daemon=True).start()
    outcome = token
    try:
        outcome = function(*args, **kwargs)
    except Stop:
        outcome = token
    while True:  # a stop sent before the lock was ours arrives at the latest inside ``finished.set``
        try:
            with lock:
                finished.set()
            break
        except Stop:
            continue
    if sys.gettrace() is not trace:
        sys.settrace(trace)
    if sys.getprofile() is not profile:
        sys.setprofile(profile)
    return outcome


def _raise_in_thread(thread: int, exception_class) -> None:
    """Have ``exception_class`` raised in the thread ``thread`` at its next
    check of pending events (a call, a backward jump).  A stop is never
    withdrawn (``PyThreadState_SetAsyncExc(thread, NULL)``): on Python 3.11
    that leaves the interpreter's pending flag set, and a traced thread then
    spins on its next call for ever."""
    ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(thread), ctypes.py_object(exception_class))
