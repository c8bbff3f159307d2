"""Measurements on the command line: ``--measure SIGNAL:KIND,KIND`` over a window.

``hbg run … --measure v_C:mean,ripple --period 1e-5 --periods 10`` prints
the figures of :func:`switching.simulate.measurements.measure` after the
run's summary; ``hbg sweep … --metric ripple:v_C --period 1e-5`` puts them
in the sweep's table.  The window: ``--window FROM:TO`` [s], or the last
``--periods N`` (default 1) of ``--period T`` [s]; default the whole run.
"""

from __future__ import annotations

from .common import UsageError, finite_number

__all__ = ["add_window", "window_options", "parse_measures", "print_measures"]


def add_window(p, what: str) -> None:
    """The window options of a command's measurements (``what``: the option that measures)."""
    p.add_argument("--period", type=float, metavar="T",
                   help=f"the window of {what}: the last --periods periods of T seconds (a converter's switching "
                        "period); thd's fundamental is 1/T")
    p.add_argument("--periods", type=float, metavar="N", help="how many periods --period's window holds (default 1)")
    p.add_argument("--window", metavar="FROM:TO", help=f"the window of {what} in s (default: the whole run)")
    p.add_argument("--fundamental", type=float, metavar="HZ", help="the fundamental of thd in Hz (default 1/T)")


def window_options(args) -> dict:
    """The measurement window the options give, as :func:`measure`'s keywords; usage errors for what
    cannot be a window."""
    window: dict = {}
    if args.window is not None:
        if args.period is not None:
            raise UsageError("--window and --period are two ways to give the window: give one")
        start, colon, end = args.window.partition(":")
        if not colon:
            raise UsageError(f"--window {args.window}: write FROM:TO in seconds (0.018:0.02)")
        window["t_from"] = finite_number(start, f"--window {args.window}: {start!r} is not a time in s",
                                         f"--window {args.window}: {start!r} is not a finite time")
        window["t_to"] = finite_number(end, f"--window {args.window}: {end!r} is not a time in s",
                                       f"--window {args.window}: {end!r} is not a finite time")
    if args.periods is not None and args.period is None:
        raise UsageError("--periods counts periods of --period T: give --period too")
    if args.period is not None:
        if not args.period > 0:
            raise UsageError(f"--period must be a time > 0 in s, got {args.period}")
        periods = 1.0 if args.periods is None else args.periods
        if not periods > 0:
            raise UsageError(f"--periods must be > 0, got {args.periods}")
        window.update(period=args.period, periods=periods)
    if args.fundamental is not None:
        if not args.fundamental > 0:
            raise UsageError(f"--fundamental must be a frequency > 0 in Hz, got {args.fundamental}")
        window["fundamental"] = args.fundamental
    return window


def parse_measures(items, model) -> list[tuple[str, list[str]]]:
    """``--measure SIGNAL:KIND,KIND`` items as ``(signal, kinds)``, checked against the model's signals
    (elements for ``power_factor`` and ``efficiency``) and the measurements' names."""
    from switching.simulate.measurements import MEASURES

    out = []
    for item in items or ():
        signal, colon, kinds = item.partition(":")
        names = [k.strip() for k in kinds.split(",") if k.strip()]
        if not colon or not signal or not names:
            raise UsageError(f"--measure {item}: write SIGNAL:KIND[,KIND…] (v_C:mean,ripple); kinds: "
                             f"{', '.join(MEASURES)}")
        for kind in names:
            if kind not in MEASURES:
                raise UsageError(f"--measure {item}: unknown measurement {kind!r}; kinds: {', '.join(MEASURES)}")
            known = model.graph.elements if kind in ("power_factor", "efficiency") else \
                set(model.signal_names) | {s.name for s in model.states}
            if signal not in known:
                what = "an element" if kind in ("power_factor", "efficiency") else "a signal"
                raise UsageError(f"--measure {item}: {kind} needs {what}; {signal!r} is none of the model's "
                                 f"({', '.join(sorted(known))})")
        out.append((signal, names))
    return out


def print_measures(trajectory, measures, window: dict, how: str | None = None) -> bool:
    """Print each measurement with its unit under a line naming the window (``how`` says what it is);
    False where one failed (its error printed)."""
    import sys

    from switching.simulate.measurements import MeasurementError, window_of

    if not measures:
        return True
    try:
        a, b = window_of(trajectory, window.get("t_from"), window.get("t_to"), window.get("periods"),
                         window.get("period"))
    except MeasurementError as exc:
        print(f"hbg: error: no measurements: {exc}", file=sys.stderr)
        return False
    how = how or (f"the last {window['periods']:g} period(s) of {window['period']:g} s" if "period" in window
                  else "the window given" if "t_from" in window else "the whole run")
    print(f"  measurements over [{a:.9g}, {b:.9g}] s ({how}):")
    notes = getattr(trajectory.model, "annotations", None)
    ok = True
    for signal, kinds in measures:
        try:
            found = trajectory.measure(signal, kinds, **window)
        except MeasurementError as exc:
            print(f"hbg: error: --measure {signal}: {exc}", file=sys.stderr)
            ok = False
            continue
        unit = notes.unit(signal) if notes is not None else None
        for kind in kinds:
            ratio = kind in ("thd", "crest", "power_factor", "efficiency")
            print(f"    {signal} {kind}: {found[kind]:.10g}" + ("" if ratio or not unit else f" {unit}"))
    return ok
