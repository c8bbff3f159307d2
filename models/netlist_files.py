'''Model files of netlists: a model built by ``Circuit`` or ``Mechanism`` saved as its components.

``model.save(path)`` (and ``hbg save``) writes a model built by :meth:`Circuit.build
<models.circuits.Circuit.build>` or :meth:`Mechanism.build <models.mechanics.Mechanism.build>` as
what it was built from (``model.built_from``): its components with their nodes and values, one line
a component, the build's parameters, inputs and options, units beside the values, and the run.
``models.load(path)``, ``switching.load_model(path)`` and ``hbg run path`` read it back: each line is
replayed as the builder call it records on a fresh netlist, which is built with the recorded
parameters and options — the same equations, the same run to the bit.  A model built as a bond graph
keeps the bond-graph form (:mod:`switching.files.modelfile`).

    >>> from models.circuits import Circuit
    >>> rc = Circuit("rc")
    >>> rc.V("V1", "in", "0", 10.0)
    >>> rc.R("R1", "in", "out", 1e3)
    >>> rc.C("C1", "out", "0", 1e-6)
    >>> model = rc.build()
    >>> text = dumps_netlist(model, run={"t_end": 0.005})
    >>> print(text[text.index("[circuit]"):], end="")
    [circuit]
    V1 = { type = "V", nodes = ["in", "0"], value = 10.0 }  # V
    R1 = { type = "R", nodes = ["in", "out"], value = 1000.0 }  # Ω
    C1 = { type = "C", nodes = ["out", "0"], value = 1e-06 }  # F
    <BLANKLINE>
    [run]
    t_end = 0.005
    >>> loads_netlist(text).fingerprint == model.fingerprint
    True

Format
======

The file is TOML with ``hbg_model_format = 1``, as every model file (the limits of
:mod:`switching.files.errors` hold), and:

``name``, ``description``
    The model's name (``build(name=...)``; default: the file's name) and a text.
``[circuit]`` or ``[mechanism]``
    One line a component, in the order added (it fixes the order of the states)::

        V1 = { type = "V", nodes = ["in", "0"], value = 12.0 }
        S1 = { type = "switch", nodes = ["in", "sw"], closed_when = { period = 1e-05, duty = 0.5 } }
        D1 = { type = "diode", nodes = ["0", "sw"], v_f = 0.7 }
        L1 = { type = "L", nodes = ["sw", "out"], value = 0.0001, i0 = 1.5 }
        RD = { type = "R", nodes = ["a", "0"], flow_law = { of = "v", law = "1e-12*(exp(v/0.025) - 1)" } }
        PI1 = { type = "pid", measure = "v_out", reference = 5.0, kp = 0.1, ki = 10.0, limits = { lo = 0.0, hi = 1.0 } }

    ``type`` is the builder's method (a circuit: ``R``, ``C``, ``L``, ``V``, ``I``, ``diode``, ``switch``,
    ``transformer``, ``gyrator``, ``coupled_inductors``, ``pid``; a mechanism: ``mass`` or ``inertia``,
    ``spring``, ``damper``, ``force`` or ``torque``, ``velocity``, ``gear``, ``motor``, ``clutch``,
    ``stop``, ``backlash``, ``pid``), ``nodes`` its nodes in the method's order (none for a
    controller), and every other key one of the method's keyword arguments, as Python takes it
    (``closed_when``, ``v0``, ``r_on``, ``engaged_when``, ``T_max``, …); an argument left out takes the
    method's default.  A value is a number, a text (a parameter name; an expression of ``t``, a
    condition or a signal's text, parsed by the toolkit's parser, never evaluated), ``true``/``false``,
    or a table: ``{ expression = "2*R0" }`` (a sympy value), ``{ input = "u" }`` (an
    :class:`~models.circuits.Input`), a PWM ``{ period = ..., duty = ..., delay = ... }``, a law ``{ of
    = "v", law = "..." }`` (a function of one argument: the law's expression of its variable ``of``),
    a controller's ``limits = { lo = ..., hi = ... }`` (:mod:`models.netlist_values`).  A component some
    calls made is written as the parts it made: a MOSFET or an IGBT as its switch and its body diode
    ``<name>_D``, a half-bridge as two of each, a DC machine as its gyrator, a :class:`~models.controllers.Hysteresis`
    schedule as its two conditions.  A comment after a line gives the units of its values.
``[build]``
    The netlist's own name (``netlist``, where it is not the model's) and a mechanism's ``kind``
    (``"rotational"``; translational by default), then the keyword arguments given to ``build``:
    ``gmin``, ``allow_floating`` (a circuit's), ``tolerance = { rtol = ... }``,
    ``max_steps_per_instant``, ``jump_law``, ``allow_infinite = [...]``, ``descriptions = {...}``.
``[positions]``
    A mechanism's nodes' positions at t = 0 (``a = 1.0``: :meth:`Mechanism.position`).
``[parameters]``
    ``name = value``: the parameters given to ``build`` (values for the parameter names the components
    use, and overrides of their numbers: ``R1 = 2000.0``).
``[inputs]``
    ``u = "5*step(t - 0.01)"`` or ``u = { expression = "A*sin(w*t)", parameters = { A = 1.0, w = 314.0 }
    }``: each declared input, an :class:`~switching.model.expression_input.ExpressionInput`.
``[run]``
    The default run, as in every model file (``t_end``, ``method``, ``rtol``, …, ``signals``);
    ``model.save`` always writes one.

Writing (:mod:`models.netlist_writer`) reads the text back and requires the same model; a model
changed after its build otherwise than in its parameter values is written as its bond graph, with a
comment that says why.  A model whose inputs are Python functions is refused — no model file holds a
function — with a :class:`~switching.files.errors.ModelFileError` naming the input and saying to give
it as an ``ExpressionInput``; so is a component value or law the text grammar cannot express, naming
the component.  Reading (:mod:`models.netlist_reader`) refuses, naming the file, the line and the
component, what is not a component line (an unknown ``type``, an unknown keyword, the wrong number of
nodes, a value of the wrong shape, a text that does not parse or calls a function the grammar lacks)
and what the builder refuses (a bad node or component name, a value out of range, a floating node).
'''

from __future__ import annotations

from switching.files.source import Source

from .netlist_reader import NetlistFile
from .netlist_writer import dumps_netlist

__all__ = ["NetlistFile", "dumps_netlist", "loads_netlist"]


def loads_netlist(text: str, display: str = "<text>", **parameters):
    """The model of a netlist's model file given as ``text``, its parameter values overridden by ``parameters``."""
    return NetlistFile(Source(None, text, display)).build(**parameters)
