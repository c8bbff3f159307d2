"""``hbg fmu``: a model packaged as an FMI 2.0 co-simulation FMU (:mod:`switching.files.fmu`)."""

from __future__ import annotations

from .common import MODEL_HELP, SET_HELP, UsageError, add_steps, build_model, run_settings, summary_of
from .outputs import check_outputs


def add_fmu(sub) -> None:
    """``hbg fmu``: its arguments and options."""
    p = sub.add_parser("fmu", help="package a model as an FMI 2.0 co-simulation FMU: its parameters, inputs, states, "
                       "signals and automata as variables; it runs this toolkit in the Python that loads it "
                       "(needs pythonfmu: pip install 'hybrid-bondgraph[fmu]')")
    p.add_argument("model", help=MODEL_HELP)
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help=SET_HELP + "; the FMU's start value")
    p.add_argument("-o", "--output", required=True, metavar="FILE.fmu", help="the FMU written")
    p.add_argument("--method", help="the integration method of every step, fixed in the FMU (default: the model's, "
                   "else RK45; not auto)")
    add_steps(p)
    p.add_argument("--t-end", type=float, dest="t_end", metavar="T",
                   help="the FMU's default stop time in s (default: the model's run)")
    p.set_defaults(run=cmd_fmu)


def cmd_fmu(args) -> int:
    """``hbg fmu``: write the model (with its --set values) as an FMU run with the method and tolerances given."""
    from switching.errors import OptionError
    from switching.files.fmu import export_settings, fmu_variables, to_fmu

    check_outputs((("-o/--output", args.output, "data"),))
    if not args.output.lower().endswith(".fmu"):
        raise UsageError(f"-o/--output {args.output}: an FMU's file name ends in .fmu")
    module, model = build_model(args)
    t_end, method, options = run_settings(args, module, default_method="RK45")
    if method == "auto":
        raise UsageError("an FMU runs one method in every step: give --method (RK45, Radau, rk4 --dt ..., ...), "
                         "not auto")
    try:
        settings = export_settings(model, method, **options)
        to_fmu(model, args.output, method=method, t_end=t_end, description=summary_of(module) or None, **options)
    except OptionError as exc:
        raise UsageError(str(exc)) from None
    count = {}
    for v in fmu_variables(model):
        count[v.causality] = count.get(v.causality, 0) + 1
    steps = ", ".join(f"{k} {v:g}" for k, v in settings.items() if k != "method")
    print(f"wrote {args.output} (FMI 2.0 co-simulation FMU of {model.name}: {count.get('parameter', 0)} parameters, "
          f"{count.get('input', 0)} inputs, {count.get('output', 0)} outputs; {method}, {steps}; default stop time "
          f"{t_end:g} s)")
    return 0
