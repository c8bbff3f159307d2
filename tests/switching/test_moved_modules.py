"""The module paths of round 2 (``switching.simulator``, ``switching.kernel``,
``switching.modelfile``, ...) keep working after ``switching/`` became
subpackages: each is the module at its new place, with a warning naming it."""

import importlib
import subprocess
import sys

import pytest

from checkout import ROOT
from switching.moved import MOVED


@pytest.mark.parametrize("old", sorted(MOVED))
def test_an_old_path_is_the_module_it_became(old):
    new = importlib.import_module("switching." + MOVED[old])
    sys.modules.pop("switching." + old, None)
    with pytest.warns(DeprecationWarning, match=rf"switching\.{old} moved to switching\.{MOVED[old]}"):
        module = importlib.import_module("switching." + old)
    assert module is new


def test_names_are_imported_from_old_paths_in_a_new_process():
    code = ("import warnings; warnings.simplefilter('error');"
            "from switching.model import HybridModel; from switching.library import ModeLibrary;"
            "warnings.simplefilter('ignore');"
            "from switching.simulator import simulate; from switching.modelfile import load_model;"
            "from switching.kernel import run; import switching.simulate.driver as d; import switching.kernel.loop as k;"
            "assert simulate is d.simulate and run is k.run; print('ok')")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert out.stdout.strip() == "ok", out.stderr

