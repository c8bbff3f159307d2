"""Writing a netlist's model file (the format: :mod:`models.netlist_files`) from what a model built by
:meth:`Circuit.build <models.circuits.Circuit.build>` or :meth:`Mechanism.build
<models.mechanics.Mechanism.build>` records of its build (``model.built_from``, a
:class:`~models.netlist.BuiltFrom`): one line a component, the build's parameters, inputs and
options, the run.

The text is read back (:mod:`models.netlist_reader`) before it is returned, and must give the same
model: the same equations (fingerprint), parameter values, initial state, tolerances, inputs, units
and step hint.  Parameter values set on the model after its build are written in ``[parameters]``; a
model changed otherwise after its build (its netlist no longer says what it is) is written as its bond
graph, with a comment that says why.  What no model file can hold is refused with a
:class:`~switching.files.errors.ModelFileError` naming it: an input given as a Python function (give
it as an :class:`~switching.model.expression_input.ExpressionInput`), a component value or law the
text grammar cannot express, a build option of no file.
"""

from __future__ import annotations

import inspect

import numpy as np

from bondgraph import __version__
from switching.files.build import file_info
from switching.files.errors import ModelFileError
from switching.files.read import FORMAT_KEY, FORMAT_VERSION
from switching.files.source import Source
from switching.files.write import dumps_model
from switching.model.expression_input import ExpressionInput
from switching.model.hybrid_model import Tolerance

from .netlist_calls import call_of, netlist_word
from .netlist_reader import NetlistFile
from .netlist_values import (
    Unwritable,
    encode,
    toml_inline,
    toml_key,
    toml_number,
    toml_string,
)

__all__ = ["dumps_netlist"]

_RUN_KEYS = ("t_end", "method", "rtol", "atol", "max_step", "first_step", "dt", "signals")


def dumps_netlist(model, *, run: dict | None = None, description: str | None = None,
                  display: str = "<model file>") -> str:
    """The model file text of ``model`` (built by a ``Circuit`` or ``Mechanism``) as its netlist, read back
    to the same model (else its bond graph, saying why: the module docstring).  ``run`` and
    ``description`` as :func:`~switching.files.modelfile.dumps_model` takes them (a model read from a
    file keeps its own)."""
    info = file_info(model)
    if run is None and info is not None:
        run = info.run
    if description is None and info is not None:
        description = info.description
    writer = _Writer(model, display)
    parameters = dict(model.built_from.parameters)
    text = writer.text(parameters, run or {}, description)
    again = _read_back(text, display)
    drift = {s.name: v for s, v in model.parameter_values.items()
             if again is not None and again.parameter_values.get(s) != v}
    if drift:  # values set after the build: written as the build's parameters
        parameters.update(drift)
        text = writer.text(parameters, run or {}, description)
        again = _read_back(text, display)
    difference = "it does not read back" if again is None else _difference(model, again)
    if not difference:
        return text
    word = netlist_word(model.built_from.netlist)
    return (f"# Written as its bond graph, not its {word}: {difference}, as its {word} builds it "
            "(changed after its build).\n" + dumps_model(model, run=run, description=description, display=display))


def _read_back(text: str, display: str):
    try:
        return NetlistFile(Source(None, text, display)).build()
    except ModelFileError:
        return None


def _difference(model, again) -> str:
    """What of ``model`` differs from ``again`` (the model its text reads back to), in words; ``""``: nothing."""
    hint = getattr(model, "max_step_hint", None), getattr(again, "max_step_hint", None)
    checks = (
        ("its equations", model.fingerprint == again.fingerprint),
        ("its parameter values", dict(model.parameter_values) == dict(again.parameter_values)),
        ("its initial state", np.array_equal(model.given_initial_state, again.given_initial_state)),
        ("its tolerances", model.tolerance == again.tolerance
         and model.max_steps_per_instant == again.max_steps_per_instant),
        ("its units and descriptions", model.annotations == again.annotations
         and model.allow_infinite == again.allow_infinite),
        ("its inputs", _inputs(model) == _inputs(again)),
        ("its step hint", hint[0] == hint[1]),
    )
    return next((what + " differ" for what, same in checks if not same), "")


def _inputs(model) -> dict:
    return {name: (f.expression, f.parameters) if isinstance(f, ExpressionInput) else f
            for name, f in model.input_signals.functions.items()}


class _Writer:
    """The text of one model's netlist, for some parameter values (:meth:`text`)."""

    def __init__(self, model, display: str):
        self.model, self.display = model, display
        self.built = model.built_from
        self.netlist = self.built.netlist
        self.word = netlist_word(self.netlist)

    def error(self, message: str, culprit: str) -> ModelFileError:
        return ModelFileError(message, self.display, None, culprit)

    def text(self, parameters: dict, run: dict, description: str | None) -> str:
        model, word = self.model, self.word
        lines = [(f"# Hybrid bond graph model {model.name!r}, written by hbg {__version__} as its {word}: one line "
                  "a component."),
                 "# Format: see the documentation of models.netlist_files (python -m pydoc models.netlist_files).",
                 f"{FORMAT_KEY} = {FORMAT_VERSION}", f"name = {toml_string(model.name)}"]
        if description:
            lines.append(f"description = {toml_string(description)}")
        lines += ["", f"[{word}]"] + [self.component(part) for part in self.netlist._parts.values()]  # (in order)
        sections = {"build": self.build_options(), "positions": self.positions(),
                    "parameters": self.numbers(parameters, "parameter"), "inputs": self.inputs(),
                    "run": self.run(run)}
        for section, entries in sections.items():
            if entries:
                lines += ["", f"[{section}]"] + entries
        return "\n".join(lines) + "\n"

    def component(self, part) -> str:
        """``name = { type = ..., nodes = [...], keyword = value, ... }  # units``."""
        call = call_of(self.netlist, part)
        method = getattr(self.netlist, call.method)
        signature = inspect.signature(method).parameters
        fields = {"type": toml_string(call.method)}
        if call.nodes:
            fields["nodes"] = "[" + ", ".join(toml_string(n) for n in part.nodes[:len(call.nodes)]) + "]"
        units = []
        for argument in call.arguments:
            value = part.values.get(argument.key)
            default = signature[argument.keyword].default
            if argument.shape != "law" and (value is None or (type(value) is type(default) and value == default)):
                if value is None and default is not None:
                    raise self.error(f"its {argument.keyword} is not given and has no default", f"component {part.name!r}")
                continue  # (the method's default)
            if argument.shape == "law" and isinstance(value, tuple):  # a circuit's (keyword, function)
                value = value[1] if value[0] == argument.keyword else None
            try:
                written = encode(value, argument)
            except Unwritable as reason:
                raise self.error(f"its {argument.keyword} cannot be written to a model file: {reason}",
                                 f"component {part.name!r}") from None
            if written is not None:
                fields[argument.keyword] = written
                if argument.unit:
                    units.append((argument.keyword, argument.unit))
        comment = "" if not units else "  # " + (units[0][1] if [k for k, _ in units] == ["value"] else
                                                 ", ".join(f"{k}: {u}" for k, u in units))
        return f"{part.name} = {toml_inline(fields)}{comment}"

    def build_options(self) -> list:
        """``[build]``: the netlist's name and kind where the file's name and the default do not say them,
        and ``build``'s keyword arguments other than their defaults."""
        entries, netlist = [], self.netlist
        if netlist.name != self.model.name:
            entries.append(f"netlist = {toml_string(netlist.name)}")
        if getattr(netlist, "kind", "translational") != "translational":
            entries.append(f"kind = {toml_string(netlist.kind)}")
        for key, value in self.built.options.items():
            if value is None or (key == "allow_floating" and value is False):
                continue
            if key == "gmin":
                text = toml_string(value) if isinstance(value, str) else toml_number(value)
            elif key == "allow_floating":
                text = "true"
            elif key == "tolerance" and isinstance(value, Tolerance):
                default = Tolerance()
                text = toml_inline({k: toml_number(getattr(value, k)) for k in ("rtol", "atol", "jump_rtol", "jump_atol")
                                    if getattr(value, k) != getattr(default, k)})
            elif key == "max_steps_per_instant" and isinstance(value, int):
                text = str(value)
            elif key == "jump_law" and isinstance(value, str):
                text = toml_string(value)
            elif key == "allow_infinite":
                text = "[" + ", ".join(toml_string(n) for n in value) + "]"
            elif key == "descriptions":
                text = toml_inline({n: toml_string(d) for n, d in value.items()})
            else:
                raise self.error(f"{value!r} cannot be written to a model file (build options a file holds: gmin, "
                                 "allow_floating, tolerance, max_steps_per_instant, jump_law, allow_infinite, "
                                 "descriptions)", f"build option {key!r}")
            entries.append(f"{key} = {text}")
        return entries

    def positions(self) -> list:
        return self.numbers(getattr(self.netlist, "_positions", {}), "position")

    def numbers(self, values: dict, what: str) -> list:
        entries = []
        for name, value in values.items():
            try:
                entries.append(f"{toml_key(name)} = {toml_number(value)}")
            except (Unwritable, TypeError, ValueError):
                raise self.error(f"{value!r} is not a finite number", f"{what} {name!r}") from None
        return entries

    def inputs(self) -> list:
        """``[inputs]``: each input the model was built with, as its expression of ``t``."""
        entries = []
        for name, function in self.model.input_signals.functions.items():
            if not isinstance(function, ExpressionInput):
                raise self.error(
                    f"is a Python function ({function!r}), which no model file can hold; build the {self.word} with "
                    f"inputs={{{name!r}: ExpressionInput(\"...\", {{parameter: value}})}} (an expression of t, from "
                    "switching.model.expression_input) to save it", f"input {name!r}")
            text = toml_string(function.text)
            if function.parameters:
                text = toml_inline({"expression": text, "parameters": toml_inline(
                    {k: toml_number(v) for k, v in function.parameters.items()})})
            entries.append(f"{toml_key(name)} = {text}")
        return entries

    def run(self, run: dict) -> list:
        entries = []
        for key, value in run.items():
            if key not in _RUN_KEYS:
                raise self.error(f"the run option {key!r} has no place in a model file; run options: "
                                 f"{', '.join(_RUN_KEYS)}", "[run]")
            if key == "method":
                entries.append(f"method = {toml_string(value)}")
            elif key == "signals":
                entries.append("signals = [" + ", ".join(toml_string(s) for s in value) + "]")
            else:
                entries.append(f"{key} = {toml_number(value)}")
        return entries
