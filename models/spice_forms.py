"""What :mod:`models.spice` reads SPICE's sources, diodes and switches as: transient functions as
expressions of ``t`` (:class:`Waveform`, :func:`waveform_text`), switch rules from gate sources and
control levels, SPICE's diode law (:class:`ExponentialDiode`) and how a ``.model`` is mapped to a
diode, the ``.tran`` card (:class:`Tran`), and text that keeps the SPICE form it was read from
(:class:`SpiceText`)."""

from __future__ import annotations

import decimal
import math
from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction

import sympy as sp
from scipy import constants

from .spice_syntax import SpiceSyntaxError, float_text

__all__ = ["Waveform", "waveform_text", "shifted", "GateControl", "SpiceText", "ExponentialDiode", "Tran",
           "DiodeMapping", "diode_mapping", "decimal_text", "IDEAL_RESISTANCE", "OPEN_RESISTANCE", "DIODE_RULES",
           "MODEL_PARAMETERS", "GMIN", "NOMINAL_TEMPERATURE", "THERMAL_VOLTAGE"]

#: a resistance [Ω] at or below which a switch's RON or a diode's RS/Ron is read as ideal (0), and
#: what :func:`~models.spice.write` gives SPICE for an ideal element's 0
IDEAL_RESISTANCE = 1e-6
#: the off-resistance [Ω] :func:`~models.spice.write` gives SPICE's switches (the toolkit's open switch is open)
OPEN_RESISTANCE = 1e12
#: SPICE's nominal temperature [K] (27 °C), its thermal voltage k·T/q there [V] and ngspice's default
#: GMIN [S] (the values of :mod:`models.spice_reference`, which the tests check; this module is kept
#: free of :mod:`models.circuits`, so that ``Circuit.to_spice`` may import the writer)
NOMINAL_TEMPERATURE = 300.15
THERMAL_VOLTAGE = constants.k * NOMINAL_TEMPERATURE / constants.e
GMIN = 1e-12
#: how diodes may be mapped (:func:`~models.spice.read`'s ``diodes``)
DIODE_RULES = ("auto", "ideal", "piecewise", "exponential")
#: each model type's parameters read (others are noted and ignored)
MODEL_PARAMETERS = {"D": ("is", "n", "rs", "ron", "vfwd"), "SW": ("vt", "vh", "ron", "roff"),
                     "CSW": ("it", "ih", "ron", "roff")}


# ---------------------------------------------------------------------------------------------- waveforms

def decimal_text(value: Fraction) -> str:
    """``value`` written exactly as a decimal when its denominator is 2^a·5^b (the float's short form
    where that is exact), else as its float."""
    if Fraction(float_text(value)) == value:
        return float_text(value)
    q = value.denominator
    twos = fives = 0
    while q % 2 == 0:
        q, twos = q // 2, twos + 1
    while q % 5 == 0:
        q, fives = q // 5, fives + 1
    if q != 1 or max(twos, fives) > 400:
        return float_text(value)
    k = max(twos, fives)
    context = decimal.Context(prec=1000)
    exact = decimal.Decimal(value.numerator * 2 ** (k - twos) * 5 ** (k - fives)).scaleb(-k, context)
    exact = exact.normalize(context)
    plain = format(exact, "f")
    return plain if len(plain) <= 20 else str(exact)


def _plus(coefficient: Fraction, term: str) -> str:
    """`` + c*term`` (`` - |c|*term`` for a negative ``c``; ``term`` alone for ±1)."""
    sign, size = (" - ", -coefficient) if coefficient < 0 else (" + ", coefficient)
    return f"{sign}{term}" if size == 1 else f"{sign}{float_text(size)}*{term}"


def _affine(offset: Fraction, scale: Fraction, shape: str) -> str:
    """The text of ``offset + scale·shape``."""
    if scale == 0:
        return float_text(offset)
    if offset == 0:
        return shape if scale == 1 else f"-{shape}" if scale == -1 else f"{float_text(scale)}*{shape}"
    return float_text(offset) + _plus(scale, shape)


def shifted(time: Fraction) -> str:
    """``(t - time)``, or ``t``."""
    return f"(t - {float_text(time)})" if time else "t"


@dataclass(frozen=True)
class Waveform:
    """A SPICE source's transient function as read: ``kind`` (``"SIN"``, ``"PULSE"``, ``"PWL"``; or
    ``"DC"``, a gate's constant level), its numbers in SPICE's order with SPICE's defaults filled in
    (exact: the decimals as written), and, for a PULSE, whether its edges are ideal (steps at their
    midpoints) or ramps."""

    kind: str
    values: tuple
    ideal: bool = True

    def card(self) -> str:
        """The function as a SPICE netlist writes it: ``PULSE(0 5 0 0 0 5e-06 1e-05)``."""
        values = list(self.values)
        if self.kind == "DC":
            return f"DC {decimal_text(Fraction(values[0]))}"
        if self.kind == "PULSE" and values[-1] is None:
            values.pop()
        return f"{self.kind}({' '.join(decimal_text(Fraction(v)) for v in values)})"

    def text(self) -> str:
        """The function as an expression of ``t`` (:func:`waveform_text`)."""
        return waveform_text(self)


def waveform_text(waveform: Waveform) -> str:
    """A SPICE transient function as an expression of ``t`` the toolkit reads (numbers as floats):

    * ``SIN(VO VA FREQ TD THETA PHASE)``: ``VO + VA·sin(2π·FREQ·t + PHASE·π/180)``, delayed and damped
      as SPICE's (``VO + VA·sin(PHASE)`` before TD);
    * ``PULSE`` with ideal edges: ``V1 + (V2−V1)·step(d − c(t))``, ``c`` the triangle carrier
      ``acos(cos(2π(t − t_r)/PER − π·d))/π`` of ``models.circuits.PWM``, ``t_r = TD + TR/2``,
      ``d = (PW + (TR+TF)/2)/PER``: high on ``[t_r + k·PER, t_r + k·PER + d·PER]``, each edge a step
      located as an instant; with ramps, the trapezoid of the phase
      ``u = PER·(atan2(−sin θ, −cos θ)/2π + ½)``, ``θ = 2π(t − TD)/PER``, clipped with ``min``/``max``;
      low before TD, and after the NP-th period when NP is given;
    * ``PWL``: ``v1`` plus, for each segment, its rise times ``min(max((t − t_k)/Δt, 0), 1)`` (a step
      where two points share a time)."""
    if waveform.kind == "DC":
        return float_text(waveform.values[0])
    return {"SIN": _sin_text, "PULSE": _pulse_text, "PWL": _pwl_text}[waveform.kind](waveform)


def _sin_text(waveform: Waveform) -> str:
    vo, va, freq, td, theta, phase = waveform.values
    shift = shifted(td)
    angle = f"{float_text(phase)}*pi/180"
    wave = f"sin(2*pi*{float_text(freq)}*{shift}{' + ' + angle if phase else ''})"
    if theta:
        wave = f"exp(-{float_text(theta)}*{shift})*{wave}"
    if td == 0:
        return _affine(vo, va, wave)
    if phase == 0:
        return _affine(vo, va, f"step(t - {float_text(td)})*{wave}")
    return _affine(vo, va, f"(sin({angle}) + step(t - {float_text(td)})*({wave} - sin({angle})))")


def _pulse_text(waveform: Waveform) -> str:
    v1, v2, td, tr, tf, pw, per, count = waveform.values
    if waveform.ideal:
        shape = _window_text(td + tr / 2, pw + (tr + tf) / 2, per)
        ends = td + tr / 2 + (count - 1) * per + (pw + (tr + tf) / 2 + per) / 2 if count else None
    else:
        shape = _trapezoid_text(td, tr, tf, pw, per)
        ends = td + (count - 1) * per + (tr + pw + tf + per) / 2 if count else None
    if shape is None:
        return float_text(v1)
    if ends is not None:
        shape = f"{shape}*step({float_text(ends)} - t)"
    return _affine(v1, v2 - v1, shape)


def _window_text(rise: Fraction, width: Fraction, period: Fraction) -> str | None:
    """1 on ``[rise + k·period, rise + k·period + width]`` for ``k ≥ 0`` and 0 elsewhere (before
    ``rise`` too), as text; ``None`` when it is always 0."""
    if width <= 0:
        return None
    if width >= period:
        return f"step(t - {float_text(rise)})"
    duty = width / period
    phase = f"2*pi*{shifted(rise)}/{float_text(period)}"
    window = f"step({float_text(duty)} - acos(cos({phase} - pi*{float_text(duty)}))/pi)"
    return f"{window}*step(t - {float_text(rise)})" if rise - period + width > 0 else window


def _trapezoid_text(td: Fraction, tr: Fraction, tf: Fraction, pw: Fraction, per: Fraction) -> str:
    """SPICE's pulse between 0 and 1 with ramps: up over TR from TD, PW at 1, down over TF."""
    theta = f"2*pi*{shifted(td)}/{float_text(per)}"
    u = f"{float_text(per)}*(atan2(-sin({theta}), -cos({theta}))/(2*pi) + 0.5)"
    shape = f"min(max(min(({u})/{float_text(tr)}, ({float_text(tr + pw + tf)} - ({u}))/{float_text(tf)}), 0), 1)"
    return f"step(t - {float_text(td)})*{shape}" if td - per + tr + pw + tf > 0 else shape


def _pwl_text(waveform: Waveform) -> str:
    values = waveform.values
    points = list(zip(values[::2], values[1::2]))
    text = float_text(points[0][1])
    for (t0, v0), (t1, v1) in zip(points, points[1:]):
        if v1 == v0:
            continue
        term = (f"step(t - {float_text(t0)})" if t1 == t0 else
                f"min(max({shifted(t0)}/{float_text(t1 - t0)}, 0), 1)")
        text += _plus(v1 - v0, term)
    return text


@dataclass(frozen=True)
class GateControl:
    """A switch's control read from the gate source that drives it alone: the source's
    ``waveform``, its ``sign`` (−1 when the switch's control nodes are the source's reversed) and the
    switch model's ``threshold`` VT and ``hysteresis`` VH [V]."""

    waveform: Waveform
    sign: int
    threshold: Fraction
    hysteresis: Fraction


class SpiceText(str):
    """Text — a source's expression of ``t``, a switch's condition — that keeps the SPICE form it
    was read from (``.spice``: a :class:`Waveform` or a :class:`GateControl`), so that
    :func:`~models.spice.write` writes that form back.  It is an ordinary ``str`` everywhere else."""

    spice: object

    def __new__(cls, text: str, spice):
        obj = super().__new__(cls, text)
        obj.spice = spice
        return obj

    def __reduce__(self):
        return SpiceText, (str(self), self.spice)


@dataclass(frozen=True)
class ExponentialDiode:
    """SPICE's junction diode as a resistor's law (``Circuit.R(..., flow_law=ExponentialDiode(1e-12))``):
    ``i = IS·(exp(v/(N·VT)) − 1) + GMIN·v`` [A] of the voltage ``v`` [V] from anode to cathode:
    ``saturation_current`` IS [A], ``emission`` N, SPICE's ``gmin`` leak [S] across the junction, and
    ``VT = k·T/q`` at the ``temperature`` T [K] (SPICE's 27 °C by default; IS is the value at T).  No
    charge storage and no breakdown.  :func:`~models.spice.write` writes it back as a ``D`` with its
    ``.model``."""

    saturation_current: float
    emission: float = 1.0
    gmin: float = GMIN
    temperature: float = NOMINAL_TEMPERATURE

    @property
    def thermal_voltage(self) -> float:
        """VT = k·T/q [V]."""
        return constants.k * self.temperature / constants.e

    def __call__(self, v):
        knee = self.emission * self.thermal_voltage
        return self.saturation_current * (sp.exp(v / knee) - 1) + self.gmin * v

    def describe(self) -> str:
        return (f"i = {self.saturation_current:g}·(exp(v/({self.emission:g}·{self.thermal_voltage * 1e3:.4g} mV)) "
                f"− 1) + {self.gmin:g}·v")


@dataclass(frozen=True)
class Tran:
    """A ``.tran TSTEP TSTOP [TSTART [TMAX]] [UIC]`` card [s]: TSTEP the printing step (and SPICE's
    default rise time), TSTOP the run's end, TSTART where SPICE starts recording (the run still starts
    at 0), TMAX the longest step (``max_step``), UIC: start from the initial conditions."""

    step: float
    stop: float
    start: float = 0.0
    max_step: float | None = None
    uic: bool = False

    @property
    def run(self) -> dict:
        """The run settings: ``t_end`` and, when TMAX is given, ``max_step``."""
        return {"t_end": self.stop, **({"max_step": self.max_step} if self.max_step else {})}


@dataclass(frozen=True)
class DiodeMapping:
    """What a ``D`` became: an ideal diode (``r_on``, ``v_f``; ``None`` where not given) or an
    exponential law (with its series resistance ``rs``, ``None`` below :data:`IDEAL_RESISTANCE`)."""

    words: str
    r_on: float | None = None
    v_f: float | None = None
    law: ExponentialDiode | None = None
    rs: float | None = None


def diode_mapping(params: Mapping, rule: str, reference_current: float, gmin: float,
                  temperature: float = NOMINAL_TEMPERATURE) -> DiodeMapping:
    """A diode model's parameters (lower case → value) mapped by ``rule``:

    * ``"ideal"``: the toolkit's ideal diode (no drop, no resistance), the model's values ignored;
    * ``"piecewise"``: the ideal diode with ``v_f`` and ``r_on``: LTspice's ``Vfwd`` and ``Ron`` where
      the model has them, else the tangent of the exponential at ``reference_current`` (``i = I_ref``:
      ``r_on = N·VT/(I_ref + IS) + RS``, ``v_f`` where the tangent meets ``i = 0``);
    * ``"exponential"``: SPICE's law (:class:`ExponentialDiode`, IS = 1e-14 A and N = 1 by default) with
      ``gmin``, and RS as a resistor in series.

    ``temperature`` [K]: the diodes' (SPICE's TEMP, equal to its TNOM: IS as given)."""
    saturation, emission = float(params.get("is", 1e-14)), float(params.get("n", 1))
    series = float(params.get("rs", 0))
    if rule == "ideal":
        return DiodeMapping("the ideal diode (its model's values ignored)")
    if saturation <= 0 or emission <= 0 or series < 0:
        raise SpiceSyntaxError(f"a diode's law needs IS > 0, N > 0 and RS ≥ 0, got IS = {saturation:g}, "
                               f"N = {emission:g}, RS = {series:g}")
    law = ExponentialDiode(saturation, emission, gmin, temperature)
    if rule == "exponential":
        rs = series if series > IDEAL_RESISTANCE else None
        return DiodeMapping(f"the exponential diode {law.describe()}" + (f", RS = {series:g} Ω in series" if rs
                                                                          else ""), law=law, rs=rs)
    if "ron" in params or "vfwd" in params:
        r_on, v_f = float(params.get("ron", 0)), float(params.get("vfwd", 0))
        source = "Vfwd and Ron"
    else:
        knee = emission * law.thermal_voltage
        r_on = knee / (reference_current + saturation) + series
        v_f = knee * math.log(reference_current / saturation + 1) + series * reference_current - r_on * reference_current
        source = f"the tangent of IS = {saturation:g}, N = {emission:g}, RS = {series:g} at {reference_current:g} A"
    r_on = r_on if r_on > IDEAL_RESISTANCE else None
    v_f = v_f or None
    return DiodeMapping(f"the ideal diode with v_f = {v_f or 0:g} V, r_on = {r_on or 0:g} Ω ({source})",
                         r_on=r_on, v_f=v_f)
