"""The Wright omega function of :mod:`codegen.omega` compiled by numba, for
generated machine code (optional extra ``fast``): the per-mode functions of
the compiled methods import it as ``wrightomega`` when their expressions
hold one (numba's front end compiles the call; the native backend
translates the very same Python function, ``wrightomega.py_func``).

It is a module of its own, not a function of the simulation kernel, so
that it joins no kernel's cache stamp: kept in numba's disk cache beside
:mod:`codegen.omega` (``cache=True``), compiled once per installation.
"""

from numba import njit

from . import omega

__all__ = ["wrightomega"]

#: ``ω(z) = W₀(eᶻ)`` (:func:`codegen.omega.wrightomega`), compiled
wrightomega = njit(cache=True, error_model="numpy")(omega.wrightomega)
