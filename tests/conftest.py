import os
import tempfile

import sympy as sp

# generated code goes to a private cache for the test session, never to ~/.cache
os.environ.setdefault("HBG_CACHE_DIR", tempfile.mkdtemp(prefix="hbg-test-cache-"))


def same(derived, expected) -> bool:
    """Symbolic equality: ``simplify(derived - expected) == 0``."""
    return sp.simplify(sp.sympify(derived) - sp.sympify(expected)) == 0
