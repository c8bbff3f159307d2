"""Reading model files: TOML text → the parts of a hybrid model.

A :class:`Reader` reads the top file and the sub-model files it places, each
into a :class:`~switching.files.part.Part` (:mod:`switching.files.part`
reads one file's tables); it owns what spans files: the limits, the parsing
of every expression within them, the resolution of sub-model paths and
components.  :mod:`switching.files.build` turns the part of the top file
into a :class:`~switching.model.hybrid_model.HybridModel`.  The format is described in
:mod:`switching.files.modelfile`.

How a file is read, and what keeps it safe:

1. the file must be a regular file of at most
   :data:`~switching.files.errors.MAX_FILE_BYTES`, UTF-8, valid TOML, with
   ``hbg_model_format = 1``;
2. every table is checked for unknown keys and wrong types before use;
3. every name is checked (:func:`bondgraph.symbols.check_name`) and collected:
   parameters, states, inputs, bond variables, mode constants, signals, and
   those of the sub-model instances (placed in a scratch graph to learn their
   names);
4. every expression is parsed by :func:`~switching.language.parsing.parse_expression`
   or :func:`~switching.language.parsing.parse_condition` within the size limits, and
   every name it uses must be one of step 3 allowed at that place (a law
   cannot use a signal, a restitution coefficient only parameters);
5. the graph, the automata and the rest are built with the toolkit's own
   constructors, whose errors are reported at the line of the culprit.

Sub-model files are read once per load and placed as often as the file asks
(``share``, ``bind`` and ``parameters`` per instance); a file that includes
itself (directly or through others) is refused, as is a path that is absolute
or leads outside the directory of the file first loaded.
"""

from __future__ import annotations

import inspect
import math
import os
from collections.abc import Callable, Mapping
from pathlib import Path

import sympy as sp

from bondgraph import BondGraph
from bondgraph.errors import HybridBondGraphError
from bondgraph.jump import JUMP_LAWS

from ..errors import GuardSyntaxError
from ..language.exprtext import as_doubles
from .forms import UNREGISTERED
from .errors import (
    MAX_DEPTH,
    MAX_EXPRESSION_CHARS,
    MAX_EXPRESSION_TOKENS,
    MAX_FILE_BYTES,
    MAX_FILES,
    MAX_PARSE_WORK,
    ModelFileError,
    count_tokens,
)
from .part import LAW_NAMES, InModeSpec, Part, build_part
from .source import Source, did_you_mean, is_number, kind_of
from ..language.parsing import parse_condition, parse_expression

__all__ = ["FORMAT_KEY", "FORMAT_VERSION", "Part", "InModeSpec", "Reader", "read_text", "run_settings"]

#: The key every model file starts with, and the version this toolkit writes and reads.
FORMAT_KEY = "hbg_model_format"
FORMAT_VERSION = 1

_TOP_KEYS = ("name", "description", "jump_law", "max_steps_per_instant", "parameters", "inputs", "elements",
             "bonds", "displacements", "ports", "automata", "signals", "initial_state", "units", "tolerance", "run")
_TOLERANCE_KEYS = ("rtol", "atol", "jump_rtol", "jump_atol")
_RUN_NUMBERS = ("t_end", "rtol", "atol", "max_step", "first_step", "dt")


# ------------------------------------------------------------------ the reader


class Reader:
    """Reads one model file and the sub-model files it places.

    ``components``: name → function returning a :class:`~bondgraph.BondGraph`
    with ports (the shipped :mod:`models.components`, given by :mod:`models`),
    placed by ``component = "name"``."""

    def __init__(self, components: Mapping[str, Callable] | None = None):
        self.components = dict(components or {})
        self.root: Path | None = None
        self.parts: dict[Path, Part] = {}
        self.stack: list[Path] = []
        self.work = 0

    # -------------------------------------------------------------- files

    def read_path(self, path) -> Part:
        """The part of the file at ``path`` (the top file of a load)."""
        return self.read_top(self.top_source(path))

    def read_text(self, text: str, display: str = "<text>", directory=None) -> Part:
        """The part of a model given as text; sub-model paths are relative to ``directory``."""
        return self.read_top(self.text_source(text, display, directory))

    def top_source(self, path) -> Source:
        """The top file of a load at ``path``: read, checked (size, UTF-8) and its TOML parsed;
        :meth:`read_top` reads its tables (a file of another form is read by its form:
        :mod:`switching.files.forms`)."""
        path = Path(path)
        resolved = self._check_file(path, str(path))
        self.root = resolved.parent
        return Source(resolved, self._text_of(resolved, str(path)), str(path))

    def text_source(self, text: str, display: str = "<text>", directory=None) -> Source:
        """A model given as text, as :meth:`top_source` gives a file (sub-model paths relative to ``directory``)."""
        self.root = Path(directory).resolve() if directory is not None else None
        if len(text.encode("utf-8", "surrogatepass")) > MAX_FILE_BYTES:
            raise ModelFileError(f"the model text is larger than {MAX_FILE_BYTES} bytes", display)
        return Source(None, text, display)

    def read_top(self, src: Source) -> Part:
        """The part of the top file ``src`` (from :meth:`top_source` or :meth:`text_source`)."""
        return self._read_part(src, 0) if src.path is None else self._read_source(src, 0)

    @staticmethod
    def _check_file(path: Path, display: str) -> Path:
        try:
            resolved = path.resolve(strict=True)
        except (OSError, RuntimeError):
            raise ModelFileError("no such file", display) from None
        if not resolved.is_file():
            raise ModelFileError("not a regular file (a model file is a .toml text file)", display)
        return resolved

    def _read_file(self, resolved: Path, display: str, depth: int) -> Part:
        if resolved in self.parts:
            return self.parts[resolved]
        if len(self.parts) >= MAX_FILES:
            raise ModelFileError(f"this load reads more than {MAX_FILES} files; refusing to read more", display)
        return self._read_source(Source(resolved, self._text_of(resolved, display), display), depth)

    @staticmethod
    def _text_of(resolved: Path, display: str) -> str:
        try:
            with open(resolved, "rb") as handle:
                raw = handle.read(MAX_FILE_BYTES + 1)
        except OSError as exc:
            raise ModelFileError(f"cannot be read: {exc.strerror or exc}", display) from None
        if len(raw) > MAX_FILE_BYTES:
            raise ModelFileError(
                f"the file is larger than {MAX_FILE_BYTES} bytes, the limit for a model file; "
                "a model this large is better split into sub-model files", display)
        try:
            return raw.decode("utf-8-sig")  # a byte-order mark (some Windows editors write one) is dropped
        except UnicodeDecodeError as exc:
            line = raw[: exc.start].count(b"\n") + 1
            raise ModelFileError(f"not UTF-8 text (byte {exc.start}); save the file as UTF-8", display, line) from None

    def _read_source(self, src: Source, depth: int) -> Part:
        self.stack.append(src.path)
        try:
            part = self._read_part(src, depth)
        finally:
            self.stack.pop()
        self.parts[src.path] = part
        return part

    # -------------------------------------------------------------- expressions

    def parse(self, src: Source, keys, culprit: str, value, names: Mapping, allowed, what: str,
              condition: bool = False, numbers: bool = True, expected: str = ""):
        """Parse ``value`` (a text, or a number where ``numbers``) into sympy and
        check that every name it uses is in ``allowed``."""
        if numbers and is_number(value):
            number = float(value)
            if not math.isfinite(number):
                raise src.error(f"{what} is {value}: it must be a finite number", keys, culprit)
            return sp.Integer(value) if isinstance(value, int) else sp.Float(number)
        if not isinstance(value, str):
            expected = "a number or an expression as text" if numbers else "an expression as text"
            raise src.error(f"{what} must be {expected}, not {kind_of(value)}", keys, culprit)
        if len(value) > MAX_EXPRESSION_CHARS:
            raise src.error(f"{what} is {len(value)} characters long, more than the {MAX_EXPRESSION_CHARS} "
                            "allowed; split it into named signals or parameters", keys, culprit)
        tokens = count_tokens(value)
        if tokens > MAX_EXPRESSION_TOKENS:
            raise src.error(f"{what} has {tokens} numbers, names and operators, more than the "
                            f"{MAX_EXPRESSION_TOKENS} allowed in a model file; split it into named signals",
                            keys, culprit)
        self.work += tokens * tokens
        if self.work > MAX_PARSE_WORK:
            raise src.error(f"the expressions of this model are too long in total (the sum of their squared "
                            f"lengths passes {MAX_PARSE_WORK}); parsing them would take too long", keys, culprit)
        try:
            expr = (parse_condition if condition else parse_expression)(value, names)
        except GuardSyntaxError as exc:
            raise src.error(f"{what} {value!r} cannot be read: {exc}", keys, culprit) from None
        expr = as_doubles(expr)
        unknown = sorted(s.name for s in expr.free_symbols if s.name not in allowed)
        if unknown:
            name = unknown[0]
            hint = ""
            if any("/" in n for n in unknown) or any(f"{a}/" in value for a in unknown):
                hint = " (a name with '/' that the model does not have reads as a division)"
            raise src.error(
                f"{what} {value!r} uses {', '.join(map(repr, unknown))}, which "
                f"{'is' if len(unknown) == 1 else 'are'} not {expected or LAW_NAMES} of this model"
                f"{did_you_mean(name, allowed)}{hint}; declare parameters in [parameters]",
                keys, culprit)
        return expr

    # -------------------------------------------------------------- one part

    def _read_part(self, src: Source, depth: int) -> Part:
        data = src.data
        if FORMAT_KEY not in data:
            raise src.error(f"not an hbg model file: it needs the key {FORMAT_KEY} = {FORMAT_VERSION} "
                            "before any table")
        version = data[FORMAT_KEY]
        if not isinstance(version, int) or isinstance(version, bool):
            raise src.error(f"{FORMAT_KEY} must be an integer, not {kind_of(version)}", (FORMAT_KEY,))
        if version != FORMAT_VERSION:
            newer = "a newer version of the toolkit" if version > FORMAT_VERSION else "an unknown version"
            raise src.error(f"the file has format {version}, from {newer}; this toolkit reads format "
                            f"{FORMAT_VERSION}", (FORMAT_KEY,))
        for table, what in UNREGISTERED.items():  # (a registered form's file never comes here at the top)
            if table in data:
                raise src.error(f"holds a [{table}] table, {what}" if depth == 0 else
                                f"holds a [{table}] table (a netlist), which cannot be placed as a sub-model; "
                                "place a model file of its bond graph (switching.files.modelfile.dumps_model)",
                                (table,))
        src.table(data, (), "a model file", allowed=(FORMAT_KEY,) + _TOP_KEYS)
        part = Part(src, BondGraph("model"))
        part.settings = self._settings(src, data)
        part.graph.name = part.settings["name"]
        build_part(self, src, part, depth)
        return part

    def _settings(self, src: Source, data: dict) -> dict:
        settings = {}
        default_name = src.path.stem if src.path is not None else "model"
        name = data.get("name", default_name)
        if not isinstance(name, str) or not name.strip() or len(name) > 200 or not name.isprintable():
            raise src.error(f"name must be a short one-line text, not {name!r}", ("name",))
        settings["name"] = name
        description = data.get("description")
        if description is not None:
            src.text_value(description, ("description",), "description")
        settings["description"] = description
        jump_law = data.get("jump_law", "conservation")
        if jump_law not in JUMP_LAWS:
            raise src.error(f"jump_law must be one of {', '.join(map(repr, JUMP_LAWS))}, not {jump_law!r}",
                            ("jump_law",))
        settings["jump_law"] = jump_law
        steps = data.get("max_steps_per_instant", 1000)
        if not isinstance(steps, int) or isinstance(steps, bool) or not 1 <= steps <= 10**9:
            raise src.error(f"max_steps_per_instant must be a positive integer, not {steps!r}",
                            ("max_steps_per_instant",))
        settings["max_steps_per_instant"] = steps
        tolerance = src.table(data.get("tolerance", {}), ("tolerance",), "[tolerance]", allowed=_TOLERANCE_KEYS)
        for key, value in tolerance.items():
            if not is_number(value) or not math.isfinite(value) or value < 0:
                raise src.error(f"{key} must be a finite number ≥ 0, not {value!r}", ("tolerance", key))
        settings["tolerance"] = {k: float(v) for k, v in tolerance.items()}
        settings["run"] = run_settings(src, data.get("run", {}))
        units = src.table(data.get("units", {}), ("units",), "[units]", example='theta = "rad"')
        for key, unit in units.items():
            src.text_value(unit, ("units", key), "a unit", f"unit of {key!r}")
        settings["units"] = dict(units)
        return settings

    # -------------------------------------------------------------- sub-models

    def sub_part(self, src: Source, keys, culprit: str, spec: dict, depth: int):
        """The graph (component) or part (file) an instance entry places."""
        if ("component" in spec) == ("file" in spec):
            raise src.error("a sub-model instance names either component = \"...\" or file = \"...\"",
                            keys, culprit)
        if "component" in spec:
            return self._component(src, keys, culprit, spec)
        if "args" in spec:
            raise src.error("args are for components; a sub-model file takes parameters = {...}", keys, culprit)
        relative = src.text_value(spec["file"], keys + ("file",), "file", culprit)
        return self._sub_file(src, keys, culprit, relative, depth)

    def _component(self, src: Source, keys, culprit: str, spec: dict) -> BondGraph:
        name = src.text_value(spec["component"], keys + ("component",), "component", culprit)
        if name not in self.components:
            known = ", ".join(sorted(self.components)) or "none (load the file with models.load to use them)"
            raise src.error(f"unknown component {name!r}{did_you_mean(name, self.components)}; "
                            f"components: {known}", keys, culprit)
        factory = self.components[name]
        args = src.table(spec.get("args", {}), keys + ("args",), "args")
        accepted = inspect.signature(factory).parameters
        for key, value in args.items():
            if key not in accepted:
                raise src.error(f"component {name!r} takes no argument {key!r}; its arguments: "
                                f"{', '.join(accepted) or 'none'}", keys, culprit)
            if not isinstance(value, (bool, int, float, str)):
                raise src.error(f"argument {key!r} must be a number, a boolean or a text", keys, culprit)
        try:
            graph = factory(**args)
        except HybridBondGraphError as exc:
            raise src.error(f"component {name!r} could not be built: {exc}", keys, culprit) from None
        if not isinstance(graph, BondGraph):
            raise src.error(f"component {name!r} did not give a bond graph", keys, culprit)
        return graph

    def _sub_file(self, src: Source, keys, culprit: str, relative: str, depth: int) -> Part:
        if depth + 1 > MAX_DEPTH:
            raise src.error(f"sub-model files nest deeper than {MAX_DEPTH} levels", keys, culprit)
        if os.path.isabs(relative) or relative.startswith("~"):
            raise src.error(f"file {relative!r} is an absolute path; give a path relative to this file",
                            keys, culprit)
        base = src.path.parent if src.path is not None else self.root
        if base is None:
            raise src.error("a model given as text cannot place sub-model files (no directory to look in)",
                            keys, culprit)
        target = base / relative
        outside = src.error(f"file {relative!r} leads outside the directory of the model ({self.root}); "
                            "sub-model files must lie in that directory or below it", keys, culprit)
        if self.root is not None and not Path(os.path.normpath(target)).is_relative_to(self.root):
            raise outside
        try:
            resolved = target.resolve(strict=True)
        except (OSError, RuntimeError):
            raise src.error(f"sub-model file {relative!r} does not exist (looked for {target})", keys, culprit) from None
        if self.root is not None and not resolved.is_relative_to(self.root):
            raise outside  # through a symbolic link
        if resolved in self.stack:
            chain = " → ".join(p.name for p in self.stack[self.stack.index(resolved):] + [resolved])
            raise src.error(f"sub-model file {relative!r} includes itself ({chain}); a model cannot contain "
                            "itself", keys, culprit)
        if not resolved.is_file():
            raise src.error(f"sub-model file {relative!r} is not a regular file", keys, culprit)
        try:
            return self._read_file(resolved, str(target), depth + 1)
        except ModelFileError as exc:
            where = f"{src.display}:{src.lines.line(keys)}"
            raise ModelFileError(f"{exc.message}\n  (in the sub-model file placed as {culprit} at {where})",
                                 exc.path, exc.line, exc.culprit) from None


def run_settings(src: Source, run) -> dict:
    """A file's ``[run]`` table checked: ``method`` one of the methods, ``signals`` an array of names,
    the numbers finite and positive."""
    from ..simulate.driver import METHODS

    run = src.table(run, ("run",), "[run]", allowed=("method", "signals") + _RUN_NUMBERS)
    out = {}
    for key, value in run.items():
        keys = ("run", key)
        if key == "method":
            if value not in METHODS:
                raise src.error(f"method must be one of {', '.join(METHODS)}, not {value!r}", keys)
        elif key == "signals":
            if not isinstance(value, list) or not all(isinstance(s, str) for s in value):
                raise src.error("signals must be an array of signal names, e.g. [\"v\", \"i_L\"]", keys)
        elif not is_number(value) or not math.isfinite(value) or value <= 0:
            raise src.error(f"{key} must be a finite positive number, not {value!r}", keys)
        out[key] = value
    return out


#: what the names of an element law may be
def read_text(text: str, display: str = "<text>", directory=None, components=None) -> Part:
    """The part of a model given as text (see :meth:`Reader.read_text`)."""
    return Reader(components).read_text(text, display, directory)
