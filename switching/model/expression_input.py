"""An input signal given as an expression of time, so that a model file can hold it.

:class:`~switching.model.hybrid_model.HybridModel` takes its inputs as callables of ``t``.
A Python function cannot be written to a model file;
:class:`ExpressionInput` is a callable that keeps its symbolic form: a sympy
expression of ``t`` and of parameters, with the parameters' values.  It is
evaluated by a function generated from the expression tree with
:mod:`codegen.source` (like every other model expression; no text is ever
executed), and it pickles (worker processes of a sweep rebuild it).

Example — a 50 Hz voltage of amplitude ``V0``::

    >>> u = ExpressionInput("V0*sin(2*pi*f*t)", {"V0": 10.0, "f": 50.0})
    >>> round(u(0.005), 12)
    10.0
    >>> u.text
    'V0*sin(2*pi*f*t)'
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import sympy as sp

from bondgraph.inverse import slope_of
from bondgraph.symbols import t as TIME

from ..errors import ModelDefinitionError
from ..language.exprtext import as_doubles, expression_text
from ..language.parsing import parse_expression

__all__ = ["ExpressionInput"]


class ExpressionInput:
    """A callable ``u(t)`` defined by ``expression`` (sympy, or text parsed
    without executing code) of time ``t`` and of ``parameters`` (name → number).

    ``expression`` keeps the symbolic form, ``parameters`` the values,
    ``text`` the expression as text (what a model file holds)."""

    def __init__(self, expression, parameters: Mapping[str, float] | None = None):
        names = {"t": TIME}
        names.update({str(k): sp.Symbol(str(k)) for k in (parameters or {})})
        if isinstance(expression, str):
            expression = parse_expression(expression, names)
        elif isinstance(expression, (int, float)) and not isinstance(expression, bool):
            expression = sp.sympify(expression)
        elif not isinstance(expression, sp.Expr):
            raise ModelDefinitionError(
                f"an input expression must be a sympy expression of t or a text, got {expression!r}")
        self.expression = as_doubles(expression)
        self.parameters = {str(k): float(v) for k, v in (parameters or {}).items()}
        free = {s.name for s in self.expression.free_symbols} - {"t"}
        missing = sorted(free - set(self.parameters))
        if missing:
            raise ModelDefinitionError(
                f"input {expression_text(self.expression)!r} uses {', '.join(missing)}, which have no value; "
                "give them in parameters= (name → number)")
        for name, value in self.parameters.items():
            if not math.isfinite(value):
                raise ModelDefinitionError(f"parameter {name!r} of input {self.text!r} is {value}: it must be finite")
        self._function = None

    @property
    def text(self) -> str:
        """The expression in the text grammar of :mod:`switching.language.parsing`."""
        return expression_text(self.expression)

    def _compile(self):
        from codegen.safety import execute
        from codegen.source import Argument, FunctionSpec, function_source, module_namespace

        numeric = self.expression.xreplace({sp.Symbol(k): sp.Float(v) for k, v in self.parameters.items()})
        spec = FunctionSpec("u", (Argument("t", (TIME,), scalar=True, doc="time [s]"),), (numeric,),
                            f"Input u(t) = {self.text}.")
        namespace = execute(function_source(spec), module_namespace(), "<hbg input>")
        function, out = namespace["u"], np.empty(1)
        self._function = lambda t: float(function(t, out)[0])

    def __call__(self, t: float) -> float:
        if self._function is None:
            self._compile()
        return self._function(float(t))

    @property
    def derivative(self) -> "ExpressionInput":
        """``du/dt`` as an input of its own (exact: the expression differentiated, time taken real so
        that ``d|t - t1|/dt`` is ``sign(t - t1)``) between the input's steps: without their Dirac pulses
        (``d step(t - t1)/dt = δ(t - t1)`` is 0 wherever ``t ≠ t1``; at ``t1`` the input changes its value,
        :func:`bondgraph.inverse.slope_of`)."""
        real = sp.Dummy("t", real=True)
        rate = slope_of(self.expression.xreplace({TIME: real}), real).xreplace({real: TIME})
        return ExpressionInput(rate, self.parameters)

    def __getstate__(self):
        return {"expression": self.expression, "parameters": self.parameters}

    def __setstate__(self, state):
        self.expression = state["expression"]
        self.parameters = state["parameters"]
        self._function = None

    def __repr__(self) -> str:
        values = f", {self.parameters}" if self.parameters else ""
        return f"ExpressionInput({self.text!r}{values})"
