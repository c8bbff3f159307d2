"""The text of a run's summary (``print(run)``): the modes visited and the time flowed in each, what the
instants passed, the energy they lost [J], the run's statistics."""

from __future__ import annotations

from collections import Counter

from bondgraph.errors import HybridBondGraphError

__all__ = ["ENERGY_ROUNDOFF", "STEP_KINDS", "energy_figure", "summary_text"]

#: what each kind of a mode passed at an instant means (DESIGN §6), as run summaries explain it
STEP_KINDS = {
    "start": "the mode the instant began in",
    "mythical": "passed through without its jump (its constraints never held)",
    "pinnacle": "jumped into and left at once",
    "continuous": "the mode the flow went on in",
    "tie": "in a cycle of switches each enabled only at a tie (equality up to round-off), none of them taken",
}

#: relative round-off band of the energy ledger: a gain below this fraction of
#: the run's stored energy at its instants is not reported
ENERGY_ROUNDOFF = 1e-9


def energy_figure(value: float, scale: float) -> str:
    """An energy [J] as the summaries print it: ``0 J`` with the round-off
    bound when ``|value|`` is within ``ENERGY_ROUNDOFF`` of ``scale`` (the
    largest energy it was computed from), else six significant digits."""
    bound = ENERGY_ROUNDOFF * scale
    if abs(value) <= bound:
        return f"0 J (within round-off, |ΔE| ≤ {bound:.1g} J)"
    return f"{value:.6g} J"


def _ledger_lines(ledger) -> list[str]:
    """The summary's lines of an energy ledger: the initial projection, then the instants' total."""
    lines = []
    for record in ledger:
        if record.what == "initial projection":
            scale = max(abs(record.before), abs(record.after))
            lines.append(f"  energy lost at the initial projection: {energy_figure(record.lost, scale)}")
    instants = [r for r in ledger if r.what == "instant"]
    if instants:
        scale = max(max(abs(r.before), abs(r.after)) for r in instants)
        lines.append(f"  energy lost at instants: {energy_figure(sum(r.lost for r in instants), scale)}")
    return lines


def summary_text(run) -> str:
    """The summary of the :class:`~switching.simulate.trajectory.Trajectory` ``run``: modes visited, the time
    [s] flowed in each and the kinds passed at instants, the instant count, mythical modes and pinnacles
    passed, the energy lost at instants, the run's statistics."""
    if not len(run.t):
        return f"trajectory of {run.model_name!r}: no samples"
    lines = [
        f"trajectory of {run.model_name!r}: t = {run.t[0]:.6g} … {run.t[-1]:.6g} s, "
        f"{len(run.t)} samples, {run.instant_count} instant{'' if run.instant_count == 1 else 's'}"
        + ("" if run.instants_kept else " (not kept: keep_instants=False)")
        + (f", stopped early ({run.stopped})" if run.stopped else "")
    ]
    spent = run.time_in_modes()
    kinds: dict = {}
    for instant in run.events:
        for step in instant.steps:
            kinds.setdefault(step.mode, Counter())[step.kind] += 1
    modes = list(dict.fromkeys(run.modes + list(spent) + [s.mode for e in run.events for s in e.steps]))
    width = max([len("mode")] + [len(m.describe()) for m in modes])
    lines.append(f"  {'mode':<{width}}  {'flowed [s]':>10}  at instants")
    for mode in modes:
        passed = ", ".join(f"{k} ×{n}" for k, n in sorted(kinds.get(mode, {}).items()))
        lines.append(f"  {mode.describe():<{width}}  {spent.get(mode, 0.0):>10.4g}  {passed}")
    seen = sorted({kind for counts in kinds.values() for kind in counts})
    if seen:
        lines.append("  (" + "; ".join(f"{kind}: {STEP_KINDS[kind]}" for kind in seen) + ")")
    if run.instants_kept:
        mythical = sum(len(e.mythical) for e in run.events)
        pinnacles = sum(len(e.pinnacles) for e in run.events)
        lines.append(f"  mythical modes passed: {mythical}; pinnacles: {pinnacles}")
        if (run.events or run.initial_projection is not None) and run.model is not None:
            try:
                ledger = run.energy_ledger(warn=False)
            except HybridBondGraphError:  # a law sympy cannot integrate: no ledger
                ledger = None
            if ledger is not None:
                lines += _ledger_lines(ledger)
    for key, value in run.stats.items():
        lines.append(f"  {key}: {value}")
    return "\n".join(lines)
