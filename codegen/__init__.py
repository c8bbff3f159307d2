"""Code generation: sympy expressions plus argument orderings → numerical
functions.  It knows nothing of the packages that use it: what it needs of
them (the functions a generated source may call, say) they pass in.

Machine code comes from one of the backends behind one contract
(:mod:`codegen.backends`: ``python``, ``numba``, ``native``), through the
in-memory and on-disk caches (:mod:`codegen.machine`, :mod:`codegen.cache`).

:func:`vector_function` is the plain path: it
compiles a list of expressions into ``fn(x, t, p) -> ndarray`` over the state
array ``x`` (shape ``(n,)``), time ``t`` and the parameter array ``p``.
"""

from .functions import vector_function as vector_function
from .cache import CacheWarning as CacheWarning
