"""The values of a model's declared inputs ``u(t)`` and of their rates ``du/dt``.

An input that fixes dependent storage (a prescribed velocity driving a mass)
enters the equations with its derivative.  The rate is exact for an input
that knows it (an :class:`~switching.model.expression_input.ExpressionInput`
has ``derivative``); otherwise a central difference of the input function with
step ``h = 6e-6·max(1, |t|)`` (relative error about ``1e-10`` for a smooth
input; one-sided where the function is not defined before ``t``)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np


class InputValues:
    """``u(t)`` and ``du/dt`` of the inputs ``names`` (in this order), given
    by ``functions`` (name → callable of ``t`` in s, returning the input's value in its unit)."""

    def __init__(self, names: Sequence[str], functions: Mapping[str, Callable[[float], float]]):
        self.names = tuple(names)
        self.functions = functions
        self._rates: dict = {}  # name → the input's own derivative, or None: a central difference

    def values(self, t: float) -> list:
        """``[u_1(t), …, u_m(t), du_1/dt(t), …, du_m/dt(t)]`` (empty without inputs)."""
        values = [float(self.functions[name](t)) for name in self.names]
        if values:
            values += [self.rate(name, t) for name in self.names]
        return values

    def columns(self, times) -> list:
        """:meth:`values` at many times [s]: one array (N,) per entry (empty without inputs)."""
        if not self.names:
            return []
        rows = [self.values(t) for t in times]
        return [np.array([row[j] for row in rows], dtype=float) for j in range(2 * len(self.names))]

    def rate(self, name: str, t: float) -> float:
        """``du/dt`` of input ``name`` at ``t`` (in its unit per second)."""
        fn = self.functions[name]
        if name not in self._rates:
            self._rates[name] = getattr(fn, "derivative", None)
        rate = self._rates[name]
        if rate is not None:
            try:
                return float(rate(t))
            except ArithmeticError:  # an infinite slope (√t at t = 0): no number; read only by equations
                return math.nan      # that take the input's rate (a flow of dependent storage), there non-finite
        h = 6.0e-6 * max(1.0, abs(t))
        try:
            return (float(fn(t + h)) - float(fn(t - h))) / (2.0 * h)
        except (ValueError, ArithmeticError):
            return (float(fn(t + h)) - float(fn(t))) / h
