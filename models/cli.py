"""The ``hbg`` command line.

    hbg list                                  shipped models, descriptions, parameters
    hbg run MODEL [--set name=value ...] [--t-end T] [--method M] [--dt DT | --rtol R]
                  [--plot FILE.png] [--csv FILE] [--npz FILE] [--signals a,b,...] [--samples N]
    hbg modes MODEL [--mode LABEL] [--latex]  f, g, h and guards of the visited modes (or one)
    hbg verify MODEL                          static divergence-of-time check
    hbg codegen MODEL -o DIR                  export the generated per-mode functions
    hbg draw MODEL [--mode LABEL] -o FILE.png the bond graph with causal strokes
    hbg graphs | hbg equations NAME           plain bond graphs and their equations

Model names accept ``-`` or ``_`` (``falling-rod``).  Bad input gets one
clear line on stderr and exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import inspect
import os
import sys
import time

from bondgraph import HybridBondGraphError

from . import MODELS, load
from .graphs import GRAPHS


class _UsageError(Exception):
    pass


def _summary(obj) -> str:
    doc = inspect.getdoc(obj) or ""
    return doc.split("\n\n")[0].replace("\n", " ")


def _module(name):
    try:
        return load(name)
    except HybridBondGraphError:
        raise _UsageError(f"unknown model {name!r}; shipped models: {', '.join(m.replace('_', '-') for m in MODELS)}")


def _parse_sets(items, defaults) -> dict:
    values = {}
    for item in items:
        if "=" not in item:
            raise _UsageError(f"--set expects name=value, got {item!r}")
        name, _, value = item.partition("=")
        name = name.strip()
        if name not in defaults:
            raise _UsageError(f"unknown parameter {name!r}; parameters: {', '.join(defaults)}")
        if isinstance(defaults[name], (bool, str)):  # parsed and checked by the model
            values[name] = value.strip()
            continue
        try:
            values[name] = float(value)
        except ValueError:
            raise _UsageError(f"parameter {name!r} needs a number, got {value!r}") from None
    return values


def _build(args):
    module = _module(args.model)
    return module, module.build(**_parse_sets(getattr(args, "set", None) or [], module.DEFAULTS))


def _run_options(args, module) -> tuple[float, str, dict]:
    run = dict(module.RUN)
    t_end = args.t_end if args.t_end is not None else run.pop("t_end")
    run.pop("t_end", None)
    method = args.method or run.pop("method", "RK45")
    run.pop("method", None)
    from switching import METHODS
    from switching.integrators import FIXED_STEP

    if method not in METHODS:
        raise _UsageError(f"unknown method {method!r}; choose one of: {', '.join(METHODS)}")
    if t_end <= 0:
        raise _UsageError("--t-end must be positive")
    options = {}
    if method in FIXED_STEP:
        if args.rtol is not None:
            raise _UsageError(f"--rtol is for adaptive methods; {method} is fixed-step: give --dt")
        if args.dt is None:
            raise _UsageError(f"method {method} is fixed-step: give --dt")
        options["dt"] = args.dt
    else:
        if args.dt is not None:
            raise _UsageError(f"--dt is for euler and rk4; {method} is adaptive: give --rtol")
        options.update({k: v for k, v in run.items() if k in ("rtol", "atol", "max_step")})
        if args.rtol is not None:
            options["rtol"] = args.rtol
    for key in ("dt", "rtol"):
        if key in options and not options[key] > 0:
            raise _UsageError(f"--{key} must be positive")
    return t_end, method, options


class _Progress:
    """A progress bar on stderr for runs longer than a couple of seconds (terminals only)."""

    def __init__(self, t_end):
        self.t_end = t_end
        self.start = time.perf_counter()
        self.active = sys.stderr.isatty()
        self.last = 0.0

    def __call__(self, t):
        if not self.active:
            return
        now = time.perf_counter()
        if now - self.start < 2.0 or now - self.last < 0.2:
            return
        self.last = now
        done = min(1.0, t / self.t_end)
        bar = "#" * int(30 * done)
        sys.stderr.write(f"\r[{bar:<30}] {100 * done:5.1f}%  t = {t:.6g} s")
        sys.stderr.flush()

    def close(self):
        if self.active and self.last:
            sys.stderr.write("\r" + " " * 70 + "\r")


def _cmd_list(args) -> int:
    for name in MODELS:
        module = load(name)
        print(f"{name.replace('_', '-')}: {_summary(module)}")
        print("    " + ", ".join(f"{k}={v}" for k, v in module.DEFAULTS.items()))
    return 0


def _cmd_run(args) -> int:
    module, model = _build(args)
    t_end, method, options = _run_options(args, module)
    signals = [s for s in (args.signals.split(",") if args.signals else module.SIGNALS) if s]
    for s in signals:
        if s not in model.signal_names and s not in {b.effort.name for b in model.graph.bonds.values()} | {
            b.flow.name for b in model.graph.bonds.values()
        }:
            raise _UsageError(f"unknown signal {s!r}; signals: {', '.join(model.signal_names)}")
    if args.samples < 0:
        raise _UsageError("--samples must be 0 (every step) or positive")
    if args.samples:
        import numpy as np

        options["t_eval"] = np.linspace(0.0, t_end, args.samples)
    progress = _Progress(t_end)
    try:
        trajectory = model.simulate(t_end, method, progress=progress, **options)
    finally:
        progress.close()
    print(trajectory.summary())
    if hasattr(module, "error_estimate"):
        print(f"  error estimate: {module.error_estimate(trajectory)}")
    if args.plot:
        from switching.plotting import plot_trajectory

        fig = plot_trajectory(trajectory, signals)
        fig.savefig(args.plot, dpi=110)
        print(f"  plot: {args.plot}")
    if args.csv:
        trajectory.to_csv(args.csv, signals=[s for s in signals if s not in trajectory.state_names])
        print(f"  csv: {args.csv}")
    if args.npz:
        trajectory.to_npz(args.npz, signals=[s for s in signals if s not in trajectory.state_names])
        print(f"  npz: {args.npz}")
    return 0


def _visited_modes(module, model):
    t_end = module.RUN["t_end"]
    options = {k: v for k, v in module.RUN.items() if k not in ("t_end",)}
    trajectory = model.simulate(t_end, **options)
    modes = list(dict.fromkeys(trajectory.modes + [s.mode for e in trajectory.events for s in e.steps]))
    return modes


def _cmd_modes(args) -> int:
    module, model = _build(args)
    modes = [model.mode(args.mode)] if args.mode else _visited_modes(module, model)
    for mode in modes:
        me = model.mode_equations(mode)
        if args.latex:
            print(f"% mode {mode.describe()}")
            print(me.equations.latex())
        else:
            print(me.pretty())
        print()
    return 0


def _cmd_verify(args) -> int:
    _, model = _build(args)
    report = model.verify(samples=args.samples)
    print(report)
    return 0 if report.ok else 1


def _cmd_codegen(args) -> int:
    module, model = _build(args)
    _visited_modes(module, model)
    os.makedirs(args.output, exist_ok=True)
    path = os.path.join(args.output, f"{model.name}_modes.py")
    labels = model.export_module(path)
    print(f"wrote {path} ({len(labels)} modes: {', '.join(labels)})")
    return 0


def _cmd_draw(args) -> int:
    import matplotlib

    matplotlib.use("Agg")
    from switching.plotting import draw_bond_graph

    _, model = _build(args)
    mode = model.mode(args.mode) if args.mode else model.initial_mode
    ax = draw_bond_graph(model.graph, model.configuration_of(mode))
    ax.set_title(f"{model.name} in mode {mode.describe()}", fontsize=9)
    ax.figure.savefig(args.output, dpi=110)
    print(f"wrote {args.output}")
    return 0


def _cmd_graphs(args) -> int:
    width = max(map(len, GRAPHS))
    for name, fn in GRAPHS.items():
        print(f"{name:<{width}}  {_summary(fn)}")
    return 0


def _cmd_equations(args) -> int:
    if args.name not in GRAPHS:
        raise _UsageError(f"unknown graph {args.name!r}; choose one of: {', '.join(GRAPHS)}")
    builder = GRAPHS[args.name]
    kwargs = {}
    if args.n is not None:
        if "n" not in inspect.signature(builder).parameters:
            raise _UsageError(f"graph {args.name!r} takes no size --n")
        if args.n < 1:
            raise _UsageError("--n must be at least 1")
        kwargs["n"] = args.n
    graph = builder(**kwargs)
    eq = graph.equations({name: False for name in args.off})
    print(eq.latex() if args.latex else eq.pretty(signals=args.signals))
    return 0


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise _UsageError(message)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="hbg", description="Hybrid bond graph toolkit")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    sub.add_parser("list", help="shipped models with their parameters").set_defaults(run=_cmd_list)

    p = sub.add_parser("run", help="simulate a shipped model")
    p.add_argument("model")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    p.add_argument("--t-end", type=float, dest="t_end")
    p.add_argument("--method")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--dt", type=float, help="step of euler / rk4")
    group.add_argument("--rtol", type=float, help="relative tolerance of adaptive methods")
    p.add_argument("--plot", metavar="FILE.png")
    p.add_argument("--csv", metavar="FILE")
    p.add_argument("--npz", metavar="FILE")
    p.add_argument("--signals", help="comma-separated signals to plot/save")
    p.add_argument("--samples", type=int, default=500,
                   help="output at this many equally spaced times plus every instant (0: every step)")
    p.set_defaults(run=_cmd_run)

    p = sub.add_parser("modes", help="derived equations of the modes a run visits")
    p.add_argument("model")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    p.add_argument("--mode", help="one mode, by label (states joined by |)")
    p.add_argument("--latex", action="store_true")
    p.set_defaults(run=_cmd_modes)

    p = sub.add_parser("verify", help="static divergence-of-time check")
    p.add_argument("model")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    p.add_argument("--samples", type=int, default=10)
    p.set_defaults(run=_cmd_verify)

    p = sub.add_parser("codegen", help="export the generated per-mode functions")
    p.add_argument("model")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    p.add_argument("-o", "--output", required=True, metavar="DIR")
    p.set_defaults(run=_cmd_codegen)

    p = sub.add_parser("draw", help="draw the bond graph with causal strokes")
    p.add_argument("model")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter (repeatable)")
    p.add_argument("--mode")
    p.add_argument("-o", "--output", required=True, metavar="FILE.png")
    p.set_defaults(run=_cmd_draw)

    sub.add_parser("graphs", help="list the shipped plain bond graphs").set_defaults(run=_cmd_graphs)
    p = sub.add_parser("equations", help="equations of a shipped plain bond graph")
    p.add_argument("name")
    p.add_argument("--off", action="append", default=[], metavar="JUNCTION")
    p.add_argument("--n", type=int, default=None)
    p.add_argument("--signals", action="store_true")
    p.add_argument("--latex", action="store_true")
    p.set_defaults(run=_cmd_equations)
    return parser


def main(argv=None) -> int:
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        return args.run(args)
    except (_UsageError, HybridBondGraphError) as exc:
        print(f"hbg: error: {str(exc).splitlines()[0]}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"hbg: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
