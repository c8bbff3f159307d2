"""The ``hbg`` command line.

    hbg list                                  shipped models, descriptions, parameters
    hbg run MODEL [--set name=value ...] [--t-end T] [--method M] [--dt DT | --rtol R]
                  [--plot FILE.png] [--csv FILE] [--npz FILE] [--signals a,b,...]
                  [--samples N] [--with-instants] [--no-keep-instants] [--on-zeno {raise,stop}]
                  [--no-stiffness-check] [--max-steps N] [--progress | --quiet]
    hbg modes MODEL [--mode LABEL] [--latex] [--state-space] [--t-end T]
                                              f, g, h and guards (or A, B, C, D) of the visited modes (or one)
    hbg verify MODEL [--samples N]            static divergence-of-time check
    hbg codegen MODEL -o DIR [--t-end T]      export the generated per-mode functions
    hbg draw MODEL [--mode LABEL] -o FILE.png|FILE.svg   the bond graph of a mode, drawn as textbooks do
    hbg save MODEL [--set name=value ...] -o FILE.toml   the model as a model file
    hbg sweep MODEL --grid name=start:stop:count --grid name=v1,v2 [--set ...] [--method M] [--t-end T]
                  [--scheduler ADDRESS | --workers N] --csv FILE [--plot FILE.png] [--metric NAME ...]
                  [--on-zeno {raise,stop}]
                                              one run per grid point on Dask, a CSV row each, a plot
    hbg orbit MODEL [--set ...] (--period T | --section AUTOMATON:SOURCE->TARGET [--period GUESS])
                  [--continue NAME=START:STOP:COUNT] [--csv FILE] [--plot FILE.png] [--signal NAME]
                                              a periodic orbit (period, start, multipliers, stability), or
                                              its continuation in one parameter
    hbg graphs | hbg equations NAME           plain bond graphs and their equations

Model names accept ``-`` or ``_`` (``falling-rod``).  Wherever a command
takes a MODEL it also takes the path of a model file (``hbg run my.toml``;
see :mod:`switching.files.modelfile`); ``--set`` then overrides the file's
parameters, and the file's ``[run]`` table gives the default run.

Output of ``hbg run``: ``--samples N`` (default 500, at least 2) runs
``simulate(..., samples=N)``: the ``N`` equally spaced times
``linspace(0, t_end, N)`` and, at every instant, its two rows (just before,
just after).  The plot draws all of them (jumps upright); the CSV/NPZ files
hold the ``N`` times (``trajectory.without_instants()``; a run that ends
early: the times it reached and its last state), and with
``--with-instants`` the instants' rows too — exactly the rows of
``model.simulate(t_end, samples=N)`` in Python (whose own default,
``output="steps"``, is every integrator step; ``t_eval=linspace(0, t_end,
N)`` gives the ``N`` rows alone).  A time that falls on an instant holds the
state after it.  ``--samples 0`` writes every integrator step and every
instant (no cap; Python's default).  Two outputs may not name one
file.  ``hbg sweep`` makes at most :data:`MAX_RUNS` runs.
``--no-keep-instants`` does not keep the record of each instant (memory stays flat on long runs; the summary
then only counts instants).  ``--on-zeno stop`` ends a Zeno run at the
accumulation point instead of failing.  ``--no-stiffness-check`` turns off
the explicit methods' stiffness test (``stiffness_check=False``: the run
goes on whatever the stability of its step).  ``--max-steps N`` (default
10 000 000) bounds the integrator's steps: a ``--dt`` that needs more, or
one below the resolution of ``t``, is a usage error before anything runs
(the checks of :mod:`switching.simulate.run_options`), and a run that takes more
stops (exit 1, the partial run saved).  The data files are written first,
then the plot, each on its own: one that cannot be written does not stop the
others.

Nothing computed is lost: when a run fails (any error of the toolkit, e.g. a
divergence of time or Zeno behaviour) or is interrupted with Ctrl-C, the
files asked for are written with the part of the run that was computed
(stderr says up to which time), the whole error message is printed, and the
exit status says what happened.  No traceback is printed (set
``HBG_TRACEBACK=1`` to see one for an unexpected error).

Exit status:

    0    success (``verify``: no divergence of time found)
    1    the run failed (the partial run is saved), ``verify`` found a
         divergence of time, ``orbit`` found no orbit (Newton did not
         converge, the mode sequence changed, a guard grazed; with
         ``--continue`` the table holds the points before), an output file
         could not be written, or an unexpected internal error
    2    bad input, rejected before anything runs: the command line (unknown
         model, parameter, option or signal; a non-finite or out-of-range
         number; an unsupported plot format; an output directory that does not
         exist or is not writable) or the model as parameterised
    130  interrupted (Ctrl-C); what was computed is saved
"""

from __future__ import annotations

import argparse
import inspect
import math
import os
import re
import sys
import time
import warnings

from bondgraph import HybridBondGraphError
from bondgraph.errors import did_you_mean
from switching.simulate.progress import ProgressBar

from . import MODELS, load
from .graphs import GRAPHS

#: exit statuses (see the module docstring)
EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


class _UsageError(Exception):
    pass


def _summary(obj) -> str:
    """The first paragraph of ``obj``'s docstring as plain text for a terminal:
    reST roles and literals (``:func:`models.x`` ``, ````V0````) shown as their text."""
    doc = inspect.getdoc(obj) or ""
    return plain_text(doc.split("\n\n")[0].replace("\n", " "))


def plain_text(rst: str) -> str:
    """reST inline markup as a terminal shows text: ``:role:`~a.b.c``` → ``c``,
    ``:role:`a.b``` → ``a.b``, ````code```` → ``code``, ``*em*`` → ``em``."""
    text = re.sub(r":[a-z]+:`~(?:[\w.]*\.)?([^`]+)`", r"\1", rst)
    text = re.sub(r":[a-z]+:`([^`]+)`", r"\1", text)
    text = re.sub(r"``([^`]+)``", r"\1", text)
    return re.sub(r"(?<![\w*])\*([^*\s][^*]*)\*(?![\w*])", r"\1", text)


def _module(name):
    """The shipped model's module, or for a path the :class:`switching.files.modelfile.ModelFile`
    (same interface); a bad file raises its ModelFileError (file, line, culprit)."""
    from switching.files.modelfile import is_model_path

    from . import resolve

    if is_model_path(name) or (name.replace("-", "_") not in MODELS and os.path.isfile(name)):
        return resolve(name)
    try:
        return load(name)
    except HybridBondGraphError:
        raise _UsageError(f"unknown model {name!r}; shipped models: {', '.join(m.replace('_', '-') for m in MODELS)} "
                          "(or a model file: a path ending in .toml)")


def _finite(value: str) -> str:
    """Why a number given as text is not finite ('' if it is)."""
    number = float(value)
    if math.isnan(number):
        return "not a number"
    if math.isinf(number):
        text = value.strip().lower().lstrip("+-")
        return "infinite" if text in ("inf", "infinity") else "too large (overflows to infinity)"
    return ""


def _finite_number(value: str, not_a_number: str, not_finite: str) -> float:
    """``value`` (text) as a finite float; a usage error ``not_a_number`` when it
    reads as no number, ``not_finite (why)`` when it is NaN or infinite."""
    try:
        number = float(value)
    except ValueError:
        raise _UsageError(not_a_number) from None
    problem = _finite(value)
    if problem:
        raise _UsageError(f"{not_finite} ({problem})")
    return number


def _parse_sets(items, defaults, others: dict | None = None) -> dict:
    """``--set name=value`` items → parameter values (numbers checked finite).
    A name that is no parameter goes to ``others`` (name → number) when given
    (an initial state, checked once the model is built), else is a usage error."""
    values = {}
    for item in items:
        if "=" not in item:
            raise _UsageError(f"--set expects name=value, got {item!r}")
        name, _, value = item.partition("=")
        name = name.strip()
        if name not in defaults and others is None:
            raise _UsageError(f"unknown parameter {name!r}; parameters: {', '.join(defaults)}")
        if name in defaults and isinstance(defaults[name], (bool, str)):  # parsed and checked by the model
            values[name] = value.strip()
            continue
        what = "parameter" if name in defaults else "initial state"
        number = _finite_number(value, f"{what} {name!r} needs a number, got {value!r}",
                                f"--set {name}={value.strip()}: {what} {name!r} must be a finite number, "
                                f"got {value.strip()!r}")
        (values if name in defaults else others)[name] = number
    return values


def _initial_state(model, states: dict, defaults):
    """The run's ``x0``: the model's initial state as given, with the states
    named in ``states`` (name → value, from ``--set``) replaced; ``None`` when none is named."""
    if not states:
        return None
    unknown = [name for name in states if name not in model.state_names]
    if unknown:
        raise _UsageError(f"unknown parameter or state {unknown[0]!r}{did_you_mean(unknown[0], [*defaults, *model.state_names])}; "
                          f"parameters: {', '.join(defaults) or '(none)'}; states: {', '.join(model.state_names)}")
    x0 = model.given_initial_state
    for name, value in states.items():
        x0[model.state_names.index(name)] = value
    return x0


def _build(args):
    module = _module(args.model)
    return module, module.build(**_parse_sets(getattr(args, "set", None) or [], module.DEFAULTS))


def _positive(option: str, value: float) -> None:
    """A usage error unless ``value`` is finite and > 0, naming the option and the value."""
    if not (math.isfinite(value) and value > 0):
        raise _UsageError(f"{option} must be a finite positive number, got {value!r}")


def _run_options(args, module, default_method: str = "RK45") -> tuple[float, str, dict]:
    """``(t_end, method, options)`` of a run from the command line over the
    model's ``RUN``; ``default_method`` where neither names a method."""
    run = dict(module.RUN)
    t_end = args.t_end if args.t_end is not None else run.pop("t_end")
    run.pop("t_end", None)
    from switching.simulate.methods import canonical_method

    method = canonical_method(args.method or run.pop("method", default_method))
    run.pop("method", None)
    from switching import METHODS
    from switching.simulate.methods import METHOD_CLASSES

    if method not in METHODS and method != "auto":
        raise _UsageError(f"unknown method {method!r}; choose one of: {', '.join(METHODS)}, auto")
    _positive("--t-end", t_end)
    atol, max_step = getattr(args, "atol", None), getattr(args, "max_step", None)
    for option, value in (("--dt", args.dt), ("--rtol", args.rtol), ("--atol", atol), ("--max-step", max_step)):
        if value is not None:
            _positive(option, value)
    options = {}
    if METHOD_CLASSES[method].fixed_step:
        for option, value in (("--rtol", args.rtol), ("--atol", atol), ("--max-step", max_step)):
            if value is not None:
                raise _UsageError(f"{option} is for adaptive methods; {method} is fixed-step: give --dt")
        if args.dt is None:
            raise _UsageError(f"method {method} is fixed-step: give --dt")
        options["dt"] = args.dt
    else:
        if args.dt is not None:
            raise _UsageError(f"--dt is for euler and rk4; {method} is adaptive: give --rtol")
        options.update({k: v for k, v in run.items() if k in ("rtol", "atol", "max_step")})
        for key, value in (("rtol", args.rtol), ("atol", atol), ("max_step", max_step)):
            if value is not None:
                options[key] = value
    return t_end, method, options


#: the command line's flag for an option of ``simulate``
_FLAGS = {"dt": "--dt", "rtol": "--rtol", "atol": "--atol", "max_step": "--max-step", "max_steps": "--max-steps",
          "t_end": "--t-end", "samples": "--samples", "x0": "--set"}


def _check_run(model, t_end, method, options) -> None:
    """The checks ``simulate`` makes of its options, before anything runs
    (:func:`switching.simulate.run_options.check_run`), as usage errors naming the flag."""
    from switching.errors import OptionError
    from switching.simulate.run_options import check_run
    from switching.simulate.driver import option_defaults

    try:
        check_run(model, t_end, method, {**option_defaults(), **options})
    except OptionError as exc:
        flag = _FLAGS.get(exc.option)
        raise _UsageError(f"{flag}: {exc}" if flag else str(exc)) from None


def _check_samples(model, samples) -> None:
    """``--samples`` refused before anything runs when its rows would not fit
    (:func:`switching.simulate.run_options.check_output_size`)."""
    from switching.errors import OptionError
    from switching.simulate.run_options import check_output_size

    try:
        check_output_size(samples, len(model.states), "--samples")
    except OptionError as exc:
        raise _UsageError(str(exc)) from None


# ------------------------------------------------------------------ output files


def _plot_formats() -> dict:
    from matplotlib.backend_bases import FigureCanvasBase

    return FigureCanvasBase.get_supported_filetypes()


def _plot_target(path: str) -> str:
    """The file matplotlib writes for ``path`` (it adds its default format's
    extension when there is none)."""
    if os.path.splitext(path)[1]:
        return path
    import matplotlib

    return f"{path}.{matplotlib.rcParams['savefig.format']}"


def _npz_target(path):
    """The file ``numpy.savez`` writes for ``path`` (it adds ``.npz`` when missing)."""
    if not path:
        return path
    return path if path.endswith(".npz") else path + ".npz"


#: the most runs ``hbg sweep --grid`` makes (the product of the grid's counts)
MAX_RUNS = 1_000_000


def _distinct_outputs(outputs) -> None:
    """A usage error if two output options name the same file (the last written would replace the other)."""
    seen: dict = {}
    for option, path in outputs:
        if not path:
            continue
        key = os.path.realpath(path)
        if key in seen:
            raise _UsageError(f"{seen[key]} and {option} both name {path}: the second would overwrite the first; "
                              "give each output its own file")
        seen[key] = option


def _check_outputs(outputs) -> None:
    """Usage errors, before anything runs, for the output options ``outputs`` (``(option, path, kind)``,
    ``kind`` ``"plot"``, ``"npz"`` or ``"data"``; a ``None`` path is an option not given): an empty path, a
    directory (``out/``, before ``numpy.savez`` or matplotlib add an extension and write a hidden file in
    it), a file that cannot be written (:func:`_check_output`), and two options writing the same file
    (compared on the files written: ``--plot r`` writes ``r.png``)."""
    written = []
    for option, path, kind in outputs:
        if path is None:
            continue
        if not path.strip():
            raise _UsageError(f"{option}: the file name is empty; give a file name or leave {option} out")
        if path.endswith(("/", os.sep)) or os.path.isdir(path):
            raise _UsageError(f"{option} {path}: is a directory, give a file name")
        written.append((option, {"plot": _plot_target, "npz": _npz_target}.get(kind, str)(path), kind))
    _distinct_outputs([(option, target) for option, target, _ in written])
    for option, target, kind in written:
        _check_output(option, target, plot=kind == "plot")


def _check_output(option: str, path: str, plot: bool = False) -> None:
    """Usage errors, before anything runs, for an output file that cannot be
    written: an unsupported plot format, a missing or read-only directory."""
    if plot:
        extension = os.path.splitext(path)[1][1:].lower()
        if extension:
            formats = _plot_formats()
            if extension not in formats:
                raise _UsageError(f"{option} {path}: matplotlib cannot write {extension!r} files; "
                                  f"supported extensions: {', '.join(sorted(formats))}")
    if os.path.isdir(path):
        raise _UsageError(f"{option} {path}: is a directory, give a file name")
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise _UsageError(f"{option} {path}: directory {directory} does not exist")
    if not os.access(directory, os.W_OK | os.X_OK) or (os.path.exists(path) and not os.access(path, os.W_OK)):
        raise _UsageError(f"{option} {path}: not writable (permission denied)")


def _output_rows(trajectory, with_instants: bool, ended_early: bool):
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


def _write_outputs(args, trajectory, signals, plotted=None) -> list[str]:
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
        attempt("npz", _npz_target(args.npz), data(lambda sig: trajectory.to_npz(args.npz, signals=sig)))
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

        attempt("plot", _plot_target(args.plot), plot)
    return failures


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
        print(f"hbg: compiling the simulation kernel for this installation (once, about {KERNEL_COMPILE_SECONDS:.0f} s)",
              file=sys.stderr, flush=True)


def _cmd_list(args) -> int:
    for name in MODELS:
        module = load(name)
        print(f"{name.replace('_', '-')}: {_summary(module)}")
        print("    " + ", ".join(f"{k}={v}" for k, v in module.DEFAULTS.items()))
    return 0


def _cmd_run(args) -> int:
    module = _module(args.model)
    states: dict = {}
    parameters = _parse_sets(args.set or [], module.DEFAULTS, states)
    t_end, method, options = _run_options(args, module, "auto")
    if args.samples < 0 or args.samples == 1:
        raise _UsageError(f"--samples must be 0 (every step) or at least 2 (the start and the end), got {args.samples}")
    _check_outputs((("--csv", args.csv, "data"), ("--npz", args.npz, "npz"), ("--plot", args.plot, "plot")))
    if args.with_instants and not args.keep_instants:
        raise _UsageError("--with-instants needs the instants: drop --no-keep-instants")
    model = module.build(**parameters)
    x0 = _initial_state(model, states, module.DEFAULTS)
    if x0 is not None:
        options["x0"] = x0
    signals = [s for s in (args.signals.split(",") if args.signals else module.SIGNALS) if s]
    for s in signals:
        if s not in model.signal_names and s not in {b.effort.name for b in model.graph.bonds.values()} | {
            b.flow.name for b in model.graph.bonds.values()
        }:
            raise _UsageError(f"unknown signal {s!r}; signals: {', '.join(model.signal_names)}")
    if args.max_steps is not None:
        options["max_steps"] = args.max_steps
    if args.samples:
        _check_samples(model, args.samples)
        options["samples"] = args.samples
    options.update(on_zeno=args.on_zeno, keep_instants=args.keep_instants)
    if not args.stiffness_check:
        options["stiffness_check"] = False
    _check_run(model, t_end, method, options)
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
    if failure is None and hasattr(module, "error_estimate"):
        try:
            print(f"  error estimate: {module.error_estimate(trajectory)}")
        except Exception as exc:  # noqa: BLE001
            print(f"hbg: warning: no error estimate ({exc})", file=sys.stderr)
    if wants_files:
        out = _output_rows(trajectory, args.with_instants, failure is not None or trajectory.stopped is not None)
        if args.samples:
            print(f"  output: {len(out.t)} rows at --samples {args.samples} times"
                  + ("" if args.with_instants or not trajectory.event_index
                     else f" (--with-instants adds 2 rows for each of the {len(trajectory.event_index)} instants)"))
        plotted = trajectory  # the times and the instants' pairs: jumps drawn upright
        if _write_outputs(args, out, signals, plotted) and status == EXIT_OK:
            status = EXIT_FAILED
    return status


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
        _positive("--t-end", args.t_end)
    return args.t_end


def _cmd_modes(args) -> int:
    module, model = _build(args)
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


def _cmd_verify(args) -> int:
    if args.samples < 1:
        raise _UsageError(f"--samples must be at least 1, got {args.samples}")
    _, model = _build(args)
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
        raise _UsageError(f"{option}: the file {filename!r} would be written outside {directory!r} "
                          f"(to {path}); give another folder or rename the model")
    return os.path.join(directory, filename)


def _cmd_codegen(args) -> int:
    module, model = _build(args)
    _visited_modes(module, model, _exploration_end(args))
    os.makedirs(args.output, exist_ok=True)
    path = _inside(args.output, f"{_file_stem(model.name)}_modes.py", "-o/--output")
    labels = model.export_module(path)
    print(f"wrote {path} ({len(labels)} modes: {', '.join(labels)})")
    return 0


def _cmd_save(args) -> int:
    """``hbg save``: write a model (with its --set values) and its default run to a model file."""
    _check_outputs((("-o/--output", args.output, "data"),))
    module, model = _build(args)
    run = dict(module.RUN)
    run["signals"] = list(module.SIGNALS)
    model.save(args.output, run=run, description=_summary(module) or None)
    print(f"wrote {args.output} (model {model.name}: {len(model.graph.elements)} elements, "
          f"{len(model.automata)} automata, {len(model.parameter_symbols)} parameters)")
    return 0


def _cmd_draw(args) -> int:
    """``hbg draw``: the bond graph of one mode as textbooks draw it (see
    :mod:`bondgraph.drawing`), written as PNG, SVG, PDF, … by the extension."""
    import matplotlib

    matplotlib.use("Agg")
    from bondgraph.drawing import draw_bond_graph, pyplot

    _check_outputs((("-o/--output", args.output, "plot"),))
    _, model = _build(args)
    mode = model.mode(args.mode) if args.mode else model.initial_mode
    described = mode.describe()
    if len(described) > 100:  # a model with many automata (ball-chain N=50): the label stays readable
        described = described[:97].rsplit(", ", 1)[0] + ", …"
    ax = draw_bond_graph(model.graph, model.configuration_of(mode), legend=not args.no_legend,
                         title=f"{model.name} in mode {described}")
    try:
        ax.figure.savefig(args.output, dpi=110)
    finally:
        pyplot().close(ax.figure)
    print(f"wrote {_plot_target(args.output)}")
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


def _grid_axis(item, defaults) -> tuple[str, list]:
    """One ``--grid``: ``name=start:stop:count`` (``count`` equally spaced
    numbers, both ends included) or ``name=v1,v2,...``; checked like ``--set``."""
    if "=" not in item:
        raise _UsageError(f"--grid expects name=start:stop:count or name=v1,v2,..., got {item!r}")
    name, _, text = item.partition("=")
    name, text = name.strip(), text.strip()
    if name not in defaults:
        raise _UsageError(f"--grid {item}: unknown parameter {name!r}; parameters: {', '.join(defaults)}")
    if isinstance(defaults[name], (bool, str)):  # parsed and checked by the model
        values = [v.strip() for v in text.split(",")]
        if not all(values):
            raise _UsageError(f"--grid {item}: an empty value in the list")
        return name, values

    def number(value):
        return _finite_number(value, f"--grid {item}: parameter {name!r} needs numbers, got {value.strip()!r}",
                              f"--grid {item}: {value.strip()!r} is not a finite number")

    if text.count(":") == 2 and "," not in text:
        start, stop, count = text.split(":")
        try:
            n = int(count)
        except ValueError:
            n = 0
        if n < 1:
            raise _UsageError(f"--grid {item}: the count after the second ':' must be a whole number >= 1, "
                              f"got {count.strip()!r}")
        if n > MAX_RUNS:
            raise _UsageError(f"--grid {item}: {n:,} values; a sweep makes at most {MAX_RUNS:,} runs")
        import numpy as np

        return name, [float(v) for v in np.linspace(number(start), number(stop), n)]
    if ":" in text:
        raise _UsageError(f"--grid {item}: write name=start:stop:count (two ':') or name=v1,v2,...")
    return name, [number(v) for v in text.split(",")]


def _sweep_metrics(names, model):
    """The ``--metric`` names split into signal specs (KIND:SIGNAL, computed
    in the workers) and columns of the table; unknown names are usage errors."""
    from switching.sweep.frame import FINAL, RUN_COLUMNS, SignalMetrics

    columns = [c for c in RUN_COLUMNS if c not in ("status", "error")] + [FINAL + s.name for s in model.states]
    specs = [name for name in names if ":" in name]
    for name in names:
        if ":" not in name and name not in columns:
            raise _UsageError(f"--metric {name}: not a column of the sweep table; use one of {', '.join(columns)} "
                              "or KIND:SIGNAL (KIND final, min or max; e.g. max:" + model.signal_names[0] + ")")
    if not specs:
        return None
    metrics = SignalMetrics(*specs)
    metrics.check(model)
    return metrics


def _cmd_sweep(args) -> int:
    """``hbg sweep``: one run per point of the grid on Dask, a CSV row per run,
    a plot of one metric over the grid."""
    import contextlib

    from switching import simulate_many
    from switching.sweep.frame import require_pandas, parameter_grid, plot_sweep, to_frame

    module = _module(args.model)
    base = _parse_sets(args.set or [], module.DEFAULTS)
    axes = {}
    for item in args.grid:
        name, values = _grid_axis(item, module.DEFAULTS)
        if name in axes or name in base:
            raise _UsageError(f"--grid {item}: {name!r} is already given ({'--grid' if name in axes else '--set'})")
        axes[name] = values
    runs = math.prod(len(values) for values in axes.values())
    if runs > MAX_RUNS:
        raise _UsageError(f"--grid: {' × '.join(str(len(v)) for v in axes.values())} = {runs:,} runs; a sweep makes "
                          f"at most {MAX_RUNS:,}: use fewer points")
    t_end, method, options = _run_options(args, module)
    options["on_zeno"] = args.on_zeno
    if args.workers is not None and args.workers < 1:
        raise _UsageError(f"--workers must be at least 1, got {args.workers}")
    varying = [name for name, values in axes.items() if len(set(values)) > 1]
    if args.plot and len(varying) not in (1, 2):
        raise _UsageError(f"--plot shows one or two parameters that vary over the grid; {len(varying)} vary"
                          + (f" ({', '.join(varying)})" if varying else ""))
    _check_outputs((("--csv", args.csv, "data"), ("--plot", args.plot, "plot")))
    require_pandas()  # a missing pandas is said before the sweep, not after
    model = module.build(**base)  # checks --set, and names the states and signals metrics may use
    _check_run(model, t_end, method, options)  # a --dt no run could take: refused once, not by every run
    names = args.metric or ["events"]
    metrics = _sweep_metrics(names, model)
    sets = [{**base, **point} for point in parameter_grid(axes)]
    where = args.scheduler or f"{min(args.workers or os.cpu_count() or 1, len(sets))} local Dask worker(s)"
    print(f"sweep of {model.name}: {len(sets)} runs over {' × '.join(f'{n} ({len(v)})' for n, v in axes.items())}, "
          f"{method} to t = {t_end:g} s, on {where}")
    start = time.perf_counter()
    bar = sys.stderr.isatty()
    with contextlib.redirect_stdout(sys.stderr) if bar else contextlib.nullcontext():  # Dask's bar: on stderr
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

        ax = plot_sweep(frame, names[0], varying)
        ax.set_title(f"{model.name}: {ax.get_title()}", fontsize=10)
        try:
            ax.figure.savefig(args.plot, dpi=110, bbox_inches="tight")
            print(f"  plot: {_plot_target(args.plot)} ({names[0]}, {'line' if len(varying) == 1 else 'heat map'})")
        except (OSError, ValueError) as exc:
            print(f"hbg: error: could not write plot {args.plot}: {exc}", file=sys.stderr)
            status = EXIT_FAILED
        finally:
            pyplot().close(ax.figure)
    return status


def _continue_axis(item, defaults) -> tuple[str, list]:
    """``--continue name=start:stop:count``: ``count`` (>= 2) equally spaced values, both ends included."""
    name, _, text = item.partition("=")
    name, text = name.strip(), text.strip()
    if not name or text.count(":") != 2:
        raise _UsageError(f"--continue expects name=start:stop:count (e.g. D=0.3:0.6:31), got {item!r}")
    if name not in defaults or isinstance(defaults[name], (bool, str)):
        raise _UsageError(f"--continue {item}: {name!r} is not a numeric parameter; parameters: {', '.join(defaults)}")
    start, stop, count = text.split(":")
    try:
        n = int(count)
    except ValueError:
        n = 0
    if n < 2 or n > MAX_RUNS:
        raise _UsageError(f"--continue {item}: the count after the second ':' must be a whole number from 2 to "
                          f"{MAX_RUNS:,}, got {count.strip()!r}")
    ends = [_finite_number(v, f"--continue {item}: {v.strip()!r} is not a number",
                           f"--continue {item}: {v.strip()!r} is not a finite number") for v in (start, stop)]
    if ends[0] == ends[1]:
        raise _UsageError(f"--continue {item}: start and stop are equal: nothing to continue")
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

    module = _module(args.model)
    states: dict = {}
    parameters = _parse_sets(args.set or [], module.DEFAULTS, states)
    axis = None
    if args.continue_:
        axis = _continue_axis(args.continue_, module.DEFAULTS)
        if axis[0] in parameters:
            raise _UsageError(f"--continue {args.continue_}: {axis[0]!r} is also given with --set")
    if args.section is None and args.period is None:
        raise _UsageError("give --period T (a fixed-period orbit, e.g. 1/f_sw of a clocked converter) or "
                          "--section AUTOMATON:SOURCE->TARGET (an autonomous orbit)")
    if args.doubled and axis is None:
        raise _UsageError("--doubled follows the branch born at a period doubling: it needs --continue")
    if args.period is not None:
        _positive("--period", args.period)
    for option, value in (("--rtol", args.rtol), ("--max-step", args.max_step)):
        if value is not None:
            _positive(option, value)
    if args.warmup < 0:
        raise _UsageError(f"--warmup must be 0 or more, got {args.warmup}")
    signal = args.signal
    _check_outputs((("--csv", args.csv, "data"), ("--plot", args.plot, "plot")))
    model = module.build(**parameters)
    x0 = _initial_state(model, states, module.DEFAULTS)
    if signal is not None and signal not in model.state_names and signal not in model.signal_names:
        raise _UsageError(f"--signal {signal}: not a state or signal of {model.name}; states: "
                          f"{', '.join(model.state_names)}; signals: {', '.join(model.signal_names)}")
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
        return _orbit_outputs(args, model, orbit=orbit)
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
    written = _orbit_outputs(args, model, continuation=result)
    return status if status != EXIT_OK else written


def _orbit_outputs(args, model, orbit=None, continuation=None) -> int:
    """Write ``--csv`` (the one-period run, or the continuation's table) and ``--plot`` (the states over the
    period, or the bifurcation diagram of ``--signal``); exit status 1 when one could not be written."""
    status = EXIT_OK
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
                orbit.trajectory.to_csv(args.csv)
                print(f"  csv: {args.csv} (the orbit over one period)")
        except OSError as exc:
            print(f"hbg: error: could not write csv {args.csv}: {exc}", file=sys.stderr)
            status = EXIT_FAILED
    if args.plot and (orbit is not None or continuation.points):
        import matplotlib

        matplotlib.use("Agg")
        from bondgraph.drawing import pyplot

        if continuation is not None:
            name = args.signal or model.state_names[0]
            ax = continuation.plot(name)
            ax.set_title(f"{model.name}: {ax.get_title()}", fontsize=9)
            figure = ax.figure
        else:
            figure, ax = pyplot().subplots(figsize=(6.4, 4.0))
            names = [args.signal] if args.signal else list(model.state_names)
            for name in names:
                ax.plot(orbit.trajectory.t, orbit.trajectory.signal(name), label=model.annotations.label(name))
            ax.set_xlabel("t [s]")
            ax.set_title(f"{model.name}: periodic orbit, period {orbit.period:.6g} s", fontsize=9)
            ax.legend(fontsize=8)
        try:
            figure.savefig(args.plot, dpi=110, bbox_inches="tight")
            print(f"  plot: {_plot_target(args.plot)}")
        except (OSError, ValueError) as exc:
            print(f"hbg: error: could not write plot {args.plot}: {exc}", file=sys.stderr)
            status = EXIT_FAILED
        finally:
            pyplot().close(figure)
    return status


class _Parser(argparse.ArgumentParser):
    """Errors are usage errors; an option is spelt out (``--max-step`` is not read as ``--max-steps``)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message):
        raise _UsageError(message)


#: what every command's MODEL argument may be
_MODEL_HELP = "a shipped model's name (hbg list shows them) or the path of a model file (.toml)"
#: what --set may set
_SET_HELP = "override a parameter (repeatable; hbg list shows each model's parameters)"
_RUN_SET_HELP = ("override a parameter, or set the initial value of a state by its name (q_C=1e-3, rod/theta=0.5); "
                 "repeatable")


def _add_exploration(p) -> None:
    p.add_argument("--t-end", type=float, dest="t_end", metavar="T",
                   help="the modes are those the model's default run passes up to T s (default: its end, or what "
                        f"it reaches in {EXPLORATION_SECONDS:g} s of computing)")


def _add_steps(p) -> None:
    """The step options of ``run`` and ``sweep``: ``--dt`` (fixed-step methods) or the tolerances."""
    group = p.add_mutually_exclusive_group()
    group.add_argument("--dt", type=float, help="step of euler / rk4")
    group.add_argument("--rtol", type=float, help="relative tolerance of adaptive methods")
    p.add_argument("--atol", type=float, help="absolute tolerance of adaptive methods, in the units of the states")
    p.add_argument("--max-step", type=float, dest="max_step", metavar="H",
                   help="the longest step an adaptive method may take, in s")


def _add_run(sub) -> None:
    """``hbg run``: its arguments and options."""
    p = sub.add_parser("run", help="simulate a shipped model or a model file: print a summary, write the plot and "
                       "data asked for")
    p.add_argument("model", help=_MODEL_HELP)
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help=_RUN_SET_HELP)
    p.add_argument("--t-end", type=float, dest="t_end", metavar="T", help="end time of the run in s (default: the "
                   "model's)")
    p.add_argument("--method", help="integration method (default: the model's, else auto); 'auto': the compiled "
                   "kernel when numba is installed and its kernel is cached, the run is long enough or the initial "
                   "mode is stiff (RK45-jit in each mode, rodas-jit where a mode is stiff), else RK45 (Radau for a "
                   "stiff start; the summary says which it chose and why)")
    _add_steps(p)
    p.add_argument("--plot", metavar="FILE.png", help="plot the signals (PNG, SVG or PDF by the extension)")
    p.add_argument("--csv", metavar="FILE", help="write the samples of the signals as CSV (time, mode, signals)")
    p.add_argument("--npz", metavar="FILE", help="write the run as numpy arrays (t, x, modes, signals, instants)")
    p.add_argument("--signals", help="comma-separated signals to plot and save (default: the model's; the plot "
                   "draws the first six of them)")
    p.add_argument("--samples", type=int, default=500, metavar="N",
                   help="sample the run at this many equally spaced times from 0 to t_end, plus the two rows "
                        "(before, after) of every instant: simulate(..., samples=N) (default 500, at least 2; "
                        "0: every step and every instant, Python's default output='steps'); the plot draws "
                        "them all, the data files the N times (a time on an instant: the state after it)")
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


def _add_sweep(sub) -> None:
    """``hbg sweep``: its arguments and options."""
    p = sub.add_parser("sweep", help="one run per point of a parameter grid, on Dask: a CSV row per run, a plot")
    p.add_argument("model", help=_MODEL_HELP)
    p.add_argument("--grid", action="append", required=True, metavar="NAME=START:STOP:COUNT|NAME=V1,V2,...",
                   help="a parameter's values (repeatable; the grid is every combination, the first varying slowest)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="a parameter fixed for every run (repeatable)")
    p.add_argument("--t-end", type=float, dest="t_end", metavar="T", help="end time of every run in s (default: "
                   "the model's)")
    p.add_argument("--method", help="integration method of every run (default: the model's, else RK45)")
    _add_steps(p)
    group = p.add_mutually_exclusive_group()
    group.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler (tcp://host:8786)")
    group.add_argument("--workers", type=int, help="size of the local Dask cluster (default: all cores)")
    p.add_argument("--csv", required=True, metavar="FILE", help="one row per run: parameters, status, events, "
                   "final state, metrics")
    p.add_argument("--plot", metavar="FILE.png", help="the first --metric over the grid (line or heat map)")
    p.add_argument("--on-zeno", choices=("raise", "stop"), default="raise",
                   help="a Zeno run fails (raise, default) or ends at the accumulation point (stop)")
    p.add_argument("--metric", action="append", metavar="NAME",
                   help="a column (events, first_event, t_final, wall_time, final_STATE) or KIND:SIGNAL with KIND "
                        "final, min or max, computed in the workers (repeatable; the first is plotted; "
                        "default: events)")
    p.set_defaults(run=_cmd_sweep)


def _add_orbit(sub) -> None:
    """``hbg orbit``: its arguments and options."""
    p = sub.add_parser("orbit", help="a periodic orbit by Newton shooting (period, start, Floquet multipliers, "
                       "stability), or its continuation in one parameter with period doublings and folds")
    p.add_argument("model", help=_MODEL_HELP)
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
    p.add_argument("--signal", metavar="NAME", help="the state or signal plotted (default: every state; with "
                   "--continue the first state)")
    p.add_argument("--csv", metavar="FILE", help="write the orbit over one period (time, mode, states), or with "
                   "--continue the table, as CSV")
    p.add_argument("--plot", metavar="FILE.png", help="plot the orbit over one period, or with --continue the "
                   "bifurcation diagram (min and max over a period; stable solid, unstable dashed)")
    p.set_defaults(run=_cmd_orbit)


def build_parser() -> argparse.ArgumentParser:
    from bondgraph import __version__

    parser = _Parser(prog="hbg", description="Hybrid bond graph toolkit: simulate, inspect, draw and save "
                     "switching physical systems modelled as hybrid bond graphs")
    parser.add_argument("--version", action="version", version=f"hbg {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    sub.add_parser("list", help="shipped models with their parameters").set_defaults(run=_cmd_list)

    _add_run(sub)

    p = sub.add_parser("modes", help="derived equations of the modes a run visits")
    p.add_argument("model", help=_MODEL_HELP)
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help=_SET_HELP)
    p.add_argument("--mode", help="one mode, as outputs show it ('contact=free, friction=stuck'; automata not named "
                   "keep their initial state) or its states joined by | ('free|stuck')")
    p.add_argument("--latex", action="store_true", help="print the equations as LaTeX")
    p.add_argument("--state-space", action="store_true",
                   help="print the A, B, C, D matrices of each (linear) mode instead (inputs: the sources' values)")
    _add_exploration(p)
    p.set_defaults(run=_cmd_modes)

    p = sub.add_parser("verify", help="static divergence-of-time check")
    p.add_argument("model", help=_MODEL_HELP)
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help=_SET_HELP)
    p.add_argument("--samples", type=int, default=10, help="sampled states per mode (at least 1)")
    p.set_defaults(run=_cmd_verify)

    p = sub.add_parser("codegen", help="export the generated per-mode functions")
    p.add_argument("model", help=_MODEL_HELP)
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help=_SET_HELP)
    p.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="the folder the module is written to (created if missing)")
    _add_exploration(p)
    p.set_defaults(run=_cmd_codegen)

    p = sub.add_parser("save", help="write a model to a model file (TOML)")
    p.add_argument("model", help=_MODEL_HELP)
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help=_SET_HELP)
    p.add_argument("-o", "--output", required=True, metavar="FILE.toml", help="the model file written")
    p.set_defaults(run=_cmd_save)

    p = sub.add_parser("draw", help="draw the bond graph of a mode as textbooks do: half-arrows, causal strokes, "
                                    "controlled junctions boxed and shown on/off (PNG, SVG, PDF by the extension)")
    p.add_argument("model", help=_MODEL_HELP)
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help=_SET_HELP)
    p.add_argument("--mode", metavar="MODE", help="the mode drawn, as outputs show it ('contact=free, friction=stuck') "
                   "or its states joined by | (default: the initial mode)")
    p.add_argument("--no-legend", action="store_true", dest="no_legend", help="leave out the line explaining the marks")
    p.add_argument("-o", "--output", required=True, metavar="FILE.png|FILE.svg",
                   help="the picture; its extension picks the format (png, svg, pdf, ...)")
    p.set_defaults(run=_cmd_draw)

    _add_sweep(sub)
    _add_orbit(sub)

    sub.add_parser("graphs", help="list the shipped plain bond graphs").set_defaults(run=_cmd_graphs)
    p = sub.add_parser("equations", help="equations of a shipped plain bond graph")
    p.add_argument("name", help="a shipped plain bond graph (hbg graphs shows them)")
    p.add_argument("--off", action="append", default=[], metavar="JUNCTION",
                   help="switch this controlled junction off (repeatable; the others are on)")
    p.add_argument("--n", type=int, default=None, help="the size of a graph that has one (a chain's length)")
    p.add_argument("--signals", action="store_true", help="also print the bond variables' expressions")
    p.add_argument("--latex", action="store_true", help="print the equations as LaTeX")
    p.set_defaults(run=_cmd_equations)
    return parser


def _failed_run(exc) -> bool:
    from switching.errors import (ContinuationError, DivergenceOfTimeError, OrbitArgumentError, OrbitError,
                                  SimulationError)

    # an OrbitError itself, an OrbitArgumentError (or a ContinuationError) is a request refused (a section that
    # names no transition); the others are searches that failed (Newton out of iterations, no orbit, grazing)
    return (isinstance(exc, (SimulationError, DivergenceOfTimeError, OrbitError))
            and not isinstance(exc, OrbitArgumentError) and type(exc) not in (OrbitError, ContinuationError))


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning as the command line says it: ``hbg: warning: <kind>: <message>``, with no line of
    the toolkit's source (the user did not write it)."""
    print(f"hbg: warning: {category.__name__}: {message}", file=file or sys.stderr)


class _ClosedPipeGuard:
    """``sys.stdout`` while a command runs: a reader that closes the pipe (``hbg run … | head``) ends the
    printing quietly — what is printed after goes nowhere — and the command goes on to write its files."""

    def __init__(self, stream):
        self.stream = stream
        self.closed_pipe = False

    def write(self, text: str) -> int:
        if not self.closed_pipe:
            try:
                return self.stream.write(text)
            except BrokenPipeError:
                self._close()
        return len(text)

    def flush(self) -> None:
        if not self.closed_pipe:
            try:
                self.stream.flush()
            except BrokenPipeError:
                self._close()

    def _close(self) -> None:
        self.closed_pipe = True
        try:  # (Python flushes stdout at exit: onto /dev/null, not into the closed pipe)
            os.dup2(os.open(os.devnull, os.O_WRONLY), self.stream.fileno())
        except (OSError, ValueError):
            pass

    def __getattr__(self, name):
        return getattr(self.stream, name)


def main(argv=None) -> int:
    """Run ``hbg`` with ``argv`` (default: the command line); return the exit status."""
    shown = warnings.showwarning
    warnings.showwarning = _show_warning
    stdout = sys.stdout
    sys.stdout = _ClosedPipeGuard(stdout)
    try:
        return _main(argv)
    finally:
        sys.stdout.flush()
        sys.stdout = stdout
        warnings.showwarning = shown


def _main(argv) -> int:
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        return args.run(args)
    except _UsageError as exc:
        print(f"hbg: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("hbg: interrupted (Ctrl-C)", file=sys.stderr)
        return EXIT_INTERRUPTED
    except HybridBondGraphError as exc:  # the whole message: loops, carets and hints span lines
        print(f"hbg: error: {exc}", file=sys.stderr)
        return EXIT_FAILED if _failed_run(exc) else EXIT_USAGE
    except OSError as exc:
        print(f"hbg: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except Exception as exc:  # noqa: BLE001 - never a raw traceback
        if os.environ.get("HBG_TRACEBACK", "") not in ("", "0"):
            raise
        print(f"hbg: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        print("hbg: this is a bug; set HBG_TRACEBACK=1 to see where it happened", file=sys.stderr)
        return EXIT_FAILED


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
