"""``hbg sweep``: a grid of runs on Dask, a CSV row each, a plot."""

from __future__ import annotations

import dataclasses
import math
import os
import sys
import time

from bondgraph import HybridBondGraphError

from .common import (EXIT_FAILED, EXIT_OK, MODEL_HELP, UsageError, add_steps, check_run_options, finite_number,
                     model_module, parse_sets, run_settings)
from .measure import add_window, window_options
from .outputs import check_outputs, plot_target


#: the most runs ``hbg sweep --grid`` makes (the product of the grid's counts)
MAX_RUNS = 1_000_000


def grid_axis(item, defaults) -> tuple[str, list]:
    """One ``--grid``: ``name=start:stop:count`` (``count`` equally spaced
    numbers, both ends included) or ``name=v1,v2,...``; checked like ``--set``."""
    if "=" not in item:
        raise UsageError(f"--grid expects name=start:stop:count or name=v1,v2,..., got {item!r}")
    name, _, text = item.partition("=")
    name, text = name.strip(), text.strip()
    if name not in defaults:
        raise UsageError(f"--grid {item}: unknown parameter {name!r}; parameters: {', '.join(defaults)}")
    if isinstance(defaults[name], (bool, str)):  # parsed and checked by the model
        values = [v.strip() for v in text.split(",")]
        if not all(values):
            raise UsageError(f"--grid {item}: an empty value in the list")
        return name, values

    def number(value):
        return finite_number(value, f"--grid {item}: parameter {name!r} needs numbers, got {value.strip()!r}",
                             f"--grid {item}: {value.strip()!r} is not a finite number")

    if text.count(":") == 2 and "," not in text:
        start, stop, count = text.split(":")
        try:
            n = int(count)
        except ValueError:
            n = 0
        if n < 1:
            raise UsageError(f"--grid {item}: the count after the second ':' must be a whole number >= 1, "
                             f"got {count.strip()!r}")
        if n > MAX_RUNS:
            raise UsageError(f"--grid {item}: {n:,} values; a sweep makes at most {MAX_RUNS:,} runs")
        import numpy as np

        # (12 significant digits: 0.1:0.5:5 gives 0.3, not linspace's 0.30000000000000004)
        return name, [float(f"{v:.12g}") for v in np.linspace(number(start), number(stop), n)]
    if ":" in text:
        raise UsageError(f"--grid {item}: write name=start:stop:count (two ':') or name=v1,v2,...")
    return name, [number(v) for v in text.split(",")]


def _sweep_metrics(names, model, window=None):
    """The ``--metric`` names split into signal specs (KIND:SIGNAL, computed
    in the workers, measurements over ``window``) and columns of the table;
    unknown names are usage errors."""
    from switching.sweep.frame import FINAL, RUN_COLUMNS, SignalMetrics

    columns = [c for c in RUN_COLUMNS if c not in ("status", "error")] + [FINAL + s.name for s in model.states]
    specs = [name for name in names if ":" in name]
    for name in names:
        if ":" not in name and name not in columns:
            raise UsageError(f"--metric {name}: not a column of the sweep table; use one of {', '.join(columns)} "
                             f"or KIND:SIGNAL (KIND {', '.join(SignalMetrics.KINDS)}; e.g. max:"
                             + model.signal_names[0] + ")")
    if not specs:
        if window:
            raise UsageError("--period, --periods, --window and --fundamental set the window of a --metric "
                             "KIND:SIGNAL: give one")
        return None
    try:
        metrics = SignalMetrics(*specs, **(window or {}))
        metrics.check(model)
    except HybridBondGraphError as exc:
        raise UsageError(f"--metric: {exc}") from None
    return metrics


def compiled_method(method: str) -> bool:
    """Is ``method`` one of the compiled methods of one kind (those a batch runs in one kernel call)?"""
    from switching.simulate.methods import METHOD_CLASSES, canonical_method

    chosen = METHOD_CLASSES[canonical_method(method)]
    return chosen.compiled and not chosen.chooses


def _check_batch(model, axes) -> None:
    """``--batch`` sets values on one model: every grid name must be one of its parameters, parameters of
    its initial state, or states (a build argument that changes the structure, a ball count, cannot)."""
    from switching.sweep.kernel_batch import settable_names

    names = settable_names(model)
    wrong = [name for name in axes if name not in names]
    if wrong:
        raise UsageError(f"--batch: {', '.join(wrong)} {'is' if len(wrong) == 1 else 'are'} not a parameter or a "
                         f"state of {model.name} (a batch sets values on one model; it takes "
                         f"{', '.join(sorted(names))}): drop --batch to build a model per run on Dask")


def _cmd_sweep(args) -> int:
    """``hbg sweep``: one run per point of the grid on Dask (``--batch``: in this process, in kernel
    batches), a CSV row per run, a plot of one metric over the grid."""
    import contextlib

    from switching import simulate_many
    from switching.sweep.frame import FAMILY, parameter_grid, plot_sweep, require_pandas, to_frame

    module = model_module(args.model)
    base = parse_sets(args.set or [], module.DEFAULTS)
    axes = {}
    for item in args.grid:
        name, values = grid_axis(item, module.DEFAULTS)
        if name in axes or name in base:
            raise UsageError(f"--grid {item}: {name!r} is already given ({'--grid' if name in axes else '--set'})")
        axes[name] = values
    runs = math.prod(len(values) for values in axes.values())
    if runs > MAX_RUNS:
        raise UsageError(f"--grid: {' × '.join(str(len(v)) for v in axes.values())} = {runs:,} runs; a sweep makes "
                         f"at most {MAX_RUNS:,}: use fewer points")
    t_end, method, options = run_settings(args, module)
    options["on_zeno"] = args.on_zeno
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers must be at least 1, got {args.workers}")
    varying = [name for name, values in axes.items() if len(set(values)) > 1]
    if args.plot and len(varying) not in (1, 2):
        raise UsageError(f"--plot shows one or two parameters that vary over the grid; {len(varying)} vary"
                         + (f" ({', '.join(varying)})" if varying else ""))
    check_outputs((("--csv", args.csv, "data"), ("--plot", args.plot, "plot")))
    require_pandas()  # a missing pandas is said before the sweep, not after
    model = module.build(**base)  # checks --set, and names the states and signals metrics may use
    check_run_options(model, t_end, method, options)  # a --dt no run could take: refused once, not by every run
    names = args.metric or ["events"]
    metrics = _sweep_metrics(names, model, window_options(args))
    sets = [{**base, **point} for point in parameter_grid(axes)]
    if args.batch:
        _check_batch(model, axes)
        sets = list(parameter_grid(axes))  # (the --set values are the model's already)
    where = ("this process" + (", kernel calls in batches over the cores" if compiled_method(method) else "")
             if args.batch else args.scheduler
             or f"{min(args.workers or os.cpu_count() or 1, len(sets))} local Dask worker(s)")
    print(f"sweep of {model.name}: {len(sets)} runs over {' × '.join(f'{n} ({len(v)})' for n, v in axes.items())}, "
          f"{method} to t = {t_end:g} s, on {where}")
    start = time.perf_counter()
    bar = sys.stderr.isatty()
    with contextlib.redirect_stdout(sys.stderr) if bar else contextlib.nullcontext():  # Dask's bar: on stderr
        if args.batch:
            results = simulate_many(model, sets, t_end, method, metrics=metrics, trajectories=False, **options)
            results = [dataclasses.replace(r, parameters={**base, **r.parameters}) for r in results]
        else:
            results = simulate_many(module.build, sets, t_end, method, client=args.scheduler, workers=args.workers,
                                    metrics=metrics, trajectories=False, progress_bar=bar, **options)
    frame = to_frame(results)
    counts = frame["status"].value_counts()
    print(f"  {counts.get('ok', 0)} ok, {counts.get('stopped', 0)} stopped early, {counts.get('failed', 0)} failed, "
          f"in {time.perf_counter() - start:.1f} s")
    failed = [r for r in results if not r.ok]
    for kind in dict.fromkeys(r.error_type for r in failed):  # one example of each kind of failure
        same = [r for r in failed if r.error_type == kind]
        point = [f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in same[0].parameters.items()
                 if k in axes]
        print(f"  {len(same)} failed with {kind}, e.g. {', '.join(point)}: {same[0].error.splitlines()[0]}",
              file=sys.stderr)
    status = EXIT_FAILED if failed else EXIT_OK
    try:
        frame.to_csv(args.csv, index=False)
        print(f"  csv: {args.csv} ({len(frame)} rows)")
    except OSError as exc:
        print(f"hbg: error: could not write csv {args.csv}: {exc}", file=sys.stderr)
        status = EXIT_FAILED
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        from bondgraph.drawing import pyplot

        ax = plot_sweep(frame, names[0], varying, unit=model.annotations.unit)
        ax.set_title(f"{model.name}: {ax.get_title()}", fontsize=10)
        try:
            ax.figure.savefig(args.plot, dpi=110, bbox_inches="tight")
            family = len(varying) == 2 and len(set(frame[varying[1]])) <= FAMILY < len(set(frame[varying[0]]))
            kind = "line" if len(varying) == 1 else f"a line per {varying[1]}" if family else "heat map"
            print(f"  plot: {plot_target(args.plot)} ({names[0]}, {kind})")
        except (OSError, ValueError) as exc:
            print(f"hbg: error: could not write plot {args.plot}: {exc}", file=sys.stderr)
            status = EXIT_FAILED
        finally:
            pyplot().close(ax.figure)
    return status


def add_sweep(sub) -> None:
    """``hbg sweep``: its arguments and options."""
    p = sub.add_parser("sweep", help="one run per point of a parameter grid, on Dask: a CSV row per run, a plot")
    p.add_argument("model", help=MODEL_HELP)
    p.add_argument("--grid", action="append", required=True, metavar="NAME=START:STOP:COUNT|NAME=V1,V2,...",
                   help="a parameter's values (repeatable; the grid is every combination, the first varying slowest)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="a parameter fixed for every run (repeatable)")
    p.add_argument("--t-end", type=float, dest="t_end", metavar="T", help="end time of every run in s (default: "
                   "the model's)")
    p.add_argument("--method", help="integration method of every run (default: the model's, else RK45)")
    add_steps(p)
    group = p.add_mutually_exclusive_group()
    group.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler (tcp://host:8786)")
    group.add_argument("--workers", type=int, help="size of the local Dask cluster (default: all cores)")
    group.add_argument("--batch", action="store_true",
                       help="no Dask: the runs in this process on one model, a compiled method's kernel calls in "
                            "batches over the cores (each run as simulate makes it; the grid's names must be the "
                            "model's parameters or states)")
    p.add_argument("--csv", required=True, metavar="FILE", help="one row per run: parameters, status, events, "
                   "final state, metrics")
    p.add_argument("--plot", metavar="FILE.png", help="the first --metric over the grid (line or heat map)")
    p.add_argument("--on-zeno", choices=("raise", "stop"), default="raise",
                   help="a Zeno run fails (raise, default) or ends at the accumulation point (stop)")
    p.add_argument("--metric", action="append", metavar="NAME",
                   help="a column (events, first_event, t_final, wall_time, final_STATE) or KIND:SIGNAL with KIND "
                        "final, min or max (over the samples), or a measurement over the window: mean, rms, "
                        "ac_rms, ripple, peak, crest, thd, power_factor, efficiency (min and max too, exact, "
                        "when a window is given), computed in the workers (repeatable; the first is plotted; "
                        "default: events)")
    add_window(p, "the --metric measurements")
    p.set_defaults(run=_cmd_sweep)
