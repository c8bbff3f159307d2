"""The toolkit's one exception hierarchy (DESIGN §9).

Every error derives from :class:`HybridBondGraphError`, so ``except
HybridBondGraphError`` catches anything the toolkit raises on purpose.  Each
error names the culprit (element, bond, mode, time, values) and says what to do.
The ``switching`` and ``codegen`` packages raise subclasses defined here or
derive their own from these bases, so the hierarchy stays single.
"""

from __future__ import annotations

import copy
import difflib
from collections.abc import Iterable

__all__ = [
    "HybridBondGraphError",
    "InvalidGraphError",
    "UnknownNameError",
    "DuplicateNameError",
    "NameCollisionError",
    "CausalityConflictError",
    "FloatingPartError",
    "AlgebraicLoopError",
    "MissingParameterError",
    "UnknownParameterError",
    "DerivationError",
    "ParameterValueError",
    "MissingDependencyError",
    "PhysicalRangeWarning",
    "EnergyGainWarning",
    "CoarseStepWarning",
    "prefixed",
]


def _restore(cls, args, state):
    """Rebuild a pickled error without calling its ``__init__`` (whose
    signature differs from ``args``, e.g. :class:`UnknownParameterError`)."""
    error = cls.__new__(cls, *args)
    error.args = args
    error.__dict__.update(state)
    return error


def close_names(name: str, known, n: int = 3) -> list[str]:
    """Up to ``n`` names of ``known`` that ``name`` may be a misspelling of (closest first)."""
    return difflib.get_close_matches(str(name), [str(k) for k in known], n=n)


def did_you_mean(name: str, known) -> str:
    """`` (did you mean 'a' or 'b'?)`` for the names of ``known`` close to ``name``, else ``''``:
    the hint every error about an unknown name ends with."""
    close = close_names(name, known)
    return f" (did you mean {' or '.join(map(repr, close))}?)" if close else ""


def prefixed(error: Exception, prefix: str, suffix: str = "") -> Exception:
    """A copy of ``error`` (same type, same attributes) whose message begins with ``prefix``
    (``"mode S1=closed, D1=on: "``, ``"at t = 0.001, "``) and ends with ``suffix``: context added
    where it is known."""
    other = copy.copy(error)
    other.args = (f"{prefix}{error}{suffix}",) + tuple(error.args[1:])
    return other


class HybridBondGraphError(Exception):
    """Base class of every error the toolkit raises on purpose.

    Every error of the hierarchy pickles and unpickles with its message and
    attributes (a sweep's worker sends it to the parent process), whatever its
    ``__init__`` takes."""

    def __reduce__(self):
        return _restore, (type(self), self.args, dict(self.__dict__))


class InvalidGraphError(HybridBondGraphError, ValueError):
    """The bond graph is malformed: a dangling or over-connected element, a
    TF/GY without exactly one bond in and one out, a junction with no bonds,
    a bond from an element to itself.  ``elements`` lists the culprits."""

    def __init__(self, message: str, elements: Iterable[str] = ()):
        super().__init__(message)
        self.elements = tuple(elements)


class UnknownNameError(HybridBondGraphError, KeyError):
    """A name (element, port, bond, state, parameter) that the graph does not have."""

    def __init__(self, message: str, name: str = ""):
        super().__init__(message)
        self.name = name

    def __str__(self) -> str:  # KeyError would otherwise quote the message
        return str(self.args[0])


class DuplicateNameError(HybridBondGraphError, ValueError):
    """Two elements, states or symbols share one name."""

    def __init__(self, message: str, name: str = ""):
        super().__init__(message)
        self.name = name


class NameCollisionError(DuplicateNameError):
    """One name would stand for two quantities (:mod:`bondgraph.namespace`):
    a resistor named ``S1_period`` beside a PWM switch ``S1`` (whose period
    is the parameter ``S1_period``), a parameter named after a bond's flow
    ``f_sw``, a component named ``t``.  ``name`` is the name and ``owners``
    the descriptions of the two quantities; the message says how to rename."""

    def __init__(self, message: str, name: str = "", owners: tuple = ()):
        super().__init__(message, name)
        self.owners = tuple(owners)


class CausalityConflictError(HybridBondGraphError):
    """Sources (or switched-off junctions) impose the same effort or flow twice.

    ``elements`` names the sources and the junction where they meet."""

    def __init__(self, message: str, elements: Iterable[str] = ()):
        super().__init__(message)
        self.elements = tuple(elements)


class FloatingPartError(CausalityConflictError):
    """Part of the graph is *under-determined* (the opposite of a conflict):
    nothing fixes the effort of some junctions — they float — or the flow
    around a loop of junctions.  In a circuit: every diode and switch around
    a group of nodes blocks (a full bridge rectifier with all four diodes
    off), so the group's common voltage is free; or ideal closed switches
    form a loop, so the current around it is free.

    ``elements`` names the floating junctions; ``cut`` the switched-off
    junctions (and sources) that isolate them; ``configuration`` is the
    configuration (controlled junction → on/off) and ``kind`` is
    ``"effort"`` (floating efforts) or ``"flow"`` (a free loop flow).  A
    subclass of :class:`CausalityConflictError`, which code catching a
    conflict already catches."""

    def __init__(self, message: str, elements: Iterable[str] = (), cut: Iterable[str] = (),
                 configuration: dict | None = None, kind: str = "effort"):
        super().__init__(message, elements)
        self.cut = tuple(cut)
        self.configuration = dict(configuration or {})
        self.kind = kind


class AlgebraicLoopError(HybridBondGraphError):
    """An algebraic loop that cannot be solved symbolically (nonlinear with no
    unique closed-form solution, or singular).  ``elements`` are the elements in
    the loop."""

    def __init__(self, message: str, elements: Iterable[str] = ()):
        super().__init__(message)
        self.elements = tuple(elements)


class MissingParameterError(HybridBondGraphError, KeyError):
    """Parameters used by the model have no numerical value; ``missing`` lists
    all of them at once.  ``hints`` maps a name to where it was met when that
    tells more than "no value" — a name written in a guard or signal that is
    no state, signal or parameter of any law is more often a typo than a
    parameter."""

    def __init__(self, missing: Iterable[str], hints: dict | None = None):
        self.missing = tuple(sorted(missing))
        self.hints = dict(hints or {})
        lines = [
            f"{len(self.missing)} parameter(s) have no value: {', '.join(self.missing)}. "
            "Pass a value for each (e.g. parameters={'%s': ...})." % self.missing[0]
        ]
        lines += [f"  {name}: {self.hints[name]}" for name in self.missing if name in self.hints]
        super().__init__("\n".join(lines))

    def __str__(self) -> str:
        return str(self.args[0])


class UnknownParameterError(HybridBondGraphError, KeyError):
    """Values were given for names that no law, guard, signal or jump of the
    model uses (usually a typo); the message offers the closest names."""

    def __init__(self, unknown: Iterable[str], known: Iterable[str]):
        self.unknown = tuple(sorted(unknown))
        known = sorted(known)
        lines = [
            f"value(s) given for {', '.join(self.unknown)}, which no law, guard, signal or jump of the model "
            f"uses; the model's parameters are: {', '.join(known) if known else '(none)'}"
        ]
        for name in self.unknown:
            close = close_names(name, known)
            if close:
                lines.append(f"  {name}: did you mean {' or '.join(map(repr, close))}?")
        super().__init__("\n".join(lines))

    def __str__(self) -> str:
        return str(self.args[0])


class DerivationError(HybridBondGraphError):
    """The symbolic derivation cannot proceed (e.g. a dependent storage element
    driven by an input whose derivative is unknown, or a nonlinear law that
    cannot be inverted for the causality the graph forces)."""

    def __init__(self, message: str, elements: Iterable[str] = ()):
        super().__init__(message)
        self.elements = tuple(elements)


class ParameterValueError(HybridBondGraphError, ValueError):
    """A parameter, initial value or option has a value the toolkit cannot
    compute with (NaN, infinite where a finite number is needed, not a
    number).  ``name`` is the culprit and ``value`` its value."""

    def __init__(self, message: str, name: str = "", value=None):
        super().__init__(message)
        self.name = name
        self.value = value


class MissingDependencyError(HybridBondGraphError, ImportError):
    """An optional dependency of a feature is not installed; the message
    names the extra that installs it (and what works without it)."""


class PhysicalRangeWarning(UserWarning):
    """A value the toolkit can compute with but that lies outside the physical
    range the model states (a negative capacitance, a restitution coefficient
    above 1): the run goes on, the result may not be physical."""


class CoarseStepWarning(UserWarning):
    """A fixed-step run whose own error estimate (step doubling on a sample
    of its steps) is large: its instants and states may be far from the
    model's.  The message gives the estimate and the step to take."""


class EnergyGainWarning(UserWarning):
    """An instant after which the stored energy is larger than before it (by
    more than round-off): a jump of a passive model only loses energy, so a
    gain points at a wrong jump map, restitution above 1 or a source that
    acts through the jump.  The message names the instant's time and modes."""
