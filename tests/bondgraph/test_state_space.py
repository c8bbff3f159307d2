"""State-space matrices ``ẋ = A x + B u``, ``y = C x + D u`` (issue 19, item 3)
against hand-derived ones; the flow source's direction (item 5)."""

import pytest
import sympy as sp

from bondgraph import C, I, R, BondGraph, DerivationError, One, Se, Sf, StateSpace, Zero

S = sp.Symbol


def same(a, b):
    a, b = sp.Matrix(a), sp.Matrix(b)
    assert a.shape == b.shape, (a.shape, b.shape)
    assert sp.simplify(a - b) == sp.zeros(*a.shape), (a, b)


def rlc():
    g = BondGraph("rlc")
    j = g.add(One("i"))
    g.connect(Se("V", "V0"), j)
    for el in (R("R", "R"), I("L", "L"), C("C", "C")):
        g.connect(j, el)
    return g


def test_rlc_series_circuit_matrices():
    Rv, L, Cv = S("R"), S("L"), S("C")
    ss = rlc().equations().state_space()
    assert isinstance(ss, StateSpace)
    A, B, Cm, D = ss
    assert ss.states == (S("p_L"), S("q_C")) and ss.inputs == (S("V0"),)
    assert ss.outputs == ("p_L", "q_C")
    # dp_L/dt = V0 − R p_L/L − q_C/C,  dq_C/dt = p_L/L
    same(A, [[-Rv / L, -1 / Cv], [1 / L, 0]])
    same(B, [[1], [0]])
    same(Cm, sp.eye(2))
    same(D, sp.zeros(2, 1))
    # constants substituted (as a mode's values are) survive the re-derivation with inputs
    ss5 = rlc().equations().substituted({Rv: 5, S("V0"): 2}).state_space()
    assert ss5.inputs == (S("V"),)  # V0 is fixed: the input is named by the source
    same(ss5.A, [[-5 / L, -1 / Cv], [1 / L, 0]])
    same(ss5.B, [[1], [0]])


def test_rlc_outputs_are_bond_variables_or_expressions():
    Rv, L, Cv = S("R"), S("L"), S("C")
    ss = rlc().equations().state_space(outputs=["e_R", "f_L", S("q_C") / Cv, "V0"])
    assert ss.outputs == ("e_R", "f_L", "q_C/C", "V0")
    same(ss.C, [[Rv / L, 0], [1 / L, 0], [0, 1 / Cv], [0, 0]])
    same(ss.D, [[0], [0], [0], [1]])


def quarter_car():
    """Sprung mass ms on a spring ks ∥ damper cs over an unsprung mass mu on a
    tyre spring kt whose lower end moves with the road velocity v_r (an Sf);
    gravity as efforts Ws = −ms g, Wu = −mu g."""
    g = BondGraph("quarter_car")
    vs, vu, susp = g.add(One("vs")), g.add(One("vu")), g.add(One("susp"))
    fs, ft = g.add(Zero("Fs")), g.add(Zero("Ft"))
    g.connect(vs, I("ms", "ms"))
    g.connect(vu, I("mu", "mu"))
    g.connect(Se("Ws", -S("ms") * S("g")), vs)
    g.connect(Se("Wu", -S("mu") * S("g")), vu)
    g.connect(vu, fs)
    g.connect(fs, vs)
    g.connect(fs, susp)
    g.connect(susp, C("ks", 1 / S("ks")))
    g.connect(susp, R("cs", "cs"))
    g.connect(Sf("road", g.input("v_r")), ft)
    g.connect(ft, vu)
    g.connect(ft, C("kt", 1 / S("kt")))
    return g


def test_quarter_car_matrices():
    ms, mu, ks, kt, cs = S("ms"), S("mu"), S("ks"), S("kt"), S("cs")
    ss = quarter_car().equations().state_space()
    A, B, Cm, D = ss
    assert ss.states == (S("p_ms"), S("p_mu"), S("q_ks"), S("q_kt"))
    # the road velocity is its declared input; the gravity sources are inputs named by the sources
    assert ss.inputs == (S("Ws"), S("Wu"), S("v_r"))
    # vs = p_ms/ms, vu = p_mu/mu; suspension force Fs = ks q_ks + cs (vu − vs)
    # dp_ms = Fs + Ws, dp_mu = kt q_kt − Fs + Wu, dq_ks = vu − vs, dq_kt = v_r − vu
    same(A, [[-cs / ms, cs / mu, ks, 0],
             [cs / ms, -cs / mu, -ks, kt],
             [-1 / ms, 1 / mu, 0, 0],
             [0, -1 / mu, 0, 0]])
    same(B, [[1, 0, 0], [0, 1, 0], [0, 0, 0], [0, 0, 1]])
    same(Cm, sp.eye(4))
    same(D, sp.zeros(4, 3))
    # outputs: sprung-mass velocity and tyre force
    out = quarter_car().equations().state_space(outputs={"v_body": "f_ms", "F_tyre": "e_kt"})
    assert out.outputs == ("v_body", "F_tyre")
    same(out.C, [[1 / ms, 0, 0, 0], [0, 0, 0, kt]])
    same(out.D, sp.zeros(2, 3))


def test_chosen_inputs_keep_sources_as_parameters():
    g = quarter_car()
    with pytest.raises(DerivationError, match=r"constant term .*g\*ms"):
        g.equations().state_space(inputs=["v_r"])
    g2 = rlc()
    ss = g2.equations().state_space(inputs=["V0"])
    assert ss.inputs == (S("V0"),)
    same(ss.B, [[1], [0]])


def test_nonlinear_rate_names_the_state_and_the_term():
    g = BondGraph("drag")
    v = g.add(One("v"))
    g.connect(Se("F", "F0"), v)
    g.connect(v, I("m", "m"))
    g.connect(Se("drag", -S("d") * S("p_m") ** 2), v)  # feedback: part of the dynamics, not an input
    with pytest.raises(DerivationError) as info:
        g.equations().state_space()
    message = str(info.value)
    assert "dp_m/dt" in message and "nonlinear term" in message and "d*p_m**2" in message


def test_nonlinear_output_is_named():
    with pytest.raises(DerivationError, match=r"output E .*nonlinear term"):
        rlc().equations().state_space(outputs={"E": S("q_C") ** 2 / (2 * S("C"))})


def test_hybrid_modes_of_the_parallel_capacitors():
    from models import parallel_capacitors

    model = parallel_capacitors.build(R=10.0)
    C1, C2, Rv = S("C1"), S("C2"), S("R")
    closed = model.mode_equations(model.mode("closed")).state_space()
    assert closed.states == (S("q1"), S("q2")) and closed.inputs == ()
    same(closed.A, [[-1 / (Rv * C1), 1 / (Rv * C2)], [1 / (Rv * C1), -1 / (Rv * C2)]])
    assert closed.B.shape == (2, 0)
    opened = model.mode_equations(model.mode("open")).state_space(outputs=["v1"])
    same(opened.A, sp.zeros(2, 2))
    same(opened.C, [[1 / C1, 0]])


def test_hybrid_modes_of_the_diode_circuit():
    from models import diode_circuit

    model = diode_circuit.build()
    Rv, L = S("R"), S("L")
    on = model.mode_equations(model.mode("open|on")).state_space(outputs=["i_L"])
    assert on.inputs == (S("V"), S("drop"))  # the drop source's value −V_th is input "drop"
    same(on.A, [[-Rv / L]])
    same(on.B, [[0, 1]])
    same(on.C, [[1 / L]])
    same(on.D, [[0, 0]])
    closed = model.mode_equations(model.mode("closed|off")).state_space()
    same(closed.B, [[1, 0]])


def test_cli_modes_state_space(capsys):
    from models.cli import main

    assert main(["modes", "parallel_capacitors", "--set", "R=10", "--mode", "closed", "--state-space"]) == 0
    out = capsys.readouterr().out
    assert "A = " in out and "B = " in out and "C = " in out and "D = " in out
    assert "x = [q1, q2]" in out and "u = []" in out and "C₁⋅R" in out and "B = [] (2×0)" in out
    assert main(["modes", "diode_circuit", "--mode", "open|on", "--state-space"]) == 0
    out = capsys.readouterr().out
    assert "u = [V, drop]" in out and "B = [0  1]" in out


@pytest.mark.parametrize("into", [False, True])
def test_flow_source_pushes_its_value_out_whatever_the_bond_direction(into):
    g = BondGraph("sf")
    n = g.add(Zero("n"))
    source = Sf("S", "u0")
    if into:
        g.connect(n, source)
    else:
        g.connect(source, n)
    g.connect(n, C("c", "Cc"))
    eq = g.equations()
    assert sp.simplify(eq.rate("q_c") - S("u0")) == 0
    assert sp.simplify(eq.flow("S") - (-S("u0") if into else S("u0"))) == 0
    ss = eq.state_space()
    same(ss.B, [[1]])
