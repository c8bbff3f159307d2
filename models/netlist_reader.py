"""Reading a netlist's model file (the format: :mod:`models.netlist_files`): each line of its
``[circuit]`` or ``[mechanism]`` table replayed as the builder call it records on a fresh
:class:`~models.circuits.Circuit` or :class:`~models.mechanics.Mechanism`, which is then built with
the file's parameters, inputs and build options.

Nothing of the file is executed: every value is checked for its shape and every text parsed by the
toolkit's parser (:mod:`models.netlist_values`); the builder's own checks judge the rest (names,
nodes, ranges, topology), as they judge a netlist written in Python.  Every refusal is a
:class:`~switching.files.errors.ModelFileError` that names the file, the line and the component (or
table) at fault and says what is expected.
"""

from __future__ import annotations

import re

from bondgraph.errors import HybridBondGraphError, did_you_mean
from switching.files.build import FileInfo, keep_file_info
from switching.files.errors import MAX_ELEMENTS, ModelFileError
from switching.files.read import FORMAT_KEY, FORMAT_VERSION, run_settings
from switching.files.source import is_number, kind_of
from switching.model.expression_input import ExpressionInput
from switching.model.hybrid_model import Tolerance

from .circuits import Circuit
from .mechanics import KINDS, Mechanism
from .netlist import NAME
from .netlist_calls import calls
from .netlist_values import decode, parsed_text

__all__ = ["NetlistFile", "TOP_KEYS", "BUILD_KEYS"]

#: the top-level keys and tables of a netlist's model file
TOP_KEYS = (FORMAT_KEY, "name", "description", "circuit", "mechanism", "build", "positions", "parameters", "inputs",
            "run")
#: the keys of ``[build]``: the netlist's own name and kind, and the keyword arguments of ``build``
BUILD_KEYS = ("netlist", "kind", "gmin", "allow_floating", "tolerance", "max_steps_per_instant", "jump_law",
              "allow_infinite", "descriptions")


class NetlistFile:
    """A netlist's model file read from ``src`` (a :class:`~switching.files.source.Source`): its
    :attr:`netlist` (the components replayed), ``parameters``, ``inputs`` and build ``options``;
    ``settings`` (``name``, ``description``, ``run``), ``defaults`` (every parameter of the model built,
    with its value), ``signal_names`` and :meth:`build`, as a
    :class:`~switching.files.modelfile.ModelFile` asks of what it reads.  Every error is raised here:
    the model is built once (and handed to the first :meth:`build` without parameters)."""

    def __init__(self, src):
        self.src = src
        data = src.data
        self._check_format(data)
        if "circuit" in data and "mechanism" in data:
            raise src.error("a file holds one netlist: a [circuit] or a [mechanism] table, not both", ("mechanism",))
        self.word = "circuit" if "circuit" in data else "mechanism"
        build = src.table(data.get("build", {}), ("build",), "[build]", allowed=BUILD_KEYS)
        self.settings = self._settings(data)
        self.netlist = self._netlist(data, build)
        self.options = self._options(build)
        self.parameters = self._numbers(data.get("parameters", {}), "parameters", "parameter")
        self.inputs = self._inputs(data.get("inputs", {}))
        self._model = self._built({})
        self.defaults = {s.name: v for s, v in self._model.parameter_values.items()}
        self.signal_names = tuple(self._model.signal_definitions)
        known = set(self._model.signal_names)
        for name in self.settings["run"].get("signals", ()):
            if name not in known:
                raise src.error(f"signals names {name!r}, which is no signal or state of the model"
                                f"{did_you_mean(name, known)}", ("run", "signals"), "[run]")

    # ------------------------------------------------------------ tables

    def _check_format(self, data) -> None:
        src = self.src
        version = data.get(FORMAT_KEY)
        if version != FORMAT_VERSION or isinstance(version, bool):
            raise src.error(f"a model file needs {FORMAT_KEY} = {FORMAT_VERSION} before any table, not "
                            f"{version!r}", (FORMAT_KEY,) if FORMAT_KEY in data else ())
        src.table(data, (), "a netlist's model file", allowed=TOP_KEYS)

    def _settings(self, data) -> dict:
        src = self.src
        name = data.get("name", src.path.stem if src.path is not None else self.word)
        if not isinstance(name, str) or not name.strip() or len(name) > 200 or not name.isprintable():
            raise src.error(f"name must be a short one-line text, not {name!r}", ("name",))
        description = data.get("description")
        if description is not None:
            src.text_value(description, ("description",), "description")
        return {"name": name, "description": description, "run": run_settings(src, data.get("run", {}))}

    def _netlist(self, data, build):
        """The netlist: its constructor from ``[build]``, then each component's call in the order written."""
        src, word = self.src, self.word
        name = self.settings["name"]
        name = build.get("netlist", name if NAME.fullmatch(name) else word)
        kind = build.get("kind", "translational")
        if word == "circuit" and "kind" in build:
            raise src.error("kind is a mechanism's (translational or rotational); a circuit has none",
                            ("build", "kind"), "[build]")
        if kind not in KINDS:
            raise src.error(f"kind must be one of {', '.join(map(repr, KINDS))}, not {kind!r}", ("build", "kind"),
                            "[build]")
        try:
            netlist = Circuit(name) if word == "circuit" else Mechanism(name, kind)
        except HybridBondGraphError as error:
            raise src.error(str(error), ("build", "netlist") if "netlist" in build else ("name",), "[build]") from None
        table = src.table(data[word], (word,), f"[{word}]", example='R1 = { type = "R", nodes = ["a", "0"], value = 1.0 }')
        if len(table) > MAX_ELEMENTS:
            raise src.error(f"[{word}] has {len(table)} components, more than the {MAX_ELEMENTS} a model file may "
                            "hold", (word,))
        methods = calls(netlist)
        for component, line in table.items():
            self._component(netlist, methods, component, line)
        if word == "mechanism":
            for node, x0 in self._numbers(data.get("positions", {}), "positions", "position").items():
                self._replay(netlist.position, (node, x0), ("positions", node), f"position of node {node!r}")
        elif "positions" in data:
            raise src.error("positions are a mechanism's nodes' positions; a circuit has none", ("positions",))
        return netlist

    def _component(self, netlist, methods, name: str, line) -> None:
        """Replay the line of component ``name``."""
        src, word = self.src, self.word
        keys, culprit = (word, name), f"component {name!r}"
        example = f'{{ type = "{next(iter(methods))}", nodes = [...], ... }}'
        if not isinstance(line, dict):
            raise src.error(f"a component is a table {example}, not {kind_of(line)}", keys, culprit)
        method = line.get("type")
        if not isinstance(method, str) or method not in methods:
            raise src.error(f"unknown component type {method!r}{did_you_mean(str(method), methods)}; a "
                            f"{word}'s types: {', '.join(methods)}", keys + ("type",), culprit)
        call = methods[method]
        keywords = {a.keyword: a for a in call.arguments}
        src.table(line, keys, culprit, allowed=("type", "nodes") + tuple(keywords), culprit=culprit)
        nodes = line.get("nodes", [])
        if not isinstance(nodes, list) or len(nodes) != len(call.nodes) or not all(
                isinstance(n, (str, int)) and not isinstance(n, bool) for n in nodes):
            said = f"[{', '.join(call.nodes)}]" if call.nodes else "none (leave nodes out)"
            raise src.error(f"{method} takes {len(call.nodes)} nodes, {said}, as texts; got {nodes!r}",
                            keys + ("nodes",), culprit)
        values = {k: decode(v, keywords[k], src, keys + (k,), culprit) for k, v in line.items() if k in keywords}
        self._replay(getattr(netlist, method), (name, *nodes), keys, culprit, values)

    def _replay(self, method, arguments: tuple, keys, culprit: str, keywords: dict | None = None) -> None:
        """``method(*arguments, **keywords)``: a builder call, its refusal at the line of ``keys``."""
        try:
            method(*arguments, **(keywords or {}))
        except (HybridBondGraphError, ValueError, TypeError) as error:
            raise self.src.error(_first_line(error), keys, culprit) from None

    def _numbers(self, table, section: str, what: str) -> dict:
        src = self.src
        table = src.table(table, (section,), f"[{section}]", example=f"{'a' if section == 'positions' else 'R1'} = 1.0")
        pattern = re.compile(r"[A-Za-z0-9_]+") if section == "positions" else NAME
        for key, value in table.items():
            if not pattern.fullmatch(key):
                raise src.error(f"{key!r} is not a {'node' if section == 'positions' else 'parameter'} name",
                                (section, key), f"{what} {key!r}")
            if not is_number(value):
                raise src.error(f"a {what} is a number, not {kind_of(value)}", (section, key), f"{what} {key!r}")
        return dict(table)

    def _inputs(self, table) -> dict:
        """name → :class:`ExpressionInput`: ``u = "text"`` or ``u = { expression = "text", parameters = {...} }``."""
        src = self.src
        inputs = {}
        for name, spec in src.table(table, ("inputs",), "[inputs]", example='u = "5*step(t - 0.01)"').items():
            keys, culprit = ("inputs", name), f"input {name!r}"
            if isinstance(spec, dict):
                spec = src.table(spec, keys, culprit, allowed=("expression", "parameters"), required=("expression",),
                                 culprit=culprit)
            text = spec["expression"] if isinstance(spec, dict) else spec
            parsed_text(text, src, keys, culprit, "its expression")
            values = src.table(spec.get("parameters", {}) if isinstance(spec, dict) else {}, keys + ("parameters",),
                               "its parameters", culprit=culprit)
            if not all(NAME.fullmatch(k) and is_number(v) for k, v in values.items()):
                raise src.error("its parameters are names with numbers (A = 1.0)", keys + ("parameters",), culprit)
            try:
                inputs[name] = ExpressionInput(text, values)
            except HybridBondGraphError as error:
                raise src.error(_first_line(error), keys, culprit) from None
        return inputs

    def _options(self, build) -> dict:
        """``build``'s keyword arguments written in ``[build]``."""
        src = self.src
        options = {k: v for k, v in build.items() if k not in ("netlist", "kind")}
        for key, value in options.items():
            keys = ("build", key)
            if key == "tolerance":
                fields = src.table(value, keys, "tolerance", allowed=("rtol", "atol", "jump_rtol", "jump_atol"),
                                   culprit="[build]")
                if not all(is_number(v) and v >= 0 for v in fields.values()):
                    raise src.error("tolerances are numbers ≥ 0", keys, "[build]")
                options[key] = Tolerance(**fields)
            elif key == "allow_infinite" and not (isinstance(value, list) and all(isinstance(v, str) for v in value)):
                raise src.error("allow_infinite is an array of parameter names", keys, "[build]")
            elif key == "descriptions" and not (isinstance(value, dict) and all(isinstance(v, str) for v in value.values())):
                raise src.error("descriptions is a table of texts (R1 = \"the load\")", keys, "[build]")
            elif key == "gmin" and not (is_number(value) or isinstance(value, str)):
                raise src.error(f"gmin is a conductance (a number) or a parameter name, not {kind_of(value)}", keys,
                                "[build]")
            elif key == "allow_floating" and not isinstance(value, bool):
                raise src.error(f"allow_floating is true or false, not {kind_of(value)}", keys, "[build]")
            elif key == "max_steps_per_instant" and not (isinstance(value, int) and not isinstance(value, bool)):
                raise src.error(f"max_steps_per_instant is a whole number, not {kind_of(value)}", keys, "[build]")
            elif key == "jump_law" and not isinstance(value, str):
                raise src.error(f"jump_law is a text, not {kind_of(value)}", keys, "[build]")
        if self.word == "mechanism" and ("gmin" in options or "allow_floating" in options):
            raise src.error("gmin and allow_floating are a circuit's; a mechanism takes neither", ("build",), "[build]")
        return options

    # ------------------------------------------------------------ building

    def _built(self, overrides: dict):
        """The model of the netlist with the file's parameters overridden by ``overrides``; an error of the
        build at the line of the component it names."""
        parameters = {**self.parameters, **overrides}
        settings = self.settings
        try:
            model = self.netlist.build(parameters=parameters, name=settings["name"], inputs=dict(self.inputs) or None,
                                       **self.options)
        except ModelFileError:
            raise
        except (HybridBondGraphError, ValueError, TypeError) as error:
            raise self._located(error) from None
        return keep_file_info(model, FileInfo(str(self.src.path) if self.src.path is not None else None,
                                              settings["description"], {}, {}, dict(settings["run"])))

    def _located(self, error: Exception) -> ModelFileError:
        """``error`` of the build at the line of the first component whose name it quotes."""
        message, src = _first_line(error, whole=True), self.src
        for name in getattr(error, "elements", None) or ():
            if str(name) in self.netlist.components:
                return src.error(message, (self.word, str(name)), f"component {name!r}")
        for name in self.netlist.components:
            if f"'{name}'" in message:
                return src.error(message, (self.word, name), f"component {name!r}")
        return ModelFileError(message, src.display, culprit=f"[{self.word}]")

    def build(self, **parameters):
        """The model, the file's parameter values overridden by ``parameters`` (each a name of
        :attr:`defaults`)."""
        if not parameters and self._model is not None:
            model, self._model = self._model, None
            return model
        return self._built(parameters)


def _first_line(error: Exception, whole: bool = False) -> str:
    """The message of ``error`` (a parse error's first line: the caret drawing is of another text)."""
    text = str(error)
    if isinstance(error, KeyError) and text.startswith(("'", '"')) and len(error.args) == 1:
        text = str(error.args[0])
    return text if whole else text.splitlines()[0] if text else type(error).__name__
