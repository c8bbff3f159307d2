"""The hybrid kernel of the compiled methods: flow, event location, resolution
of instants and restart, compiled once per installation by numba, in modules
by phase:

=================  ==========================================================
module             what
=================  ==========================================================
:mod:`.compiler`   numba's decorators with the kernel's options, the rules
                   compiled, the stamp of the kernel's disk cache
:mod:`.calls`      the model record and the calls of its per-mode functions
:mod:`.flow`       the steps of the methods, their interpolants, stiffness
:mod:`.events`     event location within a step
:mod:`.instants`   the resolution of an instant
:mod:`.loop`       the entry :func:`.loop.run`: the run by phase, its
                   workspaces and return codes
=================  ==========================================================
"""

#: the kernel's modules, in the order they import one another
MODULES = ("compiler", "calls", "flow", "events", "instants", "loop")
