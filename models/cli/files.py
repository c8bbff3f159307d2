"""``hbg list``, ``hbg save``, ``hbg graphs`` and ``hbg equations``."""

from __future__ import annotations

import inspect


from .. import MODELS, load
from ..graphs import GRAPHS
from .common import UsageError, build_model, summary_of
from .outputs import check_outputs


def cmd_list(args) -> int:
    for name in MODELS:
        module = load(name)
        print(f"{name.replace('_', '-')}: {summary_of(module)}")
        print("    " + ", ".join(f"{k}={v}" for k, v in module.DEFAULTS.items()))
    return 0


def cmd_save(args) -> int:
    """``hbg save``: write a model (with its --set values) and its default run to a model file."""
    check_outputs((("-o/--output", args.output, "data"),))
    module, model = build_model(args)
    run = dict(module.RUN)
    run["signals"] = list(module.SIGNALS)
    model.save(args.output, run=run, description=summary_of(module) or None)
    print(f"wrote {args.output} (model {model.name}: {len(model.graph.elements)} elements, "
          f"{len(model.automata)} automata, {len(model.parameter_symbols)} parameters)")
    return 0


def cmd_graphs(args) -> int:
    width = max(map(len, GRAPHS))
    for name, fn in GRAPHS.items():
        print(f"{name:<{width}}  {summary_of(fn)}")
    return 0


def cmd_equations(args) -> int:
    if args.name not in GRAPHS:
        raise UsageError(f"unknown graph {args.name!r}; choose one of: {', '.join(GRAPHS)}")
    builder = GRAPHS[args.name]
    kwargs = {}
    if args.n is not None:
        if "n" not in inspect.signature(builder).parameters:
            raise UsageError(f"graph {args.name!r} takes no size --n")
        if args.n < 1:
            raise UsageError("--n must be at least 1")
        kwargs["n"] = args.n
    graph = builder(**kwargs)
    eq = graph.equations({name: False for name in args.off})
    print(eq.latex() if args.latex else eq.pretty(signals=args.signals))
    return 0
