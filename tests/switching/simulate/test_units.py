"""Unit invariance (issue 12, item 2): the same physical model written in other
units gives the same hybrid run.

Every shipped model here is built twice or more: once in SI units and once
with its lengths, masses, voltages or currents expressed in other units (mm,
km, mg, t, mV, mA, ...), every parameter converted consistently.  The runs must
pass the same modes (labels and kinds: start, mythical, pinnacle, continuous)
at every instant, at the same times (relative 1e-9), with the same states once
converted back (relative 1e-6).  A decision at an instant that flips with the
units is a decision made by round-off or by an absolute tolerance that does
not scale with the problem.

Integration: RK45 with ``rtol = 1e-10``; ``atol`` is absolute in the states'
own units, so it is scaled with them (``1e-14`` times the smallest unit factor
of the states, so that it never matters more than in the SI run).  Every run
starts from the SI run's initial state converted to its units (``x0=``): the
state is the same, and the build's own projection of it, which derives the
initial mode's equations symbolically, is paid once per point.

The guard tolerance of the model (:class:`switching.Tolerance`) is the
default one: relative bands widened by the round-off scale of each
comparison, with no absolute part (an absolute part made the diode in µV and
kA stop time: a turn-off located at i_D = 1e-15 kA counted as "zero" while
the jump of the flux it left was a real pulse).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from models import ball_chain, diode_circuit, falling_rod
from switching import DivergenceOfTimeError

RTOL = 1e-10
ATOL_SI = 1e-14
TIME_RTOL = 1e-9
STATE_RTOL = 1e-6


# ------------------------------------------------------------------ unit systems
#
# A unit system is a set of factors, one per base dimension: a quantity with
# dimension L^a M^b is multiplied by  length**a * mass**b  when written in the
# new units (time is not scaled, so instants compare directly).

ROD_UNITS = {
    "SI": dict(length=1.0, mass=1.0),
    "mm": dict(length=1e3, mass=1.0),
    "km": dict(length=1e-3, mass=1.0),
    "mg": dict(length=1.0, mass=1e6),
    "Mg": dict(length=1.0, mass=1e-6),
    "mm,mg": dict(length=1e3, mass=1e6),
    "km,Mg": dict(length=1e-3, mass=1e-6),
}

#: (parameter or state name) → (length exponent, mass exponent)
ROD_DIMENSIONS = {
    "m": (0, 1), "J": (2, 1), "l": (1, 0), "g": (1, 0), "v_th": (1, 0),
    "y0": (1, 0), "x0": (1, 0), "y_lift": (1, 0), "mu": (0, 0), "theta0": (0, 0),
    "rod/p_x": (1, 1), "rod/p_y": (1, 1), "rod/p_J": (2, 1),
    "rod/x": (1, 0), "rod/y": (1, 0), "rod/theta": (0, 0),
}

CHAIN_DIMENSIONS = {
    "m": (0, 1), "r": (1, 0), "v0": (1, 0), "distance": (1, 0), "gap": (1, 0),
    "v_th": (1, 0), "k": (0, 1), "b": (0, 1), "e": (0, 0),
    "p": (1, 1), "pos": (1, 0), "q": (1, 0),
}

#: the mixed systems (lengths and masses both scaled) run by default; the single-unit ones are `slow`
MECHANICAL_UNITS = [u if "," in u else pytest.param(u, marks=pytest.mark.slow) for u in ROD_UNITS if u != "SI"]

DIODE_UNITS = {
    "SI": dict(volt=1.0, ampere=1.0),
    "mV,mA": dict(volt=1e3, ampere=1e3),
    "kV,uA": dict(volt=1e-3, ampere=1e6),
    "uV,kA": dict(volt=1e6, ampere=1e-3),
}

#: (name) → (volt exponent, ampere exponent); the state p_L is a flux [V·s]
DIODE_DIMENSIONS = {
    "V": (1, 0), "V_th": (1, 0), "R": (1, -1), "L": (1, -1), "I_th": (0, 1), "i0": (0, 1),
    "t_open": (0, 0), "p_L": (1, 0),
}


def factor(dimension, units) -> float:
    a, b = dimension
    first, second = units.values()
    return first**a * second**b


def convert(parameters: dict, dimensions: dict, units: dict) -> dict:
    out = {}
    for name, value in parameters.items():
        if isinstance(value, (bool, str)) or name == "N":
            out[name] = value
        else:
            out[name] = value * factor(dimensions[name], units)
    return out


def state_factors(model, dimensions, units) -> np.ndarray:
    out = []
    for s in model.states:
        name = s.name
        if name not in dimensions:  # p3, pos2, q1: by their prefix
            name = name.rstrip("0123456789")
        out.append(factor(dimensions[name], units))
    return np.array(out)


# ------------------------------------------------------------------ running and comparing


@dataclasses.dataclass
class Outcome:
    trajectory: object
    error: Exception | None
    factors: np.ndarray
    x0: np.ndarray  # the initial state, in SI units


def run(module, dimensions, units, parameters, t_end, x0=None):
    """One run in ``units``; ``x0``: the SI run's initial state, converted (the
    build's own projection of the initial state derives the initial mode's
    equations symbolically, seconds per build; the state is the same)."""
    params = convert({**module.DEFAULTS, **parameters}, dimensions, units)
    model = module.build(**params)
    factors = state_factors(model, dimensions, units)
    start = model.initial_state() if x0 is None else np.asarray(x0, dtype=float) * factors
    try:
        trajectory = model.simulate(t_end, "RK45", rtol=RTOL, atol=ATOL_SI * float(np.min(factors)), x0=start)
        return Outcome(trajectory, None, factors, start / factors)
    except DivergenceOfTimeError as exc:  # the same physics must fail the same way in every unit
        return Outcome(getattr(exc, "trajectory", None), exc, factors, start / factors)


_REFERENCES: dict = {}
_INITIAL: dict = {}


def reference_run(module, dimensions, si, point, parameters, t_end):
    """The SI run of a point (once per module and point;
    the initial state, projected by the build, once per module and point)."""
    key = (module.__name__, point)
    if key not in _REFERENCES:
        x0 = _INITIAL.get((module.__name__, point))
        _REFERENCES[key] = outcome = run(module, dimensions, si, parameters, t_end, x0=x0)
        _INITIAL[(module.__name__, point)] = outcome.x0
    return _REFERENCES[key]


def compare(module, dimensions, unit_systems, point, parameters, t_end, units, label):
    reference = reference_run(module, dimensions, unit_systems["SI"], point, parameters, t_end)
    assert reference.trajectory is not None and reference.trajectory.events, describe(reference)
    other = run(module, dimensions, unit_systems[units], parameters, t_end, x0=reference.x0)
    assert_same_run(reference, other, f"{label} {point} in {units}")
    return reference, other


def instants(outcome):
    if outcome.trajectory is None:
        return []
    return [(e.t, [(s.mode.label, s.kind) for s in e.steps], e) for e in outcome.trajectory.events]


def describe(outcome) -> str:
    lines = [f"  t = {t:.12g}: {modes}" for t, modes, _ in instants(outcome)]
    if outcome.error is not None:
        lines.append(f"  error: {type(outcome.error).__name__}: {str(outcome.error).splitlines()[0]}")
    return "\n".join(lines) or "  (no instants)"


def assert_close_states(converted, expected, scale, message):
    """``|converted − expected| <= 1e-6·|expected| + 1e-9·scale``, state by state
    (``scale``: the largest size the state reaches in the SI run)."""
    converted, expected = np.asarray(converted, dtype=float), np.asarray(expected, dtype=float)
    bad = np.abs(converted - expected) > STATE_RTOL * np.abs(expected) + STATE_RTOL * 1e-3 * scale
    assert not bad.any(), f"{message}\nstates differ at {np.flatnonzero(bad).tolist()}: {converted} vs {expected}"


def assert_same_run(reference: Outcome, other: Outcome, label: str):
    """Same outcome, same instants with the same modes and kinds, same times
    (relative 1e-9) and the same states converted back (relative 1e-6)."""
    message = f"{label}\nSI run:\n{describe(reference)}\nother units:\n{describe(other)}"
    assert type(reference.error) is type(other.error), message
    ref, oth = instants(reference), instants(other)
    assert [m for _, m, _ in ref] == [m for _, m, _ in oth], message
    for (t_ref, _, e_ref), (t_oth, _, e_oth) in zip(ref, oth):
        assert t_oth == pytest.approx(t_ref, rel=TIME_RTOL, abs=1e-12), message
    if reference.trajectory is None or other.trajectory is None:
        return
    # states converted back, compared against the size each state reaches in the run
    scale = np.max(np.abs(reference.trajectory.x), axis=0)
    scale[scale == 0] = 1.0
    for (_, _, e_ref), (_, _, e_oth) in zip(ref, oth):
        for s_ref, s_oth in zip(e_ref.steps, e_oth.steps):
            for a, b in ((s_ref.x_before, s_oth.x_before), (s_ref.x_after, s_oth.x_after)):
                assert_close_states(b / other.factors, a, scale, message)
    if reference.error is None:
        assert other.trajectory.t[-1] == pytest.approx(reference.trajectory.t[-1], rel=TIME_RTOL)
        assert_close_states(other.trajectory.x[-1] / other.factors, reference.trajectory.x[-1], scale, message)


# ------------------------------------------------------------------ the falling rod

#: documented parameter points (the module docstring): the defaults (mu = 0.005
#: sticks), small mu slides through a mythical stuck mode, large mu, the long
#: rod l = 10, y0 = 23 (slides for a point in time and lifts off), and the
#: Newton-Coulomb impact law.  (point → parameters, t_end)
ROD_POINTS = {
    "defaults": (dict(), 0.5),
    "mu=0.002": (dict(mu=0.002), 1.5),
    "mu=0.004": (dict(mu=0.004), 0.9),
    "mu=0.3": (dict(mu=0.3), 0.5),
    "long rod": (dict(mu=0.002, l=10.0, y0=23.0), 2.0),
    "newton-coulomb mu=0.002": (dict(mu=0.002, impact_law="newton-coulomb"), 1.5),
    "newton-coulomb mu=0.005": (dict(mu=0.005, impact_law="newton-coulomb"), 0.5),
}


@pytest.mark.parametrize("units", MECHANICAL_UNITS)
@pytest.mark.parametrize("point", list(ROD_POINTS))
def test_falling_rod_is_unit_invariant(point, units):
    parameters, t_end = ROD_POINTS[point]
    compare(falling_rod, ROD_DIMENSIONS, ROD_UNITS, point, parameters, t_end, units, "falling rod")


# ------------------------------------------------------------------ the ball chain

CHAIN_POINTS = {
    "elastic N=4": (dict(N=4, e=1.0), 0.3),
    "e=0.5 N=4": (dict(N=4, e=0.5), 0.3),
    "plastic N=4": (dict(N=4, e=0.0), 0.3),
    "elastic N=6 gap": (dict(N=6, e=1.0, gap=0.01), 0.3),
    "compliant k=1e4": (dict(N=4, compliant=True, k=1e4), 0.3),
    "compliant damped gap": (dict(N=3, compliant=True, k=1e4, b=5.0, gap=0.01), 0.3),
}


@pytest.mark.parametrize("units", MECHANICAL_UNITS)
@pytest.mark.parametrize("point", list(CHAIN_POINTS))
def test_ball_chain_is_unit_invariant(point, units):
    parameters, t_end = CHAIN_POINTS[point]
    compare(ball_chain, CHAIN_DIMENSIONS, ROD_UNITS, point, parameters, t_end, units, "ball chain")


# ------------------------------------------------------------------ the diode circuit

DIODE_POINTS = {
    # the switch opens (mythical open|off), the current decays through the diode to 0, the diode turns off
    "defaults": (dict(), 1.0),
    "R=100, L=1": (dict(R=100.0, L=1.0), 1.0),
    # a holding current above zero: the documented divergence of time when the current reaches it
    "I_th=1": (dict(I_th=1.0), 1.0),
}


@pytest.mark.parametrize("units", [u for u in DIODE_UNITS if u != "SI"])
@pytest.mark.parametrize("point", list(DIODE_POINTS))
def test_diode_circuit_is_unit_invariant(point, units):
    parameters, t_end = DIODE_POINTS[point]
    reference, other = compare(diode_circuit, DIODE_DIMENSIONS, DIODE_UNITS, point, parameters, t_end, units,
                               "diode circuit")
    if reference.error is not None:  # the divergence is found at the same time in every unit
        assert other.trajectory.t[-1] == pytest.approx(reference.trajectory.t[-1], rel=TIME_RTOL)
