"""Errors of the switching layer; all derive from the toolkit's one base,
:class:`bondgraph.errors.HybridBondGraphError`."""

from __future__ import annotations

from bondgraph.errors import HybridBondGraphError, InvalidGraphError

__all__ = [
    "ModelDefinitionError",
    "GuardSyntaxError",
    "DivergenceOfTimeError",
    "TooManyStepsError",
    "ImpulseError",
]


class ModelDefinitionError(InvalidGraphError):
    """Automata that do not fit the bond graph or each other (an unknown
    junction or state, a junction driven by two automata, a controlled
    junction driven by none, conflicting restitution coefficients)."""


class GuardSyntaxError(HybridBondGraphError, ValueError):
    """A guard written as text could not be parsed; ``position`` is the
    character offset of the problem in ``text``."""

    def __init__(self, message: str, text: str = "", position: int | None = None):
        if position is not None and text:
            message = f"{message}\n    {text}\n    {' ' * position}^"
        super().__init__(message)
        self.text = text
        self.position = position


class DivergenceOfTimeError(HybridBondGraphError):
    """Mode resolution at one instant does not reach a real mode: a mode
    repeats in a chain of mythical modes, or a (mode, state) pair repeats among
    pinnacles.  ``loop`` lists the steps (mode, fired guards with their
    values); ``instant`` is the partial record of the instant."""

    def __init__(self, message: str, loop=(), instant=None):
        super().__init__(message)
        self.loop = tuple(loop)
        self.instant = instant


class TooManyStepsError(DivergenceOfTimeError):
    """More discrete steps at one instant than the configured cap."""


class ImpulseError(HybridBondGraphError):
    """A guard combines impulsive signals in a way that has no meaning
    (a product of two Dirac pulses, or a nonlinear function of one)."""
