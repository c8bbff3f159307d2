"""The parser of every command, and ``main``: the exit statuses, a closed stdout pipe, warnings."""

from __future__ import annotations

import argparse
import gc
import os
import sys
import warnings

from bondgraph import HybridBondGraphError

from .common import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_USAGE, MODEL_HELP, SET_HELP, UsageError
from .draw import add_draw
from .files import cmd_equations, cmd_graphs, cmd_list, cmd_save
from .fmu import add_fmu
from .modes import add_exploration, cmd_codegen, cmd_modes, cmd_verify
from .orbit import add_orbit
from .run import add_run
from .sweep import add_sweep


def _model_command(sub, name: str, **options):
    """The parser of command ``name`` that takes a MODEL and its ``--set`` values."""
    p = sub.add_parser(name, **options)
    p.add_argument("model", help=MODEL_HELP)
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help=SET_HELP)
    return p


class _Parser(argparse.ArgumentParser):
    """Errors are usage errors; an option is spelt out (``--max-step`` is not read as ``--max-steps``)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message):
        raise UsageError(message)


def build_parser() -> argparse.ArgumentParser:
    from bondgraph import __version__

    parser = _Parser(prog="hbg", description="Hybrid bond graph toolkit: simulate, inspect, draw and save "
                     "switching physical systems modelled as hybrid bond graphs")
    parser.add_argument("--version", action="version", version=f"hbg {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    sub.add_parser("list", help="shipped models with their parameters").set_defaults(run=cmd_list)

    add_run(sub)

    p = _model_command(sub, "modes", help="derived equations of the modes a run visits")
    p.add_argument("--mode", help="one mode, as outputs show it ('contact=free, friction=stuck'; automata not named "
                   "keep their initial state) or its states joined by | ('free|stuck')")
    p.add_argument("--latex", action="store_true", help="print the equations as LaTeX")
    p.add_argument("--state-space", action="store_true",
                   help="print the A, B, C, D matrices of each (linear) mode instead (inputs: the sources' values)")
    add_exploration(p)
    p.set_defaults(run=cmd_modes)

    p = _model_command(sub, "verify", help="static divergence-of-time check")
    p.add_argument("--samples", type=int, default=10, help="sampled states per mode (at least 1)")
    p.set_defaults(run=cmd_verify)

    p = _model_command(sub, "codegen", help="export the generated per-mode functions")
    p.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="the folder the module is written to (created if missing)")
    add_exploration(p)
    p.set_defaults(run=cmd_codegen)

    p = _model_command(sub, "save", help="write a model to a model file (TOML)")
    p.add_argument("-o", "--output", required=True, metavar="FILE.toml", help="the model file written")
    p.set_defaults(run=cmd_save)

    add_draw(sub)

    add_sweep(sub)
    add_orbit(sub)
    add_fmu(sub)

    sub.add_parser("graphs", help="list the shipped plain bond graphs").set_defaults(run=cmd_graphs)
    p = sub.add_parser("equations", help="equations of a shipped plain bond graph")
    p.add_argument("name", help="a shipped plain bond graph (hbg graphs shows them)")
    p.add_argument("--off", action="append", default=[], metavar="JUNCTION",
                   help="switch this controlled junction off (repeatable; the others are on)")
    p.add_argument("--n", type=int, default=None, help="the size of a graph that has one (a chain's length)")
    p.add_argument("--signals", action="store_true", help="also print the bond variables' expressions")
    p.add_argument("--latex", action="store_true", help="print the equations as LaTeX")
    p.set_defaults(run=cmd_equations)
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


def command() -> None:
    """The ``hbg`` command (its console script, ``python -m models.cli``): :func:`main` on the command
    line, then the process exits with its status.  The objects a run made (a model's derivations, numba's
    compiler) are frozen before the interpreter's exit, which then no longer walks them with the cyclic
    collector: its exit took ~0.3 s after a run of the falling rod, ~0.04 s so."""
    status = main()
    sys.stdout.flush()
    gc.freeze()
    sys.exit(status)


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
    except UsageError as exc:
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
