"""``hbg list``, ``hbg save``, ``hbg draw``, ``hbg graphs`` and ``hbg equations``."""

from __future__ import annotations

import inspect


from .. import MODELS, load
from ..graphs import GRAPHS
from .common import UsageError, build_model, summary_of
from .outputs import check_outputs, plot_target


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


def cmd_draw(args) -> int:
    """``hbg draw``: the bond graph of one mode as textbooks draw it (see
    :mod:`bondgraph.drawing`), written as PNG, SVG, PDF, … by the extension; each controlled junction
    marked with its automaton's state, the word the run shows (``closed``, ``engaged``), not on/off."""
    import matplotlib

    matplotlib.use("Agg")
    from bondgraph.drawing import draw_bond_graph, pyplot

    check_outputs((("-o/--output", args.output, "plot"),))
    _, model = build_model(args)
    mode = model.mode(args.mode) if args.mode else model.initial_mode
    described = mode.describe()
    if len(described) > 100:  # a model with many automata (ball-chain N=50): the label stays readable
        described = described[:97].rsplit(", ", 1)[0] + ", …"
    ax = draw_bond_graph(model.graph, model.configuration_of(mode), legend=not args.no_legend,
                         title=f"{model.name} in mode {described}",
                         words=model.mode_space.junction_words(mode))  # the junctions as the run says them
    try:
        ax.figure.savefig(args.output, dpi=110)
    finally:
        pyplot().close(ax.figure)
    print(f"wrote {plot_target(args.output)}")
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
