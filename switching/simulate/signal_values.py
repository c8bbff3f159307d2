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

__all__ = ["POWER_PREFIX", "POWER_TOTALS", "signal_values", "signal_table", "element_power", "power_flows"]

#: signal names ``power:<element>`` (and the totals ``power:supplied``, …) give power flows
POWER_PREFIX = "power:"
#: the totals of :func:`power_flows`
POWER_TOTALS = ("supplied", "dissipated", "stored")


def signal_values(model, name: str, t: np.ndarray, x: np.ndarray, modes: tuple) -> np.ndarray:
    """A signal's finite part (or a power flow, the module docstring) at the samples: ``t`` (N,) [s],
    ``x`` (N, n), ``modes`` ``(numbers, distinct)``."""
    return signal_table(model, [name], t, x, modes)[name]


def signal_table(model, names, t: np.ndarray, x: np.ndarray, modes: tuple) -> dict:
    """Several signals (power flows among them) at the samples, name → (N,): the bond variables and
    signals they need evaluated together, one generated function per mode."""
    plain, powers = [], {}
    for name in names:
        if name.startswith(POWER_PREFIX):
            powers[name] = _power_terms(model, name[len(POWER_PREFIX):])
            plain += [term for _, element in powers[name] for term in _bond_names(model, element)]
        else:
            plain.append(name)
    values = _evaluated(model, list(dict.fromkeys(plain)), t, x, modes)
    for name, terms in powers.items():
        total = np.zeros(len(t))
        for sign, element in terms:
            effort, flow = _bond_names(model, element)
            total += sign * _bond_sign(model, element) * values[effort] * values[flow]
        values[name] = total
    return {name: values[name] for name in names}


def _evaluated(model, names: list, t, x, modes) -> dict:
    """The finite parts of ``names`` at the samples, one generated call per mode for all of them."""
    numbers, distinct = modes
    out = np.empty((len(names), len(t)))
    if not names:
        return {}
    for k, mode in enumerate(distinct):
        mask = numbers == k
        if not mask.any():
            continue
        fn = model.signal_function(mode, names)
        times = t[mask]
        values = np.empty((len(names), int(mask.sum())))
        try:
            fn(x[mask].T, times, model.parameter_array, model.input_signals.columns(times), values)
        except (TypeError, ValueError):  # a branch (step, sign, Piecewise) on arrays: one sample at a time
            for i, (state, tk) in enumerate(zip(x[mask], times)):
                fn(state, tk, model.parameter_array, model.input_values(tk), values[:, i])
        out[:, mask] = values
    return dict(zip(names, out))


def _power_terms(model, which: str) -> list:
    """``[(sign, element), ...]`` whose signed powers into the elements sum to ``power:<which>``."""
    if which in POWER_TOTALS and which not in model.graph.elements:
        kinds = {"supplied": (Source, -1), "dissipated": (R, 1), "stored": (Storage, 1)}
        kind, sign = kinds[which]
        return [(sign, name) for name, element in model.graph.elements.items() if isinstance(element, kind)]
    element = model.graph.element(which)
    if not isinstance(element, OnePort):
        raise HybridBondGraphError(
            f"{which!r} is a {type(element).__name__}, not a one-port element: power() is for sources, R, C "
            "and I elements (junctions and TF/GY pass power on)")
    return [(1, which)]


def _bond_names(model, element: str) -> tuple[str, str]:
    (bond,) = model.graph.bonds_of(element)
    return bond.effort.name, bond.flow.name


def _bond_sign(model, element: str) -> int:
    (bond,) = model.graph.bonds_of(element)
    return bond.sign_at(element)


def element_power(model, element: str, t, x, modes) -> np.ndarray:
    """The power into a one-port element [W] at the samples: ``e·f`` of its bond, signed by the bond's
    power direction (for an R the power it dissipates, for a C or I the rate of its energy, for a source
    minus what it supplies)."""
    return signal_table(model, [POWER_PREFIX + element], t, x, modes)[POWER_PREFIX + element]


def power_flows(model, t, x, modes) -> dict:
    """``"supplied"``, ``"dissipated"``, ``"stored"`` [W] at the samples (the module docstring)."""
    names = [POWER_PREFIX + which for which in POWER_TOTALS]
    table = signal_table(model, names, t, x, modes)
    return {which: table[POWER_PREFIX + which] for which in POWER_TOTALS}
