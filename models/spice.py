"""SPICE netlists in and out: a subset of SPICE read into a :class:`~models.circuits.Circuit`, and a
circuit written as a netlist ngspice runs.

    >>> from models import spice
    >>> netlist = spice.read('''RC charged from 10 V
    ... V1 in 0 DC 10
    ... R1 in out 1k
    ... C1 out 0 1uF
    ... .tran 10u 5m
    ... .end''')
    >>> netlist.circuit.components, netlist.run
    (('V1', 'R1', 'C1'), {'t_end': 0.005})
    >>> run = netlist.build().simulate(netlist.run["t_end"], rtol=1e-9, atol=1e-15)
    >>> round(float(run.signal("v_out")[-1]), 4)     # 10 (1 − e^−5)
    9.9326

:func:`read` takes a path or the netlist's text and returns a :class:`SpiceNetlist`: the
:class:`~models.circuits.Circuit` (``.circuit``), the ``.tran`` as run settings (``.run``:
``t_end``, and ``max_step`` where TMAX is given), and ``.notes``, one line for each choice the
reader made (which diode model each ``D`` became, a gate source folded into its switch, a card
ignored); :func:`load` gives the built model and the run settings.  ``hbg run circuit.cir`` reads a
netlist the same way (``.cir``, ``.sp``, ``.net``, ``.spice``, ``.ckt``).  :func:`write` writes a
circuit as a netlist (``Circuit.to_spice()``).

What is read (SI units; a value is a number with an optional scale and unit letters, or a
``{expression}`` of ``.param`` values):

* the first line is the title (the circuit's name, made an identifier); ``*`` starts a comment line,
  ``;`` and `` $`` an inline comment; a line starting with ``+`` continues the card before it;
  cards, names and nodes are case-insensitive (the first spelling is kept); node ``0`` (or ``gnd``)
  is ground;
* numbers: ``1.5``, ``2e-3``, with SPICE's scales ``t g meg k m u n p f a`` (``mil`` = 25.4 µm) and
  any unit letters after them ignored: ``10uF`` = 1e-5, ``1kOhm`` = 1000, ``1meg`` = 1e6 — and, as in
  SPICE, ``1M`` is 1 milli and ``1F`` 1 femto;
* ``Rxxx n1 n2 R`` [Ω]; ``Cxxx n1 n2 C [IC=v0]`` [F, V]; ``Lxxx n1 n2 L [IC=i0]`` [H, A]
  (current from n1 to n2);
* ``Kxxx L1 L2 k``: the two inductors coupled (``0 < k ≤ 1``, dots on their first nodes):
  :meth:`Circuit.coupled_inductors` named after the K card (``i_K1_p`` is L1's current, ``i_K1_s``
  L2's);
* ``Vxxx n+ n- [DC] v`` and ``Ixxx n+ n- [DC] i`` (the current flows from n+ through the source to
  n-), or one transient function: ``SIN(VO VA FREQ TD THETA PHASE)`` (``VO + VA·sin(PHASE)`` before TD,
  then ``VO + VA·e^(−THETA·(t−TD))·sin(2π·FREQ·(t−TD) + PHASE)``, PHASE in degrees), ``PULSE(V1 V2 TD
  TR TF PW PER [NP])``, ``PWL(t1 v1 t2 v2 …)`` (v1 before t1, linear between the points, the last value
  after; two points at one time are a step); ``AC`` specifications are ignored (a note says so).
  A source's transient function becomes its value as an expression of ``t`` (:func:`waveform_text`);
* PULSE edges: an edge no longer than ``ideal_edges`` (1e-3 by default) times the pulse's shortest
  level (PW, or the time it spends at V1 in a period) is *ideal*: a step at the edge's midpoint —
  the rise at ``TD + TR/2 + k·PER``, the fall at ``TD + TR + PW + TF/2 + k·PER`` — which keeps the
  pulse's area (its mean) exact; each step is an instant of the run, located exactly.  Longer
  edges are ramps as SPICE draws them (their corners are kinks the integrator steps over, not
  instants); an edge of 0 in a ramped pulse takes SPICE's TSTEP.  (ngspice itself replaces a TR or
  TF of 0 by TSTEP.)  The timing is computed in exact rational arithmetic from the numbers as
  written;
* ``Dxxx anode cathode MODEL`` with ``.model MODEL D(IS= N= RS= …)``, mapped by the rule ``diodes``
  (a word, or a mapping from a diode's or a model's name to a word; see :func:`read`): ``"auto"``,
  ``"ideal"``, ``"piecewise"`` or ``"exponential"``; :attr:`SpiceNetlist.diodes` says which mapping
  each diode got;
* ``Sxxx n1 n2 nc+ nc- MODEL [ON|OFF]`` with ``.model MODEL SW(VT= VH= RON= ROFF=)`` and ``Wxxx n1 n2
  Vsense MODEL [ON|OFF]`` with ``.model MODEL CSW(IT= IH= RON= ROFF=)``: :meth:`Circuit.switch`, closed
  when the control exceeds ``VT + VH`` (``IT + IH``) and open when it falls below ``VT − VH``
  (``IT − IH``), as SPICE's switches; ``RON`` [Ω] its ``r_on`` (ideal at or below
  :data:`IDEAL_RESISTANCE`); ``ROFF`` is taken as open.  A control voltage driven by a source that
  nothing else uses (a gate source) is the source's waveform: an ideal PULSE is a :class:`~models.circuits.PWM`
  schedule, any other waveform a condition on ``t``; the gate source leaves the circuit.  Any other
  control voltage is a condition on the nodes' signals (``v_g > 0.5``);
* ``Bxxx n+ n- V=expr`` or ``I=expr``: a source whose value is an expression of ``time`` and
  ``.param`` values (no node voltages or currents);
* ``.param name=value …`` (values and ``{…}`` expressions evaluated with the toolkit's own
  expression parser, :mod:`switching.language.parsing` — never ``eval``); ``.tran TSTEP TSTOP
  [TSTART [TMAX]] [UIC]``; ``.ic V(node)=v …``; ``.subckt NAME ports… [params: p=v …]`` … ``.ends``
  and ``Xxxx nodes… NAME [p=v …]`` (flattened as ngspice names them, ``.`` made ``_``: R1 of X1 is
  ``R_X1_R1``, node ``mid`` of X1 is ``X1_mid``); ``.options`` (``gmin`` is read, the rest noted
  and ignored); ``.control`` … ``.endc`` (skipped); ``.end``.

The run starts from the initial values given (``IC=``, ``.ic``; 0 elsewhere), as SPICE's ``.tran
… UIC``: the toolkit does not compute SPICE's DC operating point (a note says so when UIC is
missing).  Everything else — other elements (Q, M, J, E, F, G, H, T, U, A, …), other analyses
(``.ac``, ``.dc``, ``.op``, …), ``.include``/``.lib`` (a netlist never opens other files), other
model types — is refused with a :class:`SpiceNetlistError` naming the source, the line, the card
and what to do.  A netlist is a stranger's input: it is parsed, never executed.

:func:`write` writes every part a circuit has that SPICE can express; see its documentation.  A
netlist read and written again reads back to the same circuit (same parts, nodes and values: the
same equations and the same run, to the bit).

The work is shared by :mod:`models.spice_syntax` (errors, numbers, ``{expressions}``, lines and
tokens), :mod:`models.spice_forms` (waveforms as expressions of ``t``, the diode law and mappings,
``.tran``), :mod:`models.spice_reader` (definitions, scopes, subcircuits flattened),
:mod:`models.spice_assembly` (the elements as the circuit's parts, gates folded into switches) and
:mod:`models.spice_writer` (a circuit as a netlist; it imports nothing of :mod:`models.circuits`, so
``Circuit.to_spice`` may delegate to it).
"""

from __future__ import annotations

from .spice_forms import (
    DIODE_RULES,
    IDEAL_RESISTANCE,
    ExponentialDiode,
    GateControl,
    SpiceText,
    Tran,
    Waveform,
    waveform_text,
)
from .spice_reader import SpiceNetlist, read
from .spice_syntax import (
    SpiceExportError,
    SpiceNetlistError,
    SpiceSyntaxError,
    UnsupportedCardError,
    evaluate,
    exact_number,
    number,
)
from .spice_writer import write

__all__ = ["read", "load", "write", "SpiceNetlist", "Tran", "Waveform", "GateControl", "SpiceText",
           "ExponentialDiode", "SpiceNetlistError", "SpiceSyntaxError", "UnsupportedCardError",
           "SpiceExportError", "number", "exact_number", "evaluate", "waveform_text", "SUFFIXES",
           "IDEAL_RESISTANCE", "DIODE_RULES"]

#: the file name endings read as SPICE netlists (``hbg run circuit.cir``)
SUFFIXES = (".cir", ".sp", ".net", ".spice", ".ckt")


def load(source, **options):
    """``(model, run)``: the built :class:`~switching.HybridModel` of a netlist (:func:`read` with
    ``options``) and its run settings (the ``.tran``: ``{"t_end": …, "max_step": …}``)::

        model, run = spice.load("buck.cir")
        trajectory = model.simulate(run.pop("t_end"), "auto", **run)"""
    netlist = read(source, **options)
    return netlist.build(), dict(netlist.run)
