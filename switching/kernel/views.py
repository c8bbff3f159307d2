"""Two-dimensional views of the kernel's one-dimensional workspaces.

``wf[o:o + r * c].reshape((r, c))`` would do, but numba compiles part of
``reshape`` (its normaliser of the new shape) from a function of
``numba.np.arrayobj``, and the compiled kernel then keeps an environment of
that module: loading the kernel from numba's disk cache imports it, with some
twenty modules it needs (~0.03–0.05 s of a new process's first compiled run).
:func:`rows_of` makes the same view directly: the buffer's data and owner,
shape ``(r, c)``, row-major strides.
"""

from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["rows_of"]


@intrinsic
def rows_of(typingctx, buffer, rows, columns):
    """The C-contiguous ``(rows, columns)`` view of the C-contiguous one-dimensional ``buffer``, whose first
    ``rows · columns`` entries it covers (the caller sizes the buffer: nothing is checked)."""
    if not (isinstance(buffer, types.Array) and buffer.ndim == 1 and buffer.layout == "C"):
        return None
    view = types.Array(buffer.dtype, 2, "C")

    def codegen(context, builder, signature, args):
        from numba.np.arrayobj import make_array, populate_array

        source = make_array(buffer)(context, builder, value=args[0])
        intp = context.get_value_type(types.intp)
        r = context.cast(builder, args[1], signature.args[1], types.intp)
        c = context.cast(builder, args[2], signature.args[2], types.intp)
        out = make_array(view)(context, builder)
        populate_array(out, data=source.data, shape=cgutils.pack_array(builder, [r, c], intp),
                       strides=cgutils.pack_array(builder, [builder.mul(c, source.itemsize), source.itemsize], intp),
                       itemsize=source.itemsize, meminfo=source.meminfo, parent=source.parent)
        value = out._getvalue()
        if context.enable_nrt:
            context.nrt.incref(builder, view, value)  # (a view holds its owner, as reshape's does)
        return value

    return view(buffer, rows, columns), codegen
