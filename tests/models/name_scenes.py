"""Small circuits and mechanisms whose every name is given by a role, and the
names the builders and the bond graph make from names (the patterns a user's
name may meet): the material of the namespace property test
(tests/models/test_names_property.py).

A scene is ``scene(names) -> (netlist, build keyword arguments, run keyword
arguments)``, where ``names`` maps each role (a component, a node, a
parameter) to the name it takes; :data:`FRESH` holds names no pattern
reaches.
"""

from __future__ import annotations

import random
import re

from models.circuits import PWM, Circuit
from models.mechanics import Mechanism

__all__ = ["SCENES", "fresh_names", "pattern_names", "renamed", "ROLE_KINDS", "file_roles", "file_renaming",
           "hierarchy_parts", "renamed_text", "same_tables"]

#: the suffixes the builders append to a component's name (parameters, internal elements, bonds, signals)
SUFFIXES = ("period", "duty", "v_f", "r_on", "gmin", "drop", "resistance", "ground", "in", "out", "p", "s",
            "primary", "secondary", "e", "v_th", "upper", "lower", "delta", "k", "V", "R", "L", "T_max",
            "armature", "frame", "m", "law", "2")
#: the prefixes the builders and the bond graph put before a name (bond variables, states, signals)
PREFIXES = ("f_", "e_", "q_", "p_", "v_", "i_", "x_", "omega_", "theta_", "F_", "T_", "carrier_", "emf_",
            "engaged_", "node_", "branch_", "d")
#: names of their own that generated names may take
SPECIAL = ("t", "gmin", "pi")


def half_wave(n):
    """A rectifier with a real diode (drop and on-resistance) into an RC load, a sine source."""
    c = Circuit("half_wave")
    c.V(n["V1"], n["in"], "0", f"{n['Vm']}*sin(2*pi*50*t)")
    c.diode(n["D1"], n["in"], n["out"], r_on=0.5, v_f=0.7)
    c.C(n["C1"], n["out"], "0", 1e-4)
    c.R(n["R1"], n["out"], "0", 100.0)
    return c, {"parameters": {n["Vm"]: 10.0}}, {"t_end": 0.025, "method": "RK45", "rtol": 1e-9}


def chopper(n):
    """A PWM switch feeding an RL load with a freewheeling diode (r_on), a leak across both."""
    c = Circuit("chopper")
    c.V(n["V1"], n["in"], "0", 12.0)
    c.switch(n["S1"], n["in"], n["sw"], PWM(1e-3, n["D"]))
    c.diode(n["D1"], "0", n["sw"], r_on=0.01)
    c.L(n["L1"], n["sw"], n["out"], 1e-2)
    c.R(n["R1"], n["out"], "0", 10.0)
    return (c, {"parameters": {n["D"]: 0.4}, "gmin": 1e-9},
            {"t_end": 2.5e-3, "method": "RK45", "rtol": 1e-9, "max_step": 1e-4})


def coupled(n):
    """A transformer between a source with a series resistor and an RC load, switched on at 1 ms."""
    c = Circuit("coupled")
    c.V(n["V1"], n["in"], "0", 5.0)
    c.switch(n["S1"], n["in"], n["a"], f"t >= {n['t_on']}")
    c.R(n["R1"], n["a"], n["p"], 2.0)
    c.transformer(n["T1"], n["p"], "0", n["s"], "0", 2.0)
    c.C(n["C1"], n["s"], "0", 1e-4, v0=1.0)
    c.R(n["R2"], n["s"], "0", 50.0)
    return c, {"parameters": {n["t_on"]: 1e-3}}, {"t_end": 4e-3, "method": "RK45", "rtol": 1e-9}


def drop(n):
    """A mass on a spring and damper falling onto a stop (rebounds, then lands)."""
    m = Mechanism("drop")
    m.mass(n["m1"], n["a"], 2.0, x0=0.5)
    m.force(n["g"], n["a"], f"-{n['weight']}")
    m.stop(n["floor"], n["a"], lower=0.0, e=0.5, v_th=0.3)
    m.spring(n["k1"], n["a"], n["b"], 200.0)
    m.mass(n["m2"], n["b"], 1.0)
    m.damper(n["c1"], n["b"], "0", 3.0)
    return m, {"parameters": {n["weight"]: 19.62}}, {"t_end": 0.6, "method": "RK45", "rtol": 1e-9}


def drive(n):
    """A DC motor with an inertia and friction, a clutch engaging a second inertia at 20 ms."""
    m = Mechanism("drive", kind="rotational")
    m.motor(n["M"], n["w"], 0.1, V=12.0, R=2.0, L=1e-3)
    m.inertia(n["J1"], n["w"], 1e-3)
    m.damper(n["b1"], n["w"], "0", 1e-4)
    m.clutch(n["K"], n["w"], n["v"], f"t >= {n['t_on']}")
    m.inertia(n["J2"], n["v"], 2e-3)
    m.damper(n["b2"], n["v"], "0", 2e-4)
    return m, {"parameters": {n["t_on"]: 0.02}}, {"t_end": 0.04, "method": "RK45", "rtol": 1e-9}


#: scene name → (scene, its roles by kind: components, nodes, parameters)
SCENES = {
    "half_wave": (half_wave, {"component": ("V1", "D1", "C1", "R1"), "node": ("in", "out"),
                              "parameter": ("Vm",)}),
    "chopper": (chopper, {"component": ("V1", "S1", "D1", "L1", "R1"), "node": ("in", "sw", "out"),
                          "parameter": ("D",)}),
    "coupled": (coupled, {"component": ("V1", "S1", "R1", "T1", "C1", "R2"), "node": ("in", "a", "p", "s"),
                          "parameter": ("t_on",)}),
    "drop": (drop, {"component": ("m1", "g", "floor", "k1", "m2", "c1"), "node": ("a", "b"),
                    "parameter": ("weight",)}),
    "drive": (drive, {"component": ("M", "J1", "b1", "K", "J2", "b2"), "node": ("w", "v"),
                      "parameter": ("t_on",)}),
}

#: role kind of every role of every scene
ROLE_KINDS = {scene: {role: kind for kind, roles in by_kind.items() for role in roles}
              for scene, (_, by_kind) in SCENES.items()}


def fresh_names(scene: str) -> dict:
    """Each role of ``scene`` named by itself with a prefix no pattern makes (``Zq_R1``)."""
    return {role: f"Zq_{role}" for role in ROLE_KINDS[scene]}


def pattern_names(names: dict) -> list[str]:
    """Every name a pattern of the builders or the bond graph makes from the ``names`` of a scene:
    ``<name>_<suffix>``, ``<prefix><name>``, prefixes of suffixed names, and ``t``, ``gmin``, ``pi``."""
    found = set(SPECIAL)
    for name in names.values():
        suffixed = [f"{name}_{suffix}" for suffix in SUFFIXES]
        found.update(suffixed)
        found.update(f"{prefix}{base}" for prefix in PREFIXES for base in [name, *suffixed[:8]])
    return sorted(found)


def renamed(scene: str, rng: random.Random, how_many: int, made=()) -> tuple[dict, dict]:
    """``(fresh, renamed)`` names of ``scene``: ``how_many`` of its roles renamed to names drawn, half the
    time each, from the patterns of the other fresh names or from ``made`` (the names the fresh build
    made: its model's namespace), a node only to names a node may take."""
    fresh = fresh_names(scene)
    roles = rng.sample(sorted(fresh), how_many)
    names = dict(fresh)
    for role in roles:
        others = {r: n for r, n in names.items() if r != role}
        source = sorted(made) if made and rng.random() < 0.5 else pattern_names(others)
        pool = [p for p in source if p not in names.values()]
        if ROLE_KINDS[scene][role] == "node":
            pool = [p for p in pool if re.fullmatch(r"[A-Za-z0-9_]+", p) and p != "0"]
        names[role] = rng.choice(pool)
    return fresh, names


# -- shipped models, renamed in their model files

#: a key whose text value holds no name of the model (an element's type, an instant's kind, an automaton's
#: state, prose), kept as it is; or a name: an identifier not inside a hierarchical name
_TOKEN = re.compile(r'(?P<keep>\b(?:type|when|from|to|initial|unit|description|name|hbg_model_format)\s*=\s*"[^"]*")'
                    r"|(?P<word>\b[A-Za-z_][A-Za-z0-9_]*\b)")
#: a hierarchical name (``rod/body/I_x``)
_HIERARCHICAL = re.compile(r"\b[A-Za-z_]\w*(?:/[A-Za-z_]\w*)+")


def hierarchy_parts(text: str) -> set:
    """Every part of a hierarchical name in a model file's ``text``: names no renaming may take or touch
    (a plain word renamed would rename that part too; ``/`` between plain names is a division)."""
    return {part for found in _HIERARCHICAL.findall(text) for part in found.split("/")}


def file_roles(table: dict, parts=frozenset()) -> dict:
    """role → its kind, for the plain names of a model file's ``table`` (read with tomllib): its
    elements, bonds, parameters and signals, except the ``parts`` of hierarchical names."""
    roles = {}
    for kind, key in (("element", "elements"), ("bond", "bonds"), ("parameter", "parameters"),
                      ("signal", "signals")):
        for name in table.get(key, {}):
            if "/" not in name and name not in parts:
                roles.setdefault(name, kind)
    return roles


def same_tables(table: dict, name: str) -> set:
    """The keys of every table of a model file's ``table`` that has ``name`` as a key (a file holds a
    key once in a table: renaming ``name`` to one of these would break the file, not the model)."""
    keys = set()
    for value in table.values():
        if isinstance(value, dict) and name in value:
            keys |= set(value)
    return keys


def file_renaming(table: dict, old: str, new: str) -> dict:
    """The words to replace in a model file when ``old`` becomes ``new``: the name itself and the
    names the bond graph makes of it — its bond's variables ``e_``/``f_``, its storage's state."""
    mapping = {old: new}
    if old in table.get("bonds", {}):
        mapping.update({f"e_{old}": f"e_{new}", f"f_{old}": f"f_{new}"})
    element = table.get("elements", {}).get(old, {})
    prefix = {"C": "q_", "I": "p_"}.get(element.get("type"))
    if prefix and "state" not in element:
        mapping[f"{prefix}{old}"] = f"{prefix}{new}"
    return mapping


def renamed_text(text: str, mapping: dict) -> str:
    """``text`` (a model file) with every word of ``mapping`` replaced, except in comments and in the
    values of the keys that hold no names (element types, transitions' kinds and states, prose)."""
    lines = []
    for line in text.splitlines():
        if line.lstrip().startswith("#"):
            lines.append(line)
            continue
        lines.append(_TOKEN.sub(lambda m: m.group() if m.group("keep") else mapping.get(m.group(), m.group()), line))
    return "\n".join(lines) + "\n"
