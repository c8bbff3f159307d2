"""Small hybrid models used by the switching tests (built here, independently
of the model library, so the tests check the semantics, not the library)."""

import numpy as np
import sympy as sp

from bondgraph import BondGraph, C, I, One, R, Se, Sf, Zero
from models.components import rigid_planar_body
from switching import Automaton, HybridModel


def diode_circuit(I_th=0.1, p0=1.0, t_open=1.0):
    """Source V → switch → node; node → (L + R) loop; node → ideal diode (drop V_th) to ground."""
    g = BondGraph("diode")
    sw, n, loop, D = g.add(One("sw", controlled=True)), g.add(Zero("n")), g.add(One("loop")), g.add(One("D", controlled=True))
    g.connect(Se("V", "V"), sw)
    g.connect(sw, n)
    g.connect(n, loop)
    g.connect(loop, I("L", "L"))
    g.connect(loop, R("R", "R"))
    g.connect(n, D, name="diode")
    g.connect(D, Se("Vd", -sp.Symbol("V_th")))
    switch = Automaton("switch", {"closed": {"sw": True}, "open": {"sw": False}}, "closed")
    switch.add_transition("closed", "open", "t >= t_open")
    diode = Automaton("diode", {"off": {"D": False}, "on": {"D": True}}, "off")
    diode.add_transition("off", "on", "v_D >= V_th", "a posteriori")
    diode.add_transition("on", "off", "i_D <= I_th", "a posteriori")
    return HybridModel(
        g,
        [switch, diode],
        dict(V=10, R=1, L=0.1, V_th=0.7, I_th=I_th, t_open=t_open),
        initial_state={"p_L": p0},
        signals={"i_D": "-f_diode", "v_D": "-e_diode", "i_L": "p_L/L", "v_L": "e_L"},
    )


def ball_row(masses, restitution, separating=True, v_th=0.0, gaps=None):
    """Balls on a line joined by contact 0-junctions c<i> (on = touching, same velocity)."""
    n = len(masses)
    g = BondGraph("balls")
    params = {"e": restitution, **({"v_th": v_th} if separating else {})}
    signals = {}
    for i in range(1, n + 1):
        v = g.add(One(f"v{i}"))
        g.connect(v, I(f"m{i}", f"m{i}", state=f"p{i}"))
        g.displacement(f"x{i}", of=v)
        params[f"m{i}"] = masses[i - 1]
        signals[f"v{i}"] = f"p{i}/m{i}"
    automata = []
    for i in range(1, n):
        c = g.add(Zero(f"c{i}", controlled=True))
        g.connect(f"v{i}", c)
        g.connect(c, f"v{i + 1}")
        contact = Automaton(f"contact{i}", {"free": {f"c{i}": False}, "collide": {f"c{i}": True}}, "free",
                            restitution={"collide": "e"})
        approach = f"x{i + 1} - x{i} <= 0"
        if separating:
            approach += f" and v{i} - v{i + 1} > v_th"
        contact.add_transition("free", "collide", approach, "a priori")
        contact.add_transition("collide", "free", f"v{i} <= v{i + 1}", "a priori")
        automata.append(contact)
    return HybridModel(g, automata, params, signals=signals)


def parallel_capacitors(C1=1e-3, C2=2e-3, v1=5.0, v2=1.0, initial="open"):
    g = BondGraph("caps")
    n1, n2, sw = g.add(Zero("n1")), g.add(Zero("n2")), g.add(One("sw", controlled=True))
    g.connect(n1, C("C1", "C1"))
    g.connect(n2, C("C2", "C2"))
    g.connect(n1, sw)
    g.connect(sw, n2)
    switch = Automaton("switch", {"open": {"sw": False}, "closed": {"sw": True}}, initial)
    switch.add_transition("open", "closed", "t >= t_close")
    return HybridModel(g, [switch], {"C1": C1, "C2": C2, "t_close": 0.0},
                       initial_state={"q_C1": C1 * v1, "q_C2": C2 * v2})


def falling_rod(m=1.0, J=None, l=0.5, g_=9.81):
    """A rod that sticks where its tip hits the floor (contact automaton only)."""
    if J is None:
        J = m * (2 * l) ** 2 / 12
    scene = BondGraph("rod")
    rod = scene.add_submodel(rigid_planar_body(), "rod", share=["m", "J", "l", "g"])
    cx, cy = scene.add(Zero("cx", controlled=True)), scene.add(Zero("cy", controlled=True))
    scene.connect(rod.port("tip_x"), cx, name="tip_x")
    scene.connect(cx, Sf("floor_x", 0))
    scene.connect(rod.port("tip_y"), cy, name="tip_y")
    scene.connect(cy, Sf("floor_y", 0))
    contact = Automaton("contact", {"free": {"cx": False, "cy": False}, "stuck": {"cx": True, "cy": True}}, "free")
    contact.add_transition("free", "stuck", "tip_y <= 0 and tip_vy < 0", "a priori")
    contact.add_transition("stuck", "free", "normal_force <= 0", "a posteriori")
    signals = {
        "tip_y": "rod/y - l*sin(rod/theta)",
        "tip_vy": "rod/p_y/m - l*cos(rod/theta)*rod/p_J/J",
        "tip_vx": "rod/p_x/m + l*sin(rod/theta)*rod/p_J/J",
        "normal_force": "-e_tip_y",
        "friction_force": "-e_tip_x",
    }
    return HybridModel(scene, [contact], {"m": m, "J": J, "l": l, "g": g_}, signals=signals)


def independent_switches(n=20):
    """n separate RC cells, each with its own switched junction and automaton."""
    g = BondGraph("switches")
    automata = []
    for i in range(n):
        sw = g.add(One(f"sw{i}", controlled=True))
        g.connect(Se(f"V{i}", "V"), sw)
        g.connect(sw, R(f"R{i}", "R"))
        g.connect(sw, C(f"C{i}", "C"))
        a = Automaton(f"a{i}", {"open": {f"sw{i}": False}, "closed": {f"sw{i}": True}}, "open")
        a.add_transition("open", "closed", f"t >= {i + 1}")
        automata.append(a)
    return HybridModel(g, automata, {"V": 1.0, "R": 1.0, "C": 1.0})


def rc_graph():
    """Source V0 through a controlled 1-junction 'sw' onto R and C."""
    g = BondGraph("rc")
    sw = g.add(One("sw", controlled=True))
    g.connect(Se("V", "V0"), sw)
    g.connect(sw, R("R", "R"))
    g.connect(sw, C("C", "C"))
    return g


def relay_graph():
    """Source V through R1 (junction a) onto capacitor C, discharged through R2 (junction b)."""
    g = BondGraph("relay")
    n = g.add(Zero("n"))
    a, b = g.add(One("a", controlled=True)), g.add(One("b", controlled=True))
    g.connect(Se("V", "V"), a)
    g.connect(a, R("R1", "R1"))
    g.connect(a, n)
    g.connect(n, C("C", "C"))
    g.connect(n, b)
    g.connect(b, R("R2", "R2"))
    return g


def rc_relay(R1=1.0, R2=0.5, C_=1.0, V=1.0, v_hi=0.8, v_lo=0.3):
    """A capacitor charged through R1 from V until v_C >= v_hi, then
    discharged through R2 until v_C <= v_lo, and so on (closed form between events)."""
    g = relay_graph()
    relay = Automaton("relay", {"charge": {"a": True, "b": False}, "discharge": {"a": False, "b": True}}, "charge")
    relay.add_transition("charge", "discharge", "q_C/C >= v_hi")
    relay.add_transition("discharge", "charge", "q_C/C <= v_lo")
    return HybridModel(g, [relay], dict(R1=R1, R2=R2, C=C_, V=V, v_hi=v_hi, v_lo=v_lo))


def rc_relay_exact(t_end, R1=1.0, R2=0.5, C_=1.0, V=1.0, v_hi=0.8, v_lo=0.3):
    """(v_C(t_end), event times) of :func:`rc_relay` from v_C = 0, in closed form."""
    import math

    t, v, charging, events = 0.0, 0.0, True, []
    while True:
        if charging:
            duration = R1 * C_ * math.log((V - v) / (V - v_hi))
        else:
            duration = R2 * C_ * math.log(v / v_lo)
        if t + duration > t_end:
            s = t_end - t
            if charging:
                return V + (v - V) * math.exp(-s / (R1 * C_)), events
            return v * math.exp(-s / (R2 * C_)), events
        t += duration
        v = v_hi if charging else v_lo
        charging = not charging
        events.append(t)


def phase(A, b, tau):
    """``(E, c)`` of ``x(τ) = E x(0) + c`` for the affine flow ``ẋ = A x + b`` over ``τ`` [s]: the
    top-left block and last column of the exponential of ``[[A, b], [0, 0]] τ``."""
    from scipy.linalg import expm

    n = len(b)
    Z = np.zeros((n + 1, n + 1))
    Z[:n, :n], Z[:n, n] = A, b
    E = expm(Z * tau)
    return E[:n, :n], E[:n, n]


def exported_rates(model, directory, name: str, charges) -> list:
    """The rates of ``model``'s one derived mode at each of ``charges`` (a one-state model), computed
    by its exported module (``model.export_module``) in a new Python process where sympy, numpy and
    scipy cannot be imported: the module must need only ``math``."""
    import subprocess
    import sys
    import textwrap

    (label,) = model.export_module(directory / f"{name}.py")
    check = textwrap.dedent(
        f"""
        import sys
        sys.modules["sympy"] = sys.modules["numpy"] = sys.modules["scipy"] = None  # none of them importable
        sys.path.insert(0, sys.argv[1])
        import {name} as m
        out = [0.0]
        for q in {tuple(charges)!r}:
            m.MODES[{label!r}]["rates"]([q], 0.0, m.PARAMETER_VALUES, [], out)
            print(repr(out[0]))
        """)
    done = subprocess.run([sys.executable, "-c", check, str(directory)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    return [float(v) for v in done.stdout.split()]


def scalar_function_both_ways(source: str, symbol: str) -> tuple:
    """``f`` of ``source`` (one float argument, a float result, in the modes' dialect) compiled twice: by
    the native translator (:func:`codegen.native.compile_function`, as ``symbol``) and by numba's own
    front end; returns the two as ctypes callables ``(native, numba)``, to compare bit for bit."""
    import ctypes

    from numba import types
    from numba.core.ccallback import CFunc

    from codegen.native import compile_function
    from switching.library.jit_model import MODE_DIALECT, mode_calls

    native = compile_function(source, "f", ["f"], "f", symbol, dialect=MODE_DIALECT, calls=mode_calls())
    namespace: dict = {}
    exec(compile(source, f"<{symbol} source>", "exec"), namespace)
    reference = CFunc(namespace["f"], ((types.float64,), types.float64), locals={}, options={"error_model": "numpy"})
    reference.compile()
    prototype = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_double)
    return prototype(native.address), prototype(reference.address)
