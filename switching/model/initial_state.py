"""The initial state of a run: the given values projected onto the constraints
of the initial mode by its jump map at ``t = 0``, ``x₀ = g(x_given)`` (no
restitution: a projection is not an impact)."""

from __future__ import annotations

import warnings

import numpy as np

from bondgraph.errors import FloatingPartError


class InitialStateProjected(UserWarning):
    """The given initial state violated the initial mode's constraints and was projected."""


def projected(model, x_given: np.ndarray) -> np.ndarray:
    """``g(x_given)`` of the initial mode's jump map (no restitution), at ``t = 0``.
    Where the mode carries no restitution its generated jump function is
    that map, so a process whose cache holds the mode's code derives
    nothing; otherwise the symbolic map is used.  An initial mode with a
    floating part (:class:`~bondgraph.errors.FloatingPartError`) is refused
    here, the message saying it is the initial mode."""
    try:
        return _projected(model, x_given)
    except FloatingPartError as error:
        raise FloatingPartError(f"the initial mode (t = 0): {error}", error.elements, error.cut,
                                error.configuration, error.kind) from None


def _projected(model, x_given: np.ndarray) -> np.ndarray:
    mode = model.initial_mode
    if model.restitution_of(mode) is None:
        compiled = model.compiled_mode(mode)
        if compiled.jump_kind in ("identity", "symbolic"):
            return compiled.jump(np.asarray(x_given, dtype=float), 0.0)
    me = model.mode_equations(mode)
    return me.jump.apply(x_given, 0.0, model.parameter_values_with_inputs(0.0)) if not me.jump.is_identity else x_given


def initial_state(model, x_given: np.ndarray) -> tuple[np.ndarray, tuple | None]:
    """The projected initial state and, where the projection changed it,
    ``(given, projected)`` (else ``None``); an :class:`InitialStateProjected`
    warning names every changed state."""
    x0 = np.asarray(projected(model, x_given), dtype=float)
    if np.array_equal(x0, x_given) or np.allclose(x0, x_given, rtol=1e-12, atol=1e-14):  # (the first, cheap)
        return x0, None
    changed = [f"{s}: {a:.6g} → {b:.6g}" for s, a, b in zip(model.states, x_given, x0) if not np.isclose(a, b)]
    warnings.warn(f"initial state violates the constraints of mode {model.initial_mode.describe()}; projected by "
                  f"conservation of state: {', '.join(changed)}", InitialStateProjected, stacklevel=4)
    return x0, (x_given.copy(), x0.copy())
