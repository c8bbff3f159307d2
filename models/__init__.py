"""The library of ready models and reusable sub-models.

* :mod:`models.components` — sub-models with ports (mass–spring–damper cell,
  RLC cell, rigid planar body);
* :mod:`models.graphs` — ready bond graphs (series RLC, chains, pivoting rod,
  switched circuits);
* :mod:`models.cli` — the ``hbg`` command.
"""
