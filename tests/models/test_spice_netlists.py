"""SPICE netlists in and out (models/spice.py): a dozen textbook netlists of power and filter circuits
read and run against closed forms and, where ngspice is installed, against ngspice; each read, written
and read again to the same circuit (same parts, the same equations, the same run to the bit); cards
outside the subset refused by line; SPICE's numbers; circuits built in Python written for ngspice."""

import doctest
import math
import shutil
import subprocess
import sys
import tempfile
import warnings
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

from models import spice, spice_forms, spice_reference
from models.circuits import PWM, Circuit, Input
from models.spice import (
    SpiceExportError,
    SpiceNetlistError,
    SpiceSyntaxError,
    UnsupportedCardError,
)
from models.spice_reference import THERMAL_VOLTAGE

HAVE_NGSPICE = shutil.which("ngspice") is not None
needs_ngspice = pytest.mark.skipif(not HAVE_NGSPICE, reason="ngspice is not installed (Debian package ngspice): "
                                   "the comparison with SPICE needs it")

# ---------------------------------------------------------------------------------------------- the netlists

#: textbook circuits: name → netlist
NETLISTS = {
    "halfwave": """Half-wave rectifier with capacitor filter
* 10 V, 50 Hz through a small-signal diode into 100 uF and a 1 k load
Vs s 0 SIN(0 10 50)
D1 s p dsig
C1 p 0 100u
RL p 0 1k
.model dsig D(IS=1e-12 N=1)
.options reltol=1e-7 abstol=1e-14 vntol=1e-10
.tran 1u 60m 0 10u uic
.end
""",
    "bridge": """Bridge rectifier with capacitor filter
Vs s 0 SIN(0 10 50)
Rs s x 1
D1 x p dbr
D2 0 p dbr
D3 n x dbr
D4 n 0 dbr
C1 p n 100u
RL p n 1k
* node capacitances (in both): every node's potential a state
Cx x 0 100n
Cp p 0 100n
.model dbr D(IS=1e-12 N=1)
.options reltol=1e-7 abstol=1e-14 vntol=1e-10
.tran 1u 40m 0 10u uic
.end
""",
    "buck": """Buck converter, 100 kHz
V1 in 0 DC 12
Vg g 0 PULSE(0 1 0 1n 1n 4.999u 10u)
S1 in sw g 0 swmod
D1 0 sw dmod
L1 sw out 100uH
C1 out 0 100u IC=0
R1 out 0 5
.model swmod SW(VT=0.5 VH=0 RON=1m ROFF=1e12)
.model dmod D(IS=1e-12 N=1 RS=0.05)
.options reltol=1e-6
.tran 10n 1m 0 100n uic
.end
""",
    "boost": """Boost converter, 50 kHz
Vin in 0 DC 5
L1 in sw 220u
Vg g 0 PULSE(0 5 0 10n 10n 11.99u 20u)
S1 sw 0 g 0 swm
D1 sw out dbo
C1 out 0 47u
R1 out 0 25
.model swm SW(VT=2.5 RON=20m ROFF=1e12)
.model dbo D(IS=1e-12 N=1)
.options reltol=1e-6
.tran 10n 2m 0 100n uic
.end
""",
    "flyback": """Flyback converter, 50 kHz, coupled inductors
Vin in 0 DC 12
Lp in d 100u
* the secondary's dot at ground: its diode blocks while the switch conducts
Ls 0 s2 100u
K1 Lp Ls 1
Vg g 0 PULSE(0 10 0 10n 10n 7.99u 20u)
S1 d 0 g 0 swm
D1 s2 out dfly
Cout out 0 47u
Rload out 0 20
.model swm SW(VT=5 RON=10m ROFF=1e12)
.model dfly D(IS=1e-12 N=1)
.options reltol=1e-6
.tran 10n 1m 0 100n uic
.end
""",
    "lowpass": """RLC low-pass filter (series L, shunt C, load R), driven at 1 kHz
V1 in 0 SIN(0 1 1k)
L1 in out 10m
C1 out 0 1u
R1 out 0 100
.tran 1u 10m 0 1u uic
.end
""",
    "bandpass": """Series RLC band-pass, output across R, a delayed damped burst
V1 in 0 SIN(0.5 2 1.5k 1m 200 30)
L1 in a 10m
C1 a out 1u
R1 out 0 50
.tran 1u 8m 0 1u uic
.end
""",
    "rcpulse": """RC low-pass driven by a pulse train
V1 in 0 PULSE(0 5 0.2m 1u 1u 1m 2.5m)
R1 in out 1k
C1 out 0 0.2u
.tran 1u 6m 0 1u uic
.end
""",
    "rcramp": """RC driven by a trapezoid with slow edges
V1 in 0 PULSE(0 5 0.2m 0.3m 0.1m 0.5m 2m)
R1 in out 1k
C1 out 0 0.2u
.tran 1u 5m 0 1u uic
.end
""",
    "pwl": """RL driven by a piecewise linear voltage
V1 in 0 PWL(0 0 1m 2 3m 2 3.5m -1 5m -1)
R1 in a 10
L1 a 0 20mH
.tran 1u 6m 0 1u uic
.end
""",
    "ladder": """Two RC sections from one subcircuit
.subckt rcsec in out params: r=1k c=1u
R1 in out {r}
C1 out 0 {c}
.ends rcsec
V1 a 0 DC 1
X1 a b rcsec
X2 b c rcsec r=2k
.tran 10u 10m 0 10u uic
.end
""",
    "params": """RC with parameters
.param R=2.2k C={100n*2} tau={R*C} V0=3
V1 in 0 {V0*2}
R1 in out {R}
C1 out 0 {C} IC={V0}
.tran {tau/100} {5*tau} 0 {tau/100} uic
.end
""",
    "relay": """Relaxation oscillator: a switch with hysteresis discharges a capacitor
V1 in 0 DC 10
R1 in c 1k
C1 c 0 1u
S1 c r c 0 srelay
R2 r 0 100
.model srelay SW(VT=5 VH=1 RON=1m ROFF=1e12)
.tran 1u 5m 0 1u uic
.end
""",
    "limiter": """Current-controlled switch: a shunt closes when the inductor's current passes 1.2 A
V1 in 0 DC 10
Vsense in a 0
L1 a b 10m
R1 b 0 5
W1 b 0 Vsense wshed
.model wshed CSW(IT=1 IH=0.2 RON=1 ROFF=1e12)
.tran 1u 5m 0 1u uic
.end
""",
}

#: name → (ngspice's vector, the toolkit's signal, tolerance [V or A], why that tolerance)
AGREEMENT = {
    "halfwave": ("v(p)", "v_p", 5e-5, "the same equations (SPICE's diode law with GMIN at 27 °C in both); "
                 "ngspice at reltol 1e-7, 10 µs steps: 8e-6 V measured"),
    "bridge": ("v(p,n)", "v_RL", 5e-5, "the same equations; 6e-6 V measured"),
    "buck": ("v(out)", "v_out", 5e-4, "the same diode and switch laws but ROFF (1e12 Ω, open in the toolkit) and "
             "the 1 ns gate edges, steps at their midpoints here; ngspice at reltol 1e-6: 1.3e-4 V measured "
             "(in the start-up's ringing; 4e-5 V at 1 ms)"),
    "boost": ("v(out)", "v_out", 5e-4, "as the buck: 6e-6 V measured"),
    "flyback": ("v(out)", "v_out", 5e-4, "as the buck, K = 1 in both: 6e-6 V measured"),
    "lowpass": ("v(out)", "v_out", 1e-4, "ngspice's trapezoidal steps of 1 µs at its default reltol 1e-3: "
                "3e-6 V measured"),
    "bandpass": ("v(out)", "v_out", 2e-4, "as the low-pass: 4e-5 V measured"),
    "rcpulse": ("v(out)", "v_out", 2e-4, "the 1 µs edges are ideal steps at their midpoints here (the same "
                "area; the response differs by ~V·(TR/RC)²/24 = 5e-6 V) and ngspice's reltol 1e-3: 3e-5 V measured"),
    "rcramp": ("v(out)", "v_out", 1e-4, "the same ramps; ngspice's reltol 1e-3: 6e-6 V measured"),
    "pwl": ("i(L1)", "i_L1", 1e-6, "the same waveform: 5e-9 A measured"),
    "ladder": ("v(c)", "v_c", 1e-5, "linear: 4e-7 V measured"),
    "params": ("v(out)", "v_out", 5e-5, "linear: 7e-6 V measured"),
    "limiter": ("i(L1)", "i_L1", 1e-3, "ngspice puts the switch's instant within its 1 µs step, where "
                "di/dt ≈ 0.6 A/ms: 6e-5 A measured"),
}


def ngspice(text: str, vectors) -> tuple:
    """``(times, columns)`` of ngspice's run of ``text`` (ending in ``.end``) writing ``vectors``."""
    lines = text.rstrip().splitlines()
    assert lines[-1].strip().lower() == ".end"
    control = [".control", "run", "wrdata out.txt " + " ".join(vectors), "quit", ".endc", ".end"]
    with tempfile.TemporaryDirectory(prefix="hbg-spice-") as folder:
        Path(folder, "c.cir").write_text("\n".join(lines[:-1] + control) + "\n")
        done = subprocess.run(["ngspice", "-b", "c.cir"], cwd=folder, capture_output=True, text=True, timeout=300)
        out = Path(folder, "out.txt")
        assert out.exists(), done.stdout[-3000:] + done.stderr[-3000:]
        table = np.loadtxt(out, ndmin=2)
    return table[:, 0], table[:, 1::2]


def toolkit(netlist, t_eval=None, **options):
    """The run of a :class:`SpiceNetlist` over its .tran (its TMAX as max_step), at rtol 1e-9."""
    run = dict(netlist.run)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return netlist.build().simulate(run.pop("t_end"), "auto", t_eval=t_eval,
                                        **{"rtol": 1e-9, "atol": 1e-12, **run, **options})


# ---------------------------------------------------------------------------------------------- numbers

@pytest.mark.parametrize("text, value", [
    ("1meg", 1e6), ("1MEG", 1e6), ("1Meg", 1e6), ("1m", 1e-3), ("1M", 1e-3), ("10uF", 1e-5), ("10u", 1e-5),
    ("1kOhm", 1e3), ("2.2k", 2200.0), ("4.7K", 4700.0), ("100p", 1e-10), ("3n", 3e-9), ("1F", 1e-15),
    ("1mil", 25.4e-6), ("1g", 1e9), ("1T", 1e12), ("1e3", 1e3), ("1.5e-3", 1.5e-3), ("-2.5", -2.5), (".5u", 5e-7),
    ("5V", 5.0), ("100mA", 0.1), ("1ms", 1e-3), ("2e3k", 2e6), ("0", 0.0), ("+3", 3.0)])
def test_spice_numbers_with_their_scales_and_units(text, value):
    """SPICE's scales (any case; ``meg`` and ``mil`` before ``m``, so 1M is a milli), unit letters ignored."""
    assert spice.number(text) == pytest.approx(value, rel=1e-15)


@pytest.mark.parametrize("text", ["abc", "1.2.3", "", "k1", "1e", "--1", "1 k"])
def test_what_is_no_number_is_refused(text):
    if text == "1e":  # (SPICE reads "1e" as 1 with a unit letter e)
        assert spice.number(text) == 1.0
        return
    with pytest.raises(SpiceSyntaxError, match="is not a SPICE number"):
        spice.number(text)


def test_numbers_are_exact_decimals():
    """The timing of pulses is computed in exact arithmetic on the decimals as written."""
    assert spice.exact_number("4.999u") == Fraction(4999, 10**9)
    assert spice.exact_number("10u") / spice.exact_number("3") == Fraction(1, 300000)
    assert spice.evaluate("1n + 4.999u") == Fraction(5, 10**6)
    assert spice.evaluate("R*2", {"r": Fraction(1100)}.get) == 2200
    assert spice.evaluate("sqrt(4)*pi") == pytest.approx(2 * math.pi)


def test_the_writer_side_shares_the_reference_constants():
    """spice_forms keeps SPICE's 27 °C, k·T/q and GMIN itself (it imports nothing of models.circuits, so
    that Circuit.to_spice may import the writer): the same numbers as models/spice_reference.py."""
    assert spice_forms.THERMAL_VOLTAGE == spice_reference.THERMAL_VOLTAGE
    assert spice_forms.GMIN == spice_reference.GMIN
    assert spice_forms.NOMINAL_TEMPERATURE == spice_reference.NOMINAL_TEMPERATURE


def test_the_module_example_runs():
    result = doctest.testmod(spice, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0


# ---------------------------------------------------------------------------------------------- the textbook netlists

@needs_ngspice
@pytest.mark.parametrize("name", sorted(AGREEMENT))
def test_netlists_agree_with_ngspice(name):
    """The netlist run by ngspice and by the toolkit (rtol 1e-9): the largest difference at four times
    over the run (a quarter, half, three quarters and the end) within the tolerance AGREEMENT gives,
    with its reason."""
    vector, signal, tolerance, _ = AGREEMENT[name]
    text = NETLISTS[name]
    times, columns = ngspice(text, [vector])
    netlist = spice.read(text)
    t_end = netlist.run["t_end"]
    points = np.linspace(t_end / 4, t_end, 4)
    ours = toolkit(netlist, t_eval=points).signal(signal)
    theirs = np.interp(points, times, columns[:, 0])
    assert np.max(np.abs(ours - theirs)) < tolerance, (ours, theirs)


def test_rc_pulse_follows_its_closed_form_with_edges_at_their_midpoints():
    """PULSE(0 5 0.2m 1u 1u 1m 2.5m): 1 µs edges are 1e-3 of its 1 ms level, so ideal: steps at
    0.2005 ms + k·2.5 ms (up) and 1.2015 ms + k·2.5 ms (down), each an instant of the run located to
    1e-15 s; between them the RC (τ = 0.2 ms) charges and discharges exactly."""
    netlist = spice.read(NETLISTS["rcpulse"])
    points = np.array([0.5e-3, 1.2e-3, 2e-3, 3e-3, 4.5e-3, 6e-3])
    run = toolkit(netlist, t_eval=points, rtol=1e-11, atol=1e-15)
    edges = sorted([0.2005e-3 + k * 2.5e-3 for k in range(3)] + [1.2015e-3 + k * 2.5e-3 for k in range(2)])
    assert np.max(np.abs(np.array(run.event_times) - edges)) < 1e-15
    tau, v, t0, level, expected = 0.2e-3, 0.0, 0.0, 0.0, {}
    for t in sorted(set(edges) | set(points)):  # (the edges alternate: up, down, up, …)
        v, t0 = _charged(v, t0, t, level, tau), t
        level = (5.0 if edges.index(t) % 2 == 0 else 0.0) if t in edges else level
        expected[t] = v
    assert np.max(np.abs(run.signal("v_out") - [expected[t] for t in points])) < 1e-8


def _charged(v, t0, t1, level, tau):
    """An RC's voltage from ``v`` at ``t0`` to ``t1`` towards ``level``."""
    return level + (v - level) * math.exp(-(t1 - t0) / tau)


def test_parameters_in_braces_give_the_rc_its_closed_form():
    """``.param R=2.2k C={100n*2} tau={R*C} V0=3``: the source is 6 V, the capacitor starts at IC = 3 V,
    and the run ends at 5τ = 2.2 ms (exactly, from the exact product) with steps of at most τ/100."""
    netlist = spice.read(NETLISTS["params"])
    assert netlist.run == {"t_end": 2.2e-3, "max_step": 4.4e-6}
    parts = {p.name: p for p in netlist.circuit._parts.values()}
    assert parts["R1"].values["value"] == 2200.0 and parts["C1"].values["value"] == 2e-7
    assert parts["C1"].values["initial"] == 3.0 and parts["V1"].values["value"] == 6.0
    points = np.array([0.44e-3, 1e-3, 2.2e-3])
    v = toolkit(netlist, t_eval=points).signal("v_out")
    assert v == pytest.approx(6.0 - 3.0 * np.exp(-points / 0.44e-3), abs=1e-8)


def test_the_low_pass_filter_reaches_its_steady_state_response():
    """After 10 ms (50 of its decay times 2Q/ω₀ = 0.2 ms), the output is |H|·sin(ωt + ∠H) with
    H = 1/(1 − ω²LC + jωL/R) at 1 kHz, to 1e-7 V."""
    netlist = spice.read(NETLISTS["lowpass"])
    points = np.linspace(9e-3, 10e-3, 7)
    v = toolkit(netlist, t_eval=points).signal("v_out")
    w = 2 * math.pi * 1e3
    h = 1 / (1 - w**2 * 10e-3 * 1e-6 + 1j * w * 10e-3 / 100)
    assert v == pytest.approx(abs(h) * np.sin(w * points + np.angle(h)), abs=1e-7)


def test_a_switch_with_hysteresis_switches_at_its_closed_form_instants():
    """S1 closes above VT + VH = 6 V and opens below VT − VH = 4 V: the capacitor charges towards 10 V
    (τ = 1 ms) and discharges towards 10·100/1100 V through R1 ∥ (R2 + RON) — instants from the closed
    form to 1e-12 s.  (ngspice places these instants within its 1 µs steps, switching at 5.96 V and
    4.05 V here: its period is within 1 % of this one.)"""
    netlist = spice.read(NETLISTS["relay"])
    run = toolkit(netlist)
    charge = 1e-3 * math.log((10 - 4) / (10 - 6))
    r = 1e3 * 100.001 / 1100.001
    low = 10 * 100.001 / 1100.001
    discharge = r * 1e-6 * math.log((6 - low) / (4 - low))
    first = 1e-3 * math.log(10 / 4)
    expected = [first]
    while expected[-1] < 5e-3:
        expected.append(expected[-1] + (discharge if len(expected) % 2 else charge))
    expected = [t for t in expected if t <= 5e-3]
    assert np.max(np.abs(np.array(run.event_times) - expected)) < 1e-12
    if HAVE_NGSPICE:
        times, columns = ngspice(NETLISTS["relay"], ["v(c)"])
        v = columns[:, 0]
        peaks = times[1:-1][(v[1:-1] > 5.5) & (v[1:-1] >= v[:-2]) & (v[1:-1] > v[2:])]
        assert np.mean(np.diff(peaks)) == pytest.approx(charge + discharge, rel=0.01)


def test_a_current_controlled_switch_closes_where_the_current_reaches_it_plus_ih():
    """W1 closes when i(Vsense) exceeds IT + IH = 1.2 A: i = 2(1 − e^(−t/τ)), τ = L/R = 2 ms, so at
    τ·ln(2/0.8) (to 1e-12 s); the current then rises towards 10 V over R1 ∥ RON."""
    netlist = spice.read(NETLISTS["limiter"])
    run = toolkit(netlist)
    assert run.event_times[0] == pytest.approx(2e-3 * math.log(2 / 0.8), abs=1e-12)
    assert len(run.event_times) == 1
    assert "closed while i_Vsense > 1.2 A" in "\n".join(netlist.notes)


# ---------------------------------------------------------------------------------------------- round trips

def _parts(circuit):
    return [(p.kind, p.name, p.nodes, p.values) for p in circuit._parts.values()]


@pytest.mark.parametrize("name", sorted(NETLISTS))
def test_a_netlist_written_and_read_again_is_the_same_circuit_to_the_bit(name):
    """netlist → Circuit → write → read: the same parts (kinds, names, nodes, values), the same
    equations (the models' fingerprints), the same run (two runs with the same options: identical
    arrays), and the same written text again."""
    first = spice.read(NETLISTS[name])
    text = first.write()
    second = spice.read(text)
    assert _parts(second.circuit) == _parts(first.circuit)
    assert second.circuit.name == first.circuit.name and second.run == first.run
    a, b = first.build(), second.build()
    assert a.fingerprint == b.fingerprint
    t_end = first.run["t_end"] / 5
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ra, rb = (m.simulate(t_end, "auto", max_step=first.run.get("max_step", np.inf)) for m in (a, b))
    assert np.array_equal(ra.t, rb.t) and np.array_equal(ra.x, rb.x)
    assert second.write() == text


def test_a_written_netlist_says_what_it_approximates():
    text = spice.read(NETLISTS["buck"]).write()
    assert "* S1: PWM(period=1e-05, duty=0.5, delay=5e-10)" in text
    # (edges of 1 ps, 1e-6 of its levels: ideal, centred on the instants 0.5 ns and 5.0005 µs)
    assert "VS1_gate S1_gate 0 PULSE(0 1 4.995e-10 1e-12 1e-12 4.999999e-06 1e-05)" in text
    assert "RS_D1 D1_rs sw 0.05" in text and ".model m_D1 D(IS=1e-12 N=1.0)" in text
    assert text.rstrip().endswith(".tran 1e-08 0.001 0 1e-07 UIC\n.end")


# ---------------------------------------------------------------------------------------------- the reading

def test_comments_continuations_case_and_ground():
    """``*`` lines, ``;`` and `` $`` comments, ``+`` continuations (with a comment between), cards and
    names in any case (the first spelling kept), ``gnd`` as ground, ``.end`` ending the netlist."""
    netlist = spice.read("""Syntax
V1 IN gnd PULSE(0 5 ; the levels
* a comment between a card and its continuation
+ 1m 0 0 2m 4m) $ and a trailing comment
r1 in OUT 1K
C1 out 0 1u ic=1
.TRAN 10u 5m
.end
R9 this line is after .end
""")
    assert _parts(netlist.circuit)[1] == ("R", "r1", ("IN", "OUT"), {"value": 1000.0, "law": None})
    assert netlist.circuit.nodes == ("IN", "0", "OUT")
    (_, _, _, values), = [p for p in _parts(netlist.circuit) if p[1] == "V1"]
    assert values["value"].spice == spice.Waveform("PULSE", tuple(map(Fraction, (0, 5, "0.001", 0, 0, "0.002",
                                                                                 "0.004"))) + (None,))
    assert any("UIC" in note for note in netlist.notes)


def test_subcircuits_are_flattened_with_ngspice_names():
    netlist = spice.read(NETLISTS["ladder"])
    assert netlist.circuit.components == ("V1", "R_X1_R1", "C_X1_C1", "R_X2_R1", "C_X2_C1")
    parts = {p[1]: p for p in _parts(netlist.circuit)}
    assert parts["R_X1_R1"][2:] == (("a", "b"), {"value": 1000.0, "law": None})
    assert parts["R_X2_R1"][2:] == (("b", "c"), {"value": 2000.0, "law": None})


def test_subcircuit_inner_nodes_and_nesting():
    netlist = spice.read("""nested
.subckt half in out
R1 in mid 1k
R2 mid out 1k
.ends
.subckt quarter in out
X1 in m half
X2 m out half
.ends
V1 a 0 1
Xq a b quarter
R9 b 0 4k
.end
""")
    assert "R_Xq_X1_R1" in netlist.circuit.components
    assert {"Xq_X1_mid", "Xq_m", "Xq_X2_mid"} <= set(netlist.circuit.nodes)
    run = netlist.build().simulate(1e-3)
    assert run.signal("v_b")[-1] == pytest.approx(0.5, rel=1e-12)


def test_sources_and_their_defaults():
    """SIN's FREQ defaults to 1/TSTOP, PULSE's TR and TF to TSTEP (read as ideal where tiny) and PW, PER
    to TSTOP; a PULSE with NP stops after NP pulses; AC is ignored; B sources of time are read."""
    netlist = spice.read("""sources
V1 a 0 SIN(1 2)
R1 a 0 1
V2 b 0 PULSE(0 1 1m)
R2 b 0 1
V3 c 0 DC 0 AC 1 PULSE(0 1 0 0 0 1m 2m 2)
R3 c 0 1
B1 d 0 V=2*sin(2*pi*50*time) + u(time - 1m)
R4 d 0 1
I1 0 e 3m
R5 e 0 1k
.tran 1u 10m
.end
""")
    parts = {p[1]: p[3] for p in _parts(netlist.circuit)}
    assert parts["V1"]["value"].spice.values[2] == 100  # 1/TSTOP
    assert parts["V2"]["value"].spice.values[3:7] == (Fraction(1, 10**6),) * 2 + (Fraction(1, 100),) * 2
    run = netlist.build().simulate(10e-3, "auto", t_eval=[0.5e-3, 1.5e-3, 4.5e-3, 5.5e-3, 9e-3], max_step=1e-4)
    assert run.signal("v_c") == pytest.approx([1, 0, 0, 0, 0])
    assert run.signal("v_b") == pytest.approx([0, 1, 1, 1, 1])
    assert run.signal("v_d")[-1] == pytest.approx(2 * math.sin(2 * math.pi * 50 * 9e-3) + 1, abs=1e-9)
    assert run.signal("v_e")[-1] == pytest.approx(3.0)
    assert any("AC specification is ignored" in note for note in netlist.notes)


def test_ic_sets_the_capacitors_initial_voltages():
    netlist = spice.read("""ic
V1 a 0 0
R1 a b 1k
C1 b c 1u
C2 c 0 1u IC=2
R2 c 0 1k
.ic V(b)=5 V(c)=1
.tran 1u 1m uic
.end
""")
    parts = {p[1]: p[3] for p in _parts(netlist.circuit)}
    assert parts["C1"]["initial"] == 4.0 and parts["C2"]["initial"] == 2.0  # IC= wins over .ic


@pytest.mark.parametrize("rule, kind, values", [
    ("ideal", "D", {"r_on": None, "v_f": None, "on": False}),
    ("piecewise", "D", {"r_on": pytest.approx(THERMAL_VOLTAGE / (1 + 1e-12)),
                        "v_f": pytest.approx(THERMAL_VOLTAGE * (math.log(1e12 + 1) - 1 / (1 + 1e-12))),
                        "on": False}),
])
def test_the_diode_rule_ideal_or_piecewise(rule, kind, values):
    """``diodes="piecewise"`` takes the exponential's tangent at 1 A: r_on = N·VT/(1 A + IS) + RS,
    v_f where it meets i = 0 (0.689 V for IS = 1e-12, N = 1)."""
    netlist = spice.read(NETLISTS["halfwave"], diodes=rule)
    (part,) = [p for p in _parts(netlist.circuit) if p[1] == "D1"]
    assert part[0] == kind and part[3] == values
    assert netlist.diodes["D1"].startswith("D1: the ideal diode")


def test_the_diode_rule_by_name_and_ltspice_idealized_diodes():
    netlist = spice.read(NETLISTS["bridge"], diodes={"d1": "ideal", "D2": "piecewise"})
    kinds = {p[1]: p[0] for p in _parts(netlist.circuit)}
    assert (kinds["D1"], kinds["D2"], kinds["D3"], kinds["D4"]) == ("D", "D", "R", "R")
    assert "diodes='auto'" in netlist.diodes["D3"] and "exponential" in netlist.diodes["D3"]
    ltspice = spice.read(NETLISTS["halfwave"].replace("D(IS=1e-12 N=1)", "D(Ron=0.1 Vfwd=0.7 Roff=1meg)"))
    (part,) = [p for p in _parts(ltspice.circuit) if p[1] == "D1"]
    assert part[3] == {"r_on": 0.1, "v_f": 0.7, "on": False}
    assert "ROFF ignored" in ltspice.diodes["D1"] or "Vfwd and Ron" in ltspice.diodes["D1"]


def test_an_exponential_diode_with_series_resistance_gets_its_resistor():
    netlist = spice.read(NETLISTS["buck"])
    parts = {p[1]: p for p in _parts(netlist.circuit)}
    assert parts["D1"][2] == ("0", "D1_rs") and parts["RS_D1"][2:] == (("D1_rs", "sw"), {"value": 0.05,
                                                                                          "law": None})
    assert parts["D1"][3]["law"] == ("flow_law", spice.ExponentialDiode(1e-12, 1.0))


def test_gate_sources_become_pwm_schedules_exactly():
    """The buck's gate PULSE(0 1 0 1n 1n 4.999u 10u): a PWM of period 10 µs, duty (4.999 µs + 1 ns)/10 µs
    = 0.5 exactly (rational arithmetic on the decimals as written), delay 0.5 ns; the gate source leaves
    the circuit.  Inverted levels close the switch over the low part of the period."""
    netlist = spice.read(NETLISTS["buck"])
    parts = {p[1]: p[3] for p in _parts(netlist.circuit)}
    assert "Vg" not in parts and parts["S1"]["closed_when"] == PWM(1e-05, 0.5, 5e-10)
    inverted = spice.read(NETLISTS["buck"].replace("PULSE(0 1 0 1n 1n 4.999u 10u)", "PULSE(1 0 1u 0 0 3u 10u)"))
    switch = {p[1]: p[3] for p in _parts(inverted.circuit)}["S1"]
    assert switch["closed_when"] == PWM(1e-05, 0.7, 4e-06) and switch["closed"] is True


def test_other_gates_become_conditions_on_time_or_on_node_voltages():
    with_np = spice.read(NETLISTS["buck"].replace("4.999u 10u)", "4.999u 10u 3)"))
    rule = {p[1]: p[3] for p in _parts(with_np.circuit)}["S1"]["closed_when"]
    assert isinstance(rule, spice.SpiceText) and rule.endswith("and t < 2.75005e-05")  # (mid-way off)
    run = with_np.build().simulate(60e-6, "auto")
    instants = [0.5e-9 + k * 5e-6 for k in range(6)]
    assert run.event_times == pytest.approx(instants, abs=1e-15)
    sine = spice.read(NETLISTS["buck"].replace("PULSE(0 1 0 1n 1n 4.999u 10u)", "SIN(0 1 100k)"))
    rule = {p[1]: p[3] for p in _parts(sine.circuit)}["S1"]["closed_when"]
    assert str(rule) == "sin(2*pi*100000.0*t) > 0.5"
    loaded = spice.read(NETLISTS["buck"].replace("S1 in sw g 0 swmod", "S1 in sw g 0 swmod\nRg g 0 1meg"))
    parts = {p[1]: p[3] for p in _parts(loaded.circuit)}
    assert parts["S1"]["closed_when"] == "v_g > 0.5" and "Vg" in parts


# ---------------------------------------------------------------------------------------------- refusals

MINIMAL = "refusal\nV1 a 0 1\n{card}\nR1 a 0 1k\n.tran 1u 1m\n.end\n"


@pytest.mark.parametrize("card, error, words", [
    ("Q1 c b e qmod", UnsupportedCardError, "bipolar transistor"),
    ("M1 d g s s nmod", UnsupportedCardError, "MOSFET (M) is not read"),
    ("E1 a 0 b 0 2", UnsupportedCardError, "controlled source"),
    (".ac dec 10 1 1meg", UnsupportedCardError, "the analysis .ac is not run"),
    (".op", UnsupportedCardError, "the analysis .op"),
    (".model qq FOO(a=1)", UnsupportedCardError, "unknown model type"),
    (".model qn NPN(BF=100)", UnsupportedCardError, "a SPICE model type that is not read"),
    (".include models.lib", UnsupportedCardError, "never opens other files"),
    (".lib /etc/passwd", UnsupportedCardError, "never opens other files"),
    (".temp 50", UnsupportedCardError, "27 °C"),
    ("V2 b 0 EXP(0 1 1m 1m 2m 1m)", UnsupportedCardError, "EXP is not read"),
    ("R2 a 0", SpiceSyntaxError, "write it as Rname n1 n2 RESISTANCE"),
    ("R2 a 0 abc", SpiceSyntaxError, "'abc' is not a number"),
    ("R2 a 0 {1/0}", SpiceSyntaxError, "{1/0}"),
    ("R2 a 0 {x*2}", SpiceSyntaxError, "unknown parameter 'x'"),
    ("R2 a 0 {__import__('os')}", SpiceSyntaxError, "{__import__('os')}"),
    ("R2 a 0 {1", SpiceSyntaxError, "without its '}'"),
    ("D1 a 0 nomodel", SpiceSyntaxError, "model 'nomodel' is not defined"),
    ("X1 a 0 nosub", SpiceSyntaxError, "subcircuit 'nosub' is not defined"),
    ("K1 L1 L2 0.5", SpiceSyntaxError, "no L element"),
    ("R2 a 0 1k tc1=0.1", UnsupportedCardError, "TC1 is not read"),
    ("v1 b 0 2", SpiceSyntaxError, "component name 'v1' is taken (line 2: V1 a 0 1)"),
    ("B1 a 0 V=v(a)*2", UnsupportedCardError, "node voltage"),
    ("V2 b 0 PULSE(0 1 0 1m 1m 1m 2m)", SpiceSyntaxError, "TR + PW + TF"),
])
def test_cards_outside_the_subset_are_refused_by_line(card, error, words):
    with pytest.raises(error) as caught:
        spice.read(MINIMAL.format(card=card))
    assert caught.value.line == 3 and caught.value.source == "<text>"
    message = str(caught.value)
    assert message.startswith(f"<text>, line 3: {card.split()[0]}: ") and words in message, message


def test_refusals_name_the_file_and_the_line_of_a_continued_card(tmp_path):
    path = tmp_path / "bad.cir"
    path.write_text("title\nV1 a 0 1\nR1 a 0\n+ 1k\nQ1 a b\n+ c qmod\n.end\n")
    with pytest.raises(UnsupportedCardError, match=rf"^{path}, line 5: Q1: a bipolar") as caught:
        spice.read(path)
    assert caught.value.card == "Q1 a b c qmod"


def test_subcircuit_recursion_and_parameter_cycles_are_refused():
    with pytest.raises(SpiceSyntaxError, match="contains itself"):
        spice.read("r\n.subckt s a b\nX1 a b s\n.ends\nX1 n 0 s\nR1 n 0 1\n.end\n")
    with pytest.raises(SpiceSyntaxError, match="defined through itself"):
        spice.read("r\n.param a={b} b={a}\nR1 n 0 {a}\nV1 n 0 1\n.end\n")
    with pytest.raises(SpiceNetlistError, match="no elements"):
        spice.read("only a title\n.tran 1u 1m\n.end\n")


# ---------------------------------------------------------------------------------------------- writing circuits built in Python

def _transformer_circuit():
    c = Circuit("transformer_load")
    c.V("V1", "in", "0", "10*sin(2*pi*50*t)")
    c.R("R1", "in", "p", 1.0)
    c.transformer("T1", "p", "0", "s", "0", 2.0)
    c.R("R2", "s", "0", 10.0)
    c.C("C2", "s", "0", 10e-6)
    return c


@needs_ngspice
def test_a_transformer_and_an_expression_source_written_for_ngspice_agree():
    """A transformer (written as E and F with a sensing source) and a source given as an expression of t
    (written as a B source): linear, so within 1e-4 V of ngspice's run at its default tolerances."""
    c = _transformer_circuit()
    text = spice.write(c, {"t_end": 40e-3, "max_step": 10e-6})
    assert "ET1" in text and "FT1" in text and "BV1 in 0 V=" in text
    times, columns = ngspice(text, ["v(s)"])
    points = np.array([10e-3, 25e-3, 40e-3])
    run = c.build().simulate(40e-3, "auto", t_eval=points, rtol=1e-9, atol=1e-12)
    assert np.max(np.abs(run.signal("v_s") - np.interp(points, times, columns[:, 0]))) < 1e-4


@needs_ngspice
def test_a_dc_machine_written_as_two_h_sources_agrees_with_ngspice():
    """Circuit.dc_machine's example: the speed i_J reaches k·V/(Ra·b + k²)(1 − e^(−t/τ))."""
    c = Circuit("motor")
    c.V("Va", "a", "0", 12.0)
    c.R("Ra", "a", "b", 2.0)
    c.dc_machine("M", "b", "0", "w", "0", 0.1)
    c.L("J", "w", "m", 1e-3)
    c.R("Rb", "m", "0", 1e-3)
    text = spice.write(c, {"t_end": 0.5})
    _, columns = ngspice(text, ["i(LJ)"])
    expected = 0.1 * 12 / (2 * 1e-3 + 0.01) * (1 - math.exp(-0.5 / (1e-3 / (1e-3 + 0.01 / 2))))
    assert columns[-1, 0] == pytest.approx(expected, rel=1e-4)


@needs_ngspice
def test_ideal_diodes_and_a_half_bridge_written_for_ngspice():
    """A synchronous buck from Circuit.half_bridge (two MOSFETs with body diodes, a dead time): ngspice runs
    the netlist written, its switches driven by PULSE gates, its ideal diodes approximated by SPICE's
    law through the same tangent at 1 A; the output at four times up to 1 ms agrees to 2 % (0.7 % measured:
    the body diodes conduct only during the dead times, through a knee of 0.1 V and 1 mΩ instead of 0)."""
    c = Circuit("sync_buck")
    c.V("V1", "in", "0", 12.0)
    c.half_bridge("Q", "in", "0", "sw", 1e-5, 0.4, 2e-7, r_on=0.01)
    c.L("L1", "sw", "out", 100e-6)
    c.C("C1", "out", "0", 100e-6)
    c.R("R1", "out", "0", 5.0)
    text = spice.write(c, {"t_end": 1e-3, "max_step": 1e-7})
    assert "Vfwd=0.0 Ron=0.0" in text and text.count("PULSE(") == 2
    times, columns = ngspice(text, ["v(out)"])
    points = np.array([2.5e-4, 5e-4, 7.5e-4, 1e-3])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = c.build().simulate(1e-3, "auto", max_step=1e-7, t_eval=points)
    assert np.interp(points, times, columns[:, 0]) == pytest.approx(run.signal("v_out"), rel=0.02)


def test_a_circuit_built_in_python_reads_back_from_its_netlist():
    """A PWM switch (its window past the period's end: written a period earlier), an ideal diode with v_f and
    r_on (kept by Vfwd and Ron), a relay on a node voltage with hysteresis, a current-controlled switch,
    coupled inductors and a parameter given by name: read back to the same schedule and values."""
    c = Circuit("mixed")
    c.V("V1", "in", "0", "Vin")
    c.switch("S1", "in", "a", PWM(1e-4, 0.25, 9e-5))
    c.diode("D1", "0", "a", r_on=0.02, v_f=0.6)
    c.R("R1", "a", "b", 10.0)
    c.coupled_inductors("K1", "b", "0", "s", "0", 1e-3, 4e-3, 0.95)
    c.R("R2", "s", "0", 50.0)
    c.switch("S2", "s", "t", "v_s > 3", open_when="v_s < 1")
    c.R("R3", "t", "0", 100.0)
    c.V("Vm", "b", "m", 0.0)
    c.R("R4", "m", "0", 1e3)
    c.switch("S3", "m", "0", "i_Vm > 0.002")
    text = spice.write(c, parameters={"Vin": 24.0})
    assert ".param Vin=24.0" in text and "V1 in 0 DC {Vin}" in text
    back = {p[1]: p for p in _parts(spice.read(text).circuit)}
    assert back["V1"][3] == {"value": 24.0}
    assert back["D1"][3] == {"r_on": 0.02, "v_f": 0.6, "on": False}
    assert back["S1"][3]["closed_when"] == PWM(1e-4, 0.25, -1e-5) and back["S1"][3]["closed"] is True
    assert back["K1"][2:] == (("b", "0", "s", "0"), {"L1": 1e-3, "L2": 4e-3, "k": 0.95})
    assert (back["S2"][3]["closed_when"], back["S2"][3]["open_when"]) == ("v_s > 3.0", "v_s < 1.0")
    assert back["WS3"][3]["closed_when"] == "i_Vm > 0.002"  # (a W switch: its name takes the letter)


@pytest.mark.parametrize("build, words", [
    (lambda c: c.switch("S9", "a", "0", "t >= 1e-3"), "switch 'S9': its condition 't >= 1e-3' has no SPICE form"),
    (lambda c: c.R("R9", "a", "0", flow_law=lambda v: v**3), "R 'R9' has a law given as a Python function"),
    (lambda c: c.V("V9", "b", "0", Input("u")), "source 'V9' is the input 'u'"),
    (lambda c: c.R("R9", "a", "0", "R_x"), "give its value, write(..., parameters={'R_x': …})"),
])
def test_parts_spice_cannot_express_are_refused_by_name(build, words):
    c = Circuit("refused")
    c.V("V1", "a", "0", 1.0)
    c.R("R1", "a", "b", 1.0)
    c.R("R2", "b", "0", 1.0)
    build(c)
    with pytest.raises(SpiceExportError) as caught:
        spice.write(c)
    assert words in str(caught.value) and caught.value.part.endswith("9")


# ---------------------------------------------------------------------------------------------- hbg

def _hbg(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "models.cli", *args], capture_output=True, text=True,
                          timeout=300, cwd=cwd, env={**__import__("os").environ, "MPLBACKEND": "Agg"})


def test_hbg_runs_a_netlist_with_its_tran(tmp_path):
    path = tmp_path / "rc.cir"
    path.write_text(NETLISTS["rcpulse"])
    out = _hbg("run", str(path), "--measure", "v_out:max", "--window", "0:0.006")
    assert out.returncode == 0, out.stderr
    assert "t = 0 … 0.006 s" in out.stdout and "v_out max" in out.stdout
    bad = tmp_path / "bad.sp"
    bad.write_text(MINIMAL.format(card="Q1 c b e qmod"))
    out = _hbg("run", str(bad))
    assert out.returncode == 2 and f"{bad}, line 3: Q1: a bipolar transistor" in out.stderr
    untimed = tmp_path / "untimed.net"
    untimed.write_text("no tran\nV1 a 0 1\nR1 a 0 1\n.end\n")
    out = _hbg("run", str(untimed))
    assert out.returncode == 2 and "no .tran card" in out.stderr


def test_a_circuit_writes_itself_as_spice():
    """``Circuit.to_spice`` is :func:`models.spice.write`."""
    from models.circuits import Circuit
    from models.spice import write

    c = Circuit("rc")
    c.V("V1", "a", 0, 1.0)
    c.R("R1", "a", "b", 1e3)
    c.C("C1", "b", 0, 1e-6)
    assert c.to_spice(run={"t_end": 1e-3}) == write(c, {"t_end": 1e-3})
    assert ".tran" in c.to_spice(run={"t_end": 1e-3})


def test_models_load_reads_a_netlist(tmp_path):
    import models

    path = tmp_path / "rc.cir"
    path.write_text("rc\nV1 a 0 DC 1\nR1 a b 1k\nC1 b 0 1u\n.tran 1u 1m\n.end\n")
    model = models.load(path)
    run = model.simulate(1e-3, atol=1e-15)  # (a charge of a microfarad: atol in coulombs)
    assert run.signal("v_b")[-1] == pytest.approx(1 - np.exp(-1.0), rel=1e-5)
