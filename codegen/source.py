"""Readable Python source from sympy expressions.

A :class:`FunctionSpec` names a function, its array arguments (each an
ordered list of symbols) and its outputs; :func:`function_source` prints it
with repeated subexpressions computed once (:func:`common_subexpressions`), every used array entry unpacked into a
sanitized local name, a docstring listing the order of every array, and the
outputs written in place into ``out`` (or returned as a list for *raw*
functions, which run on :class:`codegen.runtime.Hyper` values).

Only sanitized identifiers reach the source: symbol names such as
``rod/theta`` become ``rod_theta``.

Lambert's W (the inverse of an exponential law in a loop) is printed
through the Wright omega function: :func:`codegen.lambert.omega_form`
rewrites it before printing, and generated code calls ``wrightomega``
(:func:`codegen.omega.wrightomega`, in every namespace and dialect).
The numeric inverse of a law sympy cannot invert is a call of a helper that
the function's source defines after it (:mod:`codegen.inverse`).
"""

from __future__ import annotations

import builtins
import itertools
import keyword
import math
import re
from dataclasses import dataclass

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from .errors import UnprintableExpressionError

__all__ = ["Argument", "FunctionSpec", "UnprintableExpressionError", "PrintMemo", "common_subexpressions",
           "composed_source", "docstring", "escaped", "function_source", "inverse_helpers", "sanitize",
           "module_namespace"]




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
    brief: bool = False  # a one-line docstring, without the lists of argument and output entries
    #: ``False``: the docstring states the arrays' shapes (``x[2000]: state vector``) and ``output_doc``, not
    #: every entry (a scene's mode functions: a list of every state in every function of every mode)
    entries: bool = True
    output_doc: str = ""
    #: an array argument whose entries most outputs equal (a jump leaves most states as they are):
    #: from COPY_MIN such outputs on, one slice copy ``out[:] = <it>`` writes them all
    copy_of: str = ""
    #: with ``copy_of``: the indices of the outputs that may differ from their entry, the others known to be
    #: that entry itself (not looked at: a scene's jump moves two of its two thousand states); ``None``:
    #: every output is compared
    differs: tuple | None = None
    #: the numeric inverses the outputs call (:mod:`codegen.inverse`) defined after the function (Python
    #: modules); ``False`` for a caller that defines them itself (machine-code modules)
    helpers: bool = True


#: outputs equal to their entry of :attr:`FunctionSpec.copy_of` written by one slice copy from this many on
COPY_MIN = 16


#: names a sanitized symbol never takes (``_`` appended): keywords, builtins, the math functions and the
#: names of the generated module's own namespace (``out``, ``H``, ``np``, ...)
_RESERVED = set(keyword.kwlist) | set(dir(builtins)) | {"out", "H", "np", "math", "inf", "nan", "pi", "e", "tau",
                                                         "carray", "wrightomega"}
#: the arrays, selectors and loop variables of the compiled per-mode functions the callers generate
_RESERVED |= {"x", "t", "p", "u", "y", "xp", "xq", "xdot", "d", "s", "post", "target", "g", "q", "k"}
_RESERVED |= {name for name in dir(math) if not name.startswith("_")}


def sanitize(name: str) -> str:
    """An ASCII Python identifier for a symbol name (``rod/theta`` → ``rod_theta``).

    It never starts with ``_`` (every name the code generator invents does:
    temporaries ``_c<k>``, helpers ``_dec``, blocks ``_sides_<hash>``, so no
    user name can take one of them; a name starting with ``_`` or a digit gets
    a ``v`` in front) and is never a keyword, a builtin or a name of the
    generated module's namespace (``_`` appended).  Distinct names may meet
    (``a/b`` and ``a_b``): callers keep locals unique."""
    ident = re.sub(r"[^0-9A-Za-z_]", "_", name)
    if not ident or not ident[0].isalpha():
        ident = "v" + ident
    if ident in _RESERVED:
        ident += "_"
    return ident


class _Printer(PythonCodePrinter):
    """Prints known functions as bare names (numeric namespace) or ``H.name`` (raw)."""

    def __init__(self, raw: bool, names: dict, temporaries: dict | None = None):
        # order="none": terms in sympy's own (deterministic) argument order; sorting them for
        # print costs more than everything else in a large mode's code generation
        super().__init__({"fully_qualified_modules": False, "standard": "python3", "order": "none"})
        self._raw = raw
        self._names = names
        self._temporaries = temporaries or {}
        self._defining = None
        #: the temporaries assigned so far (the printer also meets nodes it builds itself, a
        #: fraction's numerator, which may equal a temporary not yet assigned)
        self.available = set(self._temporaries)
        #: the names of the temporaries the last text printed uses
        self.used: set = set()

    def _temporary(self, expr):
        if not self._temporaries or not isinstance(expr, sp.Basic) or expr == self._defining:
            return None
        name = self._temporaries.get(expr)
        if name is None or expr not in self.available:
            return None
        self.used.add(name)
        return name

    def _print(self, expr, **kwargs):
        name = self._temporary(expr)
        return name if name is not None else super()._print(expr, **kwargs)

    def parenthesize(self, item, level, strict=False):
        name = self._temporary(item)
        return name if name is not None else super().parenthesize(item, level, strict)  # a name: no parentheses

    def definition(self, expr) -> str:
        """``expr`` printed as the value of its own temporary (its repeated parts by theirs)."""
        self._defining = expr
        try:
            return self.doprint(expr)
        finally:
            self._defining = None

    def _handle_UnevaluatedExpr(self, expr):  # none are generated: skip the whole-tree replace per output
        return expr

    def _module_format(self, fqn, register=True):
        leaf = fqn.split(".")[-1]
        return f"H.{leaf}" if self._raw else leaf

    def _print_not_supported(self, expr):
        from sympy.core.function import AppliedUndef

        if isinstance(expr, AppliedUndef):
            why = (f"{expr.func} is a function sympy knows only by name: write it with sympy's functions "
                   "(sp.exp, sp.Piecewise, ...)")
        else:
            name = getattr(expr, "func", type(expr)).__name__
            why = (f"the code generator cannot compute {name} numerically (it may come from inverting a law: "
                   "give the law in the causality the graph needs, effort_law= or flow_law=, or a law whose "
                   "inverse sympy writes with elementary functions)")
        raise UnprintableExpressionError(f"the expression {expr} has no numerical definition: {why}")

    def _print_Symbol(self, expr):
        return self._names.get(expr, super()._print_Symbol(expr))

    def _print_Infinity(self, expr):
        return "H.inf" if self._raw else "inf"

    def _print_NegativeInfinity(self, expr):
        return "-H.inf" if self._raw else "-inf"

    def _print_Heaviside(self, expr):
        """``Heaviside(x, h0)``: 1 for ``x > 0``, 0 for ``x < 0``, ``h0`` at 0 and NaN for NaN, as
        conditional expressions (as ``sign`` and ``Piecewise`` print: plain Python, numba and the
        native backend alike; on ``Hyper`` values a pulse's sign decides)."""
        argument, at_zero = expr.args
        x = self.parenthesize(argument, 0)
        if at_zero == 1:
            return f"(1.0 if {x} >= 0 else (0.0 if {x} < 0 else nan))"
        h0 = self._print(sp.Float(float(at_zero)) if at_zero.is_Number else at_zero)
        return f"(1.0 if {x} > 0 else (0.0 if {x} < 0 else ({h0} if {x} == 0 else nan)))"


def _is_cheap(expr) -> bool:
    """A node not worth a temporary: ``1/a`` and ``-a`` of an atom (``b/a``
    stays one correctly rounded division instead of ``b*(1/a)``)."""
    if expr.is_Pow:
        return expr.base.is_Atom and expr.exp == -1
    if expr.is_Mul and len(expr.args) == 2:
        return expr.args[0] == -1 and expr.args[1].is_Atom
    return False


def common_subexpressions(outputs: list, symbols: set | None = None, kinds: set | None = None) -> list:
    """The subtrees met more than once in ``outputs``, each after the
    subtrees it contains (the order temporaries must be assigned in).

    Only whole repeated subtrees count, found by one walk of the expression
    DAG (a subtree seen again is not walked again): the bond graph's
    expressions share whole subtrees (an effort met on several bonds).
    Unlike ``sympy.cse`` nothing is rebuilt — the printer substitutes the
    temporaries — so an expression is printed exactly as derived, and the
    cost stays linear in the size of the DAG.  ``symbols``, a set, receives
    every symbol met (the free symbols of the outputs, from the same walk);
    ``kinds``, a set, the class of every other node met (``sp.LambertW``...)."""
    seen, repeated, finished = set(), set(), []
    stack = [(expr, False) for expr in reversed(outputs)]
    while stack:  # depth first, arguments in order; a subtree is walked once, when first met
        expr, walked = stack.pop()
        if walked:
            finished.append(expr)
            continue
        if not isinstance(expr, sp.Basic) or expr.is_Atom:
            if symbols is not None and isinstance(expr, sp.Symbol):
                symbols.add(expr)
            continue
        if expr in seen:
            if not _is_cheap(expr):
                repeated.add(expr)
            continue
        seen.add(expr)
        if kinds is not None:
            kinds.add(type(expr))
        stack.append((expr, True))
        stack.extend((arg, False) for arg in reversed(expr.args))
    # post-order: a temporary after those it uses
    ordered = [expr for expr in finished if expr in repeated] if repeated else []
    return ordered


def _outer_temporaries(expr, temporaries: dict, skip=None) -> frozenset:
    """The temporaries met in ``expr`` (other than ``skip``) before any
    other: the printer writes their names and never looks inside them."""
    found = []
    stack = [expr]
    while stack:
        node = stack.pop()
        if node.is_Atom:
            continue
        if node in temporaries and node is not skip:
            found.append(node)
            continue
        stack.extend(node.args)
    return frozenset(found)


class PrintMemo:
    """Printed text of expressions, shared by the functions of one model
    (its modes repeat most expressions: a gap between two balls reads the
    same in every mode).

    The text of an expression depends only on it, on the names of the
    symbols (the same for every function of one argument list), on the raw
    flag, and on which of its subtrees are temporaries (printed as their
    names).  So that the last repeats too, a temporary is named after its
    expression, model-wide (``_c17`` is the same subtree in every mode's
    functions); text is memoized per argument list and set of temporaries."""

    def __init__(self):
        self._tables: dict = {}
        self._names: dict = {}
        #: (id of an arguments tuple, raw) → (the tuple, its table): a scene's modes hand the same tuple,
        #: whose key (every state's symbol) costs a hash of a thousand symbols
        self._by_arguments: dict = {}
        self.hits = self.misses = 0

    def table(self, spec: "FunctionSpec") -> dict:
        found = self._by_arguments.get((id(spec.arguments), spec.raw))
        if found is not None and found[0] is spec.arguments:
            return found[1]
        key = (spec.raw, tuple((a.name, a.symbols) for a in spec.arguments))
        table = self._tables.setdefault(key, {})
        self._by_arguments[(id(spec.arguments), spec.raw)] = (spec.arguments, table)  # (held: the id stays its)
        return table

    def temporary(self, expr) -> str:
        """The model-wide name of the temporary holding ``expr``."""
        name = self._names.get(expr)
        if name is None:
            name = self._names[expr] = f"_c{len(self._names)}"
        return name


def _local_names(arguments) -> dict:
    """Symbol → the local name it is unpacked into (sanitized, unique)."""
    names: dict[sp.Symbol, str] = {}
    used_names = {a.name for a in arguments} | {"out"}
    for arg in arguments:
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
    return names


def _argument_doc(arguments) -> list:
    """The docstring lines listing every argument array's entries."""
    doc = []
    for arg in arguments:
        if arg.scalar:
            doc.append(f"{arg.name}: {arg.doc or arg.symbols[0]}")
        else:
            doc.append(f"{arg.name}[{len(arg.symbols)}]: {arg.doc}")
            doc.extend(f"    {arg.name}[{k}] = {s}" for k, s in enumerate(arg.symbols))
    return doc


def _def_line(spec: FunctionSpec) -> str:
    signature = ", ".join(a.name for a in spec.arguments) + ("" if spec.raw else ", out")
    return f"def {spec.name}({signature}):"


def escaped(text: str) -> str:
    """``text`` as the inside of a ``"``-quoted Python string literal that
    reads back as ``text``: backslashes, double quotes and every character that
    is not printable (newlines, ``\\r``, NUL, line separators, bidirectional
    controls) escaped, so that no text can end the literal early or start a
    new line of code.  Printable non-ASCII characters (``µ``, ``θ``) stay."""
    if text.isprintable() and "\\" not in text and '"' not in text:
        return text
    parts = []
    for char in text:
        if char == "\\" or char == '"':
            parts.append("\\" + char)
        elif char.isprintable():
            parts.append(char)
        else:
            code = ord(char)
            parts.append(f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}" if code < 0x10000
                         else f"\\U{code:08x}")
    return "".join(parts)


def docstring(lines, indent: str = "    ") -> str:
    """A triple-quoted docstring literal of ``lines`` (a str or its lines),
    indented by ``indent``, each line passed through :func:`escaped`: user text
    (names, labels, descriptions) is shown as given and cannot end it early."""
    lines = lines.split("\n") if isinstance(lines, str) else list(lines)
    body = ("\n" + indent).join(escaped(line) for line in lines)
    return f'{indent}"""{body}\n{indent}"""' if len(lines) > 1 else f'{indent}"""{body}"""'


def _docstring(spec: FunctionSpec, n_outputs: int, argument_doc: str) -> list:
    """The docstring lines of ``spec``: its doc, then (unless brief) every argument and output entry:
    :func:`docstring` of those lines, ``argument_doc`` being the argument lines already passed through
    it (:func:`_escaped_lines`: the same for every function of an argument list, a state vector of a
    thousand entries in a large scene) and each output line escaped after its index."""
    if spec.brief:
        return [docstring([spec.doc.strip() or spec.name])]
    parts = [escaped(line) for line in (spec.doc.strip() or spec.name).split("\n")]
    parts.append("")
    if not spec.entries:
        parts += [escaped(f"{a.name}: {a.doc or a.symbols[0]}" if a.scalar else f"{a.name}[{len(a.symbols)}]: {a.doc}")
                  for a in spec.arguments]
        parts.append(escaped(("returns" if spec.raw else "out") + f"[{n_outputs}]: {spec.output_doc}".rstrip()))
        body = "\n    ".join(parts)
        return [f'    """{body}\n    """']
    if argument_doc:
        parts.append(argument_doc)
    parts.append(("returns" if spec.raw else "out") + f"[{n_outputs}]:")
    if spec.output_names:  # (an index and " = " need no escape)
        parts.extend(map("    [{}] = {}".format, itertools.count(), map(escaped, map(format, spec.output_names))))
    else:
        parts.extend(f"    [{k}] = {k}" for k in range(n_outputs))
    body = "\n    ".join(parts)
    return [f'    """{body}\n    """']


def _escaped_lines(lines: list) -> str:
    """``lines`` as in the body of an indented :func:`docstring`: each escaped, joined by a newline and the indent."""
    return "\n    ".join(escaped(line) for line in lines)


def _names_and_doc(spec: FunctionSpec, memo: PrintMemo | None):
    """The local names of the argument entries and the docstring text listing them (memoized per argument list)."""
    table = memo.table(spec) if memo is not None else None
    if table is None:
        return None, _local_names(spec.arguments), _escaped_lines(_argument_doc(spec.arguments))
    if "names" not in table:  # (expressions are keyed by tuples: no clash)
        table["names"], table["doc"] = _local_names(spec.arguments), _escaped_lines(_argument_doc(spec.arguments))
    return table, table["names"], table["doc"]


def _positions(arguments, table: dict | None) -> list:
    """Per argument: symbol → its indices in the argument (kept in the print memo's ``table``)."""
    found = table.get("positions") if table is not None else None
    if found is None:
        found = []
        for arg in arguments:
            where: dict = {}
            for k, sym in enumerate(arg.symbols):
                where.setdefault(sym, []).append(k)
            found.append(where)
        if table is not None:
            table["positions"] = found
    return found


def composed_source(spec: FunctionSpec, blocks: list, memo: PrintMemo | None = None) -> str:
    """The source of function ``spec`` (its outputs are not printed) made of
    calls of the block functions ``blocks`` — ``(name, number of outputs)``
    in order, each printed by :func:`function_source` with the arguments of
    ``spec``: each writes its outputs into its slice of ``out`` (a view: ``out``
    must be a numpy array), or, for a raw ``spec``, returns their list (the
    lists are concatenated)."""
    _, _, argument_doc = _names_and_doc(spec, memo)
    lines = [_def_line(spec), *_docstring(spec, sum(n for _, n in blocks), argument_doc)]
    call = ", ".join(a.name for a in spec.arguments)
    if spec.raw:
        lines.append("    return " + (" + ".join(f"{name}({call})" for name, _ in blocks) or "[]"))
        return "\n".join(lines) + "\n"
    start = 0
    for name, count in blocks:
        lines.append(f"    {name}({call}, out[{start}:{start + count}])")
        start += count
    lines.append("    return out")
    return "\n".join(lines) + "\n"


def function_source(spec: FunctionSpec, memo: PrintMemo | None = None) -> str:
    """The source text of one function (see the module docstring); ``memo``
    (a :class:`PrintMemo`) reuses the text of expressions printed before for
    functions of the same arguments."""
    table, names, argument_doc = _names_and_doc(spec, memo)

    outputs = _outputs(spec)
    copied = _copied_outputs(spec, outputs)
    # (the outputs written one by one: where one slice copy writes the rest, only those that may differ)
    candidates = sorted(set(spec.differs)) if copied and spec.differs is not None else range(len(outputs))
    written = [k for k in candidates if k not in copied]
    needed, kinds = set(), set()
    shared = common_subexpressions([outputs[k] for k in written] if copied else outputs, needed, kinds)
    if sp.LambertW in kinds:  # written with the Wright omega function, which never overflows (codegen.lambert)
        from .lambert import omega_form

        outputs = omega_form(outputs)
        copied = _copied_outputs(spec, outputs)
        written = [k for k in range(len(outputs)) if k not in copied]
        needed = set()
        shared = common_subexpressions([outputs[k] for k in written] if copied else outputs, needed, kinds)
    if memo is None:
        temporaries = {expr: f"_c{k}" for k, expr in enumerate(shared)}
    else:
        temporaries = {expr: memo.temporary(expr) for expr in shared}
    printer = _Printer(spec.raw, names, temporaries)
    printer.available = set()

    lines = [_def_line(spec), *_docstring(spec, len(outputs), argument_doc)]
    positions = _positions(spec.arguments, table)
    for arg, where in zip(spec.arguments, positions):
        if arg.scalar:
            continue
        if len(needed) < len(arg.symbols) // 4:  # (a block of a scene's function reads a few of a thousand)
            found = sorted(k for sym in needed for k in where.get(sym, ()))
        else:
            found = [k for k, sym in enumerate(arg.symbols) if sym in needed]
        lines.extend(f"    {names[arg.symbols[k]]} = {arg.name}[{k}]" for k in found)

    def text(expr, definition=False):
        if table is None:
            return printer.definition(expr) if definition else printer.doprint(expr)
        if definition:
            key = (expr, True, _outer_temporaries(expr, temporaries, expr))
        else:
            key = (expr, False, _outer_temporaries(expr, temporaries) if temporaries else frozenset())
        printed = table.get(key)
        # text printed for another function is reused when every temporary it names is assigned here
        if printed is None or not printed[1] <= assigned:
            memo.misses += 1
            printer.used = set()
            words = printer.definition(expr) if definition else printer.doprint(expr)
            printed = table[key] = (words, frozenset(printer.used))
        else:
            memo.hits += 1
        return printed[0]

    assigned: set = set()
    for expr in shared:
        lines.append(f"    {temporaries[expr]} = {text(expr, definition=True)}")
        printer.available.add(expr)
        assigned.add(temporaries[expr])
    if spec.raw:
        lines.append("    return [" + ", ".join(text(e) for e in outputs) + "]")
    else:
        if copied:
            lines.append(f"    out[:] = {spec.copy_of}  # (the entries below differ from it)")
        for k in written:
            lines.append(f"    out[{k}] = {text(outputs[k])}")
        lines.append("    return out")
    source = "\n".join(lines) + "\n"
    if spec.helpers:
        from .inverse import inverse_laws

        for helper in inverse_helpers(inverse_laws(kinds)):
            source += "\n\n" + helper
    return source


def inverse_helpers(laws, compiled: bool = False) -> list:
    """The definitions of the numeric inverses of ``laws`` (classes of
    :class:`bondgraph.inverse.InverseLaw`, :mod:`codegen.inverse`) for a
    Python module, or (``compiled``) for a machine-code module."""
    from . import inverse

    texts = []
    for law in laws:
        def printed(variable, law=law):
            names = {law.variable: variable, **{s: f"a{k}" for k, s in enumerate(law.others)}}
            printer = _Printer(False, names)
            return printer.doprint(law.law), printer.doprint(law.slope)

        make = inverse.compiled_source if compiled else inverse.python_source
        texts.append(make(law, printed, docstring))
    return texts


def _outputs(spec: FunctionSpec) -> list:
    """The outputs of ``spec`` as sympy expressions (those :attr:`FunctionSpec.differs` leaves out are
    their entries: symbols already)."""
    if spec.differs is None:
        return [o if isinstance(o, sp.Basic) else sp.sympify(o) for o in spec.outputs]
    outputs = list(spec.outputs)
    for k in spec.differs:
        if not isinstance(outputs[k], sp.Basic):
            outputs[k] = sp.sympify(outputs[k])
    return outputs


def _copied_outputs(spec: FunctionSpec, outputs: list) -> frozenset:
    """The indices of the outputs one slice copy of ``spec.copy_of`` writes (none below :data:`COPY_MIN`)."""
    if not spec.copy_of or spec.raw:
        return frozenset()
    (argument,) = [a for a in spec.arguments if a.name == spec.copy_of]
    if len(argument.symbols) != len(outputs):
        return frozenset()
    if spec.differs is None:
        same = frozenset(k for k, (expr, sym) in enumerate(zip(outputs, argument.symbols))
                         if expr is sym or expr == sym)
    else:
        symbols = argument.symbols
        same = frozenset(range(len(outputs))).difference(
            k for k in spec.differs if not (outputs[k] is symbols[k] or outputs[k] == symbols[k]))
    return same if len(same) >= COPY_MIN else frozenset()


def module_namespace(vectorized: bool = False) -> dict:
    """The globals generated code runs in: ``math`` functions (or their numpy
    versions, so that whole arrays of samples pass at once), builtins, ``H``,
    and ``wrightomega`` (:func:`codegen.omega.wrightomega`; vectorized,
    scipy's ufunc of the same function)."""
    from .omega import wrightomega
    from .runtime import H

    namespace = {name: getattr(math, name) for name in dir(math) if not name.startswith("_")}
    namespace.update({"H": H, "abs": abs, "max": max, "min": min, "inf": math.inf, "wrightomega": wrightomega})
    if vectorized:
        import numpy as np

        for name in list(namespace):
            if name in ("H", "inf", "pi", "e", "tau", "nan"):
                continue
            if hasattr(np, name) and callable(getattr(np, name)):
                namespace[name] = getattr(np, name)
        from scipy.special import wrightomega as wrightomega_ufunc

        namespace.update({"abs": np.abs, "max": np.maximum, "min": np.minimum, "atan2": np.arctan2,
                          "copysign": np.copysign, "wrightomega": wrightomega_ufunc})
    return namespace
