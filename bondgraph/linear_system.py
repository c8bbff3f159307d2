"""A numerical linear system with named signals, and its export to python-control.

:class:`LinearSystem` holds float matrices of

* continuous time (``dt == 0``): ``ẋ = A x + B u``, ``y = C x + D u``;
* discrete time (``dt > 0`` [s], the sampling period):
  ``x[k+1] = A x[k] + B u[k]``, ``y[k] = C x[k] + D u[k]``;

with ``A`` (n × n), ``B`` (n × m), ``C`` (p × n), ``D`` (p × m), the names of
the n states, m inputs and p outputs, and the units of whatever those are
(a bond graph's states are momenta [V·s, N·s] and charges or displacements
[C, m]; its inputs are source values).  It is what
:meth:`bondgraph.StateSpace.numeric` gives for one configuration and what a
periodic orbit's small-signal model is (:meth:`switching.PeriodicOrbit.small_signal`).

:meth:`LinearSystem.to_control` hands it to python-control, the standard
Python control-systems library (Bode plots, pole placement, LQR, ...), an
optional extra: ``pip install "hybrid-bondgraph[control]"``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import DerivationError, MissingDependencyError

__all__ = ["LinearSystem", "CONTROL_EXTRA", "import_control"]

#: the command that installs python-control with the toolkit
CONTROL_EXTRA = 'pip install "hybrid-bondgraph[control]"'


def import_control(what: str):
    """The ``control`` module, or :class:`MissingDependencyError` saying that
    ``what`` needs it and how to install it."""
    try:
        import control
    except ImportError as error:
        raise MissingDependencyError(
            f"{what} needs python-control, which is not installed here: {CONTROL_EXTRA} (or pip install control). "
            "Without it, the matrices and their names are still at hand (.A, .B, .C, .D, .states, .inputs, "
            ".outputs)") from error
    return control


@dataclass(frozen=True, eq=False)
class LinearSystem:
    """Float matrices ``A, B, C, D`` (see the module docstring for the
    equation form and shapes) with the names of the states, inputs and
    outputs.

    ``dt``: 0 for continuous time, else the sampling period [s].  ``name``:
    the system's name (the model and mode, or the orbit).  ``dependent``:
    states the system leaves out because its configuration holds them on a
    constraint (derivative causality), name → the constraint's right-hand
    side as text (``{"p_L": "0"}``); they are algebraic functions of the
    ``states`` and ``inputs``, and ask for them as outputs to see them.
    ``A, B, C, D = system`` unpacks the matrices."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    states: tuple
    inputs: tuple
    outputs: tuple
    dt: float = 0.0
    name: str = ""
    dependent: dict = field(default_factory=dict)

    def __post_init__(self):
        n, m, p = len(self.states), len(self.inputs), len(self.outputs)
        for label, matrix, shape in (("A", self.A, (n, n)), ("B", self.B, (n, m)), ("C", self.C, (p, n)),
                                     ("D", self.D, (p, m))):
            if np.shape(matrix) != shape:
                raise DerivationError(f"linear system {self.name!r}: {label} has shape {np.shape(matrix)}, expected "
                                      f"{shape} for {n} state(s), {m} input(s), {p} output(s)", [self.name])

    def __iter__(self):
        return iter((self.A, self.B, self.C, self.D))

    @property
    def is_discrete(self) -> bool:
        return self.dt > 0

    def to_control(self):
        """This system as a ``control.StateSpace`` (continuous time, or
        discrete with ``dt`` [s]), its states, inputs and outputs named as
        here and the system named :attr:`name`.

        Raises :class:`~bondgraph.errors.MissingDependencyError` without
        python-control, and :class:`~bondgraph.errors.DerivationError` for a
        system without inputs (python-control 0.10 cannot hold one: name an
        input, a source or a parameter) or with a name holding a ``.``
        (python-control's separator of a system and its signal)."""
        control = import_control(f"to_control() of {self.name or 'a linear system'}")
        if not self.inputs:
            raise DerivationError(
                f"to_control(): {self.name or 'the system'} has no inputs, and python-control cannot build a "
                "state-space system without one; name at least one input (a source or a parameter, inputs=[...])",
                [self.name])
        dotted = [name for name in (self.name, *self.states, *self.inputs, *self.outputs) if "." in name]
        if dotted:
            raise DerivationError(f"to_control(): python-control refuses names with a '.': {', '.join(dotted)}; "
                                  "rename them (outputs={new_name: expression} renames an output)", dotted)
        return control.ss(self.A, self.B, self.C, self.D, self.dt, states=list(self.states),
                          inputs=list(self.inputs), outputs=list(self.outputs), name=self.name or None)

    def __str__(self) -> str:
        kind = f"discrete, dt = {self.dt:.6g} s" if self.is_discrete else "continuous"
        lines = [f"{self.name or 'linear system'} ({kind})",
                 "  x = [" + ", ".join(self.states) + "]",
                 "  u = [" + ", ".join(self.inputs) + "]",
                 "  y = [" + ", ".join(self.outputs) + "]"]
        lines += [f"  {k} held on a constraint: {k} = {v}" for k, v in self.dependent.items()]
        for label, matrix in zip("ABCD", self):
            text = np.array2string(np.asarray(matrix), precision=6).replace("\n", "\n      ")
            lines.append(f"  {label} = {text}")
        return "\n".join(lines)
