"""Switching semantics: local automata, modes, mode resolution (mythical
modes, pinnacles, divergence of time), impulsive signals.

Example — see :mod:`switching.model.hybrid_model` and :mod:`switching.model.automaton`.
"""

from . import moved

moved.install()

from .model.automaton import A_POSTERIORI as A_POSTERIORI
from .model.automaton import A_PRIORI as A_PRIORI
from .model.automaton import Automaton as Automaton
from .model.automaton import Transition as Transition
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
from .library.mode_library import ModeLibrary as ModeLibrary
from .model.hybrid_model import HybridModel as HybridModel
from .model.hybrid_model import InMode as InMode
from .model.hybrid_model import InitialStateProjected as InitialStateProjected
from .model.hybrid_model import Tolerance as Tolerance
from .model.modes import Mode as Mode
from .model.modes import ModeEquations as ModeEquations
from .language.parsing import parse_condition as parse_condition
from .language.parsing import parse_expression as parse_expression
from .simulate.resolution import Instant as Instant
from .simulate.resolution import Step as Step
from .sweep.batch import MissingDependencyError as MissingDependencyError
from .sweep.batch import RunResult as RunResult
from .sweep.batch import local_cluster as local_cluster
from .sweep.batch import simulate_many as simulate_many
from .sweep.kernel_batch import BatchResult as BatchResult
from .sweep.kernel_batch import simulate_batch as simulate_batch
from .sweep.frame import SignalMetrics as SignalMetrics
from .sweep.frame import parameter_grid as parameter_grid
from .sweep.frame import plot_sweep as plot_sweep
from .sweep.frame import to_frame as to_frame
from .simulate.driver import METHODS as METHODS
from .model.expression_input import ExpressionInput as ExpressionInput
from .files.modelfile import ModelFileError as ModelFileError
from .files.modelfile import load_model as load_model
from .files.modelfile import save_model as save_model
from .files.fmu import to_fmu as to_fmu
from .simulate.trajectory import Trajectory as Trajectory
from .analysis.sensitivity import Sensitivities as Sensitivities
from .analysis.fitting import FitError as FitError
from .analysis.fitting import FitResult as FitResult
from .analysis.fitting import fit as fit
from .analysis.fitting import sample_indices as sample_indices
from .analysis.orbits import PeriodicOrbit as PeriodicOrbit
from .analysis.orbits import periodic_orbit as periodic_orbit
from .analysis.linear import orbit_small_signal as orbit_small_signal
from .analysis.linear import state_space as state_space
from bondgraph.linear_system import LinearSystem as LinearSystem
from .errors import OrbitError as OrbitError
from .errors import OrbitConvergenceError as OrbitConvergenceError
from .errors import OrbitArgumentError as OrbitArgumentError
from .errors import NoOrbitError as NoOrbitError
from .errors import ModeSequenceChangedError as ModeSequenceChangedError
from .errors import GrazingError as GrazingError
from .errors import ContinuationError as ContinuationError
from .analysis.continuation import Bifurcation as Bifurcation
from .analysis.continuation import Continuation as Continuation
from .analysis.continuation import continue_orbit as continue_orbit

# the model's methods reach the floors above it through these (switching.model.services)
from .model.services import provide as _provide  # noqa: E402
from .library.mode_library import ModeLibrary as _ModeLibrary  # noqa: E402
from .simulate.driver import check_option_names as _check_option_names, simulate as _simulate  # noqa: E402
from .simulate.run_options import check_sensitivity_options as _check_sensitivity_options  # noqa: E402
from .simulate.resolution import resolve_instant as _resolve_instant  # noqa: E402


def _simulate_with_sensitivities(*args, **kwargs):
    from .analysis.sensitivity_run import simulate_with_sensitivities

    return simulate_with_sensitivities(*args, **kwargs)


def _verify(*args, **kwargs):  # (scipy.optimize, 0.27 s, imported when a model is first verified)
    from .analysis.verify import verify

    return verify(*args, **kwargs)


_provide(library=_ModeLibrary, simulate=_simulate, check_option_names=_check_option_names,
         check_sensitivity_options=_check_sensitivity_options, resolve_instant=_resolve_instant,
         simulate_with_sensitivities=_simulate_with_sensitivities, verify=_verify, save=save_model,
         periodic_orbit=periodic_orbit, state_space=state_space)
