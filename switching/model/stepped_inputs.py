"""Inputs that step in time, read into the element laws so that each step is a law switch.

An input given as an expression of time (:class:`~switching.model.expression_input.ExpressionInput`,
what a model file's ``[inputs]`` hold) is computed outside a mode's equations, at
every time a method asks for it.  A step in it, ``V*step(t - t1)``, jumps inside
the step of an adaptive method that spans ``t1``: its stages on either side see
the jump, the error estimate shrinks the step around it and the state at the end
carries part of it — an RC circuit driven by ``12*step(t - 1e-3)`` at
``rtol = 1e-8`` ended 8.7e-5 V off its closed form, and no instant was recorded.

So a model derives its modes from its graph with every element law that reads
such an input reading the input's expression instead (its parameters' values
substituted): a step is then a law switch of that element
(:mod:`bondgraph.law_switches`) on the surface ``t − t1``, located as an event
exactly as a step written in the law itself, and between events the flow sees
the branch, never the jump (the same RC circuit: 1.7e-8 relative, one instant at
``t1``).  Every input whose expression holds a function that may jump (``step``,
``Heaviside``, ``sign``, ``Piecewise``) is read so; a law that stays continuous is
left as written by the law switches.  What else reads the input — signals,
guards, the run's records — reads its value as before, the right-continuous
step of :mod:`switching.language.parsing`.  The expressions with their values
are part of the model's fingerprint (:func:`stepped_inputs`): a sweep over a
step's time derives each value's modes anew.
"""

from __future__ import annotations

from collections.abc import Mapping

import sympy as sp

from bondgraph.law_substitution import with_laws_substituted
from bondgraph.law_switches import DISCONTINUOUS

from .expression_input import ExpressionInput

__all__ = ["stepped_inputs", "with_stepped_inputs"]


def stepped_inputs(graph, inputs: Mapping) -> dict:
    """Input symbol → its expression of ``t`` with its parameters' values, for each of ``graph``'s
    inputs given in ``inputs`` as an :class:`ExpressionInput` whose expression may jump."""
    found = {}
    for name, symbol in graph.inputs.items():
        given = inputs.get(name)
        if isinstance(given, ExpressionInput) and given.expression.has(*DISCONTINUOUS):
            values = {sp.Symbol(k): sp.Float(v) for k, v in given.parameters.items()}
            found[symbol] = given.expression.xreplace(values)
    return found


def with_stepped_inputs(graph, inputs: Mapping):
    """``graph`` with its element laws reading each stepped input's expression (:func:`stepped_inputs`)
    in place of the input (``graph`` itself when it has none)."""
    stepped = stepped_inputs(graph, inputs)
    return with_laws_substituted(graph, stepped) if stepped else graph
