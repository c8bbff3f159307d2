"""The definition of a hybrid model: :class:`HybridModel` (a bond graph, local
automata, parameters, signals, inputs and their validation), the automata that
switch controlled junctions and law switches, and modes with their equations.

``from switching.model import HybridModel`` keeps working (the module of
round 2 became this package).
"""

from .definition import InMode as InMode
from .hybrid_model import HybridModel as HybridModel
from .hybrid_model import InitialStateProjected as InitialStateProjected
from .hybrid_model import Tolerance as Tolerance
