"""Readable Python source from sympy expressions.

A :class:`FunctionSpec` names a function, its array arguments (each an
ordered list of symbols) and its outputs; :func:`function_source` prints it
with common subexpressions eliminated, every used array entry unpacked into a
sanitized local name, a docstring listing the order of every array, and the
outputs written in place into ``out`` (or returned as a list for *raw*
functions, which run on :class:`codegen.runtime.Hyper` values).

Only sanitized identifiers reach the source: symbol names such as
``rod/theta`` become ``rod_theta``.
"""

from __future__ import annotations

import keyword
import math
import re
from dataclasses import dataclass

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter
from sympy.simplify.cse_main import tree_cse

__all__ = ["Argument", "FunctionSpec", "function_source", "sanitize", "module_namespace"]


@dataclass(frozen=True)
class Argument:
    """An argument: ``name`` and, for an array, the symbol of each entry (a
    scalar argument has exactly one symbol and ``scalar=True``)."""

    name: str
    symbols: tuple
    scalar: bool = False
    doc: str = ""


@dataclass(frozen=True)
class FunctionSpec:
    name: str
    arguments: tuple
    outputs: tuple
    doc: str = ""
    output_names: tuple = ()
    raw: bool = False  # outputs computed on Hyper values and returned as a list


_RESERVED = set(keyword.kwlist) | {"out", "H", "math", "abs", "max", "min", "pi", "e", "inf", "float", "range"}
_RESERVED |= {name for name in dir(math) if not name.startswith("_")}


def sanitize(name: str) -> str:
    """A Python identifier for a symbol name (``rod/theta`` → ``rod_theta``)."""
    ident = re.sub(r"\W", "_", name)
    if not ident or ident[0].isdigit():
        ident = "_" + ident
    if ident in _RESERVED:
        ident += "_"
    return ident


class _Printer(PythonCodePrinter):
    """Prints known functions as bare names (numeric namespace) or ``H.name`` (raw)."""

    def __init__(self, raw: bool, names: dict):
        # order="none": terms in sympy's own (deterministic) argument order; sorting them for
        # print costs more than everything else in a large mode's code generation
        super().__init__({"fully_qualified_modules": False, "standard": "python3", "order": "none"})
        self._raw = raw
        self._names = names

    def _handle_UnevaluatedExpr(self, expr):  # none are generated: skip the whole-tree replace per output
        return expr

    def _module_format(self, fqn, register=True):
        leaf = fqn.split(".")[-1]
        return f"H.{leaf}" if self._raw else leaf

    def _print_Symbol(self, expr):
        return self._names.get(expr, super()._print_Symbol(expr))

    def _print_Infinity(self, expr):
        return "H.inf" if self._raw else "inf"

    def _print_NegativeInfinity(self, expr):
        return "-H.inf" if self._raw else "-inf"


def _common_subexpressions(outputs: list, temporaries) -> tuple[list, list]:
    """``(replacements, reduced)`` as ``sympy.cse`` gives them, for repeated
    subtrees only: sympy's own ``tree_cse`` without the search for common
    arguments of sums and products (``opt_cse``) and in the expressions' own
    argument order.  The bond graph's expressions share whole subtrees (an
    effort met on several bonds), and that search costs more than the rest of
    a large mode's code generation while finding little more."""
    return tree_cse(outputs, temporaries, opt_subs={}, order="none")


def function_source(spec: FunctionSpec) -> str:
    """The source text of one function (see the module docstring)."""
    names: dict[sp.Symbol, str] = {}
    used_names = {a.name for a in spec.arguments} | {"out"}
    for arg in spec.arguments:
        if arg.scalar:
            names[arg.symbols[0]] = arg.name
            continue
        for sym in arg.symbols:
            if sym in names:
                continue
            ident = sanitize(sym.name)
            while ident in used_names:
                ident += "_"
            names[sym] = ident
            used_names.add(ident)

    outputs = [sp.sympify(o) for o in spec.outputs]
    temporaries = sp.numbered_symbols("_c")
    replacements, reduced = _common_subexpressions(outputs, temporaries) if outputs else ([], [])
    for sym, _ in replacements:
        names[sym] = sym.name
    printer = _Printer(spec.raw, names)

    needed = set()
    for expr in [e for _, e in replacements] + list(reduced):
        needed |= expr.free_symbols

    signature = ", ".join(a.name for a in spec.arguments) + ("" if spec.raw else ", out")
    lines = [f"def {spec.name}({signature}):"]
    doc = [spec.doc.strip() or spec.name, ""]
    for arg in spec.arguments:
        if arg.scalar:
            doc.append(f"{arg.name}: {arg.doc or arg.symbols[0]}")
        else:
            doc.append(f"{arg.name}[{len(arg.symbols)}]: {arg.doc}")
            doc.extend(f"    {arg.name}[{k}] = {s}" for k, s in enumerate(arg.symbols))
    out_labels = spec.output_names or tuple(str(k) for k in range(len(outputs)))
    doc.append(("returns" if spec.raw else "out") + f"[{len(outputs)}]:")
    doc.extend(f"    [{k}] = {label}" for k, label in enumerate(out_labels))
    lines.append('    """' + "\n    ".join(doc).replace('"""', "'''") + '\n    """')
    for arg in spec.arguments:
        if arg.scalar:
            continue
        for k, sym in enumerate(arg.symbols):
            if sym in needed:
                lines.append(f"    {names[sym]} = {arg.name}[{k}]")
    for sym, expr in replacements:
        lines.append(f"    {names[sym]} = {printer.doprint(expr)}")
    if spec.raw:
        lines.append("    return [" + ", ".join(printer.doprint(e) for e in reduced) + "]")
    else:
        for k, expr in enumerate(reduced):
            lines.append(f"    out[{k}] = {printer.doprint(expr)}")
        lines.append("    return out")
    return "\n".join(lines) + "\n"


def module_namespace(vectorized: bool = False) -> dict:
    """The globals generated code runs in: ``math`` functions (or their numpy
    versions, so that whole arrays of samples pass at once), builtins, ``H``."""
    from .runtime import H

    namespace = {name: getattr(math, name) for name in dir(math) if not name.startswith("_")}
    namespace.update({"H": H, "abs": abs, "max": max, "min": min, "inf": math.inf})
    if vectorized:
        import numpy as np

        for name in list(namespace):
            if name in ("H", "inf", "pi", "e", "tau", "nan"):
                continue
            if hasattr(np, name) and callable(getattr(np, name)):
                namespace[name] = getattr(np, name)
        namespace.update({"abs": np.abs, "max": np.maximum, "min": np.minimum, "atan2": np.arctan2,
                          "copysign": np.copysign})
    return namespace
