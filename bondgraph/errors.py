"""The toolkit's one exception hierarchy (DESIGN §9).

Every error derives from :class:`HybridBondGraphError`, so ``except
HybridBondGraphError`` catches anything the toolkit raises on purpose.  Each
error names the culprit (element, bond, mode, time, values) and says what to do.
The ``switching`` and ``codegen`` packages raise subclasses defined here or
derive their own from these bases, so the hierarchy stays single.
"""

from __future__ import annotations

from collections.abc import Iterable

__all__ = [
    "HybridBondGraphError",
    "InvalidGraphError",
    "UnknownNameError",
    "DuplicateNameError",
    "CausalityConflictError",
    "AlgebraicLoopError",
    "MissingParameterError",
    "UnknownParameterError",
    "DerivationError",
]


class HybridBondGraphError(Exception):
    """Base class of every error the toolkit raises on purpose."""


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


class CausalityConflictError(HybridBondGraphError):
    """Sources (or switched-off junctions) impose the same effort or flow twice.

    ``elements`` names the sources and the junction where they meet."""

    def __init__(self, message: str, elements: Iterable[str] = ()):
        super().__init__(message)
        self.elements = tuple(elements)


class AlgebraicLoopError(HybridBondGraphError):
    """An algebraic loop that cannot be solved symbolically (nonlinear with no
    unique closed-form solution, or singular).  ``elements`` are the elements in
    the loop."""

    def __init__(self, message: str, elements: Iterable[str] = ()):
        super().__init__(message)
        self.elements = tuple(elements)


class MissingParameterError(HybridBondGraphError, KeyError):
    """Parameters used by the model have no numerical value; ``missing`` lists
    all of them at once."""

    def __init__(self, missing: Iterable[str]):
        self.missing = tuple(sorted(missing))
        super().__init__(
            f"{len(self.missing)} parameter(s) have no value: {', '.join(self.missing)}. "
            "Pass a value for each (e.g. parameters={'%s': ...})." % self.missing[0]
        )

    def __str__(self) -> str:
        return str(self.args[0])


class UnknownParameterError(HybridBondGraphError, KeyError):
    """Values were given for names the model does not use (usually a typo)."""

    def __init__(self, unknown: Iterable[str], known: Iterable[str]):
        self.unknown = tuple(sorted(unknown))
        known = sorted(known)
        super().__init__(
            f"unknown parameter(s) {', '.join(self.unknown)}; the model's parameters are: "
            f"{', '.join(known) if known else '(none)'}"
        )

    def __str__(self) -> str:
        return str(self.args[0])


class DerivationError(HybridBondGraphError):
    """The symbolic derivation cannot proceed (e.g. a dependent storage element
    driven by an input whose derivative is unknown, or a nonlinear law that
    cannot be inverted for the causality the graph forces)."""

    def __init__(self, message: str, elements: Iterable[str] = ()):
        super().__init__(message)
        self.elements = tuple(elements)
