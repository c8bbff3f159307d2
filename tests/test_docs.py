"""The runnable examples in docstrings stay true."""

import doctest
import importlib

import pytest

MODULES = ["bondgraph", "bondgraph.graph", "models.circuits", "models.components", "models.mechanics", "models.graphs", "switching.model.automaton", "switching.model.hybrid_model",
           "switching.library.mode_library"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0, f"{name} has no runnable example"
    assert result.failed == 0
