"""The hybrid kernel of the compiled methods: flow, event location, resolution
of instants and restart, compiled once per installation by numba.
"""
