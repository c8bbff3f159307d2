"""The two jump laws (bondgraph.jump): conservation of state through the
junction structure, and the impulse balance of a mode's own equations, in
which a source modulated by a constraint effort carries a pulse too — the
Newton–Coulomb impact law of the falling rod (DESIGN §5)."""

import itertools

import numpy as np
import pytest
import sympy as sp

from bondgraph.errors import CausalityConflictError, InvalidGraphError
from bondgraph.jump import JumpMapError
from models import ball_chain, colliding_balls, diode_circuit, falling_rod, parallel_capacitors
from switching import ModelDefinitionError

M, J, L, MU, SIGMA = sp.symbols("m J l mu sigma")
PX, PY, PJ, X, Y, THETA = sp.symbols("rod/p_x rod/p_y rod/p_J rod/x rod/y rod/theta")


def _configurations(graph):
    names = sorted(graph.controlled_junctions)
    for values in itertools.product((False, True), repeat=len(names)):
        yield dict(zip(names, values))


def _same_jump(graph, config, values=None):
    values = values or {}
    a = graph.jump_map(config, "conservation").substituted(values)
    b = graph.jump_map(config, "impulse balance").substituted(values)
    assert a.dependent == b.dependent
    return all(sp.simplify(a.expressions[x] - b.expressions[x]) == 0 for x in a.states)


@pytest.mark.parametrize("build", [colliding_balls.build, lambda: ball_chain.build(N=3), diode_circuit.build,
                                   parallel_capacitors.build], ids=["colliding balls", "ball chain", "diode",
                                                                    "parallel capacitors"])
def test_without_modulated_sources_both_laws_give_the_same_jump(build):
    """B = ∂F/∂ẋ_d is −M_i Kᵀ M_d⁻¹ where only storage exchanges impulses:
    the impulse balance is the conservation law, in every configuration."""
    graph = build().graph
    compared = 0
    for config in _configurations(graph):
        try:
            graph.equations(config)
        except CausalityConflictError:
            continue  # a configuration no mode has (sources over-determine the graph)
        assert _same_jump(graph, config), config
        compared += 1
    assert compared >= 2


def _hand_rod_jump(sigma_mu):
    """A plastic impact of the rod's tip with the floor: normal impulse P_n
    (up) and tangential impulse P_t = −σμ P_n at r_A − r = −l(cos θ, sin θ);
    the tip's vertical velocity after it is zero."""
    v_ay = PY / M - L * sp.cos(THETA) * PJ / J
    p_n = -v_ay / (1 / M + L**2 * sp.cos(THETA) * (sp.cos(THETA) + sigma_mu * sp.sin(THETA)) / J)
    p_t = -sigma_mu * p_n
    torque = -L * sp.cos(THETA) * p_n + L * sp.sin(THETA) * p_t
    return {PX: PX + p_t, PY: PY + p_n, PJ: PJ + torque, X: X, Y: Y, THETA: THETA}


@pytest.mark.parametrize("law, sigma", [("newton-coulomb", 1), ("newton-coulomb", -1), ("paper", 1),
                                        ("paper", 0), ("newton-coulomb", 0)])
def test_rod_impact_jump_matches_the_hand_derived_impulses(law, sigma):
    mode = {1: "contact|slide_pos", -1: "contact|slide_neg", 0: "contact|stuck"}[sigma]
    g = falling_rod.build(impact_law=law).mode_equations(mode).g
    if sigma == 0:  # stuck: the tip stops; both laws, no friction source in the stuck mode
        v_ax = PX / M + L * sp.sin(THETA) * PJ / J
        v_ay = PY / M - L * sp.cos(THETA) * PJ / J
        after = {s: g[s] for s in (PX, PY, PJ)}
        assert sp.simplify((v_ax.xreplace(after))) == 0 and sp.simplify(v_ay.xreplace(after)) == 0
        # angular momentum about the tip is conserved: L_A = p_J + (r − r_A) × p
        about_tip = PJ + L * sp.cos(THETA) * PY - L * sp.sin(THETA) * PX
        assert sp.simplify(about_tip.xreplace(after) - about_tip) == 0
        return
    expected = _hand_rod_jump(sigma * MU if law == "newton-coulomb" else 0)
    for state, value in expected.items():
        assert sp.simplify(g[state] - value) == 0, state


def test_newton_coulomb_impact_in_a_simulation_takes_the_tangential_impulse():
    """μ = 0.002 slides at the impact (the stuck mode needs |P_t| = 0.0049 P_n):
    with Newton–Coulomb the impact's tangential impulse is −σμ times its
    normal one, to round-off; with the paper's law it is zero.  The impact
    time and the mode sequence are the same."""
    runs = {law: falling_rod.build(impact_law=law, mu=0.002).simulate(0.3, "RK45", rtol=1e-10, atol=1e-12,
                                                                       output="events")
            for law in ("paper", "newton-coulomb")}
    for law, run in runs.items():
        impact = run.events[0]
        assert impact.mode_after.label == "contact|slide_neg"
        dp = impact.x_after - impact.x_before
        p_n, p_t = dp[1], dp[0]
        assert p_n > 0
        expected = 0.002 * p_n if law == "newton-coulomb" else 0.0  # σ = −1: P_t = +μ P_n
        assert p_t == pytest.approx(expected, rel=1e-12, abs=1e-15)
    assert runs["paper"].events[0].t == runs["newton-coulomb"].events[0].t
    assert [s.kind for s in runs["newton-coulomb"].events[0].steps] == ["start", "mythical", "continuous"]
    # the friction impulse does work against the slip: less kinetic energy after the impact
    rod = falling_rod.build()
    masses = np.array([rod.parameter_values[sp.Symbol(n)] for n in ("m", "m", "J")])

    def energy(x):
        return float(np.sum(x[:3] ** 2 / (2 * masses)))

    after = {law: energy(run.events[0].x_after) for law, run in runs.items()}
    assert after["newton-coulomb"] < after["paper"] < energy(runs["paper"].events[0].x_before)


def test_a_stuck_impact_is_the_same_under_both_laws():
    runs = [falling_rod.build(impact_law=law, mu=0.005).simulate(0.3, "RK45", rtol=1e-10, atol=1e-12)
            for law in ("paper", "newton-coulomb")]
    assert runs[0].mode_labels == runs[1].mode_labels
    np.testing.assert_array_equal(runs[0].x, runs[1].x)


def test_unknown_laws_are_refused_with_the_choices():
    with pytest.raises(ModelDefinitionError, match="newton-coulomb"):
        falling_rod.build(impact_law="coulomb")
    with pytest.raises(InvalidGraphError, match="must be text"):
        falling_rod.build(impact_law=1)
    from switching import HybridModel

    with pytest.raises(ModelDefinitionError, match="impulse balance"):
        HybridModel(colliding_balls.build().graph, [], {}, jump_law="momentum")


def test_impulse_balance_refuses_nonlinear_storage_and_says_what_to_use():
    """Charge sharing onto a nonlinear capacitor: its constraint is not
    linear in the charges that jump (the conservation law solves it
    numerically, tests/bondgraph/test_jump.py)."""
    from test_jump import nonlinear_capacitor_pair

    g = nonlinear_capacitor_pair()
    assert g.jump_map({"sw": True}, "conservation").expressions is None
    with pytest.raises(JumpMapError, match="jump_law='conservation'"):
        g.jump_map({"sw": True}, "impulse balance")


def test_the_command_line_chooses_the_impact_law():
    from test_cli import hbg

    out = hbg("run", "falling-rod", "--set", "impact_law=newton-coulomb", "--set", "mu=0.002", "--t-end", "0.25")
    assert out.returncode == 0, out.stderr
    assert "contact=contact, friction=slide_neg" in out.stdout
    out = hbg("run", "falling-rod", "--set", "impact_law=sticky")
    assert out.returncode != 0 and "choose one of: paper, newton-coulomb" in out.stderr
