"""Many runs of one model family: ensembles and sweeps on Dask or in-process
(:mod:`.batch`), their parameter grids and result tables (:mod:`.frame`).
"""
