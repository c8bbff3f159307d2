"""Switching semantics: local automata, modes, mode resolution (mythical modes,
pinnacles), the hybrid simulator and trajectories.

Not built yet: this package is filled by the switching-semantics work (see the
project's issues); it depends on :mod:`bondgraph` and :mod:`codegen`.
"""
