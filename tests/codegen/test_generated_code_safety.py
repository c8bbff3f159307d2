"""No text from a model file or the Python API ever becomes code (issue 32, item 1).

Every string field of a model file and every name given through the Python API
is tried with payloads that end strings, comments and lines (quotes of every
kind, backslashes, newlines, ``\\r``, NUL, line separators, ``#``, the braces of
f-strings, ``\\N{...}``, very long text).  Each payload would write a marker
file if it ever ran: no marker is ever written, and every case either runs
with the text shown as given or is refused by a :class:`ModelFileError` naming
the file and line.  Generated modules pass a structural check before they run
(:mod:`codegen.safety`), from a fresh build or from the disk cache, where an
altered entry is refused, deleted and built again.
"""

from __future__ import annotations

import ast
import hashlib
import json
import math
import os
import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

try:
    import tomllib
except ImportError:  # Python 3.10
    import tomli as tomllib

import models
from bondgraph import BondGraph, C, One, R, Se, Zero
from bondgraph.errors import HybridBondGraphError, InvalidGraphError
from bondgraph.symbols import check_name
from codegen.cache import CacheWarning, SourceCache
from codegen.safety import Dialect, GeneratedCodeError, check_source, execute
from codegen.source import docstring, escaped, sanitize
from switching import Automaton, GuardSyntaxError, HybridModel, parse_condition
from switching.files.modelfile import ModelFileError

RELAY = Path(models.__file__).parent / "examples" / "relay.toml"


def payloads(marker: Path) -> list:
    """Texts that would write ``marker`` if they ever reached code unescaped."""
    act = f'open({str(marker)!r}, "w").write("ran")'
    return [
        f'x"""; {act}; """',
        f"x'''; {act}; '''",
        f'x"; {act}; "',
        f"x'; {act}; '",
        f"x\\\n{act}\n",
        f"x\n{act}\n#",
        f"x\r{act}\r",
        f"x\x00{act}",
        f"x\u2028{act}\u2029",
        f"x # {{{act}}}",
        "x \\N{DIGIT ONE} \\x41 \\u0041",
        "x\\",
        "\\",
        '"',
        "µ θ ω ١",
        "long " + "a" * 20_000,
    ]


# ------------------------------------------------------------------ a TOML writer for mutated files


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value) if math.isfinite(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a TOML basic string
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(v)}" for k, v in value.items()) + "}"


def write_toml(data: dict, path: Path) -> None:
    path.write_text("".join(f"{json.dumps(k)} = {_toml_value(v)}\n" for k, v in data.items()))


def mutations(data, payload: str):
    """Every copy of ``data`` with one string (a value, or a key) given ``payload`` appended, with its path."""
    if isinstance(data, dict):
        for key, value in data.items():
            renamed = {(key + payload if k == key else k): v for k, v in data.items()}
            yield (key + "(key)",), renamed
            for path, mutated in mutations(value, payload):
                yield (key, *path), {**data, key: mutated}
    elif isinstance(data, list):
        for k, value in enumerate(data):
            for path, mutated in mutations(value, payload):
                yield (str(k), *path), [*data[:k], mutated, *data[k + 1:]]
    elif isinstance(data, str):
        yield (), data + payload


def _names_in_docstrings(source: str) -> str:
    """Every docstring of a module, joined (they are where names and labels are shown)."""
    tree = ast.parse(source)
    docs = [ast.get_docstring(tree, clean=False) or ""]
    docs += [ast.get_docstring(node, clean=False) or "" for node in tree.body if isinstance(node, ast.FunctionDef)]
    return "\n".join(docs)


def _try_file(path: Path, data: dict, field: tuple, marker: Path) -> str:
    """Load and run the model file; ``"ran"`` or ``"refused"`` (a ModelFileError naming the file and line)."""
    write_toml(data, path)
    try:
        model = models.load(path)
        model.simulate(0.004, method="RK45", rtol=1e-6)
    except ModelFileError as error:
        assert str(error).startswith(f"{path}:"), (field, str(error)[:300])
        outcome = "refused"
    except HybridBondGraphError as error:  # e.g. a run option of the [run] table: still the toolkit's own
        assert not isinstance(error, GeneratedCodeError), (field, str(error)[:300])
        outcome = "refused"
    else:
        source = model.compiled_mode(model.initial_mode).source
        assert model.name == data.get("name", model.name)
        assert repr(model.name) in _names_in_docstrings(source), field
        saved = path.with_name("saved.toml")  # written back and read again: the same text, nothing injected
        model.save(saved)
        again = models.load(saved)
        assert again.name == model.name and again.fingerprint == model.fingerprint, field
        outcome = "ran"
    assert not marker.exists(), f"a payload in {'.'.join(field)} ran"
    return outcome


def _file_cases(tmp_path):
    marker = tmp_path / "PWNED"
    data = tomllib.loads(RELAY.read_text())
    path = tmp_path / "mutated.toml"
    outcomes = {"ran": 0, "refused": 0}
    for payload in payloads(marker):
        for field, mutated in mutations(data, payload):
            outcomes[_try_file(path, mutated, field, marker)] += 1
    return outcomes


def test_the_audits_model_name_runs_as_given_and_runs_no_code(tmp_path, monkeypatch):
    """The audit's file: a name with a triple quote followed by Python (run by ``hbg run`` and ``load``)."""
    from models.cli import main

    monkeypatch.chdir(tmp_path)
    data = tomllib.loads(RELAY.read_text())
    data["name"] = 'x"""; open("PWNED", "w").write("ran"); """'
    write_toml(data, tmp_path / "evil.toml")
    assert main(["run", str(tmp_path / "evil.toml")]) == 0
    model = models.load(tmp_path / "evil.toml")
    run = model.simulate(0.05, method="RK45", rtol=1e-9)
    assert model.name == data["name"]
    assert len(run.events) == 15  # the relay's instants, as with its own name
    assert not (tmp_path / "PWNED").exists()


def test_every_string_field_of_a_model_file_resists_every_payload(tmp_path):
    outcomes = _file_cases(tmp_path)
    assert outcomes["ran"] >= 200 and outcomes["refused"] >= 1500, outcomes  # free text runs; names are refused


# ------------------------------------------------------------------ names through the Python API


def rc_relay(name="relay", V="V", q="q_C", signal="v"):
    """The relay circuit of the README, with its model name, source parameter and capacitor state given."""
    g = BondGraph("relay")
    relay, node = g.add(One("relay", controlled=True)), g.add(Zero("node"))
    Vs = sp.Symbol(V)
    g.connect(Se("V", Vs), relay)
    g.connect(relay, R("R", "R"))
    g.connect(relay, node)
    g.connect(node, C("C", "C", state=sp.Symbol(q)))
    g.connect(node, R("R_load", "R_load"))
    automaton = Automaton("relay", {"on": {"relay": True}, "off": {"relay": False}}, "on")
    automaton.add_transition("on", "off", "v >= v_hi")
    automaton.add_transition("off", "on", "v <= v_lo")
    return HybridModel(g, [automaton], {Vs: 10.0, "R": 1.0, "C": 1e-3, "R_load": 20.0, "v_hi": 8.0, "v_lo": 6.0},
                       signals={"v": sp.Symbol(q) / sp.Symbol("C")}, name=name)


@pytest.mark.parametrize("where", ["name", "V", "q"])
def test_symbol_and_model_names_given_in_code_never_run_and_give_the_same_numbers(tmp_path, where):
    marker = tmp_path / "PWNED"
    reference = rc_relay().simulate(0.02, method="RK45", rtol=1e-9)
    for payload in payloads(marker):
        model = rc_relay(**{where: "V" + payload if where == "V" else "q_C" + payload if where == "q" else payload})
        run = model.simulate(0.02, method="RK45", rtol=1e-9)
        assert np.array_equal(run.t, reference.t) and np.array_equal(run.x, reference.x), repr(payload[:40])
        for mode in model.visited_modes:
            source = model.compiled_mode(mode).source
            check_source(source)
            if where == "name":
                assert repr(payload) in _names_in_docstrings(source)
        assert not marker.exists(), repr(payload[:40])


@pytest.mark.parametrize("name", ["on\n", "on\r", "a b", "a\x00", "θ", "a/", "1a", "a-b", ""])
def test_names_are_whole_ascii_identifiers(name):
    with pytest.raises(InvalidGraphError):
        check_name(name)
    with pytest.raises(InvalidGraphError):
        Automaton("relay", {name: {"relay": True}, "off": {"relay": False}}, "off")


def test_numbers_in_guards_are_ascii_digits():
    v, v_hi = sp.symbols("v v_hi")
    for text in ("v >= v_hi*\u0661", "v >= \u0661", "v >= 1\u00a0+ v_hi", "v >= v_hi\u2028"):
        with pytest.raises(GuardSyntaxError):
            parse_condition(text, {"v": v, "v_hi": v_hi})
    assert parse_condition("v >= v_hi*1", {"v": v, "v_hi": v_hi}) == sp.Ge(v, v_hi)


# ------------------------------------------------------------------ the escaping and the check themselves


@pytest.mark.parametrize("text", ['"""', "'''", "\\", "a\\", "\n", "\r\n", "\x00", "\u2028", "\u202e", "\\N{BULLET}",
                                  "{x}", "µ", "\U0001f600", "'\"'"])
def test_escaped_text_reads_back_exactly_inside_a_string_and_a_docstring(text):
    assert ast.literal_eval('"' + escaped(text) + '"') == text
    module = ast.parse("def f():\n" + docstring(["head " + text, "tail"]) + "\n    return 0\n")
    assert ast.get_docstring(module.body[0], clean=False) == "head " + text + "\n    tail\n    "
    assert len(module.body) == 1 and len(module.body[0].body) == 2


@pytest.mark.parametrize("raw", [False, True])
@pytest.mark.parametrize("labels", [None, ("p1", 'say "hi"', "a\\b", "line\nbreak", "µ\u2028")])
def test_a_functions_docstring_is_every_line_escaped_with_the_argument_lines_escaped_once(labels, raw):
    """The argument lines of a function's docstring are escaped once per argument list (the same
    for every function of a model) and its output lines after their index: the text is that of
    docstring() of all the lines, whatever the names hold."""
    from codegen.source import Argument, FunctionSpec, _argument_doc, _docstring, _escaped_lines

    x, y = sp.symbols('x "y\\')
    arguments = (Argument("x", (x, y), doc='state "vector"\n'), Argument("t", (sp.Symbol("t"),), scalar=True))
    spec = FunctionSpec("f", arguments, (x, y), 'Doc of "f"\nsecond line.', labels and labels[:2], raw=raw)
    lines = ['Doc of "f"', "second line.", "", *_argument_doc(arguments), ("returns" if raw else "out") + "[2]:",
             *(f"    [{k}] = {label}" for k, label in enumerate(labels[:2] if labels else ("0", "1")))]
    assert _docstring(spec, 2, _escaped_lines(_argument_doc(arguments))) == [docstring(lines)]


@pytest.mark.parametrize("name", ["a/b", "_c0", "_c1", "__import__", "1x", "θ", "open", "lambda", "None", "x\n",
                                  "out", "np", "math", "H", "exp"])
def test_sanitized_names_are_ascii_identifiers_the_generator_never_uses(name):
    ident = sanitize(name)
    assert ident.isascii() and ident.isidentifier() and not ident.startswith("_")
    check_source(f"def f(x, out):\n    {ident} = x[0]\n    out[0] = {ident}\n    return out\n")


REFUSED = {
    "import os": "the name(s) 'os'",
    "from os import system": "the name(s) 'os', 'system'",
    "import math": "the name(s) 'math'",
    "def f(x, out):\n    import os\n    return out": "the name(s) 'os' (in 'f', from line 1)",
    "def f(x, out):\n    out[0] = open('m', 'w')\n    return out": "the name(s) 'open'",
    "def f(x, out):\n    out[0] = x.__class__\n    return out": "the name(s) '__class__'",
    "def f(x, out):\n    out[0] = __import__('os')\n    return out": "the name(s) '__import__'",
    "def f(x, out):\n    out[0] = getattr(x, 'y')\n    return out": "the name(s) 'getattr'",
    "def f(x, out):\n    out[0] = (lambda: open)()\n    return out": "the name(s) 'open' (in '<lambda>'",
    "def f(x, out):\n    out[0] = [open for y in x]\n    return out": "the name(s) 'open'",
    "def f(x, out):\n    out[0] = f'{x.__dict__}'\n    return out": "the name(s) '__dict__'",
    "def f(x, out):\n    out[0] = '{0.__class__}'.format(x)\n    return out": "the name(s) 'format'",
    "def f(x, out):\n    while True:\n        pass": "a loop",
    "def f(x, out):\n    for k in range(10**18):\n        pass": "a loop",
    "def f(x, out):\n    with x:\n        pass": "BEFORE_WITH|SETUP_WITH",
    "def f(x, out):\n    global exp\n    exp = 1\n    return out": "STORE_GLOBAL",
    "def f(x, out):\n    x.shape = 1\n    return out": "STORE_ATTR",
    "def f(x, out):\n    del out[0]\n    return out\ndel f": "DELETE_NAME",
    "def f(x, out):\n    yield out": "YIELD_VALUE|RETURN_GENERATOR",
    "@decorate\ndef f(x, out):\n    return out": "the name(s) 'decorate'",
    "def f(x, out=open('m')):\n    return out": "the name(s) 'open'",
    "class A:\n    pass": "LOAD_BUILD_CLASS",
    "print('x')": "the name(s) 'print'",
    "x = exec('1')": "the name(s) 'exec'",
    "def f(x, out):\n    out[0] = np.save('m', x)\n    return out": "the name(s) 'np', 'save'",
    "def f(x, out):\n    out[0] = H.__dict__\n    return out": "the name(s) '__dict__'",
    "def f(x, out):\n    out[0] = os.system('x')\n    return out": "the name(s) 'os', 'system'",
    "def f(x, out)\n    return out": "does not compile",
    "x = 1\x00": "does not compile",
}


@pytest.mark.parametrize("source", list(REFUSED))
def test_the_check_refuses_what_the_generator_never_writes(source):
    with pytest.raises(GeneratedCodeError, match=REFUSED[source].replace("(", r"\(").replace(")", r"\)")
                       .replace("[", r"\[")):
        check_source(source, "<test>")
    with pytest.raises(GeneratedCodeError):
        execute(source, {}, "<test>")


def test_the_compiled_dialect_holds_its_imports_and_range_loops_only():
    from switching.library.jit_model import MODE_DIALECT

    source = ("import math\nfrom math import *\nimport numpy as np\nfrom numba import carray\n\n"
              "def f(x_, n):\n    x = carray(x_, (n,))\n    for k in range(x.shape[0]):\n        x[k] = sqrt(k)\n"
              "    return 0\n")
    check_source(source, "<test>", MODE_DIALECT)
    with pytest.raises(GeneratedCodeError, match="a loop"):
        check_source(source.split("\n\n", 1)[1], "<test>", Dialect(imports=MODE_DIALECT.imports))
    with pytest.raises(GeneratedCodeError, match="'os'"):
        check_source("import os\n" + source, "<test>", MODE_DIALECT)


def test_the_generated_modules_of_the_shipped_models_pass_the_check():
    for name in ("bouncing_ball", "diode_circuit", "falling_rod", "colliding_balls"):
        model = models.load(name).build()
        model.simulate(0.3, method="RK45")
        for mode in model.visited_modes:
            source = model.compiled_mode(mode).source
            check_source(source)
            tree = ast.parse(source)
            assert any(isinstance(node, ast.FunctionDef) and node.name == "rates" for node in tree.body)


# ------------------------------------------------------------------ the disk cache


def _poison(path: Path, statement: str) -> None:
    """Add ``statement`` to the cached module at ``path`` with a header that matches it again."""
    first, _, body = path.read_text().partition("\n")
    body = body.replace("    return out\n", f"    {statement}\n    return out\n", 1)
    key = first.split("key=")[1].split()[0]
    path.write_text(f"# hbg-codegen key={key} sha256={hashlib.sha256(body.encode()).hexdigest()}\n{body}")


def test_an_altered_cache_entry_is_refused_deleted_and_built_again(tmp_path, monkeypatch):
    marker = tmp_path / "PWNED"
    monkeypatch.setenv("HBG_CACHE_DIR", str(tmp_path / "cache"))
    first = models.load("bouncing_ball").build()
    reference = first.simulate(1.0, method="RK45")
    entries = sorted((tmp_path / "cache").glob("*.py"))
    poisoned = [p for p in entries if "def rates(" in p.read_text()]
    assert poisoned
    for path in poisoned:
        _poison(path, f'open({str(marker)!r}, "w").write("ran")')
    second = models.load("bouncing_ball").build()
    assert second.cache.directory == tmp_path / "cache"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = second.simulate(1.0, method="RK45")
    assert not marker.exists()
    assert np.array_equal(run.x, reference.x)
    altered = [w for w in caught if issubclass(w.category, CacheWarning) and "altered" in str(w.message)]
    assert len(altered) == len(poisoned)
    assert second.cache.hits["rejected"] == len(poisoned)
    for path in poisoned:  # built again: the entry holds the generated module, unaltered
        assert str(marker) not in path.read_text()
        check_source(path.read_text().partition("\n")[2])


def test_a_cache_entry_is_checked_with_the_imports_its_reader_allows(tmp_path):
    cache = SourceCache(tmp_path)
    cache.store("0" * 32, "import math\nfrom math import *\n\n\ndef f(x):\n    return sqrt(x)\n")
    fresh = SourceCache(tmp_path)
    assert fresh.load("0" * 32, Dialect(imports=(("math", None, None), ("math", "*", None)))) is not None
    with pytest.warns(CacheWarning, match="altered"):
        assert SourceCache(tmp_path).load("0" * 32) is None
    assert not (tmp_path / f"{'0' * 32}.py").exists()


def test_codegen_output_stays_inside_the_folder_given(tmp_path, monkeypatch):
    from models.cli import main

    monkeypatch.chdir(tmp_path)
    data = tomllib.loads(RELAY.read_text())
    for name in ("../../escaped", "/tmp/escaped_abs", "..", "a/../../b"):
        data["name"] = name
        write_toml(data, tmp_path / "named.toml")
        out = tmp_path / "out" / "deeper"
        assert main(["codegen", str(tmp_path / "named.toml"), "-o", str(out)]) == 0
        written = [p for p in tmp_path.rglob("*_modes.py")]
        assert written and all(p.parent == out for p in written), written
        for p in written:
            p.unlink()
    assert not os.path.exists("/tmp/escaped_abs_modes.py")


# ------------------------------------------------------------------ user names that the generator also uses (issue 33)

#: names the code generator uses for itself (temporaries, arrays, modules), keywords and builtins
GENERATED_NAMES = ("_c0", "_c1", "x", "p", "u", "y", "s", "d", "q", "g", "k", "post", "target", "xp", "xq", "xdot",
                   "out", "t", "np", "math", "H", "exp", "carray", "_dec", "lambda", "None", "open", "print")


def _model_names(data: dict) -> list:
    """The parameter, state and signal names of a model file's data."""
    names = list(data.get("parameters", {})) + list(data.get("signals", {})) + list(data.get("initial_state", {}))
    names += [fields["state"] for fields in data.get("elements", {}).values() if "state" in fields]
    names += list(data.get("displacements", {}))
    elsewhere = set(data.get("elements", {})) | set(data.get("bonds", {}))  # (renamed: bond variables would change)
    return [name for name in dict.fromkeys(names) if name not in elsewhere and "/" not in name]


def _explicit_states(data: dict) -> dict:
    """``data`` with the state of each C and I element named explicitly (``q_C``, ``p_L``: the defaults)."""
    elements = {}
    for name, fields in data.get("elements", {}).items():
        if fields.get("type") in ("C", "I") and "state" not in fields and "/" not in name:
            fields = {**fields, "state": ("q_" if fields["type"] == "C" else "p_") + name}
        elements[name] = fields
    return {**data, "elements": elements}


def _renamed(data, old: str, new: str):
    """``data`` with the name ``old`` replaced by ``new`` wherever it is a whole name (keys and expressions)."""
    import re

    token = re.compile(rf"(?<![A-Za-z0-9_/]){re.escape(old)}(?![A-Za-z0-9_])")  # (not inside 'rod/q': a sub-model's)
    if isinstance(data, dict):
        return {(new if key == old else key): _renamed(value, old, new) for key, value in data.items()}
    if isinstance(data, list):
        return [_renamed(value, old, new) for value in data]
    if isinstance(data, str):
        return token.sub(new, data)
    return data


def _same_run(model, reference, t_end: float) -> None:
    run = model.simulate(t_end, method="RK45", rtol=1e-8)
    assert [m.label for m in run.modes] == [m.label for m in reference.modes]
    assert np.array_equal(run.t, reference.t) and np.array_equal(run.x, reference.x)


def _rename_each(tmp_path, data: dict, t_end: float, targets=GENERATED_NAMES, every=True) -> dict:
    """Rename each parameter, state and signal to each of ``targets`` (``every`` false: each target once, and
    each name at least once), run, compare with the original model's run: the same to the bit."""
    write_toml(data, tmp_path / "original.toml")
    reference = models.load(tmp_path / "original.toml").simulate(t_end, method="RK45", rtol=1e-8)
    taken = set(_model_names(data)) | set(data.get("elements", {})) | set(data.get("automata", {}))
    names = _model_names(data)
    targets = [new for new in targets if new not in taken]
    if every:
        pairs = [(old, new) for old in names for new in targets]
    else:
        count = max(len(names), len(targets))
        pairs = [(names[k % len(names)], targets[k % len(targets)]) for k in range(count)]
    outcomes = {"same": 0, "refused": []}
    for old, new in pairs:
        path = tmp_path / "renamed.toml"
        write_toml(_renamed(data, old, new), path)
        try:
            model = models.load(path)
        except ModelFileError as error:
            assert repr(new) in str(error) or f" {new} " in str(error), str(error)
            outcomes["refused"].append((old, new))
            continue
        _same_run(model, reference, t_end)
        outcomes["same"] += 1
    return outcomes


def test_user_names_like_the_generators_own_give_the_same_numbers_to_the_bit(tmp_path):
    """The relay of the audit: a threshold called ``_c0`` (a generated temporary) ran with 0 instants instead of 15."""
    data = _explicit_states(tomllib.loads(RELAY.read_text()))
    outcomes = _rename_each(tmp_path, data, 0.05)
    assert outcomes["same"] >= 120, outcomes
    # t is time and exp a function of the expression language: a parameter cannot be called so (refused by name)
    assert {new for _, new in outcomes["refused"]} <= {"t", "exp"}, outcomes


SHIPPED = ["bouncing_ball", "diode_circuit", "colliding_balls", "two_tanks", "parallel_capacitors"]


def _shipped_renamed(tmp_path, name: str, every: bool) -> None:
    models.load(name).build().save(tmp_path / "saved.toml")
    data = _explicit_states(tomllib.loads((tmp_path / "saved.toml").read_text()))
    outcomes = _rename_each(tmp_path, data, 0.6, every=every)
    assert outcomes["same"] >= 10 and {new for _, new in outcomes["refused"]} <= {"t", "exp"}, outcomes


@pytest.mark.parametrize("name", SHIPPED)
def test_the_shipped_models_with_names_like_the_generators_own_give_the_same_numbers(tmp_path, name):
    _shipped_renamed(tmp_path, name, every=False)  # each name renamed, each generated name taken


@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED)
def test_the_shipped_models_with_each_name_renamed_to_each_generated_name(tmp_path, name):
    _shipped_renamed(tmp_path, name, every=True)


@pytest.mark.slow
def test_names_like_the_compiled_functions_own_give_the_same_compiled_run(tmp_path):
    """The compiled mode functions have arrays and selectors of their own (``s``, ``y``, ``post``, ``target``...)."""
    pytest.importorskip("numba")
    data = _explicit_states(tomllib.loads(RELAY.read_text()))
    write_toml(data, tmp_path / "original.toml")
    reference = models.load(tmp_path / "original.toml").simulate(0.05, method="RK45-jit", rtol=1e-8)
    names = _model_names(data)
    for k, new in enumerate(GENERATED_NAMES):
        if new in ("t", "exp"):
            continue
        write_toml(_renamed(data, names[k % len(names)], new), tmp_path / "renamed.toml")
        run = models.load(tmp_path / "renamed.toml").simulate(0.05, method="RK45-jit", rtol=1e-8)
        assert np.array_equal(run.t, reference.t) and np.array_equal(run.x, reference.x), new


#: every place of the packages that runs code, and why it may: each runs what codegen.safety checked
CHECKED_RUNS = {
    "codegen/safety.py": 1,  # execute(): compile_checked, then exec
    "codegen/jit.py": 1,  # a module checked (check_code) before it runs
    "codegen/native.py": 1,  # the imports of a source check_source passed
    "switching/analysis/sensitivity.py": 2,  # compile_checked code, run in two namespaces
}


def test_generated_code_runs_only_after_the_check():
    """No module runs text as code (``exec``/``eval``) but those that run what
    :mod:`codegen.safety` checked; a new ``exec`` anywhere fails here until it
    goes through ``codegen.safety.execute``."""
    import ast

    from checkout import ROOT

    found = {}
    for package in ("bondgraph", "codegen", "switching", "models"):
        for path in (ROOT / package).rglob("*.py"):
            calls = [node for node in ast.walk(ast.parse(path.read_text()))
                     if isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                     and node.func.id in ("exec", "eval")]
            if calls:
                found[str(path.relative_to(ROOT))] = len(calls)
    assert found == CHECKED_RUNS
