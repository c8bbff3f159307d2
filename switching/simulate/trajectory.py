"""Simulation results on hybrid time.

A :class:`Trajectory` holds rows ``(t_k, x_k, mode_k)``, chosen by the
run's sampling (``trajectory.sampling``):

* ``"steps"`` (``output="steps"``, the default of ``simulate``; also
  ``output="events"``): every sample the run recorded — its start, every
  step (``"steps"``), and at every instant two rows with the same time, the
  state just before (in the mode that was flowing) and just after (in the
  mode that flows next), so jumps are kept, not smeared;
* ``"times"`` (``t_eval=ts``): exactly one row per requested time,
  ``t == sorted(ts)``, as scipy's ``solve_ivp`` gives them; at a time equal
  to an instant's the state after it (right-continuous);
* ``"samples"`` (``samples=N``, ``hbg run``'s output): the ``N`` times
  ``linspace(t0, t_end, N)`` and every instant's before and after rows in
  time order (a time equal to an instant's comes after its pair, with the
  state after it); :meth:`Trajectory.without_instants` leaves the ``N``;
* ``"dense"`` (:meth:`Trajectory.dense`, what the plots draw): a run's rows
  and uniform times between them, interpolated (cubic Hermite per flow
  interval).

Whatever the rows, ``events`` lists the
:class:`~switching.simulate.resolution.Instant` records (their states before
and after as arrays: :meth:`Trajectory.at_instants`); ``event_index[k]`` is
the row of the "after" state of event ``k`` when the rows hold the instants
(empty with ``t_eval``).
"""

from __future__ import annotations

import csv
import io
import warnings
import weakref
from collections import Counter
from typing import NamedTuple

import numpy as np

from bondgraph.energy import energy_function
from bondgraph.errors import EnergyGainWarning, HybridBondGraphError, UnknownNameError

from .dense_rows import hermite_states, interpolable, numbered
from .measurements import measure, spectrum
from .plotting import DENSE_SAMPLES, plot_trajectory
from .resolution import instants_made
from .run_summary import ENERGY_ROUNDOFF, STEP_KINDS, summary_text  # noqa: F401 (STEP_KINDS: read from here)
from .signal_values import element_power, power_flows, signal_values

__all__ = ["Trajectory", "EnergyRecord", "InstantStates"]

_energy_functions: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()



class EnergyRecord(NamedTuple):
    """The energy ledger of one instant [s, J]: ``lost = before - after``;
    ``what``: ``"instant"``, or ``"initial projection"`` for the start of a run
    whose given state the initial mode's constraints changed."""

    t: float
    before: float
    after: float
    lost: float
    what: str = "instant"


class InstantStates(NamedTuple):
    """The kept instants of a run as arrays (:meth:`Trajectory.at_instants`):
    times ``t`` [s] (K,), the states just before ``x_before`` and just after
    ``x_after`` (K, n; columns in ``state_names`` order, states' units) and
    the modes ``modes_before``, ``modes_after`` (lists of K)."""

    t: np.ndarray
    x_before: np.ndarray
    x_after: np.ndarray
    modes_before: list
    modes_after: list


def _energy_evaluator(model):
    """``bondgraph.energy_function`` for a model's graph and parameter values, cached per model."""
    key = tuple(model.parameter_array)
    cached = _energy_functions.get(model)
    if cached is None or cached[0] != key:
        cached = key, energy_function(model.graph, model.states, model.parameter_values, model.input_symbols)
        _energy_functions[model] = cached
    return cached[1]


class Trajectory:
    """Samples of a hybrid run.

    Attributes
    ----------
    t : ndarray (N,)            row times [s] (see the module docstring for which rows a run keeps)
    x : ndarray (N, n)          states, columns in ``state_names`` order
    state_names : list[str]
    modes : list[Mode]          the mode of each row
    events : list[Instant]      every instant resolved, in order (as arrays: :meth:`at_instants`)
    event_index : list[int]     the row of each event's "after" state (empty when the rows hold no
                                instants: ``t_eval``)
    sampling : str              the rows kept: ``"steps"`` (every sample recorded), ``"times"``
                                (``t_eval``), ``"samples"`` (``samples=N``: the times and the instants)
    stopped : str | None        why the run ended early (``"zeno"``) or None
    stats : dict                method, steps, wall time, ``"instants"`` (the count, kept or not), …
    sensitivities : Sensitivities | None   ``∂x/∂p`` of a run with ``simulate(..., sensitivities=[...])``
                                (:meth:`sensitivity`, :meth:`event_time_sensitivity`)

    Power flows: :meth:`power` (into one element), :meth:`power_balance`
    (supplied, dissipated, stored); energy: :meth:`energy`, :meth:`energy_ledger`.

    A trajectory pickles (a sweep's worker sends it back) without its model:
    an unpickled one has ``model = None`` and gives states, times, modes and
    summaries, but :meth:`signal` needs the model attached again
    (``trajectory.model = model``).
    """

    def __init__(self, model, t, x, modes, events, event_index, stopped=None, stats=None, mode_time=None,
                 instants_kept=True, initial_projection=None, sampling="steps"):
        self.model = model
        self.model_name = model.name
        self.t = np.asarray(t, dtype=float)
        x = np.asarray(x, dtype=float)
        self.x = x if x.shape == (len(self.t), len(model.states)) else x.reshape(len(self.t), len(model.states))
        self.state_names = [s.name for s in model.states]
        self.modes = list(modes)
        #: the instants, a kernel call's made records when first read (:meth:`__getattr__`)
        self._pending_events = list(events)
        self.event_index = list(event_index)
        self.stopped = stopped
        self.stats = dict(stats or {})
        #: the time [s] flowed in each mode as the run counted it: a dict, or what makes it when first asked
        #: (:class:`switching.simulate.recorder.ModeTimes`), or None
        self._mode_time = None if mode_time is None else mode_time if callable(mode_time) else dict(mode_time)
        self.instants_kept = instants_kept
        self.sampling = sampling
        #: ``(t0, given, projected)`` when the run started from the model's initial state projected onto
        #: the initial mode's constraints (:meth:`HybridModel.initial_state`), else None
        self.initial_projection = initial_projection
        #: :class:`switching.analysis.sensitivity.Sensitivities` of a run with ``sensitivities=[...]``, else None
        self.sensitivities = None

    def __getattr__(self, name: str):
        # (only for an attribute not set) ``events``: the instants, a kernel call's made records now; set
        # before the pending ones go, so that a thread reading them at once gets the same records
        held = self.__dict__
        if name != "events" or ("_pending_events" not in held and "events" not in held):
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        made = held.setdefault("events", instants_made(held.get("_pending_events", ())))
        held.pop("_pending_events", None)
        return made

    def __getstate__(self):
        state = dict(self.__dict__, model=None)
        if "events" not in state:  # (the records made now: a kernel call's block holds the model)
            state["events"] = instants_made(state.get("_pending_events", ()))
        state.pop("_pending_events", None)
        if callable(self._mode_time):  # (made now: it is made from the run's records)
            state["_mode_time"] = self._mode_time()
        state.pop("_numbers", None)  # (keyed by the list's id: made again after unpickling)
        return state

    def __len__(self) -> int:
        return len(self.t)

    def mode_numbers(self) -> tuple[np.ndarray, list]:
        """``(numbers, modes)``: each sample's mode as its place in ``modes``
        (the distinct modes in order of appearance); kept while ``self.modes``
        is the same list of the same length."""
        key = (id(self.modes), len(self.modes))
        cached = self.__dict__.get("_numbers")
        if cached is None or cached[0] != key:
            cached = self.__dict__["_numbers"] = (key, *numbered(self.modes))
        return cached[1], cached[2]

    @property
    def mode_labels(self) -> list[str]:
        """The mode of every sample as outputs show it (:meth:`Mode.describe`: ``"contact=free, friction=stuck"``)."""
        return [m.describe() for m in self.modes]

    @property
    def event_times(self) -> np.ndarray:
        return np.array([e.t for e in self.events])

    def at_instants(self) -> InstantStates:
        """Every kept instant's time [s] and states just before and just after
        it, as arrays (:class:`InstantStates`), whatever rows the run kept:
        with ``t_eval`` the rows are the requested times only, and the jumps
        are read here.  Empty arrays when no instant was kept
        (``keep_instants=False``: :attr:`instant_count` still counts them)."""
        n = len(self.state_names)
        events = self.events
        before = np.array([e.x_before for e in events], dtype=float).reshape(len(events), n)
        after = np.array([e.x_after for e in events], dtype=float).reshape(len(events), n)
        return InstantStates(self.event_times.astype(float).reshape(len(events)), before, after,
                             [e.mode_before for e in events], [e.mode_after for e in events])

    def without_instants(self) -> "Trajectory":
        """The trajectory without the instants' before/after rows (the rows at
        ``event_index`` and the one before each): of a run with ``samples=N``,
        exactly its ``N`` times (and, if it stopped early, where it stopped);
        the instants stay in :attr:`events`.  Itself when the rows hold no
        instants (``t_eval``)."""
        if not self.event_index:
            return self
        dropped = set(self.event_index) | {k - 1 for k in self.event_index}
        return self.take([k for k in range(len(self.t)) if k not in dropped])

    def take(self, rows) -> "Trajectory":
        """A trajectory of the rows ``rows`` (increasing indices) of this one,
        with the same model, instants, statistics (and sensitivities, their
        rows taken too); ``event_index`` keeps the instants whose before and
        after rows are both taken."""
        rows = [int(k) for k in rows]
        position = {k: j for j, k in enumerate(rows)}
        self.events  # noqa: B018 (the records made first: the copy shares them)
        out = object.__new__(type(self))
        out.__dict__.update(self.__dict__)
        out.t = self.t[rows]
        out.x = self.x[rows]
        out.modes = [self.modes[k] for k in rows]
        out.event_index = [position[k] for k in self.event_index if k in position and k - 1 in position]
        out.stats = dict(self.stats)
        if self.sensitivities is not None:
            out.sensitivities = self.sensitivities.take(rows)
        return out

    def dense(self, samples: int = DENSE_SAMPLES, t_range=None) -> "Trajectory":
        """The run with ``samples`` uniform times over ``t_range`` (default: the whole run) added between its
        rows, each state there the cubic Hermite interpolant of its flow interval from the rows' states and
        flows (:mod:`switching.simulate.dense_rows`: error ``O(h⁴)`` in the row spacing): what the plots draw,
        so that a run of solver steps is drawn as the curve it followed, not as chords.  Every row and
        instant stays; ``sampling`` is ``"dense"``; no sensitivities.  Itself without a model or rows."""
        if self.model is None or len(self.t) < 2:
            return self
        low, high = (float(self.t[0]), float(self.t[-1])) if t_range is None else map(float, t_range)
        times = np.linspace(low, high, int(samples))
        modes = self.mode_numbers()
        usable = interpolable(self.t, modes, self.event_times)
        rows, states, kept = hermite_states(self.model, self.t, self.x, modes, usable, times)
        all_t = np.concatenate([self.t, times[kept]])
        order = np.argsort(all_t, kind="stable")
        place = np.empty_like(order)
        place[order] = np.arange(len(order))
        self.events  # noqa: B018 (the records made first: the copy shares them)
        out = object.__new__(type(self))
        out.__dict__.update(self.__dict__)
        out.__dict__.pop("_numbers", None)
        out.t = all_t[order]
        out.x = np.concatenate([self.x, states])[order]
        modes = self.modes + [self.modes[r] for r in rows]
        out.modes = [modes[k] for k in order]
        out.event_index = [int(place[k]) for k in self.event_index]
        out.stats = dict(self.stats)
        out.sampling = "dense"
        out.sensitivities = None
        return out

    @property
    def instant_count(self) -> int:
        """Instants of the run (also when ``keep_instants=False`` kept none of them)."""
        counted = self.stats.get("instants")
        return len(self.events) if counted is None else int(counted)

    def state(self, name: str) -> np.ndarray:
        """The column of one state."""
        if self.model is None or name in self.state_names:
            if name not in self.state_names:
                raise UnknownNameError(f"no state {name!r}; states are: {', '.join(self.state_names)}", name)
            return self.x[:, self.state_names.index(name)]
        return self.x[:, self.state_names.index(self.model.state(name).name)]

    def signal(self, name: str) -> np.ndarray:
        """A named signal's finite part at every sample, evaluated in each
        sample's mode (generated code, one vectorized call per mode).
        ``"power:<element>"`` is the power into a one-port element
        (:meth:`power`), ``"power:supplied"``, ``"power:dissipated"`` and
        ``"power:stored"`` the totals of :meth:`power_balance` — usable
        wherever signal names are (plots, CSV, sweep metrics)."""
        if name in self.state_names:
            return self.state(name)
        return signal_values(self._needs_model(), name, self.t, self.x, self.mode_numbers())

    # ---------------------------------------------------------------- sensitivities

    def _sensitivities(self):
        record = getattr(self, "sensitivities", None)
        if record is None:
            raise HybridBondGraphError(
                "this run has no sensitivities: simulate with sensitivities=[...] naming the parameters "
                "(and x0:<state> for initial states)")
        return record

    def sensitivity(self, name: str, p: str) -> np.ndarray:
        """``∂s/∂p`` of a state or named signal ``s`` at every sample, for a
        parameter ``p`` given in ``simulate(..., sensitivities=[...])``
        (``"x0:<state>"`` for an initial state).  At fixed time: at an
        instant's two samples, the sensitivity just before and just after it.
        A signal's is its finite part's, by the chain rule
        ``∂s/∂x·∂x/∂p + ∂s/∂p`` in each sample's mode (:mod:`switching.analysis.sensitivity`)."""
        return self._sensitivities().signal(self, name, p)

    def event_time_sensitivity(self, k: int, p: str) -> float:
        """``∂t_k/∂p`` of instant ``k`` (``events[k]``) for a parameter ``p``
        given in ``simulate(..., sensitivities=[...])`` (0 for an instant at
        the start of the run)."""
        record = self._sensitivities()
        return float(record.event_times[k, record.column(p)])

    def _needs_model(self):
        if self.model is None:
            raise HybridBondGraphError(
                f"this trajectory of {self.model_name!r} was unpickled without its model, which signals need: "
                "attach the model first (trajectory.model = model)")
        return self.model

    # ---------------------------------------------------------------- energy

    def _stored_energy(self, x, times) -> np.ndarray:
        model = self._needs_model()
        times = np.atleast_1d(np.asarray(times, dtype=float))
        inputs = model.input_signals.columns(times)
        x = np.asarray(x, dtype=float).reshape(len(times), len(model.states))
        return _energy_evaluator(model)(x, times, inputs)

    def energy(self) -> np.ndarray:
        """The energy stored in the C and I elements at every sample [J]
        (``bondgraph.stored_energy``: each law integrated from 0)."""
        return self._stored_energy(self.x, self.t)

    def power(self, element: str) -> np.ndarray:
        """The power flowing into a one-port element [W] at every sample:
        ``e·f`` of its bond, signed by the bond's power direction (finite
        parts, in each sample's mode).  For an R element it is the power it
        dissipates (``≥ 0`` for a passive law), for a C or I element the rate
        of its stored energy, for a source minus the power it supplies (see
        :meth:`power_balance`)."""
        return element_power(self._needs_model(), element, self.t, self.x, self.mode_numbers())

    def power_balance(self) -> dict:
        """The model's power flows [W] at every sample: ``"supplied"`` (the
        power the sources deliver, summed), ``"dissipated"`` (taken by the R
        elements) and ``"stored"`` (into the C and I elements: the rate of
        :meth:`energy`), with ``supplied = dissipated + stored`` during flow
        (the junction structure, TF and GY conserve power).  A source
        modulated to act as friction (a Coulomb force as an ``Se``) counts
        among the sources: what it takes out is negative supply."""
        return power_flows(self._needs_model(), self.t, self.x, self.mode_numbers())

    def energy_ledger(self, warn: bool = True) -> list:
        """One :class:`EnergyRecord` ``(t, before, after, lost)`` per kept
        instant: the stored energy just before it (a priori state) and after
        its last jump, and ``lost = before - after``.  An instant that gains
        energy by more than round-off (``ENERGY_ROUNDOFF`` of the run's
        energy at its instants) warns with :class:`~bondgraph.EnergyGainWarning`.
        A run that started from a projected initial state
        (:attr:`initial_projection`) begins with that projection's record."""
        records = []
        if self.initial_projection is not None:  # the start: the given state projected, as a jump would
            t0, given, projected = self.initial_projection
            b, a = self._stored_energy([given, projected], [t0, t0])
            records.append(EnergyRecord(float(t0), float(b), float(a), float(b - a), "initial projection"))
        if not self.events:
            self._needs_model()
            return records
        times = [e.t for e in self.events]
        before = self._stored_energy([e.x_before for e in self.events], times)
        after = self._stored_energy([e.x_after for e in self.events], times)
        scale = max(float(np.max(np.abs(before))), float(np.max(np.abs(after))))
        for instant, b, a in zip(self.events, before, after):
            if warn and a - b > ENERGY_ROUNDOFF * scale:
                modes = " → ".join(f"{s.mode.describe()} [{s.kind}]" for s in instant.steps)
                warnings.warn(f"the instant at t = {instant.t:.12g} ({modes}) creates {a - b:.6g} J of stored "
                              f"energy ({b:.6g} J before, {a:.6g} J after): a jump of a passive model only loses "
                              "energy", EnergyGainWarning, stacklevel=2)
            records.append(EnergyRecord(float(instant.t), float(b), float(a), float(b - a)))
        return records

    # ---------------------------------------------------------------- summaries

    def time_in_modes(self) -> dict:
        """Total time spent flowing in each mode [s], as the run counted it
        (exact whatever samples were kept), else from the samples."""
        counted = self._mode_time() if callable(self._mode_time) else self._mode_time
        if counted is not None:
            return {mode: spent for mode, spent in counted.items() if spent > 0}
        spent: Counter = Counter()
        for k in range(len(self.t) - 1):
            if self.modes[k] == self.modes[k + 1]:
                spent[self.modes[k]] += self.t[k + 1] - self.t[k]
        return dict(spent)

    def summary(self) -> str:
        """Modes visited, time in each, event count, mythical modes passed
        (:func:`switching.simulate.run_summary.summary_text`)."""
        return summary_text(self)

    __str__ = summary

    def measure(self, signal, what="mean", **window):
        """A measurement of a signal over a window, exact where the run is piecewise smooth
        (:func:`switching.simulate.measurements.measure`): ``what`` one of ``mean``, ``rms``, ``ac_rms``,
        ``min``, ``max``, ``ripple``, ``peak``, ``crest``, ``thd``, ``power_factor`` (``signal`` an element),
        ``efficiency`` (``signal`` the load elements), or a list of them (a dict); ``window``: ``t_from``,
        ``t_to`` [s], or ``periods=N`` with ``period=T`` [s] (the last N periods); ``fundamental`` [Hz]
        for ``thd``.  ``run.measure("v_out", ["mean", "ripple"], periods=10, period=1e-5)``."""
        return measure(self, signal, what, **window)

    def spectrum(self, signal: str, fundamental: float, harmonics: int = 20, **window) -> np.ndarray:
        """The amplitudes of the harmonics 0 … ``harmonics`` of ``fundamental`` [Hz] of a signal over the
        window, integrated exactly piecewise (:func:`switching.simulate.measurements.spectrum`)."""
        return spectrum(self, signal, fundamental, harmonics, **window)

    def plot(self, signals=None, **options):
        """The run as a figure (:func:`switching.simulate.plotting.plot_trajectory`):
        a panel per signal or per list of signals (default: the model's own
        signals, then the states none renames, at most six), the flow in each
        mode shaded in a colour that stays with the mode, the instants marked,
        jumps upright where the run kept each instant's before/after samples;
        ``options`` go to ``plot_trajectory`` (``t_range``, ``axes``,
        ``title``, ``max_instants``).  Returns the matplotlib figure."""
        return plot_trajectory(self, signals, **options)

    # ---------------------------------------------------------------- export

    def _table(self, signals=()):
        columns = {"t": self.t}
        for k, name in enumerate(self.state_names):
            columns[name] = self.x[:, k]
        for name in signals:
            columns[name] = self.signal(name)
        return columns

    def to_csv(self, path=None, signals=()) -> str | None:
        """Write ``t``, every state, the mode label and the requested signals as CSV."""
        columns = self._table(signals)
        buffer = io.StringIO()
        writer = csv.writer(buffer)
        writer.writerow(list(columns) + ["mode"])
        for k in range(len(self.t)):
            writer.writerow([repr(float(col[k])) for col in columns.values()] + [self.modes[k].describe()])
        text = buffer.getvalue()
        if path is None:
            return text
        with open(path, "w", newline="") as handle:
            handle.write(text)
        return None

    def to_npz(self, path, signals=()) -> None:
        """Save arrays ``t``, ``x``, ``state_names``, ``modes`` (labels), ``event_times`` and signals."""
        extra = {f"signal:{name}": self.signal(name) for name in signals}
        np.savez(
            path,
            t=self.t,
            x=self.x,
            state_names=np.array(self.state_names),
            modes=np.array(self.mode_labels),
            event_times=self.event_times,
            **extra,
        )

    def to_dataframe(self, signals=()):
        """A pandas DataFrame (pandas is optional: ``pip install pandas``)."""
        try:
            import pandas as pd
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise ImportError("to_dataframe() needs pandas: pip install pandas") from exc
        frame = pd.DataFrame(self._table(signals))
        frame["mode"] = self.mode_labels
        return frame
