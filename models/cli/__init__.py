"""The ``hbg`` command line.

    hbg list                                  shipped models, descriptions, parameters
    hbg run MODEL [--set name=value ...] [--t-end T] [--method M] [--dt DT | --rtol R]
                  [--plot FILE.png] [--csv FILE] [--npz FILE] [--signals a,b,...]
                  [--samples N] [--with-instants] [--no-keep-instants] [--on-zeno {raise,stop}]
                  [--no-stiffness-check] [--max-steps N] [--progress | --quiet]
                  [--measure SIGNAL:KIND,KIND ...] [--period T [--periods N] | --window FROM:TO]
    hbg modes MODEL [--mode LABEL] [--latex] [--state-space] [--t-end T]
                                              f, g, h and guards (or A, B, C, D) of the visited modes (or one)
    hbg verify MODEL [--samples N]            static divergence-of-time check
    hbg codegen MODEL -o DIR [--t-end T]      export the generated per-mode functions
    hbg draw MODEL [--mode LABEL] -o FILE.png|FILE.svg [--schematic FILE | --no-schematic]
                                              the bond graph of a mode, drawn as textbooks do; a model built
                                              from a netlist also its schematic (lumped diagram) in that mode
    hbg save MODEL [--set name=value ...] -o FILE.toml   the model as a model file
    hbg sweep MODEL --grid name=start:stop:count --grid name=v1,v2 [--set ...] [--method M] [--t-end T]
                  [--scheduler ADDRESS | --workers N] --csv FILE [--plot FILE.png] [--metric NAME ...]
                  [--period T [--periods N] | --window FROM:TO] [--on-zeno {raise,stop}]
                                              one run per grid point on Dask, a CSV row each, a plot
    hbg orbit MODEL [--set ...] (--period T | --section AUTOMATON:SOURCE->TARGET [--period GUESS])
                  [--continue NAME=START:STOP:COUNT] [--csv FILE] [--plot FILE.png] [--signal NAME,NAME]
                  [--samples N] [--measure SIGNAL:KIND,KIND ...]
                                              a periodic orbit (period, start, multipliers, stability), or
                                              its continuation in one parameter
    hbg fmu MODEL [--set ...] -o FILE.fmu [--method M] [--dt DT | --rtol R]   an FMI 2.0 co-simulation FMU
    hbg graphs | hbg equations NAME           plain bond graphs and their equations

Model names accept ``-`` or ``_`` (``falling-rod``).  Wherever a command
takes a MODEL it also takes the path of a model file (``hbg run my.toml``;
see :mod:`switching.files.modelfile`); ``--set`` then overrides the file's
parameters, and the file's ``[run]`` table gives the default run (a file
without a ``t_end`` runs for the time its time scales suggest, said on
stderr).  A SPICE netlist (``hbg run buck.cir``: :mod:`models.spice`) runs
for its ``.tran``.

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

The package: one module per command (:mod:`.run`, :mod:`.modes` — with ``verify`` and ``codegen`` —,
:mod:`.files` — ``list``, ``save``, ``graphs``, ``equations`` —, :mod:`.draw`, :mod:`.sweep`, :mod:`.orbit`),
what they share (:mod:`.common`: the model, ``--set``, the run's options; :mod:`.outputs`: the files) and
:mod:`.main` (the parser, ``main`` and the console script's ``command``).
"""

from __future__ import annotations

from .common import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE, UsageError
from .main import build_parser, command, main
from .modes import EXPLORATION_SECONDS
from .sweep import MAX_RUNS

__all__ = ["EXIT_FAILED", "EXIT_INTERRUPTED", "EXIT_OK", "EXIT_USAGE", "EXPLORATION_SECONDS", "MAX_RUNS", "UsageError",
           "build_parser", "command", "main"]
