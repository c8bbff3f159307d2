"""``hbg orbit``: a periodic orbit and its multipliers, or its continuation in one parameter."""

from __future__ import annotations

import sys

from switching.simulate.plotting import plot_trajectory

from .common import (EXIT_FAILED, EXIT_OK, MODEL_HELP, UsageError, check_positive, finite_number, initial_state,
                     model_module, parse_sets)
from .measure import parse_measures, print_measures
from .outputs import check_outputs, plot_target
from .sweep import MAX_RUNS


def _continue_axis(item, defaults) -> tuple[str, list]:
    """``--continue name=start:stop:count``: ``count`` (>= 2) equally spaced values, both ends included."""
    name, _, text = item.partition("=")
    name, text = name.strip(), text.strip()
    if not name or text.count(":") != 2:
        raise UsageError(f"--continue expects name=start:stop:count (e.g. D=0.3:0.6:31), got {item!r}")
    if name not in defaults or isinstance(defaults[name], (bool, str)):
        raise UsageError(f"--continue {item}: {name!r} is not a numeric parameter; parameters: {', '.join(defaults)}")
    start, stop, count = text.split(":")
    try:
        n = int(count)
    except ValueError:
        n = 0
    if n < 2 or n > MAX_RUNS:
        raise UsageError(f"--continue {item}: the count after the second ':' must be a whole number from 2 to "
                         f"{MAX_RUNS:,}, got {count.strip()!r}")
    ends = [finite_number(v, f"--continue {item}: {v.strip()!r} is not a number",
                          f"--continue {item}: {v.strip()!r} is not a finite number") for v in (start, stop)]
    if ends[0] == ends[1]:
        raise UsageError(f"--continue {item}: start and stop are equal: nothing to continue")
    import numpy as np

    return name, [float(v) for v in np.linspace(ends[0], ends[1], n)]


def _format_multipliers(multipliers) -> str:
    if not len(multipliers):
        return "(none besides the trivial one)"
    return ", ".join(f"{complex(m).real:.8g}{complex(m).imag:+.8g}j" if complex(m).imag else f"{float(m.real):.8g}"
                     for m in multipliers)


def _print_orbit(model, orbit) -> None:
    kind = ("fixed period" if orbit.section is None else
            f"autonomous, section {orbit.section[0]}: {orbit.section[1]} → {orbit.section[2]}")
    print(f"periodic orbit of {model.name} ({kind})")
    print(f"  period: {orbit.period:.12g} s")
    print("  x0: " + ", ".join(f"{s} = {v:.12g}" for s, v in zip(model.state_names, orbit.x0)))
    print(f"  multipliers: {_format_multipliers(orbit.multipliers)}")
    if orbit.trivial_multiplier is not None:
        print(f"  trivial multiplier (along the flow): {complex(orbit.trivial_multiplier).real:.8g}")
    print(f"  stable: {'yes' if orbit.stable else 'no'}")
    print(f"  modes: {' → '.join(orbit.mode_names)}")
    print(f"  Newton: {orbit.iterations} iteration(s), residual {orbit.residual:.3g}, estimated relative error of "
          f"x0 {orbit.error:.3g}, {orbit.wall_time:.2f} s")


def _print_table(rows) -> None:
    """The continuation's rows as aligned text (multipliers and numbers to 8 digits)."""
    if not rows:
        return
    columns = [c for c in rows[0] if c != "modes" and not c.startswith(("min:", "max:"))]

    def cell(v):
        if isinstance(v, bool):
            return "yes" if v else "no"
        if isinstance(v, complex):
            return f"{v.real:.6g}{v.imag:+.6g}j"
        if isinstance(v, float):
            return f"{v:.8g}"
        return str(v)

    cells = [[cell(row.get(c, "")) for c in columns] for row in rows]
    widths = [max(len(c), *(len(r[k]) for r in cells)) for k, c in enumerate(columns)]
    print("  ".join(c.rjust(w) for c, w in zip(columns, widths)))
    for r in cells:
        print("  ".join(v.rjust(w) for v, w in zip(r, widths)))


def _cmd_orbit(args) -> int:
    """``hbg orbit``: a periodic orbit by Newton shooting, or its continuation in one parameter."""
    from switching import continue_orbit, periodic_orbit

    module = model_module(args.model)
    states: dict = {}
    parameters = parse_sets(args.set or [], module.DEFAULTS, states)
    axis = None
    if args.continue_:
        axis = _continue_axis(args.continue_, module.DEFAULTS)
        if axis[0] in parameters:
            raise UsageError(f"--continue {args.continue_}: {axis[0]!r} is also given with --set")
    if args.section is None and args.period is None:
        raise UsageError("give --period T (a fixed-period orbit, e.g. 1/f_sw of a clocked converter) or "
                         "--section AUTOMATON:SOURCE->TARGET (an autonomous orbit)")
    if args.doubled and axis is None:
        raise UsageError("--doubled follows the branch born at a period doubling: it needs --continue")
    if args.period is not None:
        check_positive("--period", args.period)
    for option, value in (("--rtol", args.rtol), ("--max-step", args.max_step)):
        if value is not None:
            check_positive(option, value)
    if args.warmup < 0:
        raise UsageError(f"--warmup must be 0 or more, got {args.warmup}")
    if args.samples < 2:
        raise UsageError(f"--samples must be at least 2 (the period's start and end), got {args.samples}")
    check_outputs((("--csv", args.csv, "data"), ("--plot", args.plot, "plot")))
    model = module.build(**parameters)
    x0 = initial_state(model, states, module.DEFAULTS)
    names = [name for name in (args.signal or "").split(",") if name]
    for name in names:
        if name not in model.state_names and name not in model.signal_names:
            raise UsageError(f"--signal {name}: not a state or signal of {model.name}; states: "
                             f"{', '.join(model.state_names)}; signals: {', '.join(model.signal_names)}")
    signal = names[0] if names else None
    measures = parse_measures(args.measure, model)
    if measures and args.continue_:
        raise UsageError("--measure measures one orbit: leave out --continue (or measure each point in Python: "
                         "continue_orbit's points are PeriodicOrbit objects with .measure)")
    options = {"rtol": args.rtol if args.rtol is not None else 1e-10, "warmup": args.warmup}
    max_step = args.max_step if args.max_step is not None else module.RUN.get("max_step")
    if max_step is not None:
        options["max_step"] = max_step
    if args.section is not None:
        options["section"] = args.section
        if args.period is None:
            options["max_period"] = module.RUN["t_end"]
    if args.crossings != 1:
        options["crossings"] = args.crossings
    if axis is None:
        orbit = periodic_orbit(model, args.period, x0=x0, **options)
        _print_orbit(model, orbit)
        start = float(orbit.trajectory.t[0])
        measured = print_measures(orbit.trajectory, measures, dict(t_from=start, t_to=start + orbit.period,
                                                                   fundamental=1.0 / orbit.period),
                                  "one period of the orbit")
        written = _orbit_outputs(args, model, orbit=orbit, names=names)
        return written if measured else EXIT_FAILED
    name, values = axis
    print(f"continuation of the periodic orbit of {model.name} in {name} from {values[0]:g} to {values[-1]:g} "
          f"({len(values)} points)")
    result = continue_orbit(module.build, name, values, period=args.period, fixed=parameters, x0=x0,
                            signals=[signal] if signal and signal not in model.state_names else [],
                            on_error="stop", switch_branch=args.doubled, **options)
    _print_table(result.rows())
    for b in result.bifurcations:
        print(f"  {b}")
    if not result.bifurcations:
        print("  no multiplier crossed -1 or +1")
    for branch in result.branches:
        print(f"doubled branch from the {branch.origin} (period 2T):")
        _print_table(branch.rows())
        if branch.stopped:
            print(f"  {branch.stopped}")
    if args.doubled and not result.branches:
        print("  no doubled branch followed (none found next to a located period doubling)")
    print(f"  {len(result.points)} orbit(s) in {result.wall_time:.2f} s")
    status = EXIT_OK
    if result.stopped:
        print(f"hbg: error: {result.stopped}", file=sys.stderr)
        status = EXIT_FAILED
    written = _orbit_outputs(args, model, continuation=result, names=names)
    return status if status != EXIT_OK else written


def _orbit_outputs(args, model, orbit=None, continuation=None, names=()) -> int:
    """Write ``--csv`` (the period at ``--samples`` times, or the continuation's table) and ``--plot`` (the
    signals over the period, a panel per unit, or the bifurcation diagram of ``--signal``); exit status 1
    when one could not be written."""
    status = EXIT_OK
    dense = orbit.sampled(args.samples) if orbit is not None and (args.csv or args.plot) else None
    if args.csv:
        try:
            if continuation is not None:
                import csv

                rows = continuation.rows()
                with open(args.csv, "w", newline="") as handle:
                    writer = csv.DictWriter(handle, fieldnames=list(rows[0]) if rows else [continuation.parameter])
                    writer.writeheader()
                    writer.writerows(rows)
                print(f"  csv: {args.csv} ({len(rows)} rows)")
            else:
                rows = dense.without_instants()
                rows.to_csv(args.csv, signals=[n for n in names if n not in model.state_names])
                print(f"  csv: {args.csv} (the orbit over one period: {len(rows.t)} rows at --samples "
                      f"{args.samples} times)")
        except OSError as exc:
            print(f"hbg: error: could not write csv {args.csv}: {exc}", file=sys.stderr)
            status = EXIT_FAILED
    if args.plot and (orbit is not None or continuation.points):
        import matplotlib

        matplotlib.use("Agg")
        from bondgraph.drawing import pyplot

        if continuation is not None:
            name = names[0] if names else model.state_names[0]
            ax = continuation.plot(name)
            ax.set_title(f"{model.name}: {ax.get_title()}", fontsize=9)
            figure = ax.figure
        else:
            figure = plot_trajectory(dense, _by_unit(model, names or list(model.state_names)),
                                     title=f"{model.name}: periodic orbit, period {orbit.period:.6g} s")
        try:
            figure.savefig(args.plot, dpi=110, bbox_inches="tight")
            print(f"  plot: {plot_target(args.plot)}")
        except (OSError, ValueError) as exc:
            print(f"hbg: error: could not write plot {args.plot}: {exc}", file=sys.stderr)
            status = EXIT_FAILED
        finally:
            pyplot().close(figure)
    return status


def _by_unit(model, names) -> list:
    """``names`` grouped by unit, in order of first appearance: a panel per unit (states of V·s and C on
    one axis would share no scale)."""
    groups: dict = {}
    for name in names:
        groups.setdefault(model.annotations.unit(name), []).append(name)
    return list(groups.values())


def add_orbit(sub) -> None:
    """``hbg orbit``: its arguments and options."""
    p = sub.add_parser("orbit", help="a periodic orbit by Newton shooting (period, start, Floquet multipliers, "
                       "stability), or its continuation in one parameter with period doublings and folds")
    p.add_argument("model", help=MODEL_HELP)
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="override a parameter, or set a state's value in the first guess of the orbit's start "
                        "(repeatable)")
    p.add_argument("--period", type=float, metavar="T", help="the orbit's period in s, fixed (clock-driven "
                   "switching); with --section only the first guess of the period")
    p.add_argument("--section", metavar="AUTOMATON:SOURCE->TARGET",
                   help="an autonomous orbit: its period ends where AUTOMATON takes SOURCE -> TARGET "
                        "(e.g. 'relay: on -> off'); without --period the return is looked for up to the model's "
                        "t_end")
    p.add_argument("--crossings", type=int, default=1, metavar="N",
                   help="with --section: the period ends at the N-th such transition (default 1)")
    p.add_argument("--continue", dest="continue_", metavar="NAME=START:STOP:COUNT",
                   help="follow the orbit as the parameter NAME takes COUNT equally spaced values from START to STOP: "
                        "a table of period, start and multipliers, with period doublings and folds located")
    p.add_argument("--doubled", action="store_true",
                   help="with --continue: at each period doubling, find the orbit of twice the period and follow it "
                        "(a second table; orange in the plot)")
    p.add_argument("--warmup", type=int, default=0, metavar="N",
                   help="periods of plain simulation before Newton's first step (default 0)")
    p.add_argument("--rtol", type=float, help="relative tolerance of every run (default 1e-10)")
    p.add_argument("--max-step", type=float, dest="max_step", metavar="H",
                   help="the longest step in s (default: the model's, e.g. a PWM converter's)")
    p.add_argument("--signal", metavar="NAME", help="the state or signal plotted and written (default: every "
                   "state; with --continue the first state); several as NAME,NAME")
    p.add_argument("--samples", type=int, default=500, metavar="N",
                   help="the orbit's files and plot at N equally spaced times over one period, plus its instants' "
                        "rows (default 500, at least 2): one run from the orbit's start")
    p.add_argument("--measure", action="append", metavar="SIGNAL:KIND[,KIND…]",
                   help="print measurements over the orbit's period (repeatable): mean, rms, ac_rms, min, max, "
                        "ripple, peak, crest, thd (fundamental 1/period), power_factor (of an element), "
                        "efficiency (of a load element); exact, the orbit's flow integrated piece by piece")
    p.add_argument("--csv", metavar="FILE", help="write the orbit over one period (time, states, the --signal "
                   "signals, mode), or with --continue the table, as CSV")
    p.add_argument("--plot", metavar="FILE.png", help="plot the orbit over one period (a panel per unit), or with "
                   "--continue the bifurcation diagram (min and max over a period; stable solid, unstable dashed)")
    p.set_defaults(run=_cmd_orbit)
