"""Switching semantics: local automata, modes, mode resolution (mythical
modes, pinnacles, divergence of time), impulsive signals.

Example — see :mod:`switching.model` and :mod:`switching.automaton`.
"""

from .automaton import A_POSTERIORI as A_POSTERIORI
from .automaton import A_PRIORI as A_PRIORI
from .automaton import Automaton as Automaton
from .automaton import Transition as Transition
from .errors import ComplexValueError as ComplexValueError
from .errors import DivergenceOfTimeError as DivergenceOfTimeError
from .errors import GuardSyntaxError as GuardSyntaxError
from .errors import ImpulseError as ImpulseError
from .errors import ModelDefinitionError as ModelDefinitionError
from .errors import NonFiniteStateError as NonFiniteStateError
from .errors import SimulationError as SimulationError
from .errors import StepSizeError as StepSizeError
from .errors import StiffnessError as StiffnessError
from .errors import SimulationInterrupted as SimulationInterrupted
from .errors import SweepInterrupted as SweepInterrupted
from .errors import UnknownOptionError as UnknownOptionError
from .errors import OptionError as OptionError
from .errors import StepLimitError as StepLimitError
from .errors import WorkLimitError as WorkLimitError
from .errors import TooManyStepsError as TooManyStepsError
from .errors import ZenoError as ZenoError
from codegen.runtime import Hyper as Hyper
from .library import ModeLibrary as ModeLibrary
from .model import HybridModel as HybridModel
from .model import InMode as InMode
from .model import InitialStateProjected as InitialStateProjected
from .model import Tolerance as Tolerance
from .modes import Mode as Mode
from .modes import ModeEquations as ModeEquations
from .parsing import parse_condition as parse_condition
from .parsing import parse_expression as parse_expression
from .resolution import Instant as Instant
from .resolution import Step as Step
from .batch import MissingDependencyError as MissingDependencyError
from .batch import RunResult as RunResult
from .batch import local_cluster as local_cluster
from .batch import simulate_many as simulate_many
from .sweep_frame import SignalMetrics as SignalMetrics
from .sweep_frame import parameter_grid as parameter_grid
from .sweep_frame import plot_sweep as plot_sweep
from .sweep_frame import to_frame as to_frame
from .simulator import METHODS as METHODS
from .expression_input import ExpressionInput as ExpressionInput
from .modelfile import ModelFileError as ModelFileError
from .modelfile import load_model as load_model
from .modelfile import save_model as save_model
from .trajectory import Trajectory as Trajectory
from .sensitivity import Sensitivities as Sensitivities
from .fitting import FitError as FitError
from .fitting import FitResult as FitResult
from .fitting import fit as fit
from .fitting import sample_indices as sample_indices
