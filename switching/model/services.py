"""What a model asks of the wings above it, without importing them.

A :class:`~switching.model.hybrid_model.HybridModel` is a definition; its
convenience methods reach the floors built on it: its mode library
(:mod:`switching.library`), a run (:mod:`switching.simulate`), the
divergence-of-time check and sensitivities (:mod:`switching.analysis`), and
model files (:mod:`switching.files`).  So that the dependencies run one way
(DESIGN §2: ``model`` below ``library``, ``simulate``, ``analysis``, ``files``),
``model/`` imports none of them: each registers its functions here with
:func:`provide` when :mod:`switching` is imported (``switching/__init__.py``),
and the model's methods call :data:`SERVICES`.  Importing any module of the
toolkit imports :mod:`switching` first, so the services are always in place.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields


def _missing(name: str) -> Callable:
    def missing(*args, **kwargs):
        raise RuntimeError(f"the model's {name!r} service is not registered: import switching (its __init__ "
                           "registers the library, the simulator, the analyses and model files)")
    return missing


@dataclass
class Services:
    """The functions a model calls on the floors above it (each registered by its wing)."""

    #: ``library(model) -> ModeLibrary`` (:mod:`switching.library`)
    library: Callable = _missing("library")
    #: ``simulate(model, t_end, method, **options) -> Trajectory`` (:mod:`switching.simulate.driver`)
    simulate: Callable = _missing("simulate")
    #: ``check_option_names(options)``: unknown keywords refused, the known ones named
    check_option_names: Callable = _missing("check_option_names")
    #: ``check_sensitivity_options(sensitivities, rtol, atol)``
    check_sensitivity_options: Callable = _missing("check_sensitivity_options")
    #: ``simulate_with_sensitivities(model, t_end, method, sensitivities, options, rtol, atol)`` (:mod:`switching.analysis`)
    simulate_with_sensitivities: Callable = _missing("simulate_with_sensitivities")
    #: ``resolve_instant(model, x, mode, t, max_steps) -> Instant`` (:mod:`switching.simulate.resolution`)
    resolve_instant: Callable = _missing("resolve_instant")
    #: ``verify(model, samples=, seed=, max_modes=, scale=)`` (:mod:`switching.analysis.verify`)
    verify: Callable = _missing("verify")
    #: ``periodic_orbit(model, period, **options) -> PeriodicOrbit`` (:mod:`switching.analysis.orbits`)
    periodic_orbit: Callable = _missing("periodic_orbit")
    #: ``state_space(model, mode, outputs, inputs, numeric)`` (:mod:`switching.analysis.linear`)
    state_space: Callable = _missing("state_space")
    #: ``save(model, path, **options)`` (:mod:`switching.files.modelfile`)
    save: Callable = _missing("save")


#: the one registry of the process
SERVICES = Services()


def provide(**functions: Callable) -> None:
    """Register ``functions`` by their service names (an unknown name is an error)."""
    known = {f.name for f in fields(Services)}
    for name, function in functions.items():
        if name not in known:
            raise TypeError(f"no model service {name!r}; services: {', '.join(sorted(known))}")
        setattr(SERVICES, name, function)
