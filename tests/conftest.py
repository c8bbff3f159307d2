import os
import sys
import tempfile
from pathlib import Path

import pytest
import sympy as sp

# the test modules share model builders (``from test_jump import nonlinear_capacitor_pair``) as they did in one
# folder: every folder of the tests is importable, whichever file pytest collects first
sys.path[:0] = [str(folder) for folder in sorted(Path(__file__).resolve().parent.rglob("*"))
                if folder.is_dir() and folder.name != "__pycache__" and str(folder) not in sys.path]

# generated code goes to a private cache for the test session, never to ~/.cache
os.environ.setdefault("HBG_CACHE_DIR", tempfile.mkdtemp(prefix="hbg-test-cache-"))


def same(derived, expected) -> bool:
    """Symbolic equality: ``simplify(derived - expected) == 0``."""
    return sp.simplify(sp.sympify(derived) - sp.sympify(expected)) == 0


def _slow_requested(config) -> bool:
    if os.environ.get("HBG_SLOW", "") not in ("", "0"):
        return True
    expression = config.getoption("-m", default="") or ""
    return "slow" in expression and "not slow" not in expression


@pytest.fixture(autouse=True)
def _slow_variants_are_opt_in(request):
    """Tests marked ``slow`` (exhaustive variants, runs that compile another
    numba kernel) run only when asked for: ``pytest -m slow`` or ``HBG_SLOW=1``."""
    if request.node.get_closest_marker("slow") and not _slow_requested(request.config):
        pytest.skip("slow variant (an exhaustive sweep — renamings, random circuits, grids — or a run compiling a "
                    "numba kernel of its own; 15 s to 2 min each; CI runs them all after the default set): "
                    "run with -m slow or HBG_SLOW=1")
