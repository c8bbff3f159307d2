"""Bond graphs with controlled junctions: elements, composition, causality and
per-configuration symbolic equations.

Example — a mass on a spring with a damper, driven by a force::

    >>> import sympy as sp
    >>> from bondgraph import BondGraph, Se, I, C, R, One
    >>> g = BondGraph("msd")
    >>> v = g.add(One("v"))
    >>> _ = g.connect(Se("F", "F0"), v)
    >>> for el in (I("m"), C("k", 1 / sp.Symbol("k")), R("c")):
    ...     _ = g.connect(v, el)
    >>> eq = g.equations()
    >>> sp.simplify(eq.rate("p_m") - (sp.Symbol("F0") - sp.Symbol("k") * sp.Symbol("q_k")
    ...     - sp.Symbol("c") * sp.Symbol("p_m") / sp.Symbol("m")))
    0
"""

from .causality import Causality as Causality
from .causality import assign_causality as assign_causality
from .causality import causality_violations as causality_violations
from .elements import C as C
from .elements import GY as GY
from .elements import TF as TF
from .elements import Element as Element
from .elements import I as I
from .elements import Junction as Junction
from .elements import One as One
from .elements import R as R
from .elements import Se as Se
from .elements import Sf as Sf
from .elements import Storage as Storage
from .elements import Zero as Zero
from .drawing import draw_bond_graph as draw_bond_graph
from .drawing import layout_bond_graph as layout_bond_graph
from .equations import ConfigurationEquations as ConfigurationEquations
from .equations import derive_equations as derive_equations
from .errors import AlgebraicLoopError as AlgebraicLoopError
from .errors import CausalityConflictError as CausalityConflictError
from .errors import DerivationError as DerivationError
from .errors import FloatingPartError as FloatingPartError
from .errors import DuplicateNameError as DuplicateNameError
from .errors import NameCollisionError as NameCollisionError
from .errors import HybridBondGraphError as HybridBondGraphError
from .errors import InvalidGraphError as InvalidGraphError
from .errors import MissingParameterError as MissingParameterError
from .errors import UnknownNameError as UnknownNameError
from .errors import UnknownParameterError as UnknownParameterError
from .errors import ParameterValueError as ParameterValueError
from .errors import PhysicalRangeWarning as PhysicalRangeWarning
from .errors import EnergyGainWarning as EnergyGainWarning
from .errors import CoarseStepWarning as CoarseStepWarning
from .energy import energy_function as energy_function
from .energy import storage_energy as storage_energy
from .energy import stored_energy as stored_energy
from .jump import JumpMap as JumpMap
from .namespace import Namespace as Namespace
from .namespace import Owner as Owner
from .jump import JumpMapError as JumpMapError
from .jump import derive_jump_map as derive_jump_map
from .state_space import StateSpace as StateSpace
from .linear_system import LinearSystem as LinearSystem
from .errors import MissingDependencyError as MissingDependencyError
from .graph import Bond as Bond
from .graph import BondGraph as BondGraph
from .graph import Instance as Instance
from .symbols import t as t

__version__ = "0.1.0"
