"""The flow's Jacobian compiled for the kernel's implicit method (``rodas-jit``).

For each mode the implicit method visits, one C function of the per-mode
signature :data:`switching.kernel.loop.MODE_SIGNATURE` whose operation 6
writes the flow's Jacobian

    J[i, j] = ∂ẏ_i/∂y_j      (``k × k``, row-major, units of ``ẏ_i/y_j``)

at the independent states ``y`` (its pointer ``x_``), ``t``, the
parameters ``p`` and the inputs' parameters ``u``, and for a model driven by
inputs the flow's time derivative ``∂ẏ_i/∂t`` after it (``out[k·k + i]``,
units of ``ẏ_i`` per second): the structurally nonzero
entries derived symbolically through the mode's constraints
(:func:`switching.library.jacobian.jacobian_entries`, within the symbolic
budget of :mod:`bondgraph.budget`), inputs given as expressions of ``t``
substituted, the other entries 0 (zeroed unless the selector ``which_`` is 1:
the kernel's buffer holds them from the flow's first call).  With ``which_``
2 it writes the pattern instead: 1 at each structurally nonzero entry, 0
elsewhere (an entry outside it is 0 at every state and time).  It is a function of its own, apart from
the mode's function (:mod:`.jit_model`), so that the explicit methods neither
derive nor compile it.  A mode whose Jacobian runs past the budget has none
(address 0): the kernel then differences ``f``.

Sources are cached like the mode functions' (key: the model's fingerprint,
the mode, the inputs), their machine code by :func:`codegen.machine.machine_function`.
"""

from __future__ import annotations

import re

import sympy as sp

from bondgraph import budget
from bondgraph.inverse import slope_of
from codegen.cache import fingerprint
from codegen.machine import machine_function
from codegen.source import Argument, docstring, inverse_helpers

from .jacobian import flow_rate, jacobian_entries
from .jit_model import (GENERATOR_VERSION, MODE_DIALECT, generated_statements, input_substitution, inputs_key,
                        mode_calls, mode_signature, parameter_names)

__all__ = ["JACOBIAN_FUNCTION_VERSION", "OP_JAC", "jacobian_function", "jacobian_function_source"]

JACOBIAN_FUNCTION_VERSION = "4"  # part of the cache key: change it when the generated functions change
OP_JAC = 6  # switching.kernel.calls.OPS["jac"]


def _key(model, mode) -> str:
    return fingerprint(model.fingerprint, "jacobian function", JACOBIAN_FUNCTION_VERSION, GENERATOR_VERSION,
                       mode.label, *inputs_key(model))


def jacobian_function_source(model, mode) -> str | None:
    """The module of ``mode``'s compiled Jacobian (see the module docstring),
    or ``None`` when the mode has no independent state or its derivation
    runs past the symbolic budget."""
    cm = model.compiled_mode(mode)
    independent = tuple(int(i) for i in cm.independent)
    if not independent:
        return None
    try:
        rows, cols, entries = budget.run(f"the flow's Jacobian in mode {mode.describe()}", jacobian_entries, model,
                                         mode, independent)
    except budget.OverBudget:
        return None
    inputs, input_parameters, _ = input_substitution(model)
    k = len(independent)
    arguments = (Argument("y", tuple(model.states[i] for i in independent)),
                 Argument("t", (model.time,), scalar=True), Argument("p", tuple(model.parameter_symbols)),
                 Argument("u", input_parameters))
    place = [r * k + c for r, c in zip(rows, cols)]  # output j → its place in the row-major matrix
    size = k * k
    if inputs:  # ∂ẏ/∂t through the inputs (expressions of t)
        me = model.mode_equations(mode)
        for i, state in enumerate(model.states[j] for j in independent):
            derivative = slope_of(sp.sympify(flow_rate(me, state)).xreplace(inputs), model.time)  # (no δ)
            if derivative != 0:
                place.append(k * k + i)
                entries = [*entries, derivative]
        size = k * k + k
    laws: dict = {}  # the numeric inverses the entries call (codegen.inverse), defined in the module
    statements = generated_statements(inputs, "jac", arguments, entries, laws=laws) if entries else []
    statements = [re.sub(r"\bout\[(\d+)\]", lambda found: f"out[{place[int(found.group(1))]}]", line)
                  for line in statements]
    P = parameter_names({"jac": statements + ["for k in range(1):"]})
    omega = any(re.search(r"\bwrightomega\(", line) for line in statements)
    label = mode.describe()
    n_par = max(len(model.parameter_symbols), 1)
    n_u = max(len(input_parameters), 1)
    lines = [
        docstring([f"Compiled Jacobian of the flow in mode {label} of model {model.name!r} (generated; do not "
                   "edit)."], ""),
        "import math",
        "from math import *",
        "import numpy as np",
        "from numba import carray",
        *(["from codegen.compiled_omega import wrightomega"] if omega else []),  # (Lambert's W, where called)
        *(["from numba import njit"] if laws else []),
        "",
        "",
        *[helper + "\n\n" for helper in inverse_helpers([laws[name] for name in sorted(laws)], compiled=True)],
        f"def mode({P['op_']}, {P['which_']}, t, rtol, atol, {P['x_']}, {P['xp_']}, {P['p_']}, {P['u_']}, "
        f"{P['d_']}, {P['s_']}, {P['post_']}, {P['target_']}, {P['q_']}, {P['out_']}):",
        docstring([f"Mode {label}: ``{P['op_']}`` {OP_JAC}: the flow's Jacobian ∂(dy/dt)/∂y at the independent "
                   f"states y (``{P['x_']}``, {k}) into ``{P['out_']}`` ({k}×{k}, row-major;",
                   "then ∂(dy/dt)/∂t when inputs drive the flow), the other entries zeroed first unless "
                   f"``{P['which_']}`` is 1 (they hold zeros from a call before); ``{P['which_']}`` 2: the "
                   "pattern (1 at each structural nonzero); returns 1 (0 for another operation).",
                   f"Array sizes: K {k}, NPAR {n_par}, NU {n_u}."]),
        f"    p = carray({P['p_']}, ({n_par},))",
        f"    u = carray({P['u_']}, ({n_u},))",
        f"    if {P['op_']} == {OP_JAC}:",
        f"        y = carray({P['x_']}, ({k},))",
        f"        out = carray({P['out_']}, ({size},))",
        f"        if {P['which_']} != 1:",
        f"            for k in range({size}):",
        "                out[k] = 0.0",
        f"        if {P['which_']} == 2:",
    ]
    lines += [f"            out[{j}] = 1.0" for j in sorted(set(place))] + ["            return 1"]
    lines += ["        " + line for line in statements]
    lines += ["        return 1", "    return 0"]
    return "\n".join(lines) + "\n"


def jacobian_function(model, mode):
    """The compiled Jacobian of ``mode`` (a :class:`codegen.backends.CompiledFunction`
    whose ``address`` the kernel calls with operation 6), or ``None`` (see
    :func:`jacobian_function_source`): its source from the cache, else
    generated and cached, its machine code as a mode function's."""
    key = _key(model, mode)
    source = model.cache.load(key, MODE_DIALECT)
    if source is None:
        source = jacobian_function_source(model, mode)
        if source is None:
            return None
        model.cache.store(key, source)
    directory = model.cache.directory / "jit" if model.cache.directory is not None else None
    return machine_function(source, "mode", mode_signature(), f"hbg_jac_{key}", dialect=MODE_DIALECT,
                            calls=mode_calls(), directory=directory,
                            describe=f"the Jacobian of mode {mode.describe()} of model {model.name!r}")
