"""How the kernel's functions are compiled: numba's decorators with the
kernel's options, and the stamp of their disk cache.

A call between compiled functions costs ~20-80 ns (reference counting of its
array arguments, status checks; the model record alone is ~150 machine
words), more than the arithmetic of a small mode: small helpers are inlined
(:data:`inline`); the larger ones, and those calling a mode's function, run
without reference counting (:data:`dispatch`: their arrays are borrowed from
``run``'s workspaces).  (Inlined into ``run``, which counts references, a
function unpacking the model record costs an increment and a decrement of
every array it takes from it, at every call: 2–3× slower than calling it.)
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from numba import njit

from codegen import decision

from .. import rules
from ..rules import bracket, instants, jumps, maximize, rosenbrock, steppers, stiffness

__all__ = ["band", "decides_as_in_flow", "dispatch", "entry", "euler_step", "finite_holds", "fixed_stiffness", "halve", "hermite_cubic",
           "inline", "instant_begin", "instant_next", "jit", "jump_pulse", "maximize_begin", "maximize_next", "parabola_peak", "peak_in_reach",
           "pulse_decides", "pulse_holds", "rk4_combine", "rodas_control", "rodas_dense", "stamp_with_rules",
           "worth_refining"]

jit = njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
entry = njit(cache=True, error_model="numpy")  # the functions Python calls
inline = njit(cache=True, error_model="numpy", inline="always")
dispatch = njit(cache=True, error_model="numpy", _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)

# the rules (switching.rules, codegen.decision), compiled as they are, once each (a rule's numba cache is kept
# beside its own file, one index per function: one compilation of each keeps it to one set of options)
maximize_begin = inline(maximize.maximize_begin)
maximize_next = inline(maximize.maximize_next)
halve = inline(bracket.halve)
parabola_peak = inline(bracket.parabola_peak)
peak_in_reach = inline(bracket.peak_in_reach)
worth_refining = inline(bracket.worth_refining)
euler_step = inline(steppers.euler_step)
rk4_combine = inline(steppers.rk4_combine)
hermite_cubic = inline(steppers.hermite_cubic)
jump_pulse = inline(jumps.jump_pulse)
fixed_stiffness = inline(stiffness.fixed_stiffness)
rodas_dense = inline(rosenbrock.rodas_dense)
rodas_control = inline(rosenbrock.rodas_control)
instant_begin = inline(instants.instant_begin)
instant_next = inline(instants.instant_next)
decides_as_in_flow = inline(instants.decides_as_in_flow)
band = inline(decision.band)
pulse_decides = inline(decision.pulse_decides)
pulse_holds = inline(decision.pulse_holds)
finite_holds = inline(decision.finite_holds)


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
