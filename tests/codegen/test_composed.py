"""A caller of block functions built from its text without compiling it (issue 46).

:func:`codegen.composed.composed_function` must give the function the text
compiles to (the same outputs, the same slices, raw lists concatenated) and
refuse any text that is not exactly what :func:`codegen.source.composed_source`
writes, or that names a function it was not handed.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from codegen.composed import composed_function
from codegen.runtime import Hyper
from codegen.source import Argument, FunctionSpec, composed_source, function_source, module_namespace
from switching.simulate.real_values import failure_point

X = sp.symbols("a b c d")
RATES = sp.symbols("a_dot b_dot c_dot d_dot")
P = (sp.Symbol("k"),)
ARGS = (Argument("x", X, doc="state vector"), Argument("t", (sp.Symbol("t"),), scalar=True, doc="time [s]"),
        Argument("p", P, doc="parameters"), Argument("u", (), doc="inputs"))
RAW_ARGS = ARGS + (Argument("xdot", RATES, doc="state derivatives"),)
A, B, C, D = X
K = P[0]
OUTPUTS = (A * K + B, sp.sqrt(C ** 2 + 1), D - A, B * C, sp.exp(-D), A / (1 + B ** 2))


def _blocks(arguments, raw: bool, cuts):
    """``(caller text, {block name: text})`` of OUTPUTS split at ``cuts``."""
    texts, calls = {}, []
    for k, (start, end) in enumerate(zip((0, *cuts), (*cuts, len(OUTPUTS)))):
        name = f"_part{k}"
        spec = FunctionSpec(name, arguments, OUTPUTS[start:end], "A block.", raw=raw, brief=True)
        texts[name] = function_source(spec)
        calls.append((name, end - start))
    whole = FunctionSpec("sides_raw" if raw else "sides", arguments, OUTPUTS, "The whole.", raw=raw)
    return composed_source(whole, calls), texts


def _namespace(texts: dict) -> dict:
    namespace = module_namespace()
    for text in texts.values():
        exec(compile(text, "<block>", "exec"), namespace)
    return namespace


@pytest.mark.parametrize("cuts", [(2, 3), (1,), ()])
def test_the_built_caller_fills_out_as_the_compiled_one(cuts):
    text, texts = _blocks(ARGS, False, cuts)
    namespace = _namespace(texts)
    built = composed_function(text, {name: namespace[name] for name in texts}, "<hbg mode test>", 7)
    assert built is not None and built.__name__ == "sides" and "The whole." in built.__doc__
    assert built.__code__.co_filename == "<hbg mode test>" and built.__code__.co_firstlineno == 7
    exec(compile(text, "<caller>", "exec"), namespace)
    rng = np.random.default_rng(3)
    for _ in range(5):
        x, p = rng.normal(size=4), rng.normal(size=1)
        expected = namespace["sides"](x, 0.5, p, np.empty(0), np.full(len(OUTPUTS), np.nan))
        out = np.full(len(OUTPUTS), np.nan)
        assert built(x, 0.5, p, np.empty(0), out) is out
        assert out.tobytes() == expected.tobytes()


def test_the_built_raw_caller_concatenates_the_blocks_lists():
    text, texts = _blocks(RAW_ARGS, True, (2, 5))
    namespace = _namespace(texts)
    built = composed_function(text, {name: namespace[name] for name in texts}, "<hbg mode test>")
    exec(compile(text, "<caller>", "exec"), namespace)
    x = [Hyper(1.5, 0.3), Hyper(0.0, -1.2), Hyper(0.0, 0.7), Hyper(0.0, 2.0)]  # (a pulse on a: its outputs are linear in a)
    xdot = [Hyper(1.0, 0.0)] * 4
    got, expected = built(x, 0.1, [2.0], [], xdot), namespace["sides_raw"](x, 0.1, [2.0], [], xdot)
    assert len(got) == len(OUTPUTS)
    assert [(v.finite, v.impulse) for v in got] == [(v.finite, v.impulse) for v in expected]


@pytest.mark.parametrize("change", [
    lambda text: text.replace("out[0:2]", "out[0:1]"),  # slices that do not follow each other
    lambda text: text.replace("    return out", "    out[0] = 1.0\n    return out"),  # a statement of its own
    lambda text: text.replace("_part1(x, t, p, u, out", "print(x, t, p, u, out"),  # a function not handed in
    lambda text: text.replace("_part1(x, t, p, u, out", "_part1(x, t, p, x, out"),  # other arguments
    lambda text: text.replace('"""The whole.', '"The whole.'),  # no docstring to close
])
def test_any_other_text_is_refused(change):
    text, texts = _blocks(ARGS, False, (2, 3))
    namespace = _namespace(texts)
    changed = change(text)
    assert changed != text
    assert composed_function(changed, {name: namespace[name] for name in texts}, "<hbg mode test>") is None


def test_a_failure_in_a_block_is_traced_to_the_callers_state():
    text, texts = _blocks(ARGS, False, (2,))
    namespace = _namespace(texts)
    built = composed_function(text, {name: namespace[name] for name in texts}, "<hbg mode test>")
    x = np.array([1.0, 2.0, 3.0, -1e4])
    with pytest.raises(OverflowError) as failure:  # (exp(-d) in the second block)
        built(x, 0.25, [1.0], [], np.empty(len(OUTPUTS)))
    point = failure_point(failure.value)
    assert point is not None and point[0].tolist() == x.tolist() and point[1] == 0.25
