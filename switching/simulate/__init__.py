"""Simulation of one run: the driver (:mod:`.driver`, ``HybridModel.simulate``),
its options (:mod:`.run_options`), the integrators of a flow, event location,
resolution of instants, the compiled kernel (:mod:`.kernel`), trajectories and
plots of runs.
"""
