"""The library of ready models and reusable sub-models.

Every model is a module ``models.<name>`` with

* a module docstring: the bond graph drawn in text, the automata and their
  guards (a priori / a posteriori, and why), the sign conventions, the
  signals it exposes;
* ``DEFAULTS`` — parameter name → default value (a meaningful run);
* ``build(**parameters) -> switching.HybridModel`` — unknown names are an error;
* ``RUN`` — the default run: ``t_end`` and the method options;
* ``SIGNALS`` — the named signals worth plotting.

Also: :mod:`models.components` (sub-models with ports), :mod:`models.graphs`
(plain bond graphs), :mod:`models.cli` (the ``hbg`` command).
"""

from __future__ import annotations

import importlib

#: name → module of every shipped hybrid model
MODELS = (
    "bouncing_ball",
    "diode_circuit",
    "falling_rod",
    "colliding_balls",
    "ball_chain",
    "parallel_capacitors",
    "boost_converter",
    "two_tanks",
)


def load(name: str):
    """The module of a shipped model (``-`` and ``_`` are interchangeable)."""
    key = name.replace("-", "_")
    if key not in MODELS:
        from bondgraph.errors import UnknownNameError

        raise UnknownNameError(f"unknown model {name!r}; shipped models: {', '.join(MODELS)}", name)
    return importlib.import_module(f"models.{key}")
