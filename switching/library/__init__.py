"""The mode library of a model (:class:`ModeLibrary`): what is derived and
generated from its definition, mode by mode and lazily. Mode caches, the
fingerprint, the per-mode generated functions (:mod:`.compiled` for the Python
methods, :mod:`.jit_model` for the compiled ones) and the export of standalone code.
"""

from .mode_library import ModeLibrary as ModeLibrary
from .mode_library import canonical as canonical
from .mode_library import definition_fingerprint as definition_fingerprint
