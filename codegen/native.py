"""Machine code for generated per-mode functions without numba's front end.

A generated function of the kind this package's callers compile per mode of a
model is straight-line floating-point arithmetic in a few branches: numba spends
1–3 s typing and lowering one (its front end runs in Python, instruction by
instruction), while LLVM needs tens of milliseconds for the same code.  This
module translates such a source directly into LLVM IR and compiles it with
numba's own code generator (the same target machine, optimisation passes
and symbol resolution as the kernel that calls it), so a new mode costs
milliseconds instead of seconds.

The translated language is the subset of Python the generator writes:

* statements: ``name = expr``, ``array[index] = expr``, ``if``/``elif``/
  ``else``, ``for k in range(n)``, ``return expr``, ``pass``, docstrings;
* values: 64-bit floats, 64-bit integers and booleans; arrays as
  ``carray(pointer, (n,))`` views of the function's pointer arguments, read
  and written with a non-negative index, their length as ``a.shape[0]``;
* expressions: ``+ - * / % **``, comparisons (one operator), ``and``/``or``/
  ``not`` on booleans, ``a if c else b``, ``abs``, ``max``, ``min``,
  ``float``, the functions of :mod:`math` and ``np.isfinite``, and calls of
  the functions the caller names (``calls`` of :func:`compile_function`, e.g. a
  comparison its kernel also compiles), written in this subset and translated
  too, with the functions they call in the same top-level packages, and of
  the source's own other top-level functions (a law's numeric inverse,
  :mod:`codegen.inverse`; their decorators are numba's business, not
  translated);
  module-level numbers are constants.

The meaning is numba's for the same source (``error_model="numpy"``, no
fast-math), operation by operation, so both compile a source to the same
numbers (``tests/codegen/test_native.py`` checks them bitwise): ``x**k`` for a
literal integer ``k`` is numba's unrolled product (``1/…`` for ``k < 0``,
infinite at ``x = 0``, where numba raises inside the C function and returns
0 with its outputs half written; likewise an integer divided by integer 0 is
infinite here), any other power is ``pow``; ``max(a, b)`` is ``b if b > a else a``; ``%`` on
floats has Python's sign rule; a variable assigned an integer and a float
holds a float; an integer ``/`` is a float division.

Anything outside the subset raises :class:`Untranslatable` before any code
is made; the caller then compiles the source with numba instead.

The machine code of a function can be kept (:meth:`NativeFunction.serialize`,
two byte strings: the object code and the module's bitcode) and loaded in a
later process (:func:`load_function`) of the same numba, llvmlite and CPU
(:func:`codegen.native_file.machine_key`; the bytes kept with that key:
:mod:`codegen.native_file`), with no translation or optimisation.

Every part of numba that is not its public interface is reached through
:mod:`codegen.numba_internals`, which says when this numba does not offer
them (:func:`~codegen.numba_internals.native_unsupported`).
"""

from __future__ import annotations

import ast
import inspect
import math
import operator
import textwrap
import types as pytypes
from dataclasses import dataclass, field

from . import numba_internals
from .llvm_arithmetic import float_modulo, static_power
from .safety import PYTHON, Dialect, check_source

__all__ = ["NativeFunction", "Untranslatable", "compile_function", "load_function"]


class Untranslatable(Exception):
    """A construct outside the translated subset (the message names it and
    its line); the source is compiled by numba instead."""


_FLOAT, _INT, _BOOL = "f", "i", "b"
# math functions: (the LLVM intrinsic numba calls, or the libm function it calls; the result's kind)
_MATH = {
    "fabs": ("llvm.fabs.f64", _FLOAT), "exp": ("llvm.exp.f64", _FLOAT), "log": ("llvm.log.f64", _FLOAT),
    "log10": ("llvm.log10.f64", _FLOAT), "sin": ("llvm.sin.f64", _FLOAT), "cos": ("llvm.cos.f64", _FLOAT),
    "pow": ("llvm.pow.f64", _FLOAT), "copysign": ("llvm.copysign.f64", _FLOAT),
    "log1p": ("log1p", _FLOAT), "expm1": ("expm1", _FLOAT), "erf": ("erf", _FLOAT), "erfc": ("erfc", _FLOAT),
    "tan": ("tan", _FLOAT), "asin": ("asin", _FLOAT), "acos": ("acos", _FLOAT), "atan": ("atan", _FLOAT),
    "asinh": ("asinh", _FLOAT), "acosh": ("acosh", _FLOAT), "atanh": ("atanh", _FLOAT), "sinh": ("sinh", _FLOAT),
    "cosh": ("cosh", _FLOAT), "tanh": ("tanh", _FLOAT), "log2": ("log2", _FLOAT), "sqrt": ("sqrt", _FLOAT),
    "lgamma": ("lgamma", _FLOAT), "atan2": ("atan2", _FLOAT), "hypot": ("hypot", _FLOAT),
    "ceil": ("ceil", _INT), "floor": ("floor", _INT), "trunc": ("trunc", _INT),
}
_ARITY = {"atan2": 2, "hypot": 2, "pow": 2, "copysign": 2}
_COMPARE = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=", ast.Eq: "==", ast.NotEq: "!="}
_FOLD = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
         ast.Pow: operator.pow, ast.Mod: operator.mod}


def _ir():
    from llvmlite import ir

    return ir


def _join(a: str, b: str) -> str:
    """The kind holding values of kinds ``a`` and ``b`` (numba's unification)."""
    if _FLOAT in (a, b):
        return _FLOAT
    if _INT in (a, b):
        return _INT
    return _BOOL


@dataclass(frozen=True)
class _ArrayKind:
    """A ``carray`` view: element kind (``f`` float64, ``i`` int64, ``u`` uint8); its length is a value."""

    element: str


def _where(node) -> str:
    return f"line {getattr(node, 'lineno', '?')}"


def _constant(node):
    """The value of a constant expression (folded as CPython folds it), or ``None``."""
    if isinstance(node, ast.Constant) and type(node.value) in (int, float, bool):
        if type(node.value) is int and not -2**63 <= node.value < 2**63:
            return None  # not an int64: refused as a constant (numba has no such literal either)
        return node.value
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        inner = _constant(node.operand)
        if inner is not None and not isinstance(inner, bool):
            return -inner if isinstance(node.op, ast.USub) else +inner
    if isinstance(node, ast.BinOp) and type(node.op) in _FOLD:
        left, right = _constant(node.left), _constant(node.right)
        if left is not None and right is not None and not isinstance(left, bool) and not isinstance(right, bool):
            try:
                value = _FOLD[type(node.op)](left, right)
            except (ArithmeticError, ValueError):
                return None
            if type(value) in (int, float) and (not isinstance(value, int) or abs(value) < 2**63):
                return value
    return None


@dataclass
class _Function:
    """A Python function being translated: its syntax tree, globals, parameter
    kinds and the kinds of its variables and of its result."""

    tree: ast.FunctionDef
    globals: dict
    parameters: dict  # name → kind or _ArrayKind (pointer parameters: ("ptr", element))
    variables: dict = field(default_factory=dict)
    result: str | None = None


class _Translator:
    """Translates one entry function and the toolkit functions it calls into one LLVM module."""

    def __init__(self, module_name: str, calls=()):
        ir = _ir()
        # the packages whose functions may be translated: those of the functions the caller named
        self.packages = tuple(sorted({(getattr(f, "py_func", f).__module__ or "").split(".")[0] + "."
                                      for f in calls}))
        self.ir = ir
        self.module = ir.Module(name=module_name)
        self.f64, self.i64, self.i1, self.i8 = ir.DoubleType(), ir.IntType(64), ir.IntType(1), ir.IntType(8)
        self.helpers: dict = {}  # (python function, argument kinds) → (llvm function, result kind)
        #: the source's other top-level functions (a numeric inverse's iteration, codegen.inverse), by name,
        #: translated from their trees when the entry calls them; ``namespace``: the source's globals
        self.local: dict = {}
        self.namespace: dict = {}

    # ------------------------------------------------------------------ kinds of values (under fn.variables)
    def llvm_type(self, kind):
        return {_FLOAT: self.f64, _INT: self.i64, _BOOL: self.i1}[kind]

    def resolve(self, fn: _Function, name: str, node):
        """A global name's value: a number, a module (math, numpy) or a function."""
        if name in fn.globals:
            return fn.globals[name]
        import builtins

        if hasattr(builtins, name):
            return getattr(builtins, name)
        raise Untranslatable(f"unknown name {name!r} ({_where(node)})")

    def callee(self, fn: _Function, node):
        """What a call calls: ``("math", name)``, ``("builtin", name)``, ``("isfinite",)``,
        ``("carray",)`` or ``("helper", python function)``."""
        import numpy as np

        target = node.func
        if isinstance(target, ast.Attribute) and isinstance(target.value, ast.Name):
            owner = self.resolve(fn, target.value.id, node)
            if owner is math and target.attr in _MATH:
                return ("math", target.attr)
            if owner is np and target.attr == "isfinite":
                return ("isfinite",)
            raise Untranslatable(f"call of {target.value.id}.{target.attr} ({_where(node)})")
        if not isinstance(target, ast.Name):
            raise Untranslatable(f"call of a computed function ({_where(node)})")
        if target.id in self.local and fn.globals is self.namespace:
            return ("helper", ("local", target.id))
        value = self.resolve(fn, target.id, node)
        if value is abs or value is max or value is min or value is float:
            return ("builtin", value.__name__)
        if value is math.isfinite or value is np.isfinite:
            return ("isfinite",)
        for name in _MATH:
            if value is getattr(math, name, None):
                return ("math", name)
        if getattr(value, "__name__", "") == "carray" and "numba" in getattr(value, "__module__", ""):
            return ("carray",)
        python = getattr(value, "py_func", value)  # a numba dispatcher: its Python function
        if isinstance(python, pytypes.FunctionType) and self.packages \
                and (python.__module__ or "").startswith(self.packages):
            return ("helper", python)
        raise Untranslatable(f"call of {target.id!r} ({_where(node)})")

    def kind_of(self, fn: _Function, node):
        """The kind of expression ``node`` (``f``, ``i``, ``b`` or an :class:`_ArrayKind`)."""
        folded = _constant(node)
        if folded is not None:
            return _BOOL if isinstance(folded, bool) else (_INT if isinstance(folded, int) else _FLOAT)
        if isinstance(node, ast.Constant):
            raise Untranslatable(f"constant {node.value!r} ({_where(node)})")
        if isinstance(node, ast.Name):
            if node.id in fn.variables:
                if fn.variables[node.id] == _UNBOUND:
                    raise Untranslatable(f"{node.id!r} is not bound the same way on every path to {_where(node)}")
                return fn.variables[node.id]
            value = self.resolve(fn, node.id, node)
            if type(value) in (int, float, bool):
                return {bool: _BOOL, int: _INT, float: _FLOAT}[type(value)]
            raise Untranslatable(f"name {node.id!r} is not a number ({_where(node)})")
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
            owner = self.resolve(fn, node.value.id, node) if node.value.id not in fn.variables else None
            if owner is math and isinstance(getattr(math, node.attr, None), float):
                return _FLOAT
            raise Untranslatable(f"attribute {node.value.id}.{node.attr} ({_where(node)})")
        if isinstance(node, ast.BinOp):
            left, right = self.kind_of(fn, node.left), self.kind_of(fn, node.right)
            if isinstance(left, _ArrayKind) or isinstance(right, _ArrayKind):
                raise Untranslatable(f"arithmetic on an array ({_where(node)})")
            if isinstance(node.op, ast.Div):
                return _FLOAT
            if isinstance(node.op, ast.Pow):
                exponent = _constant(node.right)
                if left != _FLOAT and right != _FLOAT:
                    if isinstance(exponent, int) and exponent >= 0:
                        return _INT
                    raise Untranslatable(f"an integer power with an exponent that is not a literal natural number "
                                         f"({_where(node)})")
                return _FLOAT
            if isinstance(node.op, (ast.Add, ast.Sub, ast.Mult)):
                return _INT if _join(left, right) != _FLOAT else _FLOAT
            if isinstance(node.op, ast.Mod) and _join(left, right) == _FLOAT:
                return _FLOAT
            raise Untranslatable(f"operator {type(node.op).__name__} on {left}, {right} ({_where(node)})")
        if isinstance(node, ast.UnaryOp):
            inner = self.kind_of(fn, node.operand)
            if isinstance(inner, _ArrayKind):
                raise Untranslatable(f"arithmetic on an array ({_where(node)})")
            if isinstance(node.op, ast.Not):
                return _BOOL
            if isinstance(node.op, (ast.USub, ast.UAdd)):
                return _INT if inner == _BOOL else inner
            raise Untranslatable(f"operator {type(node.op).__name__} ({_where(node)})")
        if isinstance(node, ast.BoolOp):
            if any(self.kind_of(fn, v) != _BOOL for v in node.values):
                raise Untranslatable(f"'and'/'or' on values that are not booleans ({_where(node)})")
            return _BOOL
        if isinstance(node, ast.Compare):
            if len(node.ops) != 1 or type(node.ops[0]) not in _COMPARE:
                raise Untranslatable(f"a chained or unsupported comparison ({_where(node)})")
            for side in (node.left, node.comparators[0]):
                if isinstance(self.kind_of(fn, side), _ArrayKind):
                    raise Untranslatable(f"a comparison of arrays ({_where(node)})")
            return _BOOL
        if isinstance(node, ast.IfExp):
            self.kind_of(fn, node.test)
            body, other = self.kind_of(fn, node.body), self.kind_of(fn, node.orelse)
            if isinstance(body, _ArrayKind) or isinstance(other, _ArrayKind):
                raise Untranslatable(f"a conditional array ({_where(node)})")
            return _join(body, other)
        if isinstance(node, ast.Subscript):
            if (isinstance(node.value, ast.Attribute) and node.value.attr == "shape"
                    and isinstance(node.value.value, ast.Name)
                    and isinstance(fn.variables.get(node.value.value.id), _ArrayKind)):
                return _INT
            array = self.kind_of(fn, node.value)
            if not isinstance(array, _ArrayKind):
                raise Untranslatable(f"indexing a value that is not an array ({_where(node)})")
            self.index_kind(fn, node)
            return _FLOAT if array.element == _FLOAT else _INT
        if isinstance(node, ast.Call):
            if node.keywords:
                raise Untranslatable(f"keyword arguments ({_where(node)})")
            what = self.callee(fn, node)
            if what[0] == "carray":
                return self.carray_kind(fn, node)
            if what == ("builtin", "float") and len(node.args) == 1 and isinstance(node.args[0], ast.Constant) \
                    and isinstance(node.args[0].value, str):
                if node.args[0].value.strip().lower() not in ("nan", "inf", "-inf", "+inf"):
                    raise Untranslatable(f"float({node.args[0].value!r}) ({_where(node)})")
                return _FLOAT
            kinds = [self.kind_of(fn, a) for a in node.args]
            if any(isinstance(k, _ArrayKind) for k in kinds):
                raise Untranslatable(f"an array passed to a function ({_where(node)})")
            if what[0] == "math":
                if len(kinds) != _ARITY.get(what[1], 1):
                    raise Untranslatable(f"math.{what[1]} with {len(kinds)} arguments ({_where(node)})")
                return _MATH[what[1]][1]
            if what[0] == "isfinite":
                if len(kinds) != 1:
                    raise Untranslatable(f"isfinite with {len(kinds)} arguments ({_where(node)})")
                return _BOOL
            if what[0] == "builtin":
                name = what[1]
                if name == "float":
                    if len(kinds) != 1:
                        raise Untranslatable(f"float with {len(kinds)} arguments ({_where(node)})")
                    return _FLOAT
                if name == "abs":
                    if len(kinds) != 1:
                        raise Untranslatable(f"abs with {len(kinds)} arguments ({_where(node)})")
                    return _INT if kinds[0] == _BOOL else kinds[0]
                if len(kinds) < 2:
                    raise Untranslatable(f"{name} of fewer than two numbers ({_where(node)})")
                result = kinds[0]
                for k in kinds[1:]:
                    result = _join(result, k)
                return result
            return self.helper(what[1], tuple(kinds), node)[1]
        raise Untranslatable(f"{type(node).__name__} expression ({_where(node)})")

    def index_kind(self, fn: _Function, node: ast.Subscript):
        index = node.slice
        constant = _constant(index)
        if constant is not None:
            if not isinstance(constant, int) or isinstance(constant, bool) or constant < 0:
                raise Untranslatable(f"index {constant!r} ({_where(node)})")
            return
        if self.kind_of(fn, index) not in (_INT,):
            raise Untranslatable(f"an index that is not an integer ({_where(node)})")

    def carray_kind(self, fn: _Function, node) -> _ArrayKind:
        if len(node.args) != 2 or not isinstance(node.args[0], ast.Name):
            raise Untranslatable(f"carray needs a pointer argument and a shape ({_where(node)})")
        pointer = fn.parameters.get(node.args[0].id)
        if not (isinstance(pointer, tuple) and pointer[0] == "ptr"):
            raise Untranslatable(f"carray of {node.args[0].id!r}, not a pointer argument ({_where(node)})")
        shape = node.args[1]
        length = _constant(shape.elts[0]) if isinstance(shape, ast.Tuple) and len(shape.elts) == 1 else None
        if not isinstance(length, int) or length < 0:
            raise Untranslatable(f"carray with a shape that is not a literal (n,) ({_where(node)})")
        return _ArrayKind(pointer[1])

    def infer(self, fn: _Function) -> None:
        """The kind of a called toolkit function's result, from its variables'
        kinds joined over all their assignments (to a fixed point): its LLVM
        type is needed before its body is translated (along the flow)."""
        fn.variables = {name: kind for name, kind in fn.parameters.items()}
        for _ in range(50):
            before = dict(fn.variables)
            results = []
            for node in ast.walk(fn.tree):
                if isinstance(node, ast.Assign):
                    if len(node.targets) != 1:
                        raise Untranslatable(f"a chained assignment ({_where(node)})")
                    target = node.targets[0]
                    if isinstance(target, ast.Name):
                        try:
                            kind = self.kind_of(fn, node.value)
                        except Untranslatable:
                            if target.id not in fn.variables:
                                continue  # its kind may follow from other assignments: next round
                            raise
                        known = fn.variables.get(target.id)
                        if isinstance(known, tuple):
                            raise Untranslatable(f"parameter {target.id!r} reassigned ({_where(node)})")
                        if known is None:
                            fn.variables[target.id] = kind
                        elif isinstance(kind, _ArrayKind) or isinstance(known, _ArrayKind):
                            if kind != known:
                                raise Untranslatable(f"array {target.id!r} assigned views of different kinds "
                                                     f"({_where(node)})")
                        else:
                            fn.variables[target.id] = _join(known, kind)
                    elif not isinstance(target, ast.Subscript):
                        raise Untranslatable(f"assignment to a {type(target).__name__} ({_where(node)})")
                elif isinstance(node, ast.For):
                    if not isinstance(node.target, ast.Name):
                        raise Untranslatable(f"a loop over a {type(node.target).__name__} ({_where(node)})")
                    fn.variables[node.target.id] = _INT
                elif isinstance(node, ast.Return) and node.value is not None:
                    try:
                        results.append(self.kind_of(fn, node.value))
                    except Untranslatable:
                        pass  # decided in the last round
            if fn.variables == before:
                break
        for node in ast.walk(fn.tree):  # every expression typed once more: raises what is untranslatable
            if isinstance(node, ast.Assign):
                self.kind_of(fn, node.value)
            elif isinstance(node, ast.Return):
                if node.value is None:
                    raise Untranslatable(f"a return without a value ({_where(node)})")
                results.append(self.kind_of(fn, node.value))
        if not results or any(isinstance(k, _ArrayKind) for k in results):
            raise Untranslatable(f"function {fn.tree.name!r} returns no number")
        kind = results[0]
        for k in results[1:]:
            kind = _join(kind, k)
        fn.result = kind

    # ------------------------------------------------------------------ functions
    def helper(self, python, kinds: tuple, node):
        """The LLVM function of toolkit function ``python`` (or of a function
        ``("local", name)`` the source defines itself) for argument kinds
        ``kinds`` (translated once)."""
        key = (python, kinds)
        if key in self.helpers:
            if self.helpers[key] is None:
                raise Untranslatable(f"recursive call of {_called(python)!r} ({_where(node)})")
            return self.helpers[key]
        if isinstance(python, tuple):  # a function of the source: its tree, the source's globals
            tree, namespace, module = self.local[python[1]], self.namespace, "source"
        else:
            tree, namespace, module = _function_tree(python), python.__globals__, python.__module__
        names = [a.arg for a in tree.args.args]
        if len(names) != len(kinds) or tree.args.vararg or tree.args.kwarg or tree.args.defaults:
            raise Untranslatable(f"call of {_called(python)!r} with {len(kinds)} arguments ({_where(node)})")
        self.helpers[key] = None
        fn = _Function(tree, namespace, dict(zip(names, kinds)))
        self.infer(fn)
        ir = self.ir
        name = f"hbg.{module}.{tree.name}." + "".join(kinds)
        function = ir.Function(self.module, ir.FunctionType(self.llvm_type(fn.result),
                                                             [self.llvm_type(k) for k in kinds]), name=name)
        function.linkage = "internal"
        self.helpers[key] = (function, fn.result)
        _Body(self, fn, function).translate()
        return self.helpers[key]

    def entry(self, tree: ast.FunctionDef, namespace: dict, signature: list, result: str, name: str):
        """The exported function ``name`` of ``tree``: parameter kinds ``signature``
        (``f``, ``i`` or ``("ptr", element)``) and result kind ``result``."""
        names = [a.arg for a in tree.args.args]
        if len(names) != len(signature) or tree.args.vararg or tree.args.kwarg:
            raise Untranslatable(f"function {tree.name!r} has {len(names)} parameters, the signature "
                                 f"{len(signature)}")
        fn = _Function(tree, namespace, dict(zip(names, signature)), result=result)
        ir = self.ir
        pointer = {_FLOAT: self.f64.as_pointer(), _INT: self.i64.as_pointer(), "u": self.i8.as_pointer()}
        arguments = [pointer[k[1]] if isinstance(k, tuple) else self.llvm_type(k) for k in signature]
        function = ir.Function(self.module, ir.FunctionType(self.llvm_type(result), arguments), name=name)
        _Body(self, fn, function).translate()
        return function


@dataclass
class _Array:
    pointer: object  # the alloca holding the data pointer
    length: object  # the alloca holding the length


_UNBOUND = "unbound"  # a name not bound on every path to here (assigned in one branch only, or a loop's)


def _merged(branches: list, before: dict) -> dict:
    """The kinds of the variables where ``branches`` (each its variables' kinds) meet, after ``before``."""
    if not branches:
        return dict(before)
    names = set().union(*branches)
    merged = {}
    for name in names:
        kinds = [variables.get(name, _UNBOUND) for variables in branches]
        if any(k == _UNBOUND for k in kinds) or any(isinstance(k, tuple) for k in kinds):
            merged[name] = _UNBOUND if not all(k == kinds[0] for k in kinds) else kinds[0]
        elif any(isinstance(k, _ArrayKind) for k in kinds):
            merged[name] = kinds[0] if all(k == kinds[0] for k in kinds) else _UNBOUND
        else:
            kind = kinds[0]
            for k in kinds[1:]:
                kind = _join(kind, k)
            merged[name] = kind
    return merged


class _Body:
    """The LLVM body of one function.  Variables are typed along the flow, as
    numba's SSA types them: ``fn.variables`` holds each name's kind at the
    statement being translated, one stack slot per name and kind (LLVM's
    mem2reg makes them registers); where branches meet, a name of kinds int
    and float becomes a float (converted at the end of the int branch), and
    a name bound differently (an array and a number) is not readable after."""

    def __init__(self, translator: _Translator, fn: _Function, function):
        self.t, self.fn, self.function = translator, fn, function
        ir = translator.ir
        self.ir = ir
        self.allocas = ir.IRBuilder(function.append_basic_block("entry"))  # stack slots only, then a branch
        self.start = function.append_basic_block("start")
        self.builder = ir.IRBuilder(self.start)
        self.slots: dict = {}  # (variable, kind) → alloca (numbers) or _Array
        self.pointers: dict = {}  # pointer parameter → its LLVM argument

    def slot(self, name: str, kind):
        """The stack slot of variable ``name`` holding kind ``kind``."""
        key = (name, kind)
        if key not in self.slots:
            t = self.t
            if isinstance(kind, _ArrayKind):
                element = {_FLOAT: t.f64, _INT: t.i64, "u": t.i8}[kind.element]
                self.slots[key] = _Array(self.allocas.alloca(element.as_pointer(), name=name),
                                         self.allocas.alloca(t.i64, name=name + ".length"))
            else:
                self.slots[key] = self.allocas.alloca(t.llvm_type(kind), name=name)
        return self.slots[key]

    def kind(self, name: str, node):
        kind = self.fn.variables.get(name)
        if kind == _UNBOUND:
            raise Untranslatable(f"{name!r} is not bound the same way on every path to {_where(node)}")
        return kind

    def translate(self) -> None:
        b = self.builder
        for argument, name in zip(self.function.args, [a.arg for a in self.fn.tree.args.args]):
            argument.name = name + ".arg"
            kind = self.fn.parameters[name]
            if isinstance(kind, tuple):
                self.pointers[name] = argument
            else:
                b.store(argument, self.slot(name, kind))
        self.fn.variables = {name: kind for name, kind in self.fn.parameters.items()}
        self.block(self.fn.tree.body)
        if not b.block.is_terminated:
            raise Untranslatable(f"function {self.fn.tree.name!r} may end without a return")
        self.allocas.branch(self.start)

    # ------------------------------------------------------------------ statements
    def block(self, statements) -> None:
        for statement in statements:
            if self.builder.block.is_terminated:
                return  # what follows a return is never run
            self.statement(statement)

    def statement(self, node) -> None:
        b = self.builder
        if isinstance(node, ast.Expr):
            if isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
                return
            self.value(node.value)
        elif isinstance(node, ast.Pass):
            return
        elif isinstance(node, ast.Assign):
            if len(node.targets) != 1:
                raise Untranslatable(f"a chained assignment ({_where(node)})")
            target = node.targets[0]
            if isinstance(target, ast.Name):
                if isinstance(self.fn.parameters.get(target.id), tuple):
                    raise Untranslatable(f"pointer parameter {target.id!r} reassigned ({_where(node)})")
                kind = self.t.kind_of(self.fn, node.value)
                if isinstance(kind, _ArrayKind):
                    pointer, length = self.array_view(node.value)
                    slot = self.slot(target.id, kind)
                    b.store(pointer, slot.pointer)
                    b.store(length, slot.length)
                else:
                    b.store(self.convert(self.value(node.value), kind), self.slot(target.id, kind))
                self.fn.variables[target.id] = kind
            elif isinstance(target, ast.Subscript):
                address, element = self.element_address(target)
                value = self.value(node.value)
                if element == _FLOAT:
                    b.store(self.convert(value, _FLOAT), address)
                elif value[1] == _FLOAT:
                    raise Untranslatable(f"a float stored in an integer array ({_where(node)})")
                elif element == "u":
                    b.store(b.trunc(self.convert(value, _INT), self.t.i8), address)
                else:
                    b.store(self.convert(value, _INT), address)
            else:
                raise Untranslatable(f"assignment to a {type(target).__name__} ({_where(node)})")
        elif isinstance(node, ast.If):
            self.conditional(node)
        elif isinstance(node, ast.For):
            self.loop(node)
        elif isinstance(node, ast.Return):
            if node.value is None:
                raise Untranslatable(f"a return without a value ({_where(node)})")
            b.ret(self.convert(self.value(node.value), self.fn.result))
        else:
            raise Untranslatable(f"{type(node).__name__} statement ({_where(node)})")

    def conditional(self, node: ast.If) -> None:
        b = self.builder
        condition = self.truth(self.value(node.test))
        before = self.fn.variables
        ends = []  # (block, variables) of each branch that falls through
        then, other = self.function.append_basic_block("then"), self.function.append_basic_block("else")
        after = self.function.append_basic_block("endif")
        b.cbranch(condition, then, other)
        for block, statements in ((then, node.body), (other, node.orelse)):
            self.fn.variables = dict(before)
            b.position_at_end(block)
            self.block(statements)
            if not b.block.is_terminated:
                ends.append((b.block, self.fn.variables))
        merged = _merged([variables for _, variables in ends], before)
        for block, variables in ends:
            b.position_at_end(block)
            self.convert_variables(variables, merged)
            b.branch(after)
        b.position_at_end(after)
        self.fn.variables = merged
        if not ends:
            b.unreachable()

    def convert_variables(self, variables: dict, merged: dict) -> None:
        """At the end of a branch: move each number whose kind widens at the merge into its new slot."""
        for name, kind in merged.items():
            have = variables.get(name)
            if have == kind or kind == _UNBOUND or have in (None, _UNBOUND) or isinstance(kind, (_ArrayKind, tuple)):
                continue
            value = self.builder.load(self.slot(name, have))
            self.builder.store(self.convert((value, have), kind), self.slot(name, kind))

    def loop(self, node: ast.For) -> None:
        b, t = self.builder, self.t
        call = node.iter
        if (node.orelse or not isinstance(call, ast.Call) or not isinstance(call.func, ast.Name)
                or self.t.resolve(self.fn, call.func.id, node) is not range or len(call.args) != 1
                or not isinstance(node.target, ast.Name)):
            raise Untranslatable(f"a loop that is not 'for k in range(n)' ({_where(node)})")
        if any(isinstance(n, (ast.Break, ast.Continue)) for n in ast.walk(node)):
            raise Untranslatable(f"break/continue ({_where(node)})")
        count = self.convert(self.value(call.args[0]), _INT)
        counter = self.slot("loop." + node.target.id + f".{id(node)}", _INT)
        b.store(self.ir.Constant(t.i64, 0), counter)
        head = self.function.append_basic_block("loop.head")
        body = self.function.append_basic_block("loop.body")
        after = self.function.append_basic_block("loop.end")
        b.branch(head)
        b.position_at_end(head)
        k = b.load(counter)
        b.cbranch(b.icmp_signed("<", k, count), body, after)
        b.position_at_end(body)
        before = self.fn.variables
        self.fn.variables = dict(before)
        b.store(k, self.slot(node.target.id, _INT))
        self.fn.variables[node.target.id] = _INT
        self.block(node.body)
        for name, kind in before.items():
            if self.fn.variables.get(name) != kind:
                raise Untranslatable(f"{name!r} changes its kind in a loop ({_where(node)})")
        if not b.block.is_terminated:
            b.store(b.add(k, self.ir.Constant(t.i64, 1)), counter)
            b.branch(head)
        b.position_at_end(after)
        # names bound in the body (and the loop's own) are unbound after it: the loop may run no time
        self.fn.variables = {name: before.get(name, _UNBOUND) for name in self.fn.variables}
        if node.target.id not in before:
            self.fn.variables[node.target.id] = _UNBOUND

    # ------------------------------------------------------------------ expressions: (llvm value, kind)
    def convert(self, value, kind):
        b, t = self.builder, self.t
        v, have = value
        if have == kind:
            return v
        if kind == _FLOAT:
            return b.uitofp(v, t.f64) if have == _BOOL else b.sitofp(v, t.f64)
        if kind == _INT and have == _BOOL:
            return b.zext(v, t.i64)
        if kind == _BOOL:
            return self.truth(value)
        raise Untranslatable(f"a float where an integer is needed (function {self.fn.tree.name!r})")

    def truth(self, value):
        b, t = self.builder, self.t
        v, kind = value
        if kind == _BOOL:
            return v
        if kind == _INT:
            return b.icmp_signed("!=", v, self.ir.Constant(t.i64, 0))
        return b.fcmp_unordered("!=", v, self.ir.Constant(t.f64, 0.0))

    def array_view(self, node):
        """The data pointer and length of ``carray(pointer, (n,))`` or of an array variable."""
        if isinstance(node, ast.Name):
            slot = self.slot(node.id, self.kind(node.id, node))
            return self.builder.load(slot.pointer), self.builder.load(slot.length)
        return self.pointers[node.args[0].id], self.ir.Constant(self.t.i64, _constant(node.args[1].elts[0]))

    def element_address(self, node: ast.Subscript):
        array = self.kind(node.value.id, node) if isinstance(node.value, ast.Name) else None
        if not isinstance(array, _ArrayKind):
            raise Untranslatable(f"indexing a value that is not an array variable ({_where(node)})")
        index = self.convert(self.value(node.slice), _INT)
        pointer = self.builder.load(self.slot(node.value.id, array).pointer)
        return self.builder.gep(pointer, [index], inbounds=True), array.element

    def constant(self, value):
        t, ir = self.t, self.ir
        if isinstance(value, bool):
            return ir.Constant(t.i1, int(value)), _BOOL
        if isinstance(value, int):
            return ir.Constant(t.i64, value), _INT
        return ir.Constant(t.f64, value), _FLOAT

    def value(self, node):
        b, t, ir = self.builder, self.t, self.ir
        folded = _constant(node)
        if folded is not None:
            return self.constant(folded)
        if isinstance(node, ast.Constant):
            raise Untranslatable(f"constant {node.value!r} ({_where(node)})")
        if isinstance(node, ast.Name):
            kind = self.kind(node.id, node)
            if kind is not None:
                if isinstance(kind, (_ArrayKind, tuple)):
                    raise Untranslatable(f"array {node.id!r} used as a number ({_where(node)})")
                return b.load(self.slot(node.id, kind)), kind
            return self.constant(self.t.resolve(self.fn, node.id, node))
        if isinstance(node, ast.Attribute):
            return self.constant(getattr(math, node.attr))
        if isinstance(node, ast.Subscript):
            if isinstance(node.value, ast.Attribute):  # a.shape[0]
                if _constant(node.slice) != 0:
                    raise Untranslatable(f"shape[{ast.unparse(node.slice)}] of a one-dimensional array "
                                         f"({_where(node)})")
                array = self.kind(node.value.value.id, node)
                return b.load(self.slot(node.value.value.id, array).length), _INT
            address, element = self.element_address(node)
            loaded = b.load(address)
            if element == "u":
                return b.zext(loaded, t.i64), _INT
            return loaded, (_FLOAT if element == _FLOAT else _INT)
        if isinstance(node, ast.UnaryOp):
            operand = self.value(node.operand)
            if isinstance(node.op, ast.Not):
                return b.not_(self.truth(operand)), _BOOL
            if isinstance(node.op, ast.UAdd):
                return (self.convert(operand, _INT), _INT) if operand[1] == _BOOL else operand
            if operand[1] == _FLOAT:
                return b.fsub(ir.Constant(t.f64, -0.0), operand[0]), _FLOAT
            return b.sub(ir.Constant(t.i64, 0), self.convert(operand, _INT)), _INT
        if isinstance(node, ast.BinOp):
            return self.binary(node)
        if isinstance(node, ast.BoolOp):
            return self.boolean(node)
        if isinstance(node, ast.Compare):
            return self.compare(self.value(node.left), _COMPARE[type(node.ops[0])],
                                self.value(node.comparators[0])), _BOOL
        if isinstance(node, ast.IfExp):
            kind = self.t.kind_of(self.fn, node)
            return self.branches(self.truth(self.value(node.test)), lambda: self.value(node.body),
                                 lambda: self.value(node.orelse), kind), kind
        if isinstance(node, ast.Call):
            return self.call(node)
        raise Untranslatable(f"{type(node).__name__} expression ({_where(node)})")

    def branches(self, condition, then_value, else_value, kind):
        """``then_value() if condition else else_value()``, each evaluated only on its branch."""
        b = self.builder
        then = self.function.append_basic_block("ifexp.then")
        other = self.function.append_basic_block("ifexp.else")
        after = self.function.append_basic_block("ifexp.end")
        b.cbranch(condition, then, other)
        incoming = []
        for block, make in ((then, then_value), (other, else_value)):
            b.position_at_end(block)
            value = self.convert(make(), kind)
            incoming.append((value, b.block))
            b.branch(after)
        b.position_at_end(after)
        phi = b.phi(self.t.llvm_type(kind))
        for value, block in incoming:
            phi.add_incoming(value, block)
        return phi

    def boolean(self, node: ast.BoolOp):
        """``a and b and …`` / ``a or b or …``, short-circuit."""
        b, ir = self.builder, self.ir
        is_and = isinstance(node.op, ast.And)
        after = self.function.append_basic_block("bool.end")
        incoming = []
        for value in node.values[:-1]:
            truth = self.truth(self.value(value))
            incoming.append((ir.Constant(self.t.i1, 0 if is_and else 1), b.block))
            following = self.function.append_basic_block("bool.next")
            if is_and:
                b.cbranch(truth, following, after)
            else:
                b.cbranch(truth, after, following)
            b.position_at_end(following)
        last = self.truth(self.value(node.values[-1]))
        incoming.append((last, b.block))
        b.branch(after)
        b.position_at_end(after)
        phi = b.phi(self.t.i1)
        for value, block in incoming:
            phi.add_incoming(value, block)
        return phi, _BOOL

    def compare(self, left, op, right):
        b = self.builder
        if _FLOAT in (left[1], right[1]):
            l, r = self.convert(left, _FLOAT), self.convert(right, _FLOAT)
            return b.fcmp_unordered(op, l, r) if op == "!=" else b.fcmp_ordered(op, l, r)
        if left[1] == right[1] == _BOOL and op in ("==", "!="):
            return b.icmp_unsigned(op, left[0], right[0])
        return b.icmp_signed(op, self.convert(left, _INT), self.convert(right, _INT))

    def binary(self, node: ast.BinOp):
        b = self.builder
        kind = self.t.kind_of(self.fn, node)
        if isinstance(node.op, ast.Pow):
            exponent = _constant(node.right)
            base = self.value(node.left)
            if isinstance(exponent, int) and not isinstance(exponent, bool) and abs(exponent) <= 0x10000:
                return static_power(b, self.convert(base, kind), exponent, kind == _FLOAT), kind
            power = self.intrinsic("llvm.pow.f64", 2)
            return b.call(power, [self.convert(base, _FLOAT), self.convert(self.value(node.right), _FLOAT)]), _FLOAT
        left, right = self.value(node.left), self.value(node.right)
        if isinstance(node.op, ast.Div):
            return b.fdiv(self.convert(left, _FLOAT), self.convert(right, _FLOAT)), _FLOAT
        l, r = self.convert(left, kind), self.convert(right, kind)
        if isinstance(node.op, ast.Mod):
            return float_modulo(b, l, r, self.intrinsic("llvm.copysign.f64", 2)), _FLOAT
        if kind == _FLOAT:
            operation = {ast.Add: b.fadd, ast.Sub: b.fsub, ast.Mult: b.fmul}[type(node.op)]
        else:
            operation = {ast.Add: b.add, ast.Sub: b.sub, ast.Mult: b.mul}[type(node.op)]
        return operation(l, r), kind

    def intrinsic(self, name: str, arity: int, result=None):
        module, t, ir = self.t.module, self.t, self.ir
        try:
            return module.get_global(name)
        except KeyError:
            return ir.Function(module, ir.FunctionType(result or t.f64, [t.f64] * arity), name=name)

    def call(self, node: ast.Call):
        b, t, ir = self.builder, self.t, self.ir
        what = self.t.callee(self.fn, node)
        if what[0] == "math":
            symbol, kind = _MATH[what[1]]
            arguments = [self.convert(self.value(a), _FLOAT) for a in node.args]
            result = b.call(self.intrinsic(symbol, len(arguments)), arguments)
            return (b.fptosi(result, t.i64), _INT) if kind == _INT else (result, _FLOAT)
        if what[0] == "isfinite":
            argument = self.value(node.args[0])
            if argument[1] != _FLOAT:
                return ir.Constant(t.i1, 1), _BOOL
            magnitude = b.call(self.intrinsic("llvm.fabs.f64", 1), [argument[0]])
            return b.fcmp_ordered("<", magnitude, ir.Constant(t.f64, math.inf)), _BOOL
        if what[0] == "builtin":
            name = what[1]
            if name == "float":
                if isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str):
                    return self.constant(float(node.args[0].value))
                return self.convert(self.value(node.args[0]), _FLOAT), _FLOAT
            if name == "abs":
                value = self.value(node.args[0])
                if value[1] == _FLOAT:
                    return b.call(self.intrinsic("llvm.fabs.f64", 1), [value[0]]), _FLOAT
                v = self.convert(value, _INT)
                return b.select(b.icmp_signed("<", v, ir.Constant(t.i64, 0)), b.sub(ir.Constant(t.i64, 0), v),
                                v), _INT
            kind = self.t.kind_of(self.fn, node)
            accumulator = self.convert(self.value(node.args[0]), kind)
            for argument in node.args[1:]:
                value = self.convert(self.value(argument), kind)
                pick = self.compare((value, kind), ">" if name == "max" else "<", (accumulator, kind))
                accumulator = b.select(pick, value, accumulator)
            return accumulator, kind
        if what[0] == "carray":
            raise Untranslatable(f"carray outside an assignment ({_where(node)})")
        kinds = tuple(self.t.kind_of(self.fn, a) for a in node.args)
        function, kind = self.t.helper(what[1], kinds, node)
        arguments = [self.convert(self.value(a), k) for a, k in zip(node.args, kinds)]
        return b.call(function, arguments), kind


def _called(python) -> str:
    """The name of a callee of :meth:`_Translator.helper` (a function, or ``("local", name)``)."""
    return python[1] if isinstance(python, tuple) else python.__name__


def _function_tree(python) -> ast.FunctionDef:
    try:
        source = textwrap.dedent(inspect.getsource(python))
    except (OSError, TypeError) as exc:
        raise Untranslatable(f"no source of {python.__name__!r}: {exc}") from None
    tree = ast.parse(source)
    definition = tree.body[0]
    if not isinstance(definition, ast.FunctionDef):
        raise Untranslatable(f"{python.__name__!r} is not a plain function")
    return definition


class NativeFunction:
    """A translated and compiled function: its machine code's :attr:`address`
    (a C function of the entry's signature), kept alive with this object;
    :attr:`origin` says whether it was ``"compiled"`` in this process or
    ``"loaded"`` from kept machine code."""

    def __init__(self, library, name: str, origin: str):
        self.library, self.name, self.origin = library, name, origin
        self.address = library.get_pointer_to_function(name)
        if not self.address:
            raise Untranslatable(f"function {name!r} was not compiled")

    def serialize(self) -> tuple[bytes, bytes]:
        """``(object code, bitcode)``: what :func:`load_function` needs in another process."""
        return numba_internals.serialize_library(self.library)


def compile_function(source: str, entry: str, signature: list, result: str, name: str,
                     namespace: dict | None = None, dialect: Dialect = PYTHON, calls=()) -> NativeFunction:
    """Translate function ``entry`` of module ``source`` (executed in
    ``namespace``, or its own imports run in a fresh one) to LLVM IR and
    compile it as the C function ``name`` of parameter kinds ``signature``
    (``"f"`` float64, ``"i"`` int64, ``("ptr", "f"|"i"|"u")`` pointers to
    float64/int64/uint8) returning ``result``.  The functions in ``calls``
    (plain functions or numba dispatchers), and those they call in the same
    top-level packages, may be called by the source: they are translated
    too.  Raises
    :class:`Untranslatable` for anything outside the subset (see the module),
    and :class:`~codegen.safety.GeneratedCodeError` for a source that holds
    anything the code generator never writes in its ``dialect`` (:mod:`codegen.safety`)."""
    check_source(source, f"<{name}>", dialect)  # (its imports run below: only those allowed)
    tree = ast.parse(source)
    definitions = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == entry]
    if len(definitions) != 1:
        raise Untranslatable(f"no single function {entry!r} in the source")
    if namespace is None:
        namespace = {}
        imports = ast.Module([n for n in tree.body if isinstance(n, (ast.Import, ast.ImportFrom))], [])
        exec(compile(imports, "<imports of a generated module>", "exec"), namespace)  # the source's own imports
    translator = _Translator(name, calls)
    translator.local = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name != entry}
    translator.namespace = namespace
    translator.entry(definitions[0], namespace, signature, result, name)
    with numba_internals.compiler_lock():
        library = numba_internals.compile_library(name, translator.module)  # (its object code can be kept)
        return NativeFunction(library, name, "compiled")


def load_function(name: str, object_code: bytes, bitcode: bytes) -> NativeFunction:
    """The function ``name`` from the machine code :meth:`NativeFunction.serialize` gave (on a machine of the
    same :func:`codegen.native_file.machine_key`)."""
    with numba_internals.compiler_lock():
        library = numba_internals.load_library(name, object_code, bitcode)
        return NativeFunction(library, name, "loaded")
