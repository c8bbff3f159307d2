"""The module paths of round 2, kept working after ``switching/`` became subpackages.

Until then every module lived directly in ``switching/`` (``switching.simulator``,
``switching.kernel``, ``switching.modelfile``, ...). Importing such a path
still works: it gives the module at its new place (the same module object,
so patching it patches the one the toolkit uses), with a
:class:`DeprecationWarning` naming the new path. ``switching.model`` and
``switching.library`` are packages now and re-export what their modules did, and so is
``switching.kernel`` (the compiled kernel, in modules by phase).
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: old module (under ``switching.``) → its module now (under ``switching.``)
MOVED = {
    "automaton": "model.automaton",
    "law_automata": "model.law_automata",
    "modes": "model.modes",
    "definition": "model.definition",
    "expression_input": "model.expression_input",
    "parsing": "language.parsing",
    "exprtext": "language.exprtext",
    "compiled": "library.compiled",
    "jit_model": "library.jit_model",
    "export": "library.export",
    "simulator": "simulate.driver",
    "integrators": "simulate.integrators",
    "events": "simulate.events",
    "resolution": "simulate.resolution",
    "trajectory": "simulate.trajectory",
    "plotting": "simulate.plotting",
    "run_options": "simulate.run_options",
    "preflight": "simulate.preflight",
    "real_values": "simulate.real_values",
    "verify": "analysis.verify",
    "sensitivity": "analysis.sensitivity",
    "sensitivity_run": "analysis.sensitivity_run",
    "fitting": "analysis.fitting",
    "batch": "sweep.batch",
    "sweep_frame": "sweep.frame",
    "modelfile": "files.modelfile",
    "modelfile_build": "files.build",
    "modelfile_errors": "files.errors",
    "modelfile_part": "files.part",
    "modelfile_read": "files.read",
    "modelfile_source": "files.source",
    "modelfile_write": "files.write",
    "tomllines": "files.tomllines",
}


class _Alias(importlib.abc.Loader):
    """Loads an old path as the module it became (the same object)."""

    def __init__(self, target: str):
        self.target = target

    def create_module(self, spec):
        return importlib.import_module(self.target)

    def exec_module(self, module):
        pass


class MovedModules(importlib.abc.MetaPathFinder):
    """Finds ``switching.<old name>`` as the module it became (:data:`MOVED`)."""

    def find_spec(self, fullname, path=None, target=None):
        package, _, name = fullname.rpartition(".")
        if package != "switching" or name not in MOVED:
            return None
        new = "switching." + MOVED[name]
        warnings.warn(f"{fullname} moved to {new}: import it from there (or its public names from switching)",
                      DeprecationWarning, stacklevel=2)
        return importlib.util.spec_from_loader(fullname, _Alias(new))


def install() -> None:
    """Put the finder on :data:`sys.meta_path` (once)."""
    if not any(isinstance(finder, MovedModules) for finder in sys.meta_path):
        sys.meta_path.append(MovedModules())
