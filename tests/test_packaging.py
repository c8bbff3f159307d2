"""The distribution installs every package of the checkout (a non-editable install once lacked switching.rules)."""

from pathlib import Path

from setuptools import find_packages

try:
    import tomllib
except ImportError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]


def test_every_package_of_the_toolkit_is_installed():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert isinstance(config["packages"], dict), "find the packages (packages.find): a list forgets subpackages"
    installed = set(find_packages(str(ROOT), **config["packages"]["find"]))
    present = {".".join(p.parent.relative_to(ROOT).parts) for top in ("bondgraph", "switching", "codegen", "models")
               for p in (ROOT / top).rglob("__init__.py")}
    assert present <= installed, sorted(present - installed)
    assert {"switching.rules"} <= installed and not any(p.startswith(("tests", "benchmarks")) for p in installed)
