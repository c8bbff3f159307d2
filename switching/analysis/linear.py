"""Small-signal models: the linear state space of one mode, and the discrete
linearization of a periodic orbit's period map (issue 31, item 4).

**A mode** (:func:`state_space`, also ``model.state_space(mode)``): in a mode
whose equations are linear, ``ẋ_i = A x_i + B u``, ``y = C x_i + D u`` with
``x_i`` the mode's *independent* states (a state the mode holds dependent, on
a constraint ``x_d = K x_i + L u``, is left out and named in ``dependent``),
``u`` the inputs (by default every source's value, then the declared inputs;
:meth:`bondgraph.ConfigurationEquations.state_space`) and ``y`` the named
outputs (by default the independent states: ``C = I``, ``D = 0``).  Units are
the states' (momenta [V·s, N·s], charges [C], displacements [m]) per second,
per unit of each input.

**An orbit** (:func:`orbit_small_signal`, also ``orbit.small_signal()``): a
perturbation ``δx_k`` of the state at the orbit's start, period after period,
with model parameters ``p`` (the inputs, held constant over each period) moved
by ``δu_k``, obeys to first order

    ``δx_{k+1} = A_d δx_k + B_d δu_k``,  ``y_k = C δx_k + D δu_k``,

with ``A_d`` (n × n) the Jacobian of the period map: for a fixed period the
monodromy ``M = ∂x(t0 + T)/∂x0``; for an autonomous orbit the return map's
``DP = M + f⁺ τ_x`` (the event-time term moves the end to the section, so
``DP`` maps the flow direction to 0 and its other eigenvalues are the
nontrivial multipliers). ``B_d`` (n × m): the period map's derivative with
respect to the parameters, ``∂x(t0 + T)/∂p`` from the forward sensitivities
(autonomous: ``S_p(τ⁺) + f⁺ τ_p``); ``C``, ``D``: the Jacobians of the output
signals (finite parts) with respect to the state and the parameters at the
orbit's start ``(x0, t0)`` in its start mode.  The sampling period is the
orbit's period ``T`` (autonomous orbits: the nominal one; the perturbed
return times differ to first order).  Every state is kept, so ``A_d``, like
``M``, is n × n even where the start mode holds some states dependent.
"""

from __future__ import annotations

import numpy as np

from bondgraph.linear_system import LinearSystem

from ..errors import OrbitError
from .orbit_arguments import checked_names
from .sensitivity import INITIAL_PREFIX, derivatives, parse_names

__all__ = ["state_space", "orbit_small_signal"]


def state_space(model, mode=None, outputs=None, inputs=None, numeric: bool = True):
    """The state-space matrices of one mode of ``model`` (the mathematics: the module docstring).

    ``mode``: any form :meth:`HybridModel.mode` takes (a :class:`Mode`, a
    label ``"on|off"``, ``"pwm=on, diode=off"``, a tuple of states, a mapping
    {automaton: state}); default the initial mode.  ``outputs``: names of
    states, bond variables (``e_<bond>``, ``f_<bond>``) or the model's
    signals, or a dict name → expression; default the independent states.
    ``inputs``: the input symbols or names (parameters or declared inputs),
    default every source's value.

    ``numeric=True``: a :class:`~bondgraph.linear_system.LinearSystem`, the
    model's parameter values substituted (float ``A, B, C, D``; ``states``,
    ``inputs``, ``outputs`` as names; ``dependent``: the states left out, with
    their constraints; ``.to_control()``), named ``"<model>[<mode>]"``.
    ``numeric=False``: the symbolic :class:`~bondgraph.StateSpace` over the
    independent states (``.numeric(values)`` makes it numerical).

    Raises :class:`~bondgraph.errors.DerivationError` naming the rate or
    output that is not linear in the states and inputs."""
    mode = model.initial_mode if mode is None else model.mode(mode)
    equations = model.mode_equations(mode)
    if outputs is None:
        dependent = set(equations.equations.dependent)
        outputs = [x.name for x in equations.states if x not in dependent]
    symbolic = equations.state_space(outputs, inputs).reduced()
    if not numeric:
        return symbolic
    return symbolic.numeric(model.parameter_values, name=f"{model.name}[{mode.describe()}]")


def orbit_small_signal(orbit, inputs=(), outputs=None) -> LinearSystem:
    """The discrete small-signal model of ``orbit`` (a
    :class:`~switching.analysis.orbits.PeriodicOrbit`; the mathematics: the
    module docstring), a :class:`~bondgraph.linear_system.LinearSystem` with
    ``dt`` the period [s].

    ``inputs``: model parameter names (each held constant over a period);
    ``outputs``: names of states, bond variables or signals, default the
    states.  Named ``"<model>_orbit"``.  One run over a period from the orbit's start, with forward
    sensitivities, gives ``A_d`` and ``B_d``."""
    shooter, mode = orbit.shooting
    model = shooter.model
    inputs = _parameter_names(model, inputs)
    A, B = shooter.linearization(orbit.x0, mode, inputs)
    outputs = list(model.state_names) if outputs is None else checked_names("small_signal", "outputs", outputs,
                                                                            unique=False)
    C, D = _output_jacobians(model, orbit.modes[0], orbit.x0, orbit.t0, inputs, outputs)
    return LinearSystem(A, B, C, D, tuple(model.state_names), tuple(inputs), tuple(outputs), dt=float(orbit.period),
                        name=f"{model.name}_orbit")


def _parameter_names(model, inputs) -> list:
    """``inputs`` as a list of model parameter names, each once (checked: :func:`parse_names` lists the
    parameters; a name given twice is an :class:`~switching.errors.OrbitArgumentError`)."""
    if isinstance(inputs, (list, tuple)):  # a parameter's symbol stands for its name
        inputs = [getattr(p, "name", p) for p in inputs]
    inputs = checked_names("small_signal", "inputs", inputs)
    initial = [p for p in inputs if p.startswith(INITIAL_PREFIX)]
    if initial:
        raise OrbitError(f"small-signal inputs must be model parameters; {', '.join(initial)} name initial states, "
                         "which are the system's state already (δx)")
    if inputs:
        parse_names(model, inputs)
    return inputs


def _output_jacobians(model, mode, x0, t0: float, inputs: list, outputs: list) -> tuple:
    """``(C, D)``: ``∂y/∂x`` (p × n) and ``∂y/∂p`` (p × m) of the outputs' finite parts at ``(x0, t0)`` in ``mode``."""
    n = len(model.states)
    symbols = parse_names(model, inputs).symbols if inputs else ()
    d = derivatives(model, symbols)
    rows = []
    for name in outputs:
        model.signal_expression(name)  # an unknown name raises here, listing the signals
        _, gradient = d.signal(mode, name)
        rows.append(gradient(np.asarray(x0, dtype=float).tolist(), float(t0), model.parameter_array.tolist(),
                             model.input_values(t0), np.empty(n + len(symbols))))
    jacobian = np.array(rows, dtype=float).reshape(len(outputs), n + len(symbols))
    return jacobian[:, :n], jacobian[:, n:]
