"""How the kernel's functions are compiled: numba's decorators with the
kernel's options, and the stamp of their disk cache.

A call between compiled functions costs ~20-80 ns (reference counting of its
array arguments, status checks; the model record alone is ~150 machine
words), more than the arithmetic of a small mode: small helpers taking arrays
and called at every step are inlined (:data:`inline`); the larger ones, those
called once per event or instant, and those calling a mode's function, run
without reference counting (:data:`dispatch`: their arrays are borrowed from
``run``'s workspaces).  (Inlined into ``run``, which counts references, a
function unpacking the model record costs an increment and a decrement of
every array it takes from it, at every call: 2–3× slower than calling it.)
The rules taking only numbers are plain functions (:data:`jit`): no
reference to count, and LLVM inlines them where it pays.

numba's inlining (``inline="always"``) copies a function's IR into each
caller before typing it: it is what makes the kernel's one-time compilation
long, so it is kept to the step's hot path (a helper with several call
sites, such as the interpolant ``flow.interp``, is dispatched: inlined, it
was copied into each).  Measured (a new process, empty caches, the falling
rod's first ``RK45-jit`` run): every helper inlined 37 s; the numeric rules
plain calls, the rules on arrays, the interpolant and the guard scan's
rarely reached phases dispatched, ``run`` specialised without the implicit
method (:func:`.implicit.implicit_workspaces`) 15.7 s, with the same
per-call time (``python benchmarks/compiled_speed.py``).  The guard scan's
phases that run at every step (the extrema of the parts' margins, the first
bracket) and the guards' calls at its points are inlined into
:func:`.events.event_in_step`, which counts no references: the bouncing
ball's kernel, 23 steps and 4 events, 18.1 → 16.5 µs, compiled no longer
(``benchmarks/compiled_speed.py``'s notes; inlined further, into
``flow_in_mode``, 15.1 µs, but 3 s more to compile, 9 s more for the
implicit specialisation).

The kernel calls none of numba's implementations that numba compiles from
its own Python functions (``x ** k`` of an integer ``k``, ``np.searchsorted``,
``reshape``, ``np.empty``): each keeps an environment of numba's module, which
loading the kernel from the disk cache imports (15 modules beyond ``import
numba``, ~0.1 s of a new process's first compiled run).  Squares are
products, the workspaces' 2-D views are :func:`.views.rows_of`'s
(``tests/switching/library/test_kernel_call.py`` checks a new process's
load).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from numba import njit

from codegen import decision

from .. import rules
from ..rules import bracket, instants, jumps, maximize, rosenbrock, steppers, stiffness

__all__ = ["band", "decides_as_in_flow", "dispatch", "entry", "euler_step", "finite_holds", "fixed_stiffness", "halve", "hermite_cubic",
           "inline", "instant_begin", "instant_next", "jit", "jump_pulse", "maximize_begin", "maximize_next", "narrow_begin", "narrow_next", "nearer_end", "parabola_peak", "peak_in_reach",
           "pulse_decides", "pulse_holds", "rk4_combine", "rodas_control", "rodas_dense", "stamp_with_rules",
           "switching_part", "worth_refining"]

jit = njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
entry = njit(cache=True, error_model="numpy")  # the functions Python calls
inline = njit(cache=True, error_model="numpy", inline="always")
dispatch = njit(cache=True, error_model="numpy", _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)

# the rules (switching.rules, codegen.decision), compiled as they are, once each (a rule's numba cache is kept
# beside its own file, one index per function: one compilation of each keeps it to one set of options)
maximize_begin = jit(maximize.maximize_begin)
maximize_next = jit(maximize.maximize_next)
halve = jit(bracket.halve)
narrow_begin = jit(bracket.narrow_begin)
narrow_next = jit(bracket.narrow_next)
parabola_peak = jit(bracket.parabola_peak)
peak_in_reach = jit(bracket.peak_in_reach)
worth_refining = jit(bracket.worth_refining)
switching_part = jit(bracket.switching_part)
euler_step = jit(steppers.euler_step)
rk4_combine = jit(steppers.rk4_combine)
fixed_size = jit(steppers.fixed_size)
hermite_cubic = jit(steppers.hermite_cubic)
nearer_end = jit(steppers.nearer_end)
jump_pulse = dispatch(jumps.jump_pulse)
fixed_stiffness = jit(stiffness.fixed_stiffness)
rodas_dense = jit(rosenbrock.rodas_dense)
rodas_control = jit(rosenbrock.rodas_control)
instant_begin = dispatch(instants.instant_begin)
instant_next = dispatch(instants.instant_next)
decides_as_in_flow = jit(instants.decides_as_in_flow)
band = jit(decision.band)
pulse_decides = jit(decision.pulse_decides)
pulse_holds = jit(decision.pulse_holds)
finite_holds = jit(decision.finite_holds)


def _digest():
    """SHA-256 of the sources of every kernel module and every rule module."""
    digest = hashlib.sha256()
    files = sorted(Path(__file__).resolve().parent.glob("*.py")) + [Path(module.__file__) for module in
                                                                    rules.MODULES]
    for path in files:
        digest.update(path.read_bytes())
    return digest.hexdigest()


def stamp_with_rules(namespace, module_name):
    """numba keeps a function's machine code while the function's own file is
    unchanged (its stamp: the file's time and size), but the kernel's
    functions have the rules and the other kernel modules' functions
    compiled into them: the sources of all kernel modules and all rule
    modules join the stamp of each compiled function of ``namespace`` (a
    module's globals, ``module_name`` its name), so that a change in any of
    them compiles the kernel again."""
    digest = _digest()
    for value in list(namespace.values()):
        cache_file = getattr(getattr(value, "_cache", None), "_cache_file", None)
        stamp = getattr(cache_file, "_source_stamp", None)  # (numba's own; absent in another version: then the
        # kernel's stamp is its files' alone, which an installation of a new version changes anyway)
        if stamp is not None and getattr(getattr(value, "py_func", None), "__module__", None) == module_name:
            cache_file._source_stamp = (stamp, digest)
