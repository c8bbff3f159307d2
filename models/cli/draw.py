"""``hbg draw``: the bond graph of a mode as textbooks draw it and, for a model built from a netlist, its
circuit's schematic or its mechanism's lumped diagram in the same mode."""

from __future__ import annotations

import os

from .common import MODEL_HELP, SET_HELP, UsageError, build_model
from .outputs import check_outputs, plot_target

#: what the drawing of a netlist is called, by the netlist's kind
DIAGRAMS = {"circuit": "schematic", "mechanism": "lumped diagram"}


def add_draw(sub) -> None:
    """The parser of ``hbg draw``."""
    p = sub.add_parser("draw", help="draw the bond graph of a mode as textbooks do: half-arrows, causal strokes, "
                       "controlled junctions boxed and marked with their state as the mode names it (closed, "
                       "engaged, ...); for a model built from a netlist (a SPICE netlist, a circuit's or a "
                       "mechanism's model file) also its schematic or lumped diagram, switches drawn in the mode's "
                       "states (PNG, SVG, PDF by the extension)")
    p.add_argument("model", help=MODEL_HELP)
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help=SET_HELP)
    p.add_argument("--mode", metavar="MODE", help="the mode drawn, as outputs show it ('contact=free, friction=stuck') "
                   "or its states joined by | (default: the initial mode)")
    p.add_argument("--no-legend", action="store_true", dest="no_legend", help="leave out the line explaining the marks")
    p.add_argument("-o", "--output", required=True, metavar="FILE.png|FILE.svg",
                   help="the picture; its extension picks the format (png, svg, pdf, ...)")
    p.add_argument("--schematic", metavar="FILE", help="where the schematic (a mechanism's lumped diagram) of a model "
                   "built from a netlist goes (default: beside the picture, FILE-schematic.svg for -o FILE.svg)")
    p.add_argument("--no-schematic", action="store_true", dest="no_schematic",
                   help="draw the bond graph alone")
    p.set_defaults(run=cmd_draw)


def schematic_path(output: str) -> str:
    """The schematic's default file beside the picture ``output``: ``buck.svg`` → ``buck-schematic.svg``."""
    root, extension = os.path.splitext(plot_target(output))
    return f"{root}-schematic{extension}"


def cmd_draw(args) -> int:
    """``hbg draw``: the bond graph of one mode as textbooks draw it (see :mod:`bondgraph.drawing`), written as
    PNG, SVG, PDF, … by the extension; each controlled junction marked with its automaton's state, the word
    the run shows (``closed``, ``engaged``), not on/off.  A model built from a netlist (``model.built_from``)
    also gets its netlist's drawing in the same mode (:mod:`models.schematic`, :mod:`models.lumped_diagram`)
    at ``--schematic`` or beside the picture."""
    import matplotlib

    matplotlib.use("Agg")
    from bondgraph.drawing import draw_bond_graph, pyplot

    if args.schematic is not None and args.no_schematic:
        raise UsageError("--schematic and --no-schematic: give one of them")
    check_outputs((("-o/--output", args.output, "plot"),))
    _, model = build_model(args)
    built_from = getattr(model, "built_from", None)
    if args.schematic is not None and built_from is None:
        raise UsageError(f"--schematic: model {model.name!r} was not built from a circuit or a mechanism, so it has "
                         "no schematic; leave --schematic out")
    target = None
    if built_from is not None and not args.no_schematic:
        target = args.schematic or schematic_path(args.output)
        check_outputs((("-o/--output", args.output, "plot"), ("--schematic", target, "plot")))
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
    if target is not None:
        netlist = built_from.netlist
        netlist.draw(mode).save(plot_target(target))
        print(f"wrote {plot_target(target)} (the {DIAGRAMS.get(netlist.kind_word, 'drawing')} of {netlist.kind_word} "
              f"{netlist.name!r})")
    return 0
