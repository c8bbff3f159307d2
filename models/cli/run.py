"""``hbg run``: simulate a model, print its summary, write the plot and data asked for."""

from __future__ import annotations

import argparse
import sys

from bondgraph import HybridBondGraphError
from switching.simulate.progress import ProgressBar

from .common import (EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK, MODEL_HELP, RUN_SET_HELP, UsageError, add_steps,
                     check_run_options, check_samples, initial_state, model_module, parse_sets, run_settings)
from .measure import add_window, parse_measures, print_measures, window_options
from .outputs import check_outputs, output_rows, write_outputs

#: the sample times of a run's data files unless told (--samples)
DEFAULT_SAMPLES = 500


def _auto_choice(model, t_end, options) -> str:
    """The method ``auto`` will take for this run (the run's statistics say why)."""
    from switching.library.jit_model import choose_method
    from switching.simulate.driver import option_defaults

    return choose_method(model, 0.0, t_end, options.get("rtol", option_defaults()["rtol"])).method


def _compile_notice(method: str) -> None:
    """One line on stderr before a compiled method's first run on this
    installation, which compiles the kernel first (about 16 s, once per family:
    the explicit methods, and rodas-jit)."""
    from switching.simulate.methods import METHOD_CLASSES

    if method not in METHOD_CLASSES or not METHOD_CLASSES[method].compiled:
        return
    from switching.library.jit_model import KERNEL_COMPILE_SECONDS, kernel_compiled

    if not kernel_compiled(implicit=method == "rodas-jit"):
        print("hbg: compiling the simulation kernel for this installation "
              f"(once, about {KERNEL_COMPILE_SECONDS:.0f} s)",
              file=sys.stderr, flush=True)


def _cmd_run(args) -> int:
    module = model_module(args.model)
    states: dict = {}
    parameters = parse_sets(args.set or [], module.DEFAULTS, states)
    t_end, method, options = run_settings(args, module, "auto")
    chosen = getattr(module, "t_end_chosen", None)
    if chosen and args.t_end is None:  # (a model file without a t_end: never a silent choice)
        print(f"hbg: {args.model} gives no t_end: running {t_end:g} s, {chosen}; give --t-end to choose",
              file=sys.stderr)
    window = window_options(args)
    if args.measure and args.samples not in (None, 0):
        raise UsageError(f"--measure measures the run's own steps (its flow integrated piece by piece), which "
                         f"--samples {args.samples} would not keep: leave --samples out (the files then hold every "
                         "step) or give --samples 0")
    if window and not args.measure:
        raise UsageError("--period, --periods, --window and --fundamental set the window of --measure: give "
                         "--measure SIGNAL:KIND too")
    if args.samples is None:
        args.samples = 0 if args.measure else DEFAULT_SAMPLES
    if args.samples < 0 or args.samples == 1:
        raise UsageError(f"--samples must be 0 (every step) or at least 2 (the start and the end), got {args.samples}")
    check_outputs((("--csv", args.csv, "data"), ("--npz", args.npz, "npz"), ("--plot", args.plot, "plot")))
    if args.with_instants and not args.keep_instants:
        raise UsageError("--with-instants needs the instants: drop --no-keep-instants")
    model = module.build(**parameters)
    x0 = initial_state(model, states, module.DEFAULTS)
    if x0 is not None:
        options["x0"] = x0
    signals = [s for s in (args.signals.split(",") if args.signals else module.SIGNALS) if s]
    for s in signals:
        if s not in model.signal_names and s not in {b.effort.name for b in model.graph.bonds.values()} | {
            b.flow.name for b in model.graph.bonds.values()
        }:
            raise UsageError(f"unknown signal {s!r}; signals: {', '.join(model.signal_names)}")
    measures = parse_measures(args.measure, model)
    if args.max_steps is not None:
        options["max_steps"] = args.max_steps
    if args.samples:
        check_samples(model, args.samples)
        options["samples"] = args.samples
    options.update(on_zeno=args.on_zeno, keep_instants=args.keep_instants)
    if not args.stiffness_check:
        options["stiffness_check"] = False
    check_run_options(model, t_end, method, options)
    wants_files = bool(args.csv or args.npz or args.plot)

    _compile_notice(_auto_choice(model, t_end, options) if method == "auto" else method)
    # (a file or a pipe gets no bar unless asked: --progress)
    progress = None if args.quiet else ProgressBar(0.0, t_end, terminal_only=not args.progress)
    failure = None
    status = EXIT_OK
    try:
        try:
            trajectory = model.simulate(t_end, method, progress=progress, **options)
        finally:
            if progress is not None:
                progress.close()
    except KeyboardInterrupt as exc:  # SimulationInterrupted too: it carries the partial run
        failure, status = exc, EXIT_INTERRUPTED
        trajectory = getattr(exc, "trajectory", None)
        message = str(exc) if isinstance(exc, HybridBondGraphError) and str(exc) else "the run was stopped"
        print(f"hbg: interrupted (Ctrl-C): {message}", file=sys.stderr)
    except HybridBondGraphError as exc:  # every failure of the run; simulation errors carry the partial run
        failure, status = exc, EXIT_FAILED
        trajectory = getattr(exc, "trajectory", None)
        print(f"hbg: error: {exc}", file=sys.stderr)

    if trajectory is None:
        if wants_files:
            print("hbg: nothing was computed: no file written", file=sys.stderr)
        return status
    if failure is not None:
        if len(trajectory.t):
            print(("hbg: the files hold the partial run up to " if wants_files else "hbg: the run stopped at ")
                  + f"t = {trajectory.t[-1]:.10g} s (of t_end = {t_end:g} s)", file=sys.stderr)
        else:
            print("hbg: the run stopped before its first sample", file=sys.stderr)
    try:
        print(("partial " if failure is not None else "") + trajectory.summary())
    except Exception as exc:  # noqa: BLE001 - a summary of a partial run must not lose its files
        print(f"hbg: warning: no summary of this run ({exc})", file=sys.stderr)
    if not print_measures(trajectory, measures, window) and status == EXIT_OK:
        status = EXIT_FAILED
    if failure is None and hasattr(module, "error_estimate"):
        try:
            print(f"  error estimate: {module.error_estimate(trajectory)}")
        except Exception as exc:  # noqa: BLE001
            print(f"hbg: warning: no error estimate ({exc})", file=sys.stderr)
    if wants_files:
        out = output_rows(trajectory, args.with_instants, failure is not None or trajectory.stopped is not None)
        if args.samples:
            print(f"  output: {len(out.t)} rows at --samples {args.samples} times"
                  + ("" if args.with_instants or not trajectory.event_index
                     else f" (--with-instants adds 2 rows for each of the {len(trajectory.event_index)} instants)"))
        plotted = trajectory  # the times and the instants' pairs: jumps drawn upright
        if write_outputs(args, out, signals, plotted) and status == EXIT_OK:
            status = EXIT_FAILED
    return status


def add_run(sub) -> None:
    """``hbg run``: its arguments and options."""
    p = sub.add_parser("run", help="simulate a shipped model or a model file: print a summary, write the plot and "
                       "data asked for")
    p.add_argument("model", help=MODEL_HELP)
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help=RUN_SET_HELP)
    p.add_argument("--t-end", type=float, dest="t_end", metavar="T", help="end time of the run in s (default: the "
                   "model's)")
    p.add_argument("--method", help="integration method (default: the model's, else auto); 'auto': the compiled "
                   "kernel when numba is installed and its kernel is cached, the run is long enough or the initial "
                   "mode is stiff (RK45-jit in each mode, rodas-jit where a mode is stiff), else RK45 (Radau for a "
                   "stiff start; the summary says which it chose and why)")
    add_steps(p)
    p.add_argument("--plot", metavar="FILE.png", help="plot the signals (PNG, SVG or PDF by the extension)")
    p.add_argument("--csv", metavar="FILE", help="write the samples of the signals as CSV (time, mode, signals)")
    p.add_argument("--npz", metavar="FILE", help="write the run as numpy arrays (t, x, modes, signals, instants)")
    p.add_argument("--signals", help="comma-separated signals to plot and save (default: the model's; the plot "
                   "draws the first six of them)")
    p.add_argument("--samples", type=int, default=None, metavar="N",
                   help="sample the run at this many equally spaced times from 0 to t_end, plus the two rows "
                        f"(before, after) of every instant: simulate(..., samples=N) (default {DEFAULT_SAMPLES}, "
                        "at least 2; 0: every step and every instant, Python's default output='steps', and the "
                        "default with --measure); the plot draws them all, the data files the N times (a time on "
                        "an instant: the state after it)")
    p.add_argument("--measure", action="append", metavar="SIGNAL:KIND[,KIND…]",
                   help="print measurements of a signal over the window (repeatable): mean, rms, ac_rms, min, max, "
                        "ripple, peak, crest, thd (of a signal), power_factor (of an element), efficiency (of a "
                        "load element); exact, the run's flow integrated piece by piece, so the run keeps its "
                        "steps (--samples 0)")
    add_window(p, "--measure")
    p.add_argument("--with-instants", action="store_true",
                   help="also write the two rows (before, after) of every instant to the data files: exactly the "
                        "rows of simulate(..., samples=N)")
    p.add_argument("--keep-instants", action=argparse.BooleanOptionalAction, default=True,
                   help="keep the record of every instant (default); --no-keep-instants keeps memory flat "
                        "on long runs, the summary then only counts them")
    p.add_argument("--on-zeno", choices=("raise", "stop"), default="raise",
                   help="on Zeno behaviour fail (raise, default) or end the run at the accumulation point (stop)")
    p.add_argument("--stiffness-check", action=argparse.BooleanOptionalAction, default=True,
                   help="stop with advice when the explicit method's step is beyond its stability (default); "
                        "--no-stiffness-check runs on whatever the stability (e.g. rates that jump inside an "
                        "input function)")
    p.add_argument("--max-steps", type=int, dest="max_steps",
                   help="the most integrator steps the run may take (default 10000000): options that need more "
                        "are refused up front, a run that takes more stops with its partial run saved")
    shown = p.add_mutually_exclusive_group()
    shown.add_argument("--progress", action="store_true",
                       help="show the progress bar even when stderr is no terminal (a log file); by default a run "
                            "longer than 2 s shows it on a terminal: simulated time, rate and time left")
    shown.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=_cmd_run)
