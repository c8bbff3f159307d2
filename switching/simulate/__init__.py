"""Simulation of one run: the driver (:mod:`.driver`, ``HybridModel.simulate``),
the table of its methods (:mod:`.methods`), its options checked
(:mod:`.run_options`) and grouped (:mod:`.option_groups`), the flows in Python
(:mod:`.python_flow`, :mod:`.flow_rates`, the integrators) and in the compiled
kernel (:mod:`.compiled_flow`, :mod:`.kernel`), event location, resolution of
instants, the record and trajectories, plots of runs.
"""
