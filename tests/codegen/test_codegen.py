"""Generated code: agreement with lambdified sympy, caches, export."""

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import sympy as sp
from switching_models import ball_row, diode_circuit, falling_rod

from bondgraph import CausalityConflictError
from codegen.cache import SourceCache
from codegen.runtime import Hyper, hyper
from models import bouncing_ball
from checkout import ROOT



def all_modes(model):
    import itertools

    for states in itertools.product(*[list(a.states) for a in model.automata]):
        yield model.mode(states)


@pytest.mark.parametrize("build", [falling_rod, diode_circuit, lambda: ball_row([1.0, 2.0, 3.0], 0.7)])
def test_generated_code_agrees_with_lambdified_sympy_in_every_mode(build):
    model = build()
    rng = np.random.default_rng(0)
    states, t, params = list(model.states), model.time, list(model.parameter_symbols)
    for mode in all_modes(model):
        try:
            me = model.mode_equations(mode)
        except CausalityConflictError:
            continue  # e.g. the diode circuit with switch and diode both on: two sources on one node
        cm = model.compiled_mode(mode)
        for _ in range(5):
            x = rng.normal(size=len(states))
            x[-1] = rng.uniform(0.2, 1.3)  # keep angles away from singular points
            tt = rng.uniform(0, 2)
            reference = sp.lambdify([states, t, params], [me.f[s] for s in states])(x, tt, model.parameter_array)
            np.testing.assert_allclose(cm.rates(x, tt), reference, rtol=1e-12, atol=1e-12)
            if cm.jump_kind == "identity":
                np.testing.assert_array_equal(cm.jump(x, tt), x)
            elif me.g is not None:
                ref_g = sp.lambdify([states, t, params], [me.g[s] for s in states])(x, tt, model.parameter_array)
                generated = cm._jump(x, tt, model.parameter_array, [], np.empty(len(states)))
                np.testing.assert_allclose(generated, ref_g, rtol=1e-12, atol=1e-12)
            dependent = list(me.equations.dependent)
            if dependent:
                ref_phi = sp.lambdify([states, t, params], [me.equations.constraints[s] for s in dependent])(
                    x, tt, model.parameter_array
                )
                full = cm.complete(x.copy(), tt)
                np.testing.assert_allclose(full[cm.dependent], ref_phi, rtol=1e-12, atol=1e-12)
            sides = cm.sides(x, tt)
            relations = [r for g in me.guards for r in _relations(g.condition)]
            for k, rel in enumerate(relations):
                ref_side = sp.lambdify([states, t, params], [me.finite(rel.lhs), me.finite(rel.rhs)])(
                    x, tt, model.parameter_array
                )
                np.testing.assert_allclose(sides[3 * k : 3 * k + 2], ref_side, rtol=1e-12, atol=1e-12)
                free = me.finite(rel.lhs).free_symbols | me.finite(rel.rhs).free_symbols
                if t in free and free <= {t, *params}:  # a clock: no scale (switching.library.compiled.comparison_triples)
                    assert sides[3 * k + 2] == 0
                else:  # the round-off scale max(R(left), R(right)) bounds both sides' sizes
                    assert sides[3 * k + 2] >= max(abs(v) for v in ref_side) * (1 - 1e-15)
                # raw sides with no pulse reduce to the finite ones
            raw = [hyper(h) for h in cm.sides_impulsive(x, x, tt)]
            np.testing.assert_allclose([h.finite for h in raw], sides, rtol=1e-12, atol=1e-12)
            assert all(h.impulse == 0 for h in raw)


def _relations(condition):
    from sympy.core.relational import Relational

    if isinstance(condition, Relational):
        return [condition]
    return [r for a in getattr(condition, "args", ()) for r in _relations(a)]


def test_generated_source_is_readable_and_documented():
    source = falling_rod().mode_source("stuck")
    assert "def rates(x, t, p, u, out):" in source and "x[5] = rod/theta" in source
    assert "rod_theta = x[5]" in source  # sanitized identifiers only
    assert "/" not in "".join(line.split("=")[0] for line in source.splitlines() if line.startswith("    _c"))
    compile(source, "<check>", "exec")


def test_fingerprints_are_the_same_in_every_process(tmp_path):
    """Issue 21: a model's fingerprint (its disk-cache key) does not depend on
    the process: not on sympy's Dummy indices (resistors' laws hold one), nor
    on Python's hash seed.  Two processes with different seeds, one of them
    creating Dummies first, give the same key for every shipped model."""
    script = textwrap.dedent(
        """
        import json, sys
        import sympy as sp
        [sp.Dummy() for _ in range(int(sys.argv[1]))]
        import models
        print(json.dumps({name: models.load(name).build().fingerprint for name in models.MODELS}))
        """
    )
    runs = []
    for seed, dummies in (("1", "0"), ("2", "17")):
        env = {**os.environ, "HBG_CACHE_DIR": str(tmp_path), "PYTHONPATH": str(ROOT), "PYTHONHASHSEED": seed}
        done = subprocess.run([sys.executable, "-c", script, dummies], cwd=ROOT, env=env, capture_output=True,
                              text=True, check=True, timeout=600)
        runs.append(json.loads(done.stdout))
    assert runs[0] == runs[1]
    assert len(set(runs[0].values())) == len(runs[0])  # and different models differ


def test_disk_cache_is_reused_by_a_second_process(tmp_path):
    script = textwrap.dedent(
        """
        import json, sys, time
        sys.path.insert(0, "tests")
        t0 = time.perf_counter()
        from switching_models import falling_rod
        model = falling_rod()
        built = time.perf_counter()
        for mode in ("free", "stuck"):
            model.compiled_mode(mode)
        done = time.perf_counter()
        print(json.dumps({"derived": model.derivation_count, "compile_s": done - built, "hits": model.cache.hits}))
        """
    )
    env = {**os.environ, "HBG_CACHE_DIR": str(tmp_path), "PYTHONPATH": str(ROOT)}
    runs = [
        json.loads(subprocess.run([sys.executable, "-c", script], cwd=ROOT, env=env, capture_output=True, text=True,
                                  check=True, timeout=300).stdout)
        for _ in range(2)
    ]
    first, second = runs
    assert first["derived"] == 2 and first["hits"]["built"] == 2
    assert second["derived"] == 0 and second["hits"]["disk"] == 2  # no symbolic work at all
    assert second["compile_s"] < first["compile_s"]
    print(f"mode generation: first process {first['compile_s']:.3f} s, second {second['compile_s']:.4f} s")


def test_corrupted_cache_file_is_detected_and_rebuilt(tmp_path):
    cache = SourceCache(tmp_path)
    cache.store("k1", "RECORD = 1\n")
    assert SourceCache(tmp_path).load("k1") == "RECORD = 1\n"
    path = tmp_path / "k1.py"
    path.write_text(path.read_text().replace("RECORD = 1", "RECORD = 2"))  # tampered: checksum mismatch
    fresh = SourceCache(tmp_path)
    assert fresh.load("k1") is None and fresh.hits["rejected"] == 1
    path.write_text("garbage without header")
    assert SourceCache(tmp_path).load("k1") is None
    # through a model: a corrupted mode file is regenerated and works
    model = bouncing_ball.build()
    model.cache = SourceCache(tmp_path)
    model.compiled_mode("flight")
    (file,) = [p for p in tmp_path.glob("*.py") if p.name != "k1.py"]
    file.write_text(file.read_text()[:-40])
    again = bouncing_ball.build()
    again.cache = SourceCache(tmp_path)
    cm = again.compiled_mode("flight")
    assert again.cache.hits["rejected"] == 1 and again.cache.hits["built"] == 1
    assert cm.rates(np.array([0.0, 1.0]), 0.0)[0] == pytest.approx(-9.81)


def test_export_runs_without_sympy(tmp_path):
    model = bouncing_ball.build()
    model.simulate(1.0, "RK45")
    labels = model.export_module(tmp_path / "ball_modes.py")
    assert set(labels) == {"flight", "impact"}
    check = textwrap.dedent(
        """
        import sys
        sys.modules["sympy"] = None  # importing sympy would now fail
        sys.modules["numpy"] = None
        sys.path.insert(0, sys.argv[1])
        import ball_modes as m
        flight = m.MODES["flight"]
        out = [0.0, 0.0]
        flight["rates"]([0.0, 1.0], 0.0, m.PARAMETER_VALUES, [], out)
        assert abs(out[0] + 9.81) < 1e-12 and out[1] == 0.0
        impact = m.MODES["impact"]
        plus = impact["jump"]([-4.0, 0.0], 0.0, m.PARAMETER_VALUES, [], [0.0, 0.0])
        assert abs(plus[0] - 3.2) < 1e-12
        sides = flight["sides_raw"]([-4.0, 0.0], 0.0, m.PARAMETER_VALUES, [], [m.Hyper(0, -9.81), m.Hyper(0, -4.0)])
        print("ok", len(m.MODES))
        """
    )
    out = subprocess.run([sys.executable, "-c", check, str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["ok", "2"]


def test_trajectory_signals_use_generated_code():
    model = falling_rod()
    trajectory = model.simulate(0.3, "RK45", rtol=1e-8)
    tip = trajectory.signal("tip_y")
    y, th = trajectory.state("rod/y"), trajectory.state("rod/theta")
    np.testing.assert_allclose(tip, y - 0.5 * np.sin(th), rtol=1e-13, atol=1e-15)


def test_hyper_runtime_matches_the_impulse_formula():
    """Raw signal evaluated with Hyper state derivatives gives a(x)ᵀΔx as its pulse."""
    model = falling_rod()
    cm = model.compiled_mode("stuck")
    x = np.array([0.3, -1.2, 0.4, 0.0, 0.2, 0.9])
    plus = cm.jump(x, 0.0)
    sides = cm.sides_impulsive(x, plus, 0.0)
    # normal_force <= 0: left side is -e_tip_y = dp_y/dt + m g → its pulse is Δp_y
    assert sides[0].impulse == pytest.approx(plus[1] - x[1], rel=1e-14)
    assert isinstance(sides[0], Hyper)


@pytest.mark.parametrize("build", [falling_rod, lambda: ball_row([1.0, 2.0, 3.0], 0.7)])
def test_a_mode_made_now_and_one_read_from_its_source_are_the_same(build):
    """A mode generated in this process keeps the META it printed; one read
    from the cache parses the printed text: both must be the same value.
    Its functions, compiled when first used, report the source's own line
    numbers."""
    import ast
    import traceback

    from codegen.cache import SourceCache
    from switching.library.compiled import CompiledMode, _function_chunks

    model = build()
    model.cache = SourceCache(None)
    model.simulate(0.5, "RK45")
    for mode in model.visited_modes:
        made = model.compiled_mode(mode)
        assert made.meta == ast.literal_eval(_function_chunks(made.source)["META"])
        read = CompiledMode(model, mode, made.source)
        assert read.meta == made.meta
        x = model.initial_state()
        np.testing.assert_array_equal(read.rates(x, 0.1), made.rates(x, 0.1))
        np.testing.assert_array_equal(read.sides(x, 0.1), made.sides(x, 0.1))
        try:
            read._rates(x, 0.1, None, [], None)  # no parameters: fails inside the generated code
        except TypeError:
            frame = traceback.extract_tb(sys.exc_info()[2])[-1]
            assert frame.filename == f"<hbg mode {mode.label}>"
            assert "p[" in made.source.splitlines()[frame.lineno - 1]
        else:
            raise AssertionError("the generated rates ran without parameters")


def test_text_shared_between_functions_names_only_temporaries_each_assigns():
    """The printer rebuilds nodes (``b**2`` of the denominator of ``a*b**-2``) that may equal a temporary
    of one function; its text, reused for another function without that temporary, named a variable
    the other never assigned (a bridge with line resistance and diode ``r_on`` stopped on it)."""
    from codegen.source import Argument, FunctionSpec, PrintMemo, function_source, module_namespace

    a, b, c = sp.symbols("a b c", positive=True)
    arguments = (Argument("x", (a, b, c)),)
    memo = PrintMemo()
    both = FunctionSpec("both", arguments, (a / b**2, sp.sin(b**2), sp.cos(b**2)))
    alone = FunctionSpec("alone", arguments, (a / b**2,))
    values = np.array([2.0, 3.0, 5.0])
    for spec in (both, alone, both):
        namespace = dict(module_namespace())
        exec(compile(function_source(spec, memo), "<test>", "exec"), namespace)
        out = namespace[spec.name](values, np.zeros(len(spec.outputs)))
        assert out[0] == pytest.approx(2.0 / 9.0, rel=1e-15)


def test_a_jump_told_which_states_it_may_move_is_the_text_of_one_compared_state_by_state():
    """A jump's outputs are mostly its states themselves: told which may differ (``differs``), the
    generator writes the very text it writes comparing every output — for a scene's jump, a small
    model's, a jump with a moved state that stays, and one with too few copies for the slice copy."""
    import dataclasses

    from codegen.source import COPY_MIN, Argument, FunctionSpec, PrintMemo, function_source
    from models import ball_chain

    chain = ball_chain.build(N=40, e=1.0)
    row = ball_row([1.0, 2.0, 3.0], 0.7)
    cases = []
    for model in (chain, row):
        model.simulate(0.6, "RK45", rtol=1e-9)
        for mode in model.visited_modes:
            me = model.mode_equations(mode)
            if me.g is not None and not me.jump.is_identity:
                states = list(model.states)
                cases.append((tuple(states), tuple(me.g[s] for s in states)))
    assert len(cases) > 3
    x = sp.symbols(f"x0:{COPY_MIN + 4}")
    cases.append((x, (x[0] + x[1], *x[1:])))  # (x[1] among the outputs that may move, yet itself)
    cases.append((x[:4], (x[1], x[0], x[2], x[3] * 2)))  # (fewer outputs that stay than a slice copy needs)
    for states, outputs in cases:
        spec = FunctionSpec("jump", (Argument("x", states),), outputs, "x+", copy_of="x")
        moved = tuple(k for k, (o, s) in enumerate(zip(outputs, states)) if o is not s)
        told = dataclasses.replace(spec, differs=moved + ((1,) if len(states) > 2 else ()))
        assert function_source(told, PrintMemo()) == function_source(spec, PrintMemo())


# ------------------------------------------------------------------ the unit step


def test_heaviside_prints_as_the_unit_step_on_every_path():
    """``Heaviside(x, h0)``: 0 below 0, 1 above, ``h0`` at ±0 (1 for the text's ``step``), NaN for NaN,
    in the module the checker passes, on Python floats, on numpy scalars and (raw) on ``Hyper``
    values, where a pulse's sign decides."""
    from codegen.safety import check_source, execute
    from codegen.source import Argument, FunctionSpec, function_source, module_namespace

    x = sp.Symbol("x")
    outputs = (sp.Heaviside(x, 1), sp.Heaviside(x), sp.Heaviside(3 * x - 1, sp.Rational(1, 4)))
    source = function_source(FunctionSpec("h", (Argument("x", (x,), scalar=True),), outputs))
    check_source(source)
    python, numpy = (execute(source, module_namespace(vectorized=v))["h"] for v in (False, True))
    expected = [(-2.0, [0, 0, 0]), (-0.0, [1, 0.5, 0]), (0.0, [1, 0.5, 0]), (1 / 3, [1, 1, 0.25]), (3.0, [1, 1, 1])]
    for value, row in expected:
        assert list(python(value, np.empty(3))) == row
        assert list(numpy(np.float64(value), np.empty(3))) == row
    assert np.all(np.isnan(python(float("nan"), np.empty(3))))
    raw = function_source(FunctionSpec("h", (Argument("x", (x,), scalar=True),), outputs, raw=True))
    check_source(raw)
    hyper_h = execute(raw, module_namespace())["h"]
    assert hyper_h(Hyper(-1.0, 5.0)) == [0, 0, 0] and hyper_h(Hyper(2.0, -5.0)) == [1, 1, 1]
    assert hyper_h(Hyper(0.0, 0.0)) == [1, 0.5, 0]


def one_way_damper():
    """A mass (1 kg) on a spring (1 N/m) with a damper that acts only while the mass moves forwards,
    ``e = c·f·step(f)``: a law that stays continuous, kept as written (no law switch), so the step
    reaches the generated rates, their Jacobian and the signals."""
    from bondgraph import C, I, One, R
    from bondgraph import BondGraph as Graph
    from switching import HybridModel
    from switching.language.parsing import parse_expression

    g = Graph("one_way_damper")
    v = g.add(One("v"))
    g.connect(v, I("m", 1.0))
    g.connect(v, C("k", 1.0))
    g.connect(v, R("d", effort_law=lambda f: parse_expression("c*f*step(f)", {"f": f})))
    return HybridModel(g, [], {"c": 0.5}, initial_state={"q_k": 1.0}, signals={"forwards": "step(p_m)"})


def one_way_damper_closed_form(t):
    """``q_k(t)`` from ``q = 1``, ``p = 0`` (α = c/2, ω = √(1 − α²)): undamped backwards ``cos t`` until
    π; damped forwards ``−e^{−αs}(cos ωs + (α/ω) sin ωs)`` for ``s = t − π`` up to ``π/ω``, where
    ``q = A = e^{−απ/ω}``; undamped backwards ``A cos(t − t₂)`` from ``t₂ = π + π/ω`` for π."""
    alpha = 0.25
    omega = np.sqrt(1 - alpha**2)
    t2 = np.pi + np.pi / omega
    s = t - np.pi
    damped = -np.exp(-alpha * s) * (np.cos(omega * s) + alpha / omega * np.sin(omega * s))
    return np.where(t <= np.pi, np.cos(t), np.where(t <= t2, damped, np.exp(-alpha * np.pi / omega) * np.cos(t - t2)))


@pytest.mark.parametrize("method", ["RK45", "Radau", "RK45-jit", "rodas-jit"])
def test_a_continuous_law_with_a_step_runs_against_its_closed_form(method):
    """The kept step in the rates (Python, numba's or the native backend's machine code; for the
    implicit methods the Jacobian, whose ``c·f·δ(f)`` is dropped: 0 wherever flow evaluates it) gives
    the piecewise closed form; the signal ``step(p_m)`` evaluates on the run's samples (a branch on
    arrays: one sample at a time)."""
    if method.endswith("-jit"):
        pytest.importorskip("numba")
    model = one_way_damper()
    assert model.law_switches == {}
    rtol = 1e-10
    run = model.simulate(9.0, method, rtol=rtol, atol=1e-12)
    assert np.max(np.abs(run.state("q_k") - one_way_damper_closed_form(run.t))) <= 10 * rtol
    np.testing.assert_array_equal(run.signal("forwards"), np.where(run.state("p_m") >= 0, 1.0, 0.0))
