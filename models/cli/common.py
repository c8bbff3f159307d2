"""What every command shares: the model and its ``--set`` values, the run's options checked as usage
errors, the exit statuses and the usage error."""

from __future__ import annotations

import inspect
import math
import os
import re

from bondgraph import HybridBondGraphError
from bondgraph.errors import did_you_mean

from .. import MODELS, load


#: exit statuses (see the module docstring)
EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


class UsageError(Exception):
    pass


def summary_of(obj) -> str:
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


def model_module(name):
    """The shipped model's module, or for a path the :class:`switching.files.modelfile.ModelFile`
    (same interface), or for a SPICE netlist (``.cir``, ``.sp``, ``.net``, …) its
    :class:`models.spice.SpiceNetlist` (same interface); a bad file raises its ModelFileError (file,
    line, culprit) or SpiceNetlistError (line, card)."""
    from switching.files.modelfile import is_model_path

    from .. import resolve
    from ..spice import SUFFIXES

    if str(name).lower().endswith(SUFFIXES) or is_model_path(name) or (
            name.replace("-", "_") not in MODELS and os.path.isfile(name)):
        return resolve(name)
    try:
        return load(name)
    except HybridBondGraphError:
        raise UsageError(f"unknown model {name!r}; shipped models: {', '.join(m.replace('_', '-') for m in MODELS)} "
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


def finite_number(value: str, not_a_number: str, not_finite: str) -> float:
    """``value`` (text) as a finite float; a usage error ``not_a_number`` when it
    reads as no number, ``not_finite (why)`` when it is NaN or infinite."""
    try:
        number = float(value)
    except ValueError:
        raise UsageError(not_a_number) from None
    problem = _finite(value)
    if problem:
        raise UsageError(f"{not_finite} ({problem})")
    return number


def parse_sets(items, defaults, others: dict | None = None) -> dict:
    """``--set name=value`` items → parameter values (numbers checked finite).
    A name that is no parameter goes to ``others`` (name → number) when given
    (an initial state, checked once the model is built), else is a usage error."""
    values = {}
    for item in items:
        if "=" not in item:
            raise UsageError(f"--set expects name=value, got {item!r}")
        name, _, value = item.partition("=")
        name = name.strip()
        if name not in defaults and others is None:
            raise UsageError(f"unknown parameter {name!r}; parameters: {', '.join(defaults)}")
        if name in defaults and isinstance(defaults[name], (bool, str)):  # parsed and checked by the model
            values[name] = value.strip()
            continue
        what = "parameter" if name in defaults else "initial state"
        number = finite_number(value, f"{what} {name!r} needs a number, got {value!r}",
                               f"--set {name}={value.strip()}: {what} {name!r} must be a finite number, "
                               f"got {value.strip()!r}")
        (values if name in defaults else others)[name] = number
    return values


def initial_state(model, states: dict, defaults):
    """The run's ``x0``: the model's initial state as given, with the states
    named in ``states`` (name → value, from ``--set``) replaced; ``None`` when none is named."""
    if not states:
        return None
    unknown = [name for name in states if name not in model.state_names]
    if unknown:
        hint = did_you_mean(unknown[0], [*defaults, *model.state_names])
        raise UsageError(f"unknown parameter or state {unknown[0]!r}{hint}; "
                         f"parameters: {', '.join(defaults) or '(none)'}; states: {', '.join(model.state_names)}")
    x0 = model.given_initial_state
    for name, value in states.items():
        x0[model.state_names.index(name)] = value
    return x0


def build_model(args):
    module = model_module(args.model)
    return module, module.build(**parse_sets(getattr(args, "set", None) or [], module.DEFAULTS))


def check_positive(option: str, value: float) -> None:
    """A usage error unless ``value`` is finite and > 0, naming the option and the value."""
    if not (math.isfinite(value) and value > 0):
        raise UsageError(f"{option} must be a finite positive number, got {value!r}")


def run_settings(args, module, default_method: str = "RK45") -> tuple[float, str, dict]:
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
        raise UsageError(f"unknown method {method!r}; choose one of: {', '.join(METHODS)}, auto")
    check_positive("--t-end", t_end)
    atol, max_step = getattr(args, "atol", None), getattr(args, "max_step", None)
    for option, value in (("--dt", args.dt), ("--rtol", args.rtol), ("--atol", atol), ("--max-step", max_step)):
        if value is not None:
            check_positive(option, value)
    options = {}
    if METHOD_CLASSES[method].fixed_step:
        for option, value in (("--rtol", args.rtol), ("--atol", atol), ("--max-step", max_step)):
            if value is not None:
                raise UsageError(f"{option} is for adaptive methods; {method} is fixed-step: give --dt")
        if args.dt is None:
            raise UsageError(f"method {method} is fixed-step: give --dt")
        options["dt"] = args.dt
    else:
        if args.dt is not None:
            raise UsageError(f"--dt is for euler and rk4; {method} is adaptive: give --rtol")
        options.update({k: v for k, v in run.items() if k in ("rtol", "atol", "max_step")})
        for key, value in (("rtol", args.rtol), ("atol", atol), ("max_step", max_step)):
            if value is not None:
                options[key] = value
    return t_end, method, options


#: the command line's flag for an option of ``simulate``
_FLAGS = {"dt": "--dt", "rtol": "--rtol", "atol": "--atol", "max_step": "--max-step", "max_steps": "--max-steps",
          "t_end": "--t-end", "samples": "--samples", "x0": "--set"}


def check_run_options(model, t_end, method, options) -> None:
    """The checks ``simulate`` makes of its options, before anything runs
    (:func:`switching.simulate.run_options.check_run`), as usage errors naming the flag."""
    from switching.errors import OptionError
    from switching.simulate.run_options import check_run
    from switching.simulate.driver import option_defaults

    try:
        check_run(model, t_end, method, {**option_defaults(), **options})
    except OptionError as exc:
        flag = _FLAGS.get(exc.option)
        raise UsageError(f"{flag}: {exc}" if flag else str(exc)) from None


def check_samples(model, samples) -> None:
    """``--samples`` refused before anything runs when its rows would not fit
    (:func:`switching.simulate.run_options.check_output_size`)."""
    from switching.errors import OptionError
    from switching.simulate.run_options import check_output_size

    try:
        check_output_size(samples, len(model.states), "--samples")
    except OptionError as exc:
        raise UsageError(str(exc)) from None


#: what every command's MODEL argument may be
MODEL_HELP = ("a shipped model's name (hbg list shows them), the path of a model file (.toml) or of a SPICE netlist "
              "(.cir, .sp, .net: its .tran is the run)")


#: what --set may set
SET_HELP = "override a parameter (repeatable; hbg list shows each model's parameters)"


RUN_SET_HELP = ("override a parameter, or set the initial value of a state by its name (q_C=1e-3, rod/theta=0.5); "
                "repeatable")


def add_steps(p) -> None:
    """The step options of ``run`` and ``sweep``: ``--dt`` (fixed-step methods) or the tolerances."""
    group = p.add_mutually_exclusive_group()
    group.add_argument("--dt", type=float, help="step of euler / rk4")
    group.add_argument("--rtol", type=float, help="relative tolerance of adaptive methods")
    p.add_argument("--atol", type=float, help="absolute tolerance of adaptive methods, in the units of the states")
    p.add_argument("--max-step", type=float, dest="max_step", metavar="H",
                   help="the longest step an adaptive method may take, in s")
