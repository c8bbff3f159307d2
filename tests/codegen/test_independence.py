"""codegen stands on the ground floor (DESIGN §2): it knows neither the
switching package nor the models, and only one of its modules touches numba
beyond numba's public interface."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

CODEGEN = Path(__file__).resolve().parents[2] / "codegen"
MODULES = sorted(CODEGEN.glob("*.py"))
#: attributes and modules of numba that are not its public interface
NUMBA_INTERNALS = ("cpu_target", "global_compiler_lock", "serialize_using_object_code", "unserialize_library",
                   "create_library", "_get_host_cpu_name", "_get_host_cpu_features", "_cache_path", "_cache_file",
                   "CFunc")


def _imported(tree) -> list[str]:
    names = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            names.append(node.module or "")
    return names


def test_codegen_has_modules():
    assert {p.name for p in MODULES} >= {"backends.py", "machine.py", "native.py", "numba_internals.py"}


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.name)
def test_no_codegen_module_imports_or_names_switching(path):
    tree = ast.parse(path.read_text())
    imports = [n for n in _imported(tree) if n.split(".")[0] in ("switching", "models")]
    assert not imports, f"{path.name} imports {imports}"
    texts = [node.value for node in ast.walk(tree) if isinstance(node, ast.Constant) and isinstance(node.value, str)]
    naming = [text for text in texts if re.search(r"\bswitching\b", text)]  # (docstrings are constants too)
    assert not naming, f"{path.name} names switching in {naming}"


@pytest.mark.parametrize("path", [p for p in MODULES if p.name != "numba_internals.py"], ids=lambda p: p.name)
def test_only_one_module_uses_numbas_internals(path):
    tree = ast.parse(path.read_text())
    imports = [n for n in _imported(tree) if n.startswith("numba.core") or n.startswith("numba.")]
    assert not imports, f"{path.name} imports {imports} (numba's internals belong in codegen.numba_internals)"
    used = sorted({node.attr for node in ast.walk(tree) if isinstance(node, ast.Attribute)} & set(NUMBA_INTERNALS))
    assert not used, f"{path.name} uses {used} (numba's internals belong in codegen.numba_internals)"
