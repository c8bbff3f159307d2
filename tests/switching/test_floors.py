"""The wings of ``switching/`` stand on floors (DESIGN §2), and every import,
at the top of a module or inside a function, runs down or level: a wing uses
the wings below it, never one above.  A mode handed from the simulation to
the library, the kernel or the model therefore travels down and never back up."""

import ast
from pathlib import Path

import pytest

import switching

#: the floor of each wing, lowest first (wings on one floor do not import each other)
FLOORS = {
    "errors": 0, "moved": 0, "rules": 1, "language": 2, "kernel": 2, "model": 3, "library": 4, "simulate": 5,
    "files": 6, "sweep": 6, "analysis": 7,
}
PACKAGE = Path(switching.__file__).parent


def wing_of(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[0] == "switching" else None


def imports(path: Path):
    """The switching modules ``path`` imports (absolute names), with the line of each import."""
    here = ["switching", *path.relative_to(PACKAGE).with_suffix("").parts]
    package = here if path.name == "__init__.py" else here[:-1]
    package = package[:-1] if package[-1] == "__init__" else package
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            target = ".".join(base + ([node.module] if node.module else []))
            names = [target] if node.module else [f"{target}.{alias.name}" for alias in node.names]
            for name in names:
                yield name, node.lineno
        elif isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno


def test_every_wing_has_a_floor():
    wings = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    wings |= {p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__"}
    assert wings == set(FLOORS)


@pytest.mark.parametrize("wing", sorted(FLOORS))
def test_a_wing_imports_no_wing_above_it_nor_beside_it(wing):
    paths = [PACKAGE / f"{wing}.py"] if (PACKAGE / f"{wing}.py").exists() else sorted((PACKAGE / wing).rglob("*.py"))
    wrong = []
    for path in paths:
        for name, line in imports(path):
            other = wing_of(name)
            if other is None or other == wing:
                continue
            if FLOORS[other] >= FLOORS[wing]:
                wrong.append(f"{path.relative_to(PACKAGE)}:{line} imports {name} (floor {FLOORS[other]} "
                             f"from floor {FLOORS[wing]})")
    assert not wrong, "\n".join(wrong)
