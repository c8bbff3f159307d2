"""The structural check every generated module passes before it is compiled or run.

Generated source is built from a model's names and expressions, and a model
may come from a stranger's file.  Names reach the source only as sanitized
identifiers, and other text (names, descriptions, units, labels) only through
:func:`codegen.source.docstring` or ``repr``; this module is the second line
of defence, so that a future escaping mistake fails closed.  It parses the
source (never runs it) and accepts only what the code generator writes:

* at module level: function definitions, assignments of names, docstrings,
  and the imports the caller allows (by default none);
* in a function: assignments (to names, subscripts and slices), ``return``,
  ``if``/``else``, ``for name in range(...)``, docstrings and calls as statements;
* in expressions: arithmetic, comparisons, boolean and conditional
  expressions, subscripts, literals, names, calls of names, attributes of
  the known modules (``H``, ``np``, ``math``) and an array's ``shape``, ``size``, ``ndim``;
* never a name or attribute with a leading double underscore (``__import__``,
  ``__class__``), nor a builtin that is not plain arithmetic (``open``,
  ``exec``, ``getattr``, ...), nor ``lambda``, ``class``, ``import`` inside a
  function, ``global``, ``with``, ``try``, ``while``, other loops, ``del``,
  ``raise``, ``yield``, ``await``, f-strings, comprehensions.

:func:`execute` checks, compiles and runs a module in a namespace: the one
way generated code runs.
"""

from __future__ import annotations

import ast
import builtins
import hashlib

from bondgraph.errors import HybridBondGraphError

__all__ = ["GeneratedCodeError", "check_source", "execute", "SAFE_BUILTINS", "MODULES"]


class GeneratedCodeError(HybridBondGraphError):
    """A generated module holds something the code generator never writes (an
    import, a call of ``open``, a statement after a docstring that ended too
    early...).  It is not run.  ``where`` names the module, ``line`` the line."""

    def __init__(self, message: str, where: str = "", line: int = 0):
        super().__init__(message)
        self.where = where
        self.line = line


#: builtins generated code may name: arithmetic and conversions, nothing that reaches files,
#: objects' internals or the interpreter
SAFE_BUILTINS = frozenset({"abs", "max", "min", "float", "int", "bool", "round", "range", "len", "pow", "divmod",
                           "True", "False", "None"})

#: modules whose attributes generated code may read (``H`` is :data:`codegen.runtime.H`)
MODULES = frozenset({"H", "np", "math"})

#: attributes of other names (arrays) generated code may read
ARRAY_ATTRIBUTES = frozenset({"shape", "size", "ndim"})

_FORBIDDEN_BUILTINS = frozenset(dir(builtins)) - SAFE_BUILTINS

_MODULE_STATEMENTS = (ast.FunctionDef, ast.Assign, ast.Expr, ast.Import, ast.ImportFrom)
_STATEMENTS = (ast.Assign, ast.AugAssign, ast.Return, ast.If, ast.For, ast.Expr, ast.Pass)
_EXPRESSIONS = (ast.BinOp, ast.UnaryOp, ast.BoolOp, ast.Compare, ast.IfExp, ast.Call, ast.Subscript, ast.Slice,
                ast.Name, ast.Attribute, ast.Constant, ast.Tuple, ast.List, ast.Dict, ast.Set, ast.Starred,
                ast.keyword)
_CONTEXTS_AND_OPERATORS = (ast.expr_context, ast.operator, ast.unaryop, ast.boolop, ast.cmpop)


def _refuse(where: str, node, what: str) -> GeneratedCodeError:
    line = getattr(node, "lineno", 0)
    return GeneratedCodeError(
        f"generated module {where} holds {what} (line {line}), which the code generator never writes; it is not "
        "run. If the module came from the disk cache, the entry was altered: it is discarded and built again. "
        "Otherwise this is a bug of the code generator: please report it with the model.", where, line)


def _check_import(node, where: str, imports: frozenset) -> None:
    if isinstance(node, ast.Import):
        found = {(alias.name, None, alias.asname) for alias in node.names}
    else:
        found = {(node.module, alias.name, alias.asname) for alias in node.names}
        if node.level:
            raise _refuse(where, node, "a relative import")
    for item in found:
        if item not in imports:
            module, name, asname = item
            text = f"import {module}" if name is None else f"from {module} import {name}"
            raise _refuse(where, node, f"'{text}{f' as {asname}' if asname else ''}'")


def _check_function(node: ast.FunctionDef, where: str) -> None:
    if node.decorator_list or node.returns is not None or node.args.kwonlyargs or node.args.vararg \
            or node.args.kwarg or node.args.defaults or node.args.kw_defaults or node.args.posonlyargs:
        raise _refuse(where, node, f"a function {node.name!r} with decorators, annotations or special arguments")
    for argument in node.args.args:
        if argument.annotation is not None:
            raise _refuse(where, node, f"an annotated argument of {node.name!r}")
        _check_identifier(argument.arg, where, node)
    _check_identifier(node.name, where, node)
    for statement in node.body:
        _check_statement(statement, where)


def _check_statement(node, where: str) -> None:
    if not isinstance(node, _STATEMENTS):
        raise _refuse(where, node, f"a statement of kind {type(node).__name__}")
    if isinstance(node, ast.For):  # only ``for name in range(...)``
        if not (isinstance(node.target, ast.Name) and isinstance(node.iter, ast.Call)
                and isinstance(node.iter.func, ast.Name) and node.iter.func.id == "range") or node.orelse:
            raise _refuse(where, node, "a loop other than 'for name in range(...)'")
        _check_expression(node.target, where)
        _check_expression(node.iter, where)
        for statement in node.body:
            _check_statement(statement, where)
        return
    if isinstance(node, ast.If):
        _check_expression(node.test, where)
        for statement in (*node.body, *node.orelse):
            _check_statement(statement, where)
        return
    for child in ast.iter_child_nodes(node):
        _check_expression(child, where)


def _check_identifier(name: str, where: str, node) -> None:
    if name.startswith("__"):
        raise _refuse(where, node, f"the name {name!r}")
    if name in _FORBIDDEN_BUILTINS:
        raise _refuse(where, node, f"the builtin {name!r}")


def _check_expression(root, where: str) -> None:
    for node in ast.walk(root):
        if isinstance(node, _CONTEXTS_AND_OPERATORS):
            continue
        if not isinstance(node, _EXPRESSIONS):
            raise _refuse(where, node, f"an expression of kind {type(node).__name__}")
        if isinstance(node, ast.Name):
            _check_identifier(node.id, where, node)
        elif isinstance(node, ast.Attribute):
            known = isinstance(node.value, ast.Name) and (node.value.id in MODULES or node.attr in ARRAY_ATTRIBUTES)
            if not known or node.attr.startswith("_"):
                raise _refuse(where, node, f"the attribute {ast.unparse(node)!r}")
        elif isinstance(node, ast.Call):
            if not isinstance(node.func, (ast.Name, ast.Attribute)):
                raise _refuse(where, node, f"a call of {ast.unparse(node.func)!r}")
        elif isinstance(node, ast.keyword) and node.arg is None:
            raise _refuse(where, node, "a call with **keywords")


def _checked(source: str, where: str, imports: frozenset) -> None:
    try:
        tree = ast.parse(source, filename=where)
    except SyntaxError as exc:
        raise GeneratedCodeError(
            f"generated module {where} does not parse (line {exc.lineno}: {exc.msg}); it is not run. If it came "
            "from the disk cache, the entry is discarded and built again; otherwise please report it with the "
            "model.", where, exc.lineno or 0) from None
    for node in tree.body:
        if not isinstance(node, _MODULE_STATEMENTS):
            raise _refuse(where, node, f"a module-level statement of kind {type(node).__name__}")
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            _check_import(node, where, imports)
        elif isinstance(node, ast.FunctionDef):
            _check_function(node, where)
        elif isinstance(node, ast.Assign):
            for target in node.targets:
                if not isinstance(target, ast.Name):
                    raise _refuse(where, node, "an assignment to something other than a name")
                _check_identifier(target.id, where, node)
            _check_expression(node.value, where)
        else:  # a docstring or another constant expression
            if not isinstance(node.value, ast.Constant):
                raise _refuse(where, node, f"a module-level expression {ast.unparse(node)[:60]!r}")


#: digests of the (source, allowed imports) that passed, so that a source is parsed once per process
_PASSED: set = set()
_PASSED_MAX = 100_000


def check_source(source: str, where: str = "<generated>", imports=()) -> None:
    """Parse ``source`` and check it holds only what the code generator writes
    (see the module docstring); ``imports`` lists the allowed imports as
    ``(module, name, asname)`` triples (``name`` ``None`` for ``import
    module``).  Raises :class:`GeneratedCodeError` naming the line and what
    was found.  A source that passed (with the same imports) is not parsed again."""
    imports = frozenset(imports)
    digest = hashlib.blake2b(source.encode("utf-8", "surrogatepass"), digest_size=20,
                             person=b"hbg-check").digest() + repr(sorted(imports, key=repr)).encode()
    if digest in _PASSED:
        return
    _checked(source, where, imports)
    if len(_PASSED) >= _PASSED_MAX:
        _PASSED.clear()
    _PASSED.add(digest)


def execute(source: str, namespace: dict, where: str = "<generated>", imports=(), first_line: int = 1) -> dict:
    """Check ``source`` (:func:`check_source`), then compile and run it in
    ``namespace`` (its line numbers start at ``first_line``); returns the namespace."""
    check_source(source, where, imports)
    code = compile("\n" * (first_line - 1) + source, where, "exec")
    exec(code, namespace)  # checked above: only what the code generator writes
    return namespace
