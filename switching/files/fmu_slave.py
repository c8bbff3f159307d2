"""The slave every FMU of :func:`switching.files.fmu.to_fmu` runs: a pythonfmu ``Fmi2Slave`` over a
:class:`~switching.files.fmu.CoSimulation` of the model in the FMU's ``resources/model.toml``.

pythonfmu's C++ wrapper calls these methods from the FMI functions (``fmi2DoStep`` →
:meth:`ModelSlave.do_step`, ``fmi2GetReal`` → ``get_real``, ...).  The model file is read with the
toolkit's loader (:func:`~switching.files.modelfile.load_model`: parsed, never executed).  This
module needs pythonfmu (the FMU carries a copy of it); :mod:`switching.files.fmu` does not.
"""

from __future__ import annotations

from functools import partial
from pathlib import Path
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Status

from bondgraph.errors import HybridBondGraphError

from .build import file_info
from .fmu import MODEL_FILE, CoSimulation, FmuVariable, fmu_variables
from .modelfile import load_model

__all__ = ["ModelSlave", "keep"]


class _Real(Real):
    """pythonfmu's Real with the ``unit`` attribute FMI 2.0 gives a Real variable."""

    def __init__(self, name: str, unit: str | None = None, **kwargs):
        super().__init__(name, **kwargs)
        self.unit = unit

    def to_xml(self) -> Element:
        node = super().to_xml()
        if self.unit:
            node.find("Real").set("unit", self.unit)
        return node


class ModelSlave(Fmi2Slave):
    """An FMU of a hybrid bond graph model (see :mod:`switching.files.fmu`): the model read from
    ``resources/model.toml``, its parameters, inputs, states, signals and automata as variables."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        model = load_model(Path(self.resources) / MODEL_FILE)
        self.cosimulation = CoSimulation(model)
        self.variables = fmu_variables(model)
        info = file_info(model)
        run = info.run if info is not None else {}
        self.description = (info.description if info is not None else None) or f"hybrid bond graph model {model.name}"
        self.default_experiment = DefaultExperiment(start_time=0.0, stop_time=run.get("t_end"),
                                                    tolerance=run.get("rtol"))
        for variable in self.variables:
            self.register_variable(self._variable(variable), nested=False)

    # ---------------------------------------------------------------- variables

    def _variable(self, v: FmuVariable):
        """The pythonfmu variable of ``v``, its getter and setter reading and setting the co-simulation."""
        cosim = self.cosimulation
        causality = Fmi2Causality[v.causality]
        variability = Fmi2Variability[v.variability]
        if v.causality == "parameter":
            getter, setter = partial(cosim.parameter, v.name), partial(cosim.set_parameter, v.name)
        elif v.causality == "input":
            getter, setter = partial(_held, cosim.inputs[v.name]), partial(cosim.set_input, v.name)
        else:
            getter, setter = partial(_output, cosim, v.name), partial(_refuse, v.name)
        if v.kind == "mode":
            return Integer(v.name, causality=causality, variability=variability, description=v.description,
                           getter=getter, setter=setter)
        return _Real(v.name, v.unit, causality=causality, variability=variability, description=v.description,
                     getter=getter, setter=setter)

    def to_xml(self, model_options: dict | None = None) -> Element:
        """pythonfmu's model description, with flat names (``rod/theta`` as written), the units declared
        and the outputs as the initial unknowns too (computed at initialization, as FMI 2.0 asks)."""
        root = super().to_xml(model_options or {})
        root.set("variableNamingConvention", "flat")
        outputs = root.find("ModelStructure/Outputs")
        if outputs is not None:
            unknowns = SubElement(root.find("ModelStructure"), "InitialUnknowns")
            for unknown in outputs:
                SubElement(unknowns, "Unknown", dict(unknown.attrib))
        units = sorted({v.unit for v in self.variables if v.unit})
        if units:
            definitions = Element("UnitDefinitions")
            for unit in units:
                SubElement(definitions, "Unit", {"name": unit})
            position = list(root).index(root.find("CoSimulation")) + 1
            root.insert(position, definitions)
        return root

    # ---------------------------------------------------------------- FMI

    def setup_experiment(self, start_time: float, stop_time=None, tolerance=None):
        """The start time (the stop time and tolerance are the FMU's own, fixed at export)."""
        self.cosimulation.t = float(start_time)

    def exit_initialization_mode(self):
        """The start: the initial state and mode with the parameters set, the instant at the start time resolved."""
        try:
            self.cosimulation.start(self.cosimulation.t)
        except HybridBondGraphError as error:
            self.log(f"the initial instant failed: {error}", Fmi2Status.error)
            raise

    def do_step(self, current_time: float, step_size: float) -> bool:
        """One communication step; False (fmi2Discard: the state where it began) when its run fails."""
        try:
            self.cosimulation.step(current_time, step_size)
        except HybridBondGraphError as error:
            self.log(f"the step from t = {current_time!r} s by {step_size!r} s failed: {error}", Fmi2Status.error)
            return False
        return True


#: the namespaces of the FMUs' slave modules, each held once more every time pythonfmu reads its file
KEPT: list = []


def keep(namespace: dict) -> None:
    """Hold the slave module's ``namespace`` once more (its file calls this each time it runs).

    pythonfmu 0.7's FMI library finds the slave class by importing the module and running its file
    again in the module's namespace, then releases that namespace once, which it never held (a
    borrowed reference, ``PyModule_GetDict``): the module's namespace was freed under it, and a second
    FMU of the same model in one process failed to instantiate ("module has no attribute"), or the
    process crashed collecting garbage.  The file runs once more than the library releases (at its
    import), so each namespace stays held once here, for the life of the process."""
    KEPT.append(namespace)


def _held(held) -> float:
    """The value an input holds."""
    return held.value


def _output(cosim: CoSimulation, name: str):
    """Output ``name`` at the current communication point."""
    return cosim.outputs()[name]


def _refuse(name: str, value) -> None:
    """An output is not set by the master (FMI 2.0)."""
    raise ValueError(f"{name!r} is an output of the FMU: it cannot be set")
