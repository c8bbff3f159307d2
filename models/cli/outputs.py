"""The output files of ``run``, ``sweep``, ``orbit``, ``save`` and ``draw``: checked before anything runs
(on the files actually written), then written from what was computed."""

from __future__ import annotations

import os
import sys


from .common import UsageError


def _plot_formats() -> dict:
    from matplotlib.backend_bases import FigureCanvasBase

    return FigureCanvasBase.get_supported_filetypes()


def plot_target(path: str) -> str:
    """The file matplotlib writes for ``path`` (it adds its default format's
    extension when there is none)."""
    if os.path.splitext(path)[1]:
        return path
    import matplotlib

    return f"{path}.{matplotlib.rcParams['savefig.format']}"


def npz_target(path):
    """The file ``numpy.savez`` writes for ``path`` (it adds ``.npz`` when missing)."""
    if not path:
        return path
    return path if path.endswith(".npz") else path + ".npz"


def _distinct_outputs(outputs) -> None:
    """A usage error if two output options name the same file (the last written would replace the other)."""
    seen: dict = {}
    for option, path in outputs:
        if not path:
            continue
        key = os.path.realpath(path)
        if key in seen:
            raise UsageError(f"{seen[key]} and {option} both name {path}: the second would overwrite the first; "
                             "give each output its own file")
        seen[key] = option


def check_outputs(outputs) -> None:
    """Usage errors, before anything runs, for the output options ``outputs`` (``(option, path, kind)``,
    ``kind`` ``"plot"``, ``"npz"`` or ``"data"``; a ``None`` path is an option not given): an empty path, a
    directory (``out/``, before ``numpy.savez`` or matplotlib add an extension and write a hidden file in
    it), a file that cannot be written (:func:`check_output`), and two options writing the same file
    (compared on the files written: ``--plot r`` writes ``r.png``)."""
    written = []
    for option, path, kind in outputs:
        if path is None:
            continue
        if not path.strip():
            raise UsageError(f"{option}: the file name is empty; give a file name or leave {option} out")
        if path.endswith(("/", os.sep)) or os.path.isdir(path):
            raise UsageError(f"{option} {path}: is a directory, give a file name")
        written.append((option, {"plot": plot_target, "npz": npz_target}.get(kind, str)(path), kind))
    _distinct_outputs([(option, target) for option, target, _ in written])
    for option, target, kind in written:
        check_output(option, target, plot=kind == "plot")


def check_output(option: str, path: str, plot: bool = False) -> None:
    """Usage errors, before anything runs, for an output file that cannot be
    written: an unsupported plot format, a missing or read-only directory."""
    if plot:
        extension = os.path.splitext(path)[1][1:].lower()
        if extension:
            formats = _plot_formats()
            if extension not in formats:
                raise UsageError(f"{option} {path}: matplotlib cannot write {extension!r} files; "
                                 f"supported extensions: {', '.join(sorted(formats))}")
    if os.path.isdir(path):
        raise UsageError(f"{option} {path}: is a directory, give a file name")
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise UsageError(f"{option} {path}: directory {directory} does not exist")
    if not os.access(directory, os.W_OK | os.X_OK) or (os.path.exists(path) and not os.access(path, os.W_OK)):
        raise UsageError(f"{option} {path}: not writable (permission denied)")


def output_rows(trajectory, with_instants: bool, ended_early: bool):
    """The rows the data files hold: those of a run with ``samples=N`` (the
    times and the instants' pairs) when ``with_instants``, else its ``N``
    times alone (:meth:`Trajectory.without_instants`); a run that
    ``ended_early`` keeps its last state (where it stopped), which replaces a
    row at that time.  A run of every step (``--samples 0``): every row."""
    if with_instants or trajectory.sampling != "samples" or not trajectory.event_index:
        return trajectory
    n = len(trajectory.t)
    dropped = set(trajectory.event_index) | {k - 1 for k in trajectory.event_index}
    rows = [k for k in range(n) if k not in dropped]
    if ended_early and n and n - 1 not in rows:  # the run stopped at an instant: its last state is the last row
        rows = [k for k in rows if trajectory.t[k] != trajectory.t[n - 1]] + [n - 1]
    return trajectory.take(rows)


def write_outputs(args, trajectory, signals, plotted=None) -> list[str]:
    """Write the requested files, data first, each on its own; return the
    failures (each names the file and the reason).  The plot draws
    ``plotted`` (default: ``trajectory``, the rows of the data files)."""
    extra = [s for s in signals if s not in trajectory.state_names]
    failures = []

    def attempt(kind, path, write):
        try:
            write()
        except KeyboardInterrupt:
            raise
        except Exception as exc:  # noqa: BLE001 - reported, the other files are still written
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            failures.append(f"could not write {kind} {path}: {reason}")
            print(f"hbg: error: could not write {kind} {path}: {reason}", file=sys.stderr)
            return
        print(f"  {kind}: {path}")

    def data(writer):
        def write():
            try:
                writer(extra)
            except (OSError, KeyboardInterrupt):
                raise
            except Exception as exc:  # a signal that cannot be evaluated: keep the states at least
                if not extra:
                    raise
                print(f"hbg: warning: signals {', '.join(extra)} could not be evaluated "
                      f"({str(exc).splitlines()[0] if str(exc) else type(exc).__name__}); writing the states only",
                      file=sys.stderr)
                writer([])
        return write

    if args.csv:
        attempt("csv", args.csv, data(lambda sig: trajectory.to_csv(args.csv, signals=sig)))
    if args.npz:
        attempt("npz", npz_target(args.npz), data(lambda sig: trajectory.to_npz(args.npz, signals=sig)))
    if args.plot:
        def plot():
            from bondgraph.drawing import pyplot
            from switching.simulate.plotting import DEFAULT_PANELS, plot_trajectory

            shown = trajectory if plotted is None else plotted
            if len(shown.t) == 0:
                raise ValueError("no samples to plot")
            fig = plot_trajectory(shown, signals if args.signals else signals[:DEFAULT_PANELS])  # (the files: all)
            try:
                fig.savefig(args.plot, dpi=110)
            finally:
                pyplot().close(fig)

        attempt("plot", plot_target(args.plot), plot)
    return failures
