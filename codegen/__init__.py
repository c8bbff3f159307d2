"""Code generation: sympy expressions plus argument orderings → numerical
functions.  It knows neither switching nor models.

:func:`vector_function` is the plain path used by mode resolution: it
compiles a list of expressions into ``fn(x, t, p) -> ndarray`` over the state
array ``x`` (shape ``(n,)``), time ``t`` and the parameter array ``p``.
"""

from .functions import vector_function as vector_function
from .cache import CacheWarning as CacheWarning
