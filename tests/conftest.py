import sympy as sp


def same(derived, expected) -> bool:
    """Symbolic equality: ``simplify(derived - expected) == 0``."""
    return sp.simplify(sp.sympify(derived) - sp.sympify(expected)) == 0
