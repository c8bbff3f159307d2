"""Transitions whose jump abstracts a continuous approach (``pulses=False``).

A block of mass m pushed by a constant force P < μ m g slides on a floor
with Coulomb friction and decelerates at ``a = μ g − P/m``; it sticks when
its velocity reaches the threshold ``v_th`` (the paper's Eq. 25): the stick
sets the remaining ``v_th`` to 0.  That jump is the abstraction of the last
of a continuous deceleration, not a collision: judged with its Dirac pulse
(``−m v_th``, which dominates any finite force) the stuck mode would slip at
once and time would stop; marked ``pulses=False`` the stuck mode judges the
finite force it needs, ``−P``, which the cone holds.  Exact answers: the
stick at ``t* = (v0 − v_th)/a``, the position ``v0 t* − a t*²/2`` kept after.
"""

from __future__ import annotations

import pytest
import sympy as sp

from bondgraph import BondGraph, I, One, Se, Sf, Zero
from switching import Automaton, DivergenceOfTimeError, HybridModel

M, G, MU, P, V0, V_TH = 2.0, 9.81, 0.4, 3.0, 1.5, 1e-3


def pushed_block(pulses: bool) -> HybridModel:
    g = BondGraph("pushed_block")
    v = g.add(One("v"))
    g.connect(Se("push", sp.Symbol("P")), v)
    g.connect(v, I("block", "m", state="p"))
    # drawn out of the junction, the source's effort σ μ m g opposes forward sliding
    g.connect(v, Se("coulomb", sp.Symbol("sigma") * sp.Symbol("mu") * sp.Symbol("m") * sp.Symbol("g")),
              name="friction")
    stick = g.add(Zero("stick", controlled=True))
    g.connect(v, stick)
    g.connect(stick, Sf("floor", 0))
    g.displacement("x", of="block")
    friction = Automaton("friction", {"slide": {"stick": False}, "stuck": {"stick": True}}, "slide",
                         values={"slide": {"sigma": 1}, "stuck": {"sigma": 0}})
    friction.add_transition("slide", "stuck", "vel <= v_th and abs(F_stick) < mu*m*g", "a posteriori",
                            pulses=pulses)
    friction.add_transition("stuck", "slide", "F_floor < -mu*m*g", "a posteriori")
    from switching import InMode

    return HybridModel(
        g, [friction], {"m": M, "g": G, "mu": MU, "P": P, "v_th": V_TH},
        initial_state={"p": M * V0},
        signals={"vel": "p/m", "F_floor": "-e_floor", "F_stick": InMode("-e_floor", friction="stuck")},
        name="pushed_block",
    )


def _exact():
    a = MU * G - P / M
    t_stick = (V0 - V_TH) / a
    return t_stick, V0 * t_stick - a * t_stick**2 / 2


def test_the_stick_jump_judged_with_its_pulse_stops_time():
    with pytest.raises(DivergenceOfTimeError) as info:
        pushed_block(pulses=True).simulate(2.0, "RK45", rtol=1e-10, atol=1e-12)
    assert "friction=stuck" in str(info.value) and "δ" in str(info.value)


@pytest.mark.parametrize("method, options", [("RK45", {"rtol": 1e-10, "atol": 1e-12}), ("rk4", {"dt": 1e-3})])
def test_a_pulse_free_stick_holds_at_the_exact_instant(method, options):
    model = pushed_block(pulses=False)
    trajectory = model.simulate(2.0, method, **options)
    t_stick, x_stick = _exact()
    (instant,) = trajectory.events
    assert instant.t == pytest.approx(t_stick, rel=1e-9)
    assert [s.mode.label for s in instant.steps] == ["slide", "stuck"]
    assert instant.x_after[model.state_index[model.state("p")]] == 0.0
    assert trajectory.mode_labels[-1] == "friction=stuck"
    assert trajectory.state("x")[-1] == pytest.approx(x_stick, rel=1e-9)
    # the stuck mode's force is the finite −P, inside the cone
    assert trajectory.signal("F_floor")[-1] == pytest.approx(-P, rel=1e-12)


def test_the_option_is_part_of_the_definition():
    plain, abstracted = pushed_block(True), pushed_block(False)
    assert plain.fingerprint != abstracted.fingerprint
    (stick,) = [tr for tr in abstracted.automata[0].transitions if tr.target == "stuck"]
    assert not stick.pulses and "no pulses" in str(stick)
    with pytest.raises(Exception, match="pulses= must be True or False"):
        Automaton("a", {"x": {}, "y": {}}, "x").add_transition("x", "y", "t > 1", pulses="no")


@pytest.mark.slow
def test_compiled_kernel_hands_the_pulse_free_instant_to_python():
    pytest.importorskip("numba")
    model = pushed_block(pulses=False)
    python = model.simulate(2.0, "RK45", rtol=1e-10, atol=1e-12)
    compiled = model.simulate(2.0, "RK45-jit", rtol=1e-10, atol=1e-12)
    assert compiled.event_times == pytest.approx(python.event_times, rel=1e-12)
    assert compiled.x[-1] == pytest.approx(python.x[-1], rel=1e-12, abs=1e-15)
    assert compiled.stats["instants resolved in Python"] == 1  # the stick: its pulses are dropped in Python
