"""A model's named signals and power flows at many samples ``(t_j, x_j, mode_j)``.

Each signal's finite part is evaluated by the generated code of each mode,
one vectorized call per mode (:meth:`HybridModel.signal_function`); the
samples' modes come numbered (:func:`switching.simulate.dense_rows.numbered`).
Power flows [W]: ``"power:<element>"`` is ``e·f`` of a one-port element's
bond signed by its power direction (the power into it), ``"power:supplied"``,
``"power:dissipated"`` and ``"power:stored"`` the sums over the sources (what
they deliver), the R and the C and I elements, ``supplied = dissipated +
stored`` during flow.  A trajectory's rows use them
(:meth:`Trajectory.signal`), and so do the measurements' quadrature nodes.
"""

from __future__ import annotations

import numpy as np

from bondgraph.elements import R, OnePort, Source, Storage
from bondgraph.errors import HybridBondGraphError

__all__ = ["POWER_PREFIX", "POWER_TOTALS", "signal_values", "element_power", "power_flows"]

#: signal names ``power:<element>`` (and the totals ``power:supplied``, …) give power flows
POWER_PREFIX = "power:"
#: the totals of :func:`power_flows`
POWER_TOTALS = ("supplied", "dissipated", "stored")


def signal_values(model, name: str, t: np.ndarray, x: np.ndarray, modes: tuple) -> np.ndarray:
    """A signal's finite part (or a power flow, the module docstring) at the samples: ``t`` (N,) [s],
    ``x`` (N, n), ``modes`` ``(numbers, distinct)``."""
    if name.startswith(POWER_PREFIX):
        which = name[len(POWER_PREFIX):]
        if which in POWER_TOTALS and which not in model.graph.elements:
            return power_flows(model, t, x, modes)[which]
        return element_power(model, which, t, x, modes)
    numbers, distinct = modes
    out = np.empty(len(t))
    for k, mode in enumerate(distinct):
        mask = numbers == k
        if not mask.any():
            continue
        fn = model.signal_function(mode, [name])
        times = t[mask]
        values = np.empty((1, int(mask.sum())))
        try:
            fn(x[mask].T, times, model.parameter_array, model.input_columns(times), values)
        except (TypeError, ValueError):  # a branch (step, sign, Piecewise) on arrays: one sample at a time
            for i, (state, tk) in enumerate(zip(x[mask], times)):
                fn(state, tk, model.parameter_array, model.input_values(tk), values[:, i])
        out[mask] = values[0]
    return out


def element_power(model, element: str, t, x, modes) -> np.ndarray:
    """The power into a one-port element [W] at the samples: ``e·f`` of its bond, signed by the bond's
    power direction (for an R the power it dissipates, for a C or I the rate of its energy, for a source
    minus what it supplies)."""
    if not isinstance(model.graph.element(element), OnePort):
        raise HybridBondGraphError(
            f"{element!r} is a {type(model.graph.element(element)).__name__}, not a one-port element: "
            "power() is for sources, R, C and I elements (junctions and TF/GY pass power on)")
    (bond,) = model.graph.bonds_of(element)
    effort = signal_values(model, bond.effort.name, t, x, modes)
    return bond.sign_at(element) * effort * signal_values(model, bond.flow.name, t, x, modes)


def power_flows(model, t, x, modes) -> dict:
    """``"supplied"``, ``"dissipated"``, ``"stored"`` [W] at the samples (the module docstring)."""
    out = {key: np.zeros(len(t)) for key in POWER_TOTALS}
    for name, element in model.graph.elements.items():
        if isinstance(element, Source):
            out["supplied"] -= element_power(model, name, t, x, modes)
        elif isinstance(element, R):
            out["dissipated"] += element_power(model, name, t, x, modes)
        elif isinstance(element, Storage):
            out["stored"] += element_power(model, name, t, x, modes)
    return out
