"""A conflicting configuration seen through vanishing resistances.

Two kinds of configuration have no equations of their own, and both are
seen through resistances that vanish or grow.

A configuration whose sources over-determine the graph (a causality
conflict: a voltage source shorted through closed switches and conducting
diodes) has no equations.  Put a resistance ``ε`` in series with every
*on* controlled 1-junction (an ideal switch or diode conducting): the
conflict is gone, the loop the sources drive carries a current of order
``1/ε``, and every bond variable becomes a rational function of ``ε``.  Its
limit as ``ε → 0⁺`` is what the ideal configuration would do at the instant
it is entered: a bond variable of order ``1/ε`` tends to ``±∞`` (the
impulse direction of the conflict: the diode whose current that impulse
reverses turns off, as PLECS's switch consistency iteration decides it); one
of order 1 to its finite value.

:func:`regularized_equations` derives the ``ε`` configuration;
:func:`leading_term` splits an expression of ``ε`` into its order and
leading coefficient, which the simulator evaluates at the state.

A configuration that leaves part of the graph *under*-determined (nodes
that float: a bridge rectifier's load while all four diodes block; a free
loop current through ideal switches in parallel) has states whose rates are
defined and bond variables that are not.  Put ``1/ε`` in series with every
blocking controlled 1-junction (a leak across it) and ``ε`` with every
conducting one: in the limit ``ε → 0⁺`` every bond variable has a value —
a floating node the potential the vanishing leaks give it, the same for
any leak that vanishes evenly — and the rates keep their own.  That limit
is found without ``ε`` (:func:`floating_limit`): virtual sources on the free
directions make the configuration derivable, and the leaks choose their
values by least dissipation, a small linear system.  This is SPICE's
``GMIN`` taken to its limit exactly, not at 1e-12.
"""

from __future__ import annotations

import sympy as sp

from .elements import Junction, One, R, Se, Sf
from .errors import FloatingPartError
from .graph import BondGraph

__all__ = ["EPSILON", "regularized_graph", "regularized_equations", "leading_term", "floating_limit"]

#: the vanishing series resistance of every conducting ideal switch
EPSILON = sp.Symbol("epsilon_conflict", positive=True)


def _copy(graph, name: str) -> BondGraph:
    """A copy of ``graph``: its elements, bonds (by name), displacements and inputs."""
    copy = BondGraph(name)
    for element in graph.elements.values():
        copy.add(element)
    for bond in graph.bonds.values():
        copy.connect(bond.tail, bond.head, name=bond.name)
    copy.displacements = dict(graph.displacements)
    copy.inputs = dict(graph.inputs)
    return copy


def regularized_graph(graph, config: dict) -> BondGraph:
    """A copy of ``graph`` with a resistance :data:`EPSILON` bonded to every controlled 1-junction that
    ``config`` turns on (its elements, bonds, displacements and inputs kept, by name)."""
    copy = _copy(graph, f"{graph.name} (regularized)")
    for name, element in graph.elements.items():
        if isinstance(element, One) and element.controlled and config.get(name, True):
            copy.connect(name, R(f"{name}/conflict_resistance", EPSILON))
    return copy


def regularized_equations(graph, config: dict):
    """The :class:`~bondgraph.equations.ConfigurationEquations` of ``config`` on :func:`regularized_graph`:
    every bond variable of ``graph`` an expression of the states, parameters, inputs, ``t`` and
    :data:`EPSILON`.  Raises as :meth:`BondGraph.equations` does when the resistances do not remove the
    conflict (sources that over-determine the graph without any switch)."""
    return regularized_graph(graph, config).equations(dict(config))


def leading_term(expr: sp.Expr) -> tuple[list, list]:
    """``(numerator, denominator)`` coefficients of ``expr`` as a ratio of polynomials in
    :data:`EPSILON`, lowest order first: the limit ``ε → 0⁺`` is decided by the first non-zero
    coefficient of each at the state (order of the numerator's minus the denominator's: below 0
    an infinity of the sign of their ratio, 0 their ratio, above 0 zero)."""
    numerator, denominator = sp.fraction(sp.together(sp.sympify(expr)))
    coefficients = []
    for part in (numerator, denominator):
        poly = sp.Poly(sp.expand(part), EPSILON)
        coefficients.append(list(reversed(poly.all_coeffs())))
    return coefficients[0], coefficients[1]


def _free_variables(graph, config: dict, limit_of: int = 64) -> tuple[BondGraph, list, object]:
    """``(graph with virtual sources, their symbols, equations)``: ``graph`` with an effort source
    ``z_k`` bonded to one floating junction of each free effort direction and a flow source on one
    junction of each free loop, added one at a time until the configuration derives — every bond
    variable then an expression of the states, inputs, ``t`` and the ``z_k`` (affine in them: a free
    direction of the junction structure moves no port).  Raises the last ``FloatingPartError`` when a
    source added does not remove a free direction."""
    copy = _copy(graph, f"{graph.name} (floating)")
    symbols: list = []
    for k in range(limit_of):
        try:
            return copy, symbols, copy.equations(dict(config), open_ports=False)
        except FloatingPartError as error:
            junction = next(iter(error.elements), None)
            if junction is None or junction not in copy.elements or (symbols and _stuck(error, copy)):
                raise
            z = sp.Dummy(f"floating_{k}")  # (no name of the model's can be it)
            source = (Se if error.kind == "effort" else Sf)(f"{junction}/floating_{k}", z)
            copy.connect(source, junction)
            symbols.append(z)
    raise ValueError(f"more than {limit_of} free directions")


def _stuck(error, copy) -> bool:
    """Whether the floating junction ``error`` names already carries a virtual source (adding another
    would remove nothing)."""
    return any("/floating_" in bond.tail for bond in copy.bonds_of(error.elements[0]))


def _across(graph, values: dict, junction: str) -> sp.Expr:
    """Σ of the efforts (a 1-junction) or flows (a 0-junction) of ``junction``'s bonds, + into it: what a
    resistance bonded to it would take — the effort across a blocking switch, the flow through a
    released coupling."""
    total = sp.Integer(0)
    for bond in graph.bonds_of(junction):
        if bond.name in values:
            total += values[bond.name] if bond.head == junction else -values[bond.name]
    return total


def floating_limit(graph, config: dict, jump_law: str):
    """``(equations, jump map)`` of an under-determined ``config`` (floating nodes, a free loop
    current, a torque free between couplings in parallel) as the limit of vanishing leaks: every
    blocking controlled 1-junction in series with a resistance ``1/ε``, every conducting one with ``ε``
    (dually for controlled 0-junctions: an engaged coupling's effort, a released one's flow), ``ε → 0⁺``.

    The limit is found without ``ε``.  The configuration with a virtual source on each free direction
    (:func:`_free_variables`) gives every bond variable as an affine function of the sources'
    values ``z``; the leaks pick the ``z`` that dissipates least in them (a linear network's currents
    minimise its dissipation, and the leaks' is the only dissipation ``z`` changes),

        min_z  Σ_blocking a_k(z)² + Σ_conducting f_k(z)²   (a_k the effort across, f_k the flow;
                                                            for 0-junctions the flow through, the effort),

    i.e. ``Mz = −r`` with ``M_ij = Σ ∂v_k/∂z_i ∂v_k/∂z_j`` and ``r_i = Σ ∂v_k/∂z_i v_k(0)``.  A
    floating node takes the potential that divides the voltage across the blocking elements around it
    equally; a free loop current is divided equally among the conducting elements of the loop; a
    storage element the configuration ties (a capacitor across conducting diodes) keeps its
    dependent state, as in any mode.  Raises ``ValueError`` where no leak decides a free direction,
    a virtual source would carry power (the configuration is over-determined as well) or the jump
    map depends on ``z``."""
    from dataclasses import replace

    augmented, free, equations = _free_variables(graph, config)
    jump = augmented.jump_map(dict(config), jump_law)
    if not free:
        return equations, jump
    if jump.expressions is None or any(sp.sympify(v).has(*free) for v in jump.expressions.values()):
        raise ValueError("the jump map into the configuration depends on the floating part")
    variables = []
    for name, element in graph.elements.items():
        if not (isinstance(element, Junction) and element.controlled):
            continue
        on, series = config.get(name, True), isinstance(element, One)
        if on:  # a conducting switch's flow (a 1-junction), an engaged coupling's effort (a 0-junction)
            table = equations.flows if series else equations.efforts
            variables.append(table[graph.bonds_of(name)[0].name])
        else:  # the effort across a blocking switch, the flow through a released coupling
            variables.append(_across(graph, equations.efforts if series else equations.flows, name))
    if not variables:
        raise ValueError("no leak decides the floating part (it touches no diode or switch)")
    at_zero = {z: 0 for z in free}
    slopes = sp.Matrix([[sp.diff(v, z) for z in free] for v in variables])
    if any(s.has(*free) for s in slopes):
        raise ValueError("the floating part enters the equations nonlinearly")
    offsets = sp.Matrix([v.xreplace(at_zero) for v in variables])
    normal = slopes.T * slopes
    if normal.det() == 0:
        raise ValueError("no leak decides the floating part (it touches no diode or switch)")
    solution = dict(zip(free, list(-normal.LUsolve(slopes.T * offsets))))
    for source in (b for b in augmented.bonds if b not in graph.bonds):
        power = sp.expand(equations.efforts[source] * equations.flows[source]).xreplace(solution)
        if sp.simplify(power) != 0:
            raise ValueError("a virtual source of the floating part carries power (the configuration is "
                             "over-determined as well)")

    equations = equations.substituted(solution)  # (recorded: a derivation again from its graph substitutes it)
    equations = replace(equations, graph_name=graph.name, configuration=dict(config),
                        efforts={k: v for k, v in equations.efforts.items() if k in graph.bonds},
                        flows={k: v for k, v in equations.flows.items() if k in graph.bonds})
    return equations, jump
