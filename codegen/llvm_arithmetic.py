"""numba's meaning of two arithmetic operations, written as LLVM IR (for :mod:`codegen.native`).

Each function emits instructions at an ``llvmlite.ir.IRBuilder``'s position
and returns the resulting value; operation by operation they compute what
numba computes for the same Python (``error_model="numpy"``, no fast-math),
so code translated by :mod:`codegen.native` gives numba's numbers to the bit.
"""

from __future__ import annotations

__all__ = ["float_modulo", "static_power"]


def static_power(builder, value, exponent: int, is_float: bool):
    """numba's ``x**k`` for a literal integer ``k``: the unrolled
    square-and-multiply of ``value`` (a double when ``is_float``, else an
    int64), inverted (``1/…``, a double) for ``k < 0``."""
    from llvmlite import ir

    double, integer = ir.DoubleType(), ir.IntType(64)
    multiply = builder.fmul if is_float else builder.mul
    result = ir.Constant(double, 1.0) if is_float else ir.Constant(integer, 1)
    invert, remaining = exponent < 0, abs(exponent)
    while remaining:
        if remaining & 1:
            result = multiply(result, value)
        remaining >>= 1
        if remaining:
            value = multiply(value, value)
    if invert:
        return builder.fdiv(ir.Constant(double, 1.0), result)
    return result


def float_modulo(builder, x, y, copysign):
    """Python's ``x % y`` on doubles: the remainder with the sign of ``y``
    (``nan`` for ``y == 0``); ``copysign`` is the module's ``llvm.copysign.f64``."""
    from llvmlite import ir

    zero = ir.Constant(ir.DoubleType(), 0.0)
    remainder = builder.frem(x, y)
    differ = builder.xor(builder.fcmp_ordered("<", remainder, zero), builder.fcmp_ordered("<", y, zero))
    adjust = builder.and_(builder.fcmp_unordered("!=", remainder, zero), differ)
    moved = builder.select(adjust, builder.fadd(remainder, y), remainder)
    signed_zero = builder.call(copysign, [zero, y])
    return builder.select(builder.fcmp_ordered("==", moved, zero), signed_zero, moved)
