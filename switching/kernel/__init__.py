"""The hybrid kernel of the compiled methods: flow, event location, resolution
of instants and restart, compiled once per installation by numba, in modules
by phase.  A wing of its own beneath the mode library: the per-mode functions
the library generates are written to the kernel's calling convention
(:data:`.calls.MODE_SIGNATURE`) and call its compiled guard decision, so the
kernel sits below both the library and the simulation that runs it.

=================  ==========================================================
module             what
=================  ==========================================================
:mod:`.compiler`   numba's decorators with the kernel's options, the rules
                   compiled, the stamp of the kernel's disk cache
:mod:`.calls`      the model record and the calls of its per-mode functions
:mod:`.flow`       the steps of the methods, their interpolants, stiffness
:mod:`.implicit`   the implicit method (RODAS4P) and its linear algebra
:mod:`.events`     event location within a step
:mod:`.instants`   the resolution of an instant
:mod:`.loop`       the entry :func:`.loop.run`: the run by phase, its
                   workspaces and return codes
:mod:`.batch`      :func:`.batch.run_many`: many runs' first calls of
                   :func:`.loop.run` at once, in parallel
=================  ==========================================================
"""

#: the kernel's modules, in the order they import one another
MODULES = ("compiler", "calls", "flow", "implicit", "events", "instants", "loop", "batch")

# the entry and the names of round 2's switching.kernel module (it was one module then)
from .loop import (  # noqa: E402
    COLLAPSED as COLLAPSED, DONE as DONE, FULL as FULL, MODE_SIGNATURE as MODE_SIGNATURE, Model as Model,
    NONFINITE as NONFINITE, OPS as OPS, RESOLVE as RESOLVE, RK_A as RK_A, RK_B as RK_B, RK_C as RK_C, RK_E as RK_E,
    RK_P as RK_P, STIFF as STIFF, WORKSPACE as WORKSPACE, call as call, decide as decide, larger as larger,
    run as run, workspace_sizes as workspace_sizes,
)
