"""Writing model files: :class:`~switching.model.hybrid_model.HybridModel` → TOML text.

The text is written by hand (no TOML writer is needed: the layout is fixed,
one line per element, bond, state, signal and parameter) in the format of
:mod:`switching.files.modelfile`.  Expressions are printed by
:mod:`switching.language.exprtext`, which the reader parses back to the same sympy
trees, so the model read back has the same symbolic fingerprint (the disk
cache key) as the model written.  :func:`dumps_model` checks exactly that
before returning: it reads its own text back and compares the fingerprints.

What is written: the *flattened* model — sub-model instances appear as their
elements with hierarchical names (``rod/body/I_x``), exactly as the bond graph
holds them.  What cannot be written raises
:class:`~switching.files.errors.ModelFileError` naming the culprit: an
input given as a Python function (give it as an
:class:`~switching.model.expression_input.ExpressionInput`), a law that uses a
function the text grammar lacks (``Piecewise``), an element class of one's
own.  A ``Heaviside(x, h0)`` is written ``step(x)`` when ``h0 = 1`` (the text's
right-continuous unit step), else ``Heaviside(x, h0)`` (``Heaviside(x, 1/2)``
for sympy's ``Heaviside(x)``), and reads back to the same tree.
"""

from __future__ import annotations

import json
import math

import sympy as sp

from bondgraph import GY, TF, C, I, One, R, Se, Sf, Zero
from bondgraph.elements import Storage

from ..language.exprtext import ExpressionTextError, condition_text, expression_text
from ..model.expression_input import ExpressionInput
from ..library.mode_library import canonical
from ..model.hybrid_model import HybridModel, Tolerance
from ..model.stepped_inputs import stepped_inputs
from .errors import ModelFileError
from .read import FORMAT_KEY, FORMAT_VERSION

__all__ = ["dumps_model"]

_BARE_KEY = __import__("re").compile(r"^[A-Za-z0-9_-]+$")
_RUN_KEYS = ("t_end", "method", "rtol", "atol", "max_step", "first_step", "dt")


# ------------------------------------------------------------------ TOML pieces


def _string(text: str) -> str:
    """A TOML basic string."""
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")


def _key(name: str) -> str:
    return name if _BARE_KEY.fullmatch(name) else _string(name)


def _float(value: float) -> str:
    if math.isnan(value):
        return "nan"
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return repr(float(value))


def _inline(fields: dict) -> str:
    return "{ " + ", ".join(f"{_key(k)} = {v}" for k, v in fields.items()) + " }" if fields else "{}"


class _Writer:
    def __init__(self, model: HybridModel, display: str, inputs: dict | None = None):
        self.model = model
        self.display = display
        self.lines: list[str] = []
        #: input name → the ExpressionInput written in place of the model's own (``dumps_model(inputs=)``)
        self.inputs = dict(inputs or {})

    def error(self, message: str, culprit: str) -> ModelFileError:
        return ModelFileError(message, self.display, None, culprit)

    def expression(self, expr, culprit: str) -> str:
        """A TOML value for an expression: an integer or float as a number, else a text."""
        expr = sp.sympify(expr)
        if expr.is_Integer and abs(int(expr)) < 2**53:
            return str(int(expr))
        if expr.is_Float and math.isfinite(float(expr)) and expr._prec == 53:
            return _float(float(expr))
        try:
            return _string(expression_text(expr))
        except ExpressionTextError as exc:
            raise self.error(f"cannot be written to a model file: {exc}", culprit) from None

    def condition(self, condition, culprit: str) -> str:
        try:
            return _string(condition_text(condition))
        except ExpressionTextError as exc:
            raise self.error(f"cannot be written to a model file: {exc}", culprit) from None

    def section(self, header: str) -> None:
        if self.lines and self.lines[-1] != "":
            self.lines.append("")
        self.lines.append(header)

    # ------------------------------------------------------------ sections

    def write(self, run: dict | None, description: str | None, info) -> str:
        model = self.model
        from bondgraph import __version__

        self.lines += [f"# Hybrid bond graph model {model.name!r}, written by hbg {__version__}.",
                       "# Format: see the documentation of switching.files.modelfile (python -m pydoc switching.files.modelfile).",
                       f"{FORMAT_KEY} = {FORMAT_VERSION}", f"name = {_string(model.name)}"]
        if description:
            self.lines.append(f"description = {_string(description)}")
        if model.jump_law != "conservation":
            self.lines.append(f"jump_law = {_string(model.jump_law)}")
        if model.max_steps_per_instant != 1000:
            self.lines.append(f"max_steps_per_instant = {model.max_steps_per_instant}")
        inputs = self._inputs_text()
        self._parameters(info, inputs)
        if inputs:
            self.section("[inputs]")
            self.lines += [f"{_key(name)} = {_string(text)}" for name, (text, _) in inputs.items()]
        self._elements()
        self._bonds()
        self._displacements()
        if model.graph.ports:
            self.section("[ports]")
            self.lines += [f"{_key(p)} = {_string(e)}" for p, e in model.graph.ports.items()]
        self._automata()
        self._signals()
        self._initial_state()
        self._units()
        self._tolerance()
        self._run(run)
        return "\n".join(self.lines) + "\n"

    def _inputs_text(self) -> dict:
        """input name → (text, parameters it uses with their values)."""
        out = {}
        for name in self.model.graph.inputs:
            function = self.inputs.get(name, self.model._inputs[name])
            if not isinstance(function, ExpressionInput):
                raise self.error(
                    f"is a Python function ({function!r}), which a model file cannot hold; give the input as "
                    f"an expression of t: inputs={{{name!r}: ExpressionInput(\"...\", {{parameter: value}})}} "
                    "(from switching.model.expression_input)", f"input {name!r}")
            out[name] = (self.expression_text_of(function.expression, f"input {name!r}"), function.parameters)
        return out

    def expression_text_of(self, expr, culprit: str) -> str:
        try:
            return expression_text(expr)
        except ExpressionTextError as exc:
            raise self.error(f"cannot be written to a model file: {exc}", culprit) from None

    def _parameters(self, info, inputs: dict) -> None:
        model = self.model
        values = {s.name: v for s, v in {**model.parameter_values, **model.initial_parameters}.items()}
        for name, (_, parameters) in inputs.items():
            for p, v in parameters.items():
                if p in values and values[p] != v:
                    raise self.error(f"uses parameter {p!r} = {v}, but the model has {p} = {values[p]}",
                                     f"input {name!r}")
                values.setdefault(p, v)
        if not values:
            return
        self.section("[parameters]")
        notes = model.annotations
        units = {**(info.units if info else {}), **notes.units}
        descriptions = {**(info.descriptions if info else {}), **notes.descriptions}
        for name in sorted(values):
            value = _float(values[name])
            fields = {}
            if name in units:
                fields["unit"] = _string(units[name])
            if name in descriptions:
                fields["description"] = _string(descriptions[name])
            if name in model.allow_infinite:
                fields["allow_infinite"] = "true"
            line = _inline({"value": value, **fields}) if fields else value
            self.lines.append(f"{_key(name)} = {line}")

    def _elements(self) -> None:
        graph = self.model.graph
        self.section("[elements]")
        for name, element in graph.elements.items():
            fields = {"type": _string(element.kind)}
            fields.update(self._element_fields(element))
            self.lines.append(f"{_key(name)} = {_inline(fields)}")

    def _element_fields(self, el) -> dict:
        culprit = f"{el}"
        kind = type(el)
        if kind in (Se, Sf):
            return {"value": self.expression(el.value, culprit)}
        if kind in (TF, GY):
            return {"modulus": self.expression(el.modulus, culprit)}
        if kind in (Zero, One):
            return {"controlled": "true"} if el.controlled else {}
        if kind in (C, I):
            return self._storage_fields(el, culprit)
        if kind is R:
            return self._r_fields(el, culprit)
        raise self.error(f"is a {type(el).__name__}, an element class model files do not know; "
                         "model files hold Se, Sf, C, I, R, TF, GY, 0- and 1-junctions", culprit)

    def _storage_fields(self, el: Storage, culprit: str) -> dict:
        cls = type(el)
        linear, nonlinear = ("capacitance", "effort_law") if cls is C else ("inertance", "flow_law")
        fields = {}
        state = el.state.name
        candidate = el.state / el.law if el.law != 0 else None
        if candidate is not None and el.state not in candidate.free_symbols:
            rebuilt = cls(el.name, candidate, state=el.state)
            if canonical(rebuilt.law) == canonical(el.law):
                fields[linear] = self.expression(candidate, culprit)
        if not fields:
            if el.law.atoms(sp.Dummy):
                raise self.error("its law holds a placeholder symbol; build it from its state symbol", culprit)
            fields[nonlinear] = self.expression(el.law, culprit)
        if state != el.default_state_name():
            fields["state"] = _string(state)
        return fields

    def _r_fields(self, el: R, culprit: str) -> dict:
        (bond,) = self.model.graph.bonds_of(el.name)
        if el.effort_law is not None and el.flow_law is not None:
            (placeholder,) = el.effort_law.atoms(sp.Dummy) or (None,)
            if placeholder is not None:
                candidate = el.effort_law / placeholder
                if placeholder not in candidate.free_symbols:
                    rebuilt = R(el.name, candidate)
                    if [canonical(e) for e in rebuilt.expressions()] == [canonical(e) for e in el.expressions()]:
                        return {"resistance": self.expression(candidate, culprit)}
            raise self.error("has an effort law and a flow law that are not one linear resistance; "
                             "a model file holds one law (effort_law or flow_law) or a resistance", culprit)
        key, law, own = (("effort_law", el.effort_law, bond.flow) if el.effort_law is not None
                         else ("flow_law", el.flow_law, bond.effort))
        placeholders = law.atoms(sp.Dummy)
        if len(placeholders) > 1:
            raise self.error(f"its {key} holds {len(placeholders)} placeholder symbols; it needs one", culprit)
        if own in law.free_symbols:
            raise self.error(f"its {key} uses {own}, the variable the law is written in; it cannot be written",
                             culprit)
        return {key: self.expression(law.xreplace({p: own for p in placeholders}), culprit)}

    def _bonds(self) -> None:
        graph = self.model.graph
        if not graph.bonds:
            return
        self.section("[bonds]")
        self.lines += [f"{_key(b.name)} = {_string(f'{b.tail} -> {b.head}')}" for b in graph.bonds.values()]

    def _displacements(self) -> None:
        graph = self.model.graph
        if not graph.displacements:
            return
        self.section("[displacements]")
        for d in graph.displacements.values():
            self.lines.append(f"{_key(d.symbol.name)} = {_inline({'bond': _string(d.bond), 'sign': str(d.sign)})}")

    def _automata(self) -> None:
        model = self.model
        for automaton in model.automata:
            if automaton.name in model.law_switches:
                continue  # made from a discontinuous element law, again when the file is read
            prefix = f"automata.{_key(automaton.name)}"
            self.section(f"[{prefix}]")
            self.lines.append(f"initial = {_string(automaton.initial)}")
            if automaton.aliases:  # the old names of renamed states, still read
                self.lines.append(f"aliases = {_inline({a: _string(s) for a, s in automaton.aliases.items()})}")
            self.section(f"[{prefix}.states]")
            for state, setting in automaton.states.items():
                self.lines.append(f"{_key(state)} = {_inline({j: 'true' if on else 'false' for j, on in setting.items()})}")
            culprit = f"automaton {automaton.name!r}"
            if automaton.restitution:
                self.section(f"[{prefix}.restitution]")
                self.lines += [f"{_key(s)} = {self.expression(e, culprit)}" for s, e in automaton.restitution.items()]
            if automaton.values:
                self.section(f"[{prefix}.values]")
                for state, table in automaton.values.items():
                    fields = {k: self.expression(v, culprit) for k, v in table.items()}
                    self.lines.append(f"{_key(state)} = {_inline(fields)}")
            for k, tr in enumerate(automaton.transitions):
                tculprit = f"transition {k + 1} of automaton {automaton.name!r} ({tr.source} → {tr.target})"
                condition, _ = model.guard_conditions[(automaton.name, tr)]
                self.section(f"[[{prefix}.transitions]]")
                self.lines += [f"from = {_string(tr.source)}", f"to = {_string(tr.target)}",
                               f"guard = {self._guard(tr, condition, tculprit)}", f"when = {_string(tr.when)}"]
                if not tr.pulses:
                    self.lines.append("pulses = false")

    def _guard(self, tr, condition, culprit: str) -> str:
        """The guard as written when it reads back to the model's condition, else the condition printed."""
        if isinstance(tr.guard, str):
            from ..language.parsing import parse_condition

            try:
                if parse_condition(tr.guard, self._reader_names()) == condition:
                    return _string(tr.guard)
            except ValueError:
                pass
        return self.condition(condition, culprit)

    def _reader_names(self) -> dict:
        """The names a reader parses guards with: every symbol of the model, the signals by value."""
        if not hasattr(self, "_names"):
            model = self.model
            names = {"t": model.time}
            for s in (*model.states, *model.graph.bond_symbols(), *model.parameter_symbols,
                      *model.graph.inputs.values()):
                names[s.name] = s
            for automaton in model.automata:
                for table in automaton.values.values():
                    names.update({k: sp.Symbol(k) for k in table})
            names.update(model.signal_definitions)
            self._names = names
        return self._names

    def _signals(self) -> None:
        model = self.model
        if not model.signal_definitions:
            return
        self.section("[signals]")
        for name, value in model.signal_definitions.items():
            culprit = f"signal {name!r}"
            if name in model.cross_signals:
                expression, states = model.cross_signals[name]
                fields = {"expression": _string(self.expression_text_of(expression, culprit)),
                          "in_mode": _inline({a: _string(s) for a, s in states.items()})}
                self.lines.append(f"{_key(name)} = {_inline(fields)}")
            else:
                self.lines.append(f"{_key(name)} = {_string(self.expression_text_of(value, culprit))}")

    def _initial_state(self) -> None:
        model = self.model
        self.section("[initial_state]")
        for state, value in zip(model.states, model.given_initial_state):
            expr = model.initial_expressions.get(state)
            if expr is not None and expr.free_symbols:  # written with parameters: kept so, --set moves it
                text = _string(self.expression_text_of(expr, f"initial value of {state.name!r}"))
            else:
                text = _float(float(value))
            self.lines.append(f"{_key(state.name)} = {text}")

    def _units(self) -> None:
        """``[units]``: the units of states, signals and inputs (a parameter's is in its own entry)."""
        model = self.model
        parameters = {s.name for s in model.parameter_symbols} | {s.name for s in model.initial_parameters}
        units = {name: unit for name, unit in model.annotations.units.items() if name not in parameters}
        if units:
            self.section("[units]")
            self.lines += [f"{_key(name)} = {_string(unit)}" for name, unit in units.items()]

    def _tolerance(self) -> None:
        tolerance = self.model.tolerance
        default = Tolerance()
        changed = {k: getattr(tolerance, k) for k in ("rtol", "atol", "jump_rtol", "jump_atol")
                   if getattr(tolerance, k) != getattr(default, k)}
        if changed:
            self.section("[tolerance]")
            self.lines += [f"{k} = {_float(v)}" for k, v in changed.items()]

    def _run(self, run: dict | None) -> None:
        if not run:
            return
        self.section("[run]")
        for key, value in run.items():
            if key == "method":
                self.lines.append(f"method = {_string(value)}")
            elif key == "signals":
                self.lines.append("signals = [" + ", ".join(_string(s) for s in value) + "]")
            elif key in _RUN_KEYS:
                self.lines.append(f"{key} = {_float(float(value))}")
            else:
                raise self.error(f"the run option {key!r} has no place in a model file; run options: "
                                 f"{', '.join(_RUN_KEYS)}, signals", "[run]")


def dumps_model(model: HybridModel, *, run: dict | None = None, description: str | None = None,
                display: str = "<model file>", check: bool = True, inputs: dict | None = None) -> str:
    """The model file text of ``model``.

    ``run``: the default run (``t_end``, ``method``, ``rtol``, ``atol``,
    ``max_step``, ``first_step``, ``dt`` and ``signals``, the names to plot),
    ``description``: one paragraph about the model.  A model read from a file
    keeps its description, units, parameter descriptions and run unless these
    are given.  ``inputs``: input name → :class:`ExpressionInput` written in
    place of the model's own (an FMU's model file holds its inputs' start
    values: :mod:`switching.files.fmu`).  ``check``: read the text back and
    require the same fingerprint (the disk-cache key; where ``inputs`` change
    which inputs step, and so the laws the modes are derived with, the text
    need only read back)."""
    from .build import LoadedModel, file_info
    from .read import read_text

    if not isinstance(model, HybridModel):
        raise ModelFileError(f"expected a HybridModel, got {type(model).__name__}", display)
    info = file_info(model)
    if run is None and info is not None:
        run = info.run
    if description is None and info is not None:
        description = info.description
    text = _Writer(model, display, inputs).write(dict(run or {}), description, info)
    if check:
        loaded = LoadedModel(read_text(text, display)).build()
        if loaded.fingerprint != model.fingerprint and _same_steps(model, inputs):
            raise ModelFileError(
                "the written text does not read back to the same model (its fingerprint differs); this is a "
                "bug of the model file writer: please report it with the model", display)
    return text


def _same_steps(model: HybridModel, inputs: dict | None) -> bool:
    """Do the inputs written (``inputs`` over the model's own) step where the model's do
    (:func:`~switching.model.stepped_inputs.stepped_inputs`: the modes' laws, part of the fingerprint)?"""
    if not inputs:
        return True
    own = model.input_signals.functions
    return stepped_inputs(model.graph, own) == stepped_inputs(model.graph, {**own, **inputs})
