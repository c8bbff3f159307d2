"""Whether a fixed-step run created energy in its flows.

An explicit fixed-step method can create energy that the model cannot:
Euler multiplies the energy of an undamped oscillator by ``1 + (h·ω)²`` at
every step, at any step size, and the stiffness check (which watches the
real axis) does not see it.  The energy balance of the flows says so:
between two samples ``k`` and ``k + 1`` of one flow,

    created_k = E(t_{k+1}) − E(t_k) − ∫ (P_supplied − P_dissipated) dt

with the integral by the trapezoidal rule on the samples (``E`` the energy
stored in the C and I elements [J], ``P`` the power balance
[W] of :meth:`~switching.simulate.trajectory.Trajectory.power_balance`);
the changes at instants (sample pairs at one time) are the ledger's.  The
run's created energy is the running sum; more than
:data:`CREATED_TOLERANCE` of the run's energy scale (its largest stored
energy, the energy supplied and the energy dissipated) warns once with
:class:`~bondgraph.EnergyGainWarning`, naming the time, the mode and the
remedy.  An accurate run creates none: its balance closes to the
quadrature's error (``O(h²)`` of the power, far below the tolerance at a
step that resolves the motion).
"""

from __future__ import annotations

import warnings

import numpy as np

from bondgraph.errors import EnergyGainWarning, HybridBondGraphError

__all__ = ["CREATED_TOLERANCE", "MAX_SAMPLES", "EnergyBalance", "energy_created", "warn_if_created"]

#: created energy beyond this fraction of the run's energy scale warns
CREATED_TOLERANCE = 0.05
#: runs with more samples are not checked (the balance evaluates every element's power at every sample)
MAX_SAMPLES = 200_000


class EnergyBalance:
    """The flows' energy balance of a run: ``created`` [J] (the running sum
    at every sample, zero at the first), ``scale`` [J] and ``first`` (the
    first sample where ``created`` exceeds the tolerance, or ``None``)."""

    def __init__(self, created: np.ndarray, scale: float):
        self.created, self.scale = created, scale
        over = np.flatnonzero(created > CREATED_TOLERANCE * scale) if scale > 0 else np.zeros(0, dtype=int)
        self.first = int(over[0]) if len(over) else None

    @property
    def total(self) -> float:
        """The energy the flows created over the run [J] (negative: lost beyond dissipation)."""
        return float(self.created[-1]) if len(self.created) else 0.0


def energy_created(trajectory) -> EnergyBalance | None:
    """The :class:`EnergyBalance` of ``trajectory`` from its samples, or
    ``None`` when it cannot be told (fewer than two samples, more than
    :data:`MAX_SAMPLES`, a storage law whose energy has no closed form)."""
    t = np.asarray(trajectory.t, dtype=float)
    if not 2 <= len(t) <= MAX_SAMPLES:
        return None
    try:
        stored = trajectory.energy()
        balance = trajectory.power_balance()
    except HybridBondGraphError:
        return None
    except Exception as exc:  # a finished run is never lost to its energy bookkeeping: the watch is skipped
        warnings.warn(f"the energy watch of this run was skipped: its stored energy or power could not be "
                      f"computed ({type(exc).__name__}: {exc}); the run itself is complete", RuntimeWarning,
                      stacklevel=7)
        return None
    net = balance["supplied"] - balance["dissipated"]
    dt = np.diff(t)
    with np.errstate(invalid="ignore", over="ignore"):
        increments = np.where(dt > 0, np.diff(stored) - 0.5 * (net[1:] + net[:-1]) * dt, 0.0)
        created = np.concatenate([[0.0], np.cumsum(increments)])
        work = np.concatenate([[0.0], np.cumsum(0.5 * (np.abs(balance["supplied"][1:]) + np.abs(balance["supplied"][:-1])
                                                       + np.abs(balance["dissipated"][1:])
                                                       + np.abs(balance["dissipated"][:-1])) * dt)])
    if not (np.all(np.isfinite(created)) and np.all(np.isfinite(stored))):
        return None
    return EnergyBalance(created, max(float(np.max(np.abs(stored))), float(work[-1])))


def warn_if_created(trajectory, method: str, dt) -> float | None:
    """Warn once (:class:`~bondgraph.EnergyGainWarning`) when the flows of
    ``trajectory`` (a run of the fixed-step ``method`` with step ``dt`` [s])
    created energy beyond the tolerance; returns the energy created [J], or
    ``None`` when it could not be told."""
    balance = energy_created(trajectory)
    if balance is None:
        return None
    k = balance.first
    if k is not None:
        mode = trajectory.modes[k]
        where = f" (in mode {mode.describe()})" if mode.automata else ""
        warnings.warn(
            f"{method} with dt = {dt:g} s created energy in the flows: {balance.created[k]:.6g} J by t = "
            f"{trajectory.t[k]:.12g} s{where}, {balance.total:.6g} J over the run, against an energy scale of "
            f"{balance.scale:.6g} J (the stored energy's change beyond what the sources supplied and the resistors "
            "took). The model creates none: the step is too long for its fastest dynamics (an explicit method "
            "gains energy on a fast oscillation). Take a smaller dt, rk4, or an adaptive or implicit method "
            "(RK45, Radau)", EnergyGainWarning, stacklevel=6)  # (the caller of HybridModel.simulate)
    return balance.total
