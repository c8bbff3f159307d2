"""Export of generated per-mode functions to one standalone module.

The module holds the run-time support (:mod:`codegen.runtime`: ``Hyper``,
``H``, ``decide``, with the rules of :mod:`codegen.decision` and the Wright
omega function of :mod:`codegen.omega`), the guard-tree evaluator, and for every exported mode its
functions (renamed ``m<k>_phi``, ``m<k>_rates``, …) and metadata; ``MODES``
maps each mode label to them.  ``STATES``, ``PARAMETERS`` (names, in the
order of the ``x`` and ``p`` arrays) and ``PARAMETER_VALUES`` complete it.
It imports only :mod:`math`.
"""

from __future__ import annotations

import inspect
import re
from pathlib import Path

from codegen.source import docstring, escaped

__all__ = ["export_module"]

_FUNCTIONS = ("phi", "rates", "sides", "sides_raw", "jump")


def export_module(model, path, modes="visited") -> list:
    from codegen import decision, omega, runtime

    from . import compiled

    if modes == "visited":
        selected = list(model.visited_modes)
    elif modes == "reachable":
        report = model.verify(samples=5)
        selected = list(dict.fromkeys([*report.explored, *report.kinds]))
    else:
        selected = [model.mode(m) for m in modes]
    if not selected:
        selected = [model.initial_mode]
    parts = [
        docstring([f"Generated functions of model {model.name!r}: {len(selected)} mode(s). Standalone: needs only "
                   "math.", "",
                   "Arrays: x = STATES, p = PARAMETERS (values in PARAMETER_VALUES), u = inputs.",
                   "MODES[label] gives 'meta' and the functions phi, rates, sides, sides_raw and (symbolic jumps) "
                   "jump."], ""),
        "",
        "import math",
        "from math import *",
        "",
        f"STATES = {[s.name for s in model.states]!r}",
        f"PARAMETERS = {[s.name for s in model.parameter_symbols]!r}",
        f"PARAMETER_VALUES = {[float(v) for v in model.parameter_array]!r}",
        f"INPUTS = {list(model.graph.inputs)!r}",
        "",
        "# ---- the guards' comparison (from codegen.decision)",
        _strip_module_header(inspect.getsource(decision)),
        "# ---- the Wright omega function (from codegen.omega)",
        _strip_module_header(inspect.getsource(omega)),
        "# ---- run-time support (from codegen.runtime)",
        re.sub(r"^from \.(decision|omega) import .*\n", "", _strip_module_header(inspect.getsource(runtime)),
               flags=re.M),
        "",
        "# ---- guard trees",
        inspect.getsource(compiled.decide_tree),
    ]
    table = []
    blocks: set = set()  # (the raw guard sides of a large mode come in blocks shared by modes: each written once)
    for k, mode in enumerate(selected):
        source = compiled.flat_sides(model.compiled_mode(mode).source)
        for name, chunk in compiled._function_chunks(source).items():
            if name.startswith("_sides_raw_") and name in blocks:
                source = source.replace(chunk[1], "")
            elif name.startswith("_sides_raw_"):
                blocks.add(name)
        source = re.sub(r"^META = ", f"META_{k} = ", source, flags=re.M)
        for name in _FUNCTIONS:
            source = re.sub(rf"^def {name}\(", f"def m{k}_{name}(", source, flags=re.M)
        parts += [f"# ---- mode {escaped(mode.describe())}", source]
        functions = ", ".join(
            f"{name!r}: m{k}_{name}" for name in _FUNCTIONS if f"def m{k}_{name}(" in source
        )
        table.append(f"    {mode.label!r}: {{'meta': META_{k}, {functions}}},")
    parts += ["", "MODES = {", *table, "}", ""]
    Path(path).write_text("\n".join(parts))
    return [m.label for m in selected]


def _strip_module_header(text: str) -> str:
    """A run-time module's source without its docstring and __all__ (the export has its own)."""
    text = re.sub(r'^""".*?"""\n', "", text, count=1, flags=re.S)
    return re.sub(r"^__all__ = .*\n", "", text, flags=re.M)
