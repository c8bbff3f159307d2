"""The ``hbg`` command line.

    hbg graphs                              list the shipped bond graphs
    hbg equations NAME [--off J ...] [--signals] [--latex]
                                            derive and print a graph's equations

Bad input gets one clear line on stderr and exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import inspect
import sys

from bondgraph import HybridBondGraphError

from .graphs import GRAPHS


def _summary(fn) -> str:
    doc = inspect.getdoc(fn) or ""
    return doc.split("\n\n")[0].replace("\n", " ")


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
    config = {name: False for name in args.off}
    eq = graph.equations(config)
    print(eq.latex() if args.latex else eq.pretty(signals=args.signals))
    return 0


class _UsageError(Exception):
    pass


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="hbg", description="Hybrid bond graph toolkit")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("graphs", help="list the shipped bond graphs")
    p.set_defaults(run=_cmd_graphs)
    p = sub.add_parser("equations", help="derive and print the equations of a shipped bond graph")
    p.add_argument("name", help="graph name (see `hbg graphs`)")
    p.add_argument("--off", action="append", default=[], metavar="JUNCTION", help="switch a controlled junction off")
    p.add_argument("--n", type=int, default=None, help="size, for graphs built in a loop")
    p.add_argument("--signals", action="store_true", help="also print every bond's effort and flow")
    p.add_argument("--latex", action="store_true", help="print LaTeX instead of text")
    p.set_defaults(run=_cmd_equations)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except (_UsageError, HybridBondGraphError) as exc:
        print(f"hbg: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
