"""The semantics written once (DESIGN §2, §6): each *rule* is a plain function
in the subset of Python that numba compiles — arguments and results are
floats, integers, booleans, tuples of them and numpy arrays; no Python
objects, no callables, no allocation of Python containers.

The Python path calls a rule as it is; the compiled kernel
(:mod:`switching.kernel`) compiles the very same function object
(``njit(rule)``), so a fix made here lands in both engines at once and the
two give the same results to the bit wherever they run the same arithmetic.
A rule that needs a value only its caller can compute (a guard's margin at a
time, the rates at a stage) does not take a callable: it returns what it
needs evaluated next and is called again with the value (*reverse
communication*), so the Python path can evaluate with Python objects and the
kernel through its function pointers.

Each rule module lists its rules in ``RULES``; ``tests/switching/rules/test_rules.py`` fails
when a function of one of those names (or of the module's) is defined
anywhere else in the packages.  This package imports nothing but the standard library, numpy and
:mod:`codegen.decision`: the guards' comparison is a rule that lives on codegen's floor, because
:func:`codegen.runtime.decide` calls it and codegen imports nothing of ``switching``.

==============================  ===============================================
module                          rules
==============================  ===============================================
:mod:`.maximize`                Brent's maximisation of a margin on an interval
:mod:`.steppers`                Euler's step, the classical RK4 step, its Hermite interpolant
:mod:`.jumps`                   the pulse at a jump: ``x⁺ − x`` without round-off
:mod:`.bracket`                 event bracketing: which margins to refine, narrowing to adjacent floats
:mod:`.stiffness`               the fixed-step methods' stiffness verdict on an estimate of ``|h·λ|``
:mod:`.rosenbrock`              RODAS4's tableau, its continuous extension and its step-size control
:mod:`.instants`                the resolution of an instant: mythical modes, pinnacles, divergence of time
:mod:`codegen.decision`         the guards' comparison: its round-off band and decision, the larger scale
==============================  ===============================================
"""

from codegen import decision as decision

from . import bracket as bracket
from . import instants as instants
from . import jumps as jumps
from . import maximize as maximize
from . import rosenbrock as rosenbrock
from . import steppers as steppers
from . import stiffness as stiffness

#: the rule modules (each with its ``RULES``)
MODULES = (maximize, bracket, steppers, jumps, stiffness, rosenbrock, instants, decision)
