"""``hbg modes``, ``hbg verify`` and ``hbg codegen``: the equations and code of the modes a run passes."""

from __future__ import annotations

import os
import re
import sys
import time

from bondgraph import HybridBondGraphError

from .common import UsageError, build_model, check_positive


#: wall seconds the default run may take to find the modes ``modes`` and ``codegen`` show (without --t-end)
EXPLORATION_SECONDS = 10.0


class _ExplorationSpent(Exception):
    """The default run of ``modes``/``codegen`` reached its wall-time budget at simulated time ``t``."""

    def __init__(self, t: float):
        super().__init__(f"stopped at t = {t:g} s")
        self.t = t


def _visited_modes(module, model, t_end=None):
    """The modes the model's default run passes (its flows and every mode its instants passed): to
    ``t_end`` [s] when given, else to the run's own end or for at most :data:`EXPLORATION_SECONDS` of
    computing, whichever comes first (a 100 kHz converter's second of simulated time took minutes).  Says on
    stderr which run it used."""
    from switching.errors import SimulationError

    end = module.RUN["t_end"] if t_end is None else t_end
    options = {k: v for k, v in module.RUN.items() if k != "t_end"}
    started = time.perf_counter()

    def budget(t):
        if t_end is None and time.perf_counter() - started > EXPLORATION_SECONDS:
            raise _ExplorationSpent(t)

    try:
        trajectory = model.simulate(end, progress=budget, **options)
        told = f"to t = {end:g} s" + (" (--t-end)" if t_end is not None else " (its end)")
    except SimulationError as exc:
        if not isinstance(exc.__cause__, _ExplorationSpent) or getattr(exc, "trajectory", None) is None:
            raise
        trajectory = exc.trajectory
        told = (f"to t = {exc.__cause__.t:g} s of its {end:g} s, stopped after {EXPLORATION_SECONDS:g} s of "
                "computing (give --t-end to choose the run)")
    modes = list(dict.fromkeys(trajectory.modes + [s.mode for e in trajectory.events for s in e.steps]))
    print(f"hbg: the {len(modes)} mode(s) the default run passes {told}", file=sys.stderr)
    return modes


def _exploration_end(args):
    """``--t-end`` of ``modes``/``codegen``, checked (``None`` when not given)."""
    if args.t_end is not None:
        check_positive("--t-end", args.t_end)
    return args.t_end


def cmd_modes(args) -> int:
    module, model = build_model(args)
    modes = [model.mode(args.mode)] if args.mode else _visited_modes(module, model, _exploration_end(args))
    for mode in modes:
        me = model.mode_equations(mode)
        if getattr(args, "state_space", False):
            print(f"mode {mode.describe()}: state space x' = A x + B u, y = C x + D u")
            try:
                print(me.state_space().pretty())
            except HybridBondGraphError as error:
                print(f"  no state-space matrices: {error}")
        elif args.latex:
            print(f"% mode {mode.describe()}")
            print(me.equations.latex())
        else:
            print(me.pretty())
        print()
    return 0


def cmd_verify(args) -> int:
    if args.samples < 1:
        raise UsageError(f"--samples must be at least 1, got {args.samples}")
    _, model = build_model(args)
    report = model.verify(samples=args.samples)
    print(report)
    return 0 if report.ok else 1


def _file_stem(name: str) -> str:
    """A file name stem from a model's name (a stranger's text): ASCII letters,
    digits, ``_``, ``-`` and inner dots only; no separators, no leading dot."""
    stem = re.sub(r"[^A-Za-z0-9_.-]", "_", name).lstrip(".")[:100]
    return stem or "model"


def _inside(directory: str, filename: str, option: str) -> str:
    """``directory/filename``, refused unless it resolves inside ``directory``
    (after symbolic links: a file name from a model must not leave the folder the user gave)."""
    root = os.path.realpath(directory)
    path = os.path.realpath(os.path.join(root, filename))
    if os.path.dirname(path) != root:
        raise UsageError(f"{option}: the file {filename!r} would be written outside {directory!r} "
                         f"(to {path}); give another folder or rename the model")
    return os.path.join(directory, filename)


def cmd_codegen(args) -> int:
    module, model = build_model(args)
    _visited_modes(module, model, _exploration_end(args))
    os.makedirs(args.output, exist_ok=True)
    path = _inside(args.output, f"{_file_stem(model.name)}_modes.py", "-o/--output")
    labels = model.export_module(path)
    print(f"wrote {path} ({len(labels)} modes: {', '.join(labels)})")
    return 0


def add_exploration(p) -> None:
    p.add_argument("--t-end", type=float, dest="t_end", metavar="T",
                   help="the modes are those the model's default run passes up to T s (default: its end, or what "
                        f"it reaches in {EXPLORATION_SECONDS:g} s of computing)")
