"""The methods of a run, one class each, in one table.

:func:`switching.simulate.driver.simulate` looks its ``method`` up in
:data:`METHOD_CLASSES` (name → class); :data:`METHODS`, the names a model
file or the command line may give, is read from that table, and so are the
names an unknown method's error lists (a name in any case: :func:`canonical_method`).  A class says
what the driver needs to know of its method:

* ``fixed_step``: steps of the given length ``dt`` [s]; else the step is
  adaptive, its local error held below ``atol + rtol·|y|`` (``rtol`` [1],
  ``atol`` [the states' units]: a number, or an array of each state's own,
  :mod:`switching.simulate.state_tolerances`), at most ``max_step`` [s], the first one
  ``first_step`` [s] (:meth:`Method.step_options`);
* ``compiled``: flows and instants run in the compiled kernel (numba),
  ``python`` the class of the same method in Python (a Python method's
  ``python`` is itself): the flows the kernel leaves to Python step with it;
* ``stiff``: an implicit method, advised where an explicit one's step
  collapses; ``chooses``: the method picks another one per run
  (``"auto"``), and is not one of :data:`METHODS`;
* :meth:`Method.stepper`: the integrator of one flow
  (:mod:`switching.simulate.integrators`).

A new method is one class given to :func:`register`.
"""

from __future__ import annotations

from typing import ClassVar

from ..errors import OptionTypeError, OptionValueError
from .integrators import RK4, Adaptive, Euler

__all__ = ["METHOD_CLASSES", "METHODS", "FIXED_STEP", "ADAPTIVE", "COMPILED", "Method", "FixedStepMethod",
           "ScipyMethod", "CompiledMethod", "canonical_method", "method_class", "method_names", "register"]

#: every method of a run by its name, in the order the error messages list them
METHOD_CLASSES: dict[str, type[Method]] = {}


class Method:
    """A method of flow integration (the class attributes; see the module)."""

    name: ClassVar[str] = ""
    fixed_step: ClassVar[bool] = False
    compiled: ClassVar[bool] = False
    stiff: ClassVar[bool] = False
    chooses: ClassVar[bool] = False
    python: ClassVar[type[Method] | None] = None
    #: how an adaptive method is described when it is given ``dt``
    adaptive_text: ClassVar[str] = "is adaptive"

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if not cls.compiled and "python" not in vars(cls):
            cls.python = cls  # a Python method flows as itself (unless it names the method it flows as)

    @classmethod
    def step_options(cls) -> tuple:
        """The options of ``simulate`` that set its steps."""
        return ("dt",) if cls.fixed_step else ("rtol", "atol", "max_step", "first_step")

    @classmethod
    def stepper(cls, fun, t0, y0, t_bound, *, dt=None, rtol=1e-6, atol=1e-9, max_step=float("inf"),
                first_step=None, autonomous=True, fun_list=None, stiffness_check=True, jac=None):
        """The integrator of ``y' = fun(t, y)`` from ``(t0, y0)`` up to
        ``t_bound`` [s] (``autonomous``: ``fun`` has no explicit dependence
        on ``t`` through inputs, which lets the fixed-step stiffness test act
        on one estimate; ``fun_list``: the same rates on lists of floats, for
        the fixed-step methods; ``stiffness_check=False``: no stiffness test;
        ``jac``: ``J(t, y) = ∂fun/∂y``, which the implicit methods use instead
        of finite differences, the others ignore).
        A method that flows as another (``python``: a compiled method's flows
        left to Python, ``auto``'s) takes that one's integrator; :func:`register`
        refuses a method that has neither."""
        return cls.python.stepper(fun, t0, y0, t_bound, dt=dt, rtol=rtol, atol=atol, max_step=max_step,
                                  first_step=first_step, autonomous=autonomous, fun_list=fun_list,
                                  stiffness_check=stiffness_check, jac=jac)


class FixedStepMethod(Method):
    """A fixed step ``dt`` [s] (the last one shortened to end at ``t_bound``)."""

    fixed_step = True
    integrator: ClassVar[type] = Euler
    #: the method's order p: a step's error is O(dt^(p+1))
    order: ClassVar[int] = 1

    @classmethod
    def stepper(cls, fun, t0, y0, t_bound, *, dt=None, rtol=1e-6, atol=1e-9, max_step=float("inf"),
                first_step=None, autonomous=True, fun_list=None, stiffness_check=True, jac=None):
        return cls.integrator(fun, t0, y0, t_bound, dt, autonomous, fun_list, stiffness_check)


class ScipyMethod(Method):
    """scipy's ``OdeSolver`` of the same name, driven step by step, its dense output the interpolant."""

    @classmethod
    def stepper(cls, fun, t0, y0, t_bound, *, dt=None, rtol=1e-6, atol=1e-9, max_step=float("inf"),
                first_step=None, autonomous=True, fun_list=None, stiffness_check=True, jac=None):
        return Adaptive(fun, t0, y0, t_bound, cls.name, rtol, atol, max_step, first_step, stiffness_check,
                        jac if cls.stiff else None)


class CompiledMethod(Method):
    """The method ``python`` in the compiled kernel: its step options, fixed
    or adaptive like it; a flow left to Python steps with ``python``."""

    compiled = True

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.python is not None:
            cls.fixed_step, cls.stiff = cls.python.fixed_step, cls.python.stiff
            cls.order = getattr(cls.python, "order", None)


def register(cls: type[Method]) -> type[Method]:
    """Add ``cls`` to :data:`METHOD_CLASSES` under ``cls.name`` (a name not
    taken yet); returns ``cls``, so it serves as a class decorator."""
    if not (isinstance(cls, type) and issubclass(cls, Method)):
        raise TypeError(f"a method is a subclass of Method, got {cls!r}")
    if not isinstance(cls.name, str) or not cls.name:
        raise ValueError(f"method class {cls.__name__} has no name")
    if cls.python is None or (cls.python is cls and vars(Method)["stepper"].__func__ is cls.stepper.__func__):
        raise TypeError(f"method class {cls.__name__} has no integrator: define stepper, or name the method it "
                        "flows as (python = ...)")
    if cls.name in METHOD_CLASSES:
        raise ValueError(f"a method {cls.name!r} is registered already ({METHOD_CLASSES[cls.name].__name__})")
    METHOD_CLASSES[cls.name] = cls
    return cls


def method_names(choosers: bool = True) -> tuple:
    """The names of the methods in the table (those that choose another method, ``auto``, last or left out)."""
    names = tuple(name for name, cls in METHOD_CLASSES.items() if not cls.chooses)
    return names + tuple(name for name, cls in METHOD_CLASSES.items() if cls.chooses) if choosers else names


def canonical_method(method):
    """The registered name ``method`` names, whatever its case (``"rk45"`` → ``"RK45"``, ``"Rodas-JIT"`` →
    ``"rodas-jit"``); anything else as it is (its error is :func:`method_class`'s)."""
    if not isinstance(method, str) or method in METHOD_CLASSES:
        return method
    folded = [name for name in METHOD_CLASSES if name.casefold() == method.strip().casefold()]
    return folded[0] if len(folded) == 1 else method


def method_class(method) -> type[Method]:
    """The class of ``method`` (a name); an unknown one raises
    :class:`~switching.errors.OptionValueError` (not text:
    :class:`~switching.errors.OptionTypeError`) listing the names."""
    cls = METHOD_CLASSES.get(method) if isinstance(method, str) else None
    if cls is None:
        text = repr(method)
        text = text if len(text) <= 60 else text[:57] + "..."
        error = OptionValueError if isinstance(method, str) else OptionTypeError
        raise error(f"unknown method {text}; choose one of: {', '.join(method_names())}", "method", method)
    return cls


# ------------------------------------------------------------------ the methods


@register
class EulerMethod(FixedStepMethod):
    """Euler's method, order 1; its interpolant the step itself (the paper's Alg. 1)."""

    name, integrator, order = "euler", Euler, 1


@register
class RK4Method(FixedStepMethod):
    """The classical Runge–Kutta method, order 4; a cubic Hermite interpolant from the end-point slopes."""

    name, integrator, order = "rk4", RK4, 4


@register
class RK45Method(ScipyMethod):
    """Dormand–Prince 5(4) (scipy's ``RK45``), Hairer's stiffness test."""

    name = "RK45"


@register
class RK23Method(ScipyMethod):
    """Bogacki–Shampine 3(2) (scipy's ``RK23``)."""

    name = "RK23"


@register
class DOP853Method(ScipyMethod):
    """Dormand–Prince 8(5,3) (scipy's ``DOP853``), Hairer's stiffness test."""

    name = "DOP853"


@register
class RadauMethod(ScipyMethod):
    """Radau IIA of order 5, implicit (scipy's ``Radau``)."""

    name, stiff = "Radau", True


@register
class BDFMethod(ScipyMethod):
    """Backward differentiation formulas of orders 1 to 5, implicit (scipy's ``BDF``)."""

    name, stiff = "BDF", True


@register
class LSODAMethod(ScipyMethod):
    """Adams/BDF switching on stiffness (scipy's ``LSODA``)."""

    name, stiff = "LSODA", True


@register
class EulerJitMethod(CompiledMethod):
    """Euler's method in the compiled kernel."""

    name, python = "euler-jit", EulerMethod


@register
class RK4JitMethod(CompiledMethod):
    """The classical Runge–Kutta method in the compiled kernel."""

    name, python = "rk4-jit", RK4Method


@register
class RK45JitMethod(CompiledMethod):
    """Dormand–Prince 5(4) in the compiled kernel."""

    name, python = "RK45-jit", RK45Method


@register
class RodasJitMethod(CompiledMethod):
    """RODAS4P, a Rosenbrock method of order 4(3), implicit, in the compiled kernel, with each mode's Jacobian
    derived symbolically (:mod:`switching.kernel.implicit`); a flow left to Python steps with ``Radau``."""

    name, python = "rodas-jit", RadauMethod


@register
class AutoMethod(Method):
    """``RK45`` compiled or not, chosen per run
    (:func:`switching.library.jit_model.choose_method`; the statistics say which and why)."""

    name, chooses = "auto", True
    python = RK45Method  # its flows in Python (when it does not choose the compiled kernel)
    adaptive_text = "chooses between 'RK45' and 'RK45-jit' (adaptive)"


#: the names of the methods a run may be given besides ``"auto"`` (those of the table when it was built)
METHODS = method_names(choosers=False)
FIXED_STEP = tuple(name for name in METHODS if not METHOD_CLASSES[name].compiled and METHOD_CLASSES[name].fixed_step)
ADAPTIVE = tuple(name for name in METHODS if not METHOD_CLASSES[name].compiled and not METHOD_CLASSES[name].fixed_step)
COMPILED = tuple(name for name in METHODS if METHOD_CLASSES[name].compiled)
