"""Small-signal bridge (issue 31, item 4): a mode's state space and an orbit's
discrete small-signal model, against exact answers.

Boost converter (models/boost_converter.py), states x = (p_L, q_C), i_L = p_L/L,
v_C = q_C/C, default inputs u = (Vin, ground) (every source's value; ``ground``
is the switch's return, an effort source of value 0):

* ``pwm=on, diode=off`` (v_A = e_ground): ṗ_L = Vin − R_L p_L/L − ground,
  q̇_C = −q_C/(C R): ``A_on = [[−R_L/L, 0], [0, −1/(C R)]]``, ``B = [[1, −1], [0, 0]]``;
  outputs (i_L, v_C, v_sw): ``C = [[1/L, 0], [0, 1/C], [0, 0]]``, ``D`` zero but
  ``∂v_sw/∂ground = 1``;
* ``pwm=off, diode=on`` (v_A = v_C): ``A_off = [[−R_L/L, −1/C], [1/L, −1/(C R)]]``,
  ``B = [[1, 0], [0, 0]]``, and v_sw = v_C: ``C`` row ``[0, 1/C]``;
* ``pwm=off, diode=off``: the inductor is dependent (p_L = 0), one state q_C with
  ``A = [[−1/(C R)]]``, ``B = 0``, and v_sw = Vin.

These are test_orbits.py's A_on, A_off (its docstring).  The off mode is an RLC
circuit: from Vin to v_C, ``H(s) = 1/(L C s² + (L/R + R_L C) s + 1 + R_L/R)``
(Laplace of the two rate equations, ``P = L (s + 1/(C R)) Q``), DC gain
``R/(R + R_L)``.

The orbit in continuous conduction (test_orbits.boost_exact, fixed duty D,
T = 1/f_sw): the period map from t = 0 is ``x ↦ E_off (E_on x + c_on) + c_off``
with ``E = e^{Aτ}``, ``c = ∫₀^τ e^{As} ds (Vin, 0)``, τ_on = D T, τ_off = (1 − D) T.

* ``A_d = E_off E_on`` (the monodromy);
* Vin enters only through ``c = E_off c_on + c_off``, which is linear in it:
  ``∂φ/∂Vin = c/Vin`` exactly;
* the duty moves the switch's turn-off (the clock edge ``carrier = D`` at
  ``t_sw = D T``; the turn-on at ``k T`` does not move) by ``δτ = T δD``: the
  on phase lasts ``δτ`` longer and the off phase ``δτ`` shorter, so at the
  edge the state differs by ``(f_on(x_sw) − f_off(x_sw)) δτ`` (``f = A x + b``
  of each phase, ``x_sw = E_on x* + c_on`` the state at the edge), which the
  off phase carries to the period's end: ``∂φ/∂D = T E_off (f_on(x_sw) − f_off(x_sw))``.

Relay (models/examples/relay.toml), an autonomous orbit with the section at the
relay's opening: its start is always ``q_C = C v_hi`` (just after opening), so
the return map is constant: ``DP = 0``, ``∂P/∂v_hi = C``, ``∂P/∂v_lo = ∂P/∂V = 0``.
The sensitivity at fixed time alone would miss the event-time term
``f⁺ τ_p`` and give neither.

Tolerances: every orbit run integrates the states and their sensitivities
with rtol = 1e-10 (the default of periodic_orbit), so derivatives of the
period map agree to about 1e-8 relative to their size.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest
import sympy as sp
from test_orbits import BOOST, T, boost_exact, phase  # the exact two-phase answers

import models
import switching
from bondgraph import HybridBondGraphError, LinearSystem, MissingDependencyError
from bondgraph.errors import DerivationError, UnknownNameError
from models import boost_converter

RTOL = 1e-8  # from the orbit runs' rtol = 1e-10 (module docstring)
L_, C_, R_L_, R_, Vin_ = sp.symbols("L C R_L R_load Vin")


@pytest.fixture(scope="module")
def boost():
    return boost_converter.build(**BOOST)


@pytest.fixture(scope="module")
def boost_orbit(boost):
    return boost.periodic_orbit(T, max_step=0.3 * T)


def is_zero(matrix) -> bool:
    return sp.simplify(matrix) == sp.zeros(*matrix.shape)


def as_numbers(matrix) -> np.ndarray:
    values = {sp.Symbol(k): v for k, v in BOOST.items()}
    return np.array(matrix.xreplace(values), dtype=float)


# ------------------------------------------------------------------ a mode's state space

MODES = {
    "pwm=on, diode=off": (sp.Matrix([[-R_L_ / L_, 0], [0, -1 / (C_ * R_)]]), sp.Matrix([[1, -1], [0, 0]]),
                          sp.Matrix([[1 / L_, 0], [0, 1 / C_], [0, 0]]), sp.Matrix([[0, 0], [0, 0], [0, 1]])),
    "pwm=off, diode=on": (sp.Matrix([[-R_L_ / L_, -1 / C_], [1 / L_, -1 / (C_ * R_)]]), sp.Matrix([[1, 0], [0, 0]]),
                          sp.Matrix([[1 / L_, 0], [0, 1 / C_], [0, 1 / C_]]), sp.zeros(3, 2)),
}


@pytest.mark.parametrize("mode", list(MODES))
def test_boost_mode_matrices_match_the_hand_derived_ones(boost, mode):
    expected = MODES[mode]
    symbolic = boost.state_space(mode, outputs=["i_L", "v_C", "v_sw"], numeric=False)
    assert all(is_zero(got - want) for got, want in zip(symbolic, expected))
    assert symbolic.states == (boost.state("p_L"), boost.state("q_C")) and not symbolic.constraints
    numeric = boost.state_space(mode, outputs=["i_L", "v_C", "v_sw"])
    assert isinstance(numeric, LinearSystem) and numeric.dt == 0 and numeric.dependent == {}
    for got, want in zip(numeric, expected):
        assert got.dtype == float and np.allclose(got, as_numbers(want), rtol=1e-14, atol=0.0)
    assert (numeric.states, numeric.inputs, numeric.outputs) == (("p_L", "q_C"), ("Vin", "ground"),
                                                                 ("i_L", "v_C", "v_sw"))
    assert numeric.name == f"boost_converter[{mode}]"


def test_mode_forms_and_default_outputs(boost):
    by_label = boost.state_space("off|on", inputs=["Vin"])
    by_mapping = switching.state_space(boost, {"pwm": "off", "diode": "on"}, inputs=["Vin"])
    assert by_label.outputs == ("p_L", "q_C") and np.array_equal(by_label.C, np.eye(2))
    assert np.array_equal(by_label.D, np.zeros((2, 1))) and by_label.inputs == ("Vin",)
    for got, want in zip(by_label, by_mapping):
        assert np.array_equal(got, want)
    initial = boost.state_space()  # the initial mode: pwm=on, diode=off
    assert np.allclose(initial.A, as_numbers(MODES["pwm=on, diode=off"][0]), rtol=1e-14, atol=0.0)


def test_a_mode_with_a_dependent_state_has_one_state(boost):
    """pwm=off, diode=off: p_L is held at 0 (derivative causality), v_sw = Vin."""
    symbolic = boost.state_space("pwm=off, diode=off", outputs=["v_C", "v_sw", "i_L"], numeric=False)
    assert symbolic.states == (boost.state("q_C"),)
    assert symbolic.constraints == {boost.state("p_L"): 0}
    assert is_zero(symbolic.A - sp.Matrix([[-1 / (C_ * R_)]])) and is_zero(symbolic.B)
    assert is_zero(symbolic.C - sp.Matrix([[1 / C_], [0], [0]]))
    assert is_zero(symbolic.D - sp.Matrix([[0, 0], [1, 0], [0, 0]]))
    numeric = boost.state_space("off|off")
    assert numeric.states == ("q_C",) and numeric.outputs == ("q_C",) and numeric.dependent == {"p_L": "0"}
    assert numeric.A.shape == (1, 1) and numeric.A[0, 0] == pytest.approx(-1 / (BOOST["C"] * BOOST["R_load"]),
                                                                        rel=1e-14)
    assert "p_L held on a constraint: p_L = 0" in str(numeric)


def test_reduction_through_a_nonzero_constraint():
    """x_d = 2 x1 + 3 u: ẋ1 = −x1 + x_d → (1) x1 + 3 u; y = x_d → 2 x1 + 3 u."""
    from bondgraph import StateSpace

    x1, xd, u = sp.symbols("x1 x_d u")
    full = StateSpace(sp.Matrix([[-1, 1], [0, 0]]), sp.Matrix([[0], [0]]), sp.Matrix([[0, 1]]), sp.Matrix([[0]]),
                      (x1, xd), (u,), ("x_d",), {xd: 2 * x1 + 3 * u})
    reduced = full.reduced()
    assert reduced.states == (x1,) and reduced.reduced() is reduced
    assert list(reduced) == [sp.Matrix([[1]]), sp.Matrix([[3]]), sp.Matrix([[2]]), sp.Matrix([[3]])]
    with pytest.raises(DerivationError, match="still holds the symbol"):
        StateSpace(sp.Matrix([[-sp.Symbol("k")]]), sp.zeros(1, 0), sp.eye(1), sp.zeros(1, 0), (x1,), (), ("x1",)
                   ).numeric()


def test_rlc_mode_frequency_response_is_the_closed_form_transfer_function(boost):
    control = pytest.importorskip("control")
    system = boost.state_space("pwm=off, diode=on", outputs=["v_C"], inputs=["Vin"]).to_control()
    assert isinstance(system, control.StateSpace) and system.isctime(strict=True)
    assert system.name == "boost_converter[pwm=off, diode=on]"
    assert (system.state_labels, system.input_labels, system.output_labels) == (["p_L", "q_C"], ["Vin"], ["v_C"])
    L, C, R_L, R = (BOOST[k] for k in ("L", "C", "R_L", "R_load"))
    H = lambda s: 1.0 / (L * C * s**2 + (L / R + R_L * C) * s + 1.0 + R_L / R)  # noqa: E731
    assert control.dcgain(system) == pytest.approx(R / (R + R_L), rel=1e-12)
    for w in (1e1, 3.2e3, 1e5):  # below, at and above the resonance 1/sqrt(LC) ≈ 3.2e3 rad/s
        assert complex(system(1j * w)) == pytest.approx(H(1j * w), rel=1e-12)


# ------------------------------------------------------------------ the orbit's small-signal model


def boost_period_map_derivatives(D=BOOST["D"]):
    """``(Φ, ∂φ/∂Vin, ∂φ/∂D)`` of the exact period map (module docstring)."""
    L, C, R_L, R, V = (BOOST[k] for k in ("L", "C", "R_L", "R_load", "Vin"))
    A_on = np.array([[-R_L / L, 0.0], [0.0, -1.0 / (C * R)]])
    A_off = np.array([[-R_L / L, -1.0 / C], [1.0 / L, -1.0 / (C * R)]])
    b = np.array([V, 0.0])
    E_on, c_on = phase(A_on, b, D * T)
    E_off, c_off = phase(A_off, b, (1 - D) * T)
    x_star, Phi = boost_exact(D)
    x_sw = E_on @ x_star + c_on
    by_duty = T * E_off @ ((A_on @ x_sw + b) - (A_off @ x_sw + b))
    return Phi, (E_off @ c_on + c_off) / V, by_duty


def test_orbit_small_signal_is_the_exact_period_maps_linearization(boost_orbit):
    Phi, by_vin, by_duty = boost_period_map_derivatives()
    ss = boost_orbit.small_signal(["Vin", "D"], ["i_L", "v_C"])
    assert ss.dt == T and ss.is_discrete and ss.name == "boost_converter_orbit"
    assert (ss.states, ss.inputs, ss.outputs) == (("p_L", "q_C"), ("Vin", "D"), ("i_L", "v_C"))
    assert np.allclose(ss.A, Phi, rtol=0.0, atol=RTOL * np.abs(Phi).max())
    assert np.allclose(ss.A, boost_orbit.monodromy, rtol=0.0, atol=RTOL * np.abs(Phi).max())
    for column, exact in ((0, by_vin), (1, by_duty)):
        assert np.allclose(ss.B[:, column], exact, rtol=0.0, atol=RTOL * np.abs(exact).max())
    assert np.allclose(ss.C, np.diag([1 / BOOST["L"], 1 / BOOST["C"]]), rtol=1e-14, atol=0.0)
    assert np.array_equal(ss.D, np.zeros((2, 2)))


def test_orbit_to_control_is_discrete_with_the_period_as_its_step(boost_orbit):
    control = pytest.importorskip("control")
    Phi, by_vin, _ = boost_period_map_derivatives()
    system = boost_orbit.to_control(inputs=["Vin"])
    assert isinstance(system, control.StateSpace) and system.dt == T and system.isdtime(strict=True)
    assert (system.state_labels, system.input_labels, system.output_labels) == (["p_L", "q_C"], ["Vin"],
                                                                                ["p_L", "q_C"])
    # the steady state moves with Vin by (I − Φ)⁻¹ ∂φ/∂Vin = x*/Vin (the orbit is linear in Vin)
    x_star, _ = boost_exact()
    assert np.allclose(np.ravel(control.dcgain(system)), x_star / BOOST["Vin"], rtol=1e-6, atol=0.0)
    assert np.allclose(np.sort_complex(system.poles()), np.sort_complex(np.linalg.eigvals(Phi)), rtol=0.0,
                       atol=RTOL)


def test_output_jacobians_take_the_signals_at_the_orbits_start(boost_orbit):
    """v_sw in the start mode (pwm=on, diode=off) is the ground source, 0: no state and no parameter in it;
    i_L = p_L/L depends on L: ∂i_L/∂L = −p_L/L² at x0."""
    ss = boost_orbit.small_signal(["L"], ["v_sw", "i_L"])
    assert np.array_equal(ss.C[0], [0.0, 0.0]) and ss.D[0, 0] == 0.0
    assert ss.D[1, 0] == pytest.approx(-boost_orbit.x0[0] / BOOST["L"] ** 2, rel=1e-14)
    no_inputs = boost_orbit.small_signal()
    assert no_inputs.B.shape == (2, 0) and no_inputs.D.shape == (2, 0)
    with pytest.raises(DerivationError, match="no inputs"):
        no_inputs.to_control()


def test_autonomous_orbit_includes_the_event_time_term():
    model = models.load("models/examples/relay.toml")
    orbit = model.periodic_orbit(section="relay: on -> off", period=0.01)
    ss = orbit.small_signal(["v_hi", "v_lo", "V"], ["v"])
    C = 1e-3
    assert ss.A.shape == (1, 1) and abs(ss.A[0, 0]) < RTOL
    assert ss.B[0] == pytest.approx([C, 0.0, 0.0], abs=RTOL * C)
    assert ss.C[0, 0] == pytest.approx(1 / C, rel=1e-14) and ss.dt == orbit.period


def test_inputs_must_be_parameters(boost_orbit):
    with pytest.raises(UnknownNameError, match="no parameter 'Vdc'"):
        boost_orbit.small_signal(["Vdc"])
    with pytest.raises(switching.OrbitError, match="initial states"):
        boost_orbit.small_signal(["x0:p_L"])
    with pytest.raises(UnknownNameError, match="no signal 'v_out'"):
        boost_orbit.small_signal(["Vin"], ["v_out"])


# ------------------------------------------------------------------ python-control is optional


def test_missing_python_control_names_the_extra(boost, boost_orbit, monkeypatch):
    monkeypatch.setitem(sys.modules, "control", None)  # import control → ImportError
    for export in (boost.state_space("on|off").to_control, lambda: boost_orbit.to_control(["Vin"])):
        with pytest.raises(MissingDependencyError, match=r'pip install "hybrid-bondgraph\[control\]"') as info:
            export()
        assert isinstance(info.value, HybridBondGraphError) and isinstance(info.value, ImportError)
    assert boost_orbit.small_signal(["Vin"]).A.shape == (2, 2)  # the numbers need no extra


def test_linear_system_checks_its_shapes():
    with pytest.raises(DerivationError, match=r"B has shape \(2, 1\), expected \(2, 2\)"):
        LinearSystem(np.eye(2), np.ones((2, 1)), np.eye(2), np.zeros((2, 2)), ("a", "b"), ("u", "v"), ("a", "b"))
