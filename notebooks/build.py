"""Write (and execute) the tutorial notebooks from the cell sources below.

    python notebooks/build.py            # write and execute all notebooks in place
    python notebooks/build.py --no-run   # only write them

The test suite executes every notebook again (tests/test_notebooks.py), so a
notebook that stops working fails the build.
"""

from __future__ import annotations

import sys
from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

HERE = Path(__file__).resolve().parent

SETUP = """\
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
%matplotlib inline
from switching.plotting import plot_trajectory, phase_portrait, mode_graph, draw_bond_graph"""

def md(text):
    return ("md", text)


def py(text):
    return ("py", text)


NOTEBOOKS = {
    "circuits": [
        md("# Switching circuits\n\nIdeal switches and diodes as controlled junctions driven by local automata: "
        "the paper's diode circuit (a mythical mode on switch opening, and the divergence-of-time error), "
        "charge sharing between capacitors, and a PWM boost converter in continuous and discontinuous conduction."),
        py(SETUP),
        md("## The diode circuit (the paper's Fig. 1)\n\nThe bond graph with its causal strokes while the switch is closed:"),
        py("from models import diode_circuit\nmodel = diode_circuit.build()\n"
        "draw_bond_graph(model.graph, model.configuration_of(model.initial_mode));"),
        md("The derived equations of the modes a run visits:"),
        py("trajectory = model.simulate(**{**diode_circuit.RUN, 't_end': 1.0})\n"
        "for mode in dict.fromkeys(trajectory.modes):\n    print(model.mode_equations(mode).pretty(), '\\n')"),
        md("Opening the switch passes the mythical mode (open, off): the inductor's flux is the same before and after."),
        py("print(trajectory.events[0])\nplot_trajectory(trajectory, ['i_L', 'v_D', 'i_D']);"),
        md("With a holding current above the inductor's current the diode cannot stay on, and cannot stay off: "
        "time would stop.  The toolkit reports the loop and keeps what was computed."),
        py("from switching import DivergenceOfTimeError\ntry:\n    diode_circuit.build(I_th=200.0).simulate(1.0)\n"
        "except DivergenceOfTimeError as error:\n    print(str(error)[:900])\n"
        "    print('samples kept:', len(error.trajectory.t))"),
        md("## Two capacitors joined by a switch\n\nWith no resistance the charge is shared at once "
        "(conservation of state) and energy C1·C2/(2(C1+C2))·ΔV² is lost."),
        py("from models import parallel_capacitors\ncaps = parallel_capacitors.build()\n"
        "run = caps.simulate(**parallel_capacitors.RUN)\nplot_trajectory(run, ['v1', 'v2', 'q_total', 'energy']);"),
        md("## A boost converter\n\nPWM drives the switch; the diode is ideal.  Heavy load: continuous conduction; "
        "light load: the inductor current reaches zero with switch and diode both off."),
        py("from models import boost_converter\nconverter = boost_converter.build()\n"
        "out = converter.simulate(**boost_converter.RUN)\nprint(out.summary())\n"
        "plot_trajectory(out, ['i_L', 'v_C']);"),
    ],
    "impacts": [
        md("# Impacts\n\nCollisions as pinnacles with Newton's restitution: a bouncing ball (exact bounce times, "
        "a resting rule, Zeno behaviour without it), two colliding balls, and Newton's cradle."),
        py(SETUP),
        md("## Bouncing ball"),
        py("from models import bouncing_ball\nball = bouncing_ball.build(v_rest=0.3)\n"
        "run = ball.simulate(6.0, 'RK45', rtol=1e-9)\nprint(run.summary())\nplot_trajectory(run, ['y', 'v']);"),
        md("The first bounce times against the closed form t₁(1 + 2e + … + 2eᵏ⁻¹):"),
        py("t1 = np.sqrt(2 / 9.81)\nexact = t1 * (1 + 2 * np.cumsum([0] + [0.8 ** k for k in range(1, 4)]))\n"
        "print(np.c_[run.event_times[:4], exact, run.event_times[:4] - exact])"),
        md("Without the resting rule the bounces accumulate at t₁(1+e)/(1−e) = 4.0637 s: Zeno behaviour is detected "
        "and the run stops there when asked to."),
        py("zeno = bouncing_ball.build(v_rest=0.0).simulate(10.0, 'RK45', rtol=1e-9, on_zeno='stop')\n"
        "print(zeno.stopped, zeno.stats['zeno accumulation time [s]'])"),
        md("## Two balls"),
        py("from models import colliding_balls\npair = colliding_balls.build()\n"
        "run = pair.simulate(**colliding_balls.RUN)\nplot_trajectory(run, ['x1', 'x2', 'v1', 'v2']);"),
        md("## Newton's cradle\n\nFour touching balls: one instant, three pinnacles, the last ball leaves "
        "with the first one's velocity (the paper's Figs. 13–14)."),
        py("from models import ball_chain\nchain = ball_chain.build()\nrun = chain.simulate(**ball_chain.RUN)\n"
        "print(run.events[0])\nmode_graph(run);"),
    ],
    "falling_rod": [
        md("# The falling rod\n\nA rod released at an angle hits the floor; Coulomb friction decides whether its tip "
        "sticks or slides (the paper's Figs. 7–9, 19–20)."),
        py(SETUP),
        py("from models import falling_rod\nrod = falling_rod.build()\n"
        "draw_bond_graph(rod.graph, rod.configuration_of(rod.mode('contact|stuck')));"),
        md("Equations of the stuck mode: the translational momenta are dependent, the jump into it is the paper's Eq. (23)."),
        py("print(rod.mode_equations('contact|stuck').pretty())"),
        md("## A μ sweep\n\nSmall μ: the stuck mode is passed as mythical and the tip slides at once.  Large μ: it sticks."),
        py("runs = {mu: falling_rod.build(mu=mu).simulate(0.5, 'RK45', rtol=1e-9, atol=1e-12) for mu in (0.002, 0.004, 0.005)}\n"
        "for mu, run in runs.items():\n    print(mu, [(s.mode.label, s.kind) for s in run.events[0].steps])\n"
        "fig, ax = plt.subplots(figsize=(6, 4))\n"
        "for (mu, run), color in zip(runs.items(), ['tab:blue', 'tab:orange', 'tab:green']):\n"
           "    phase_portrait(run, 'theta', 'tip_vx', ax=ax, label=f'mu = {mu}', color=color)"),
        md("Forces while in contact: the floor only pushes, friction stays within the cone."),
        py("plot_trajectory(runs[0.005], ['normal_force', 'friction_force', 'tip_vx']);"),
        md("## A long rod (Fig. 20)\n\nIt slides for a point in time, then lifts off."),
        py("long = falling_rod.build(mu=0.002, l=10.0, y0=23.0).simulate(3.0, 'RK45', rtol=1e-9, atol=1e-12)\n"
        "print(long.events[0])\nphase_portrait(long, 'theta', 'omega');"),
    ],
    "hydraulics": [
        md("# Hydraulics: two tanks and a level-switched valve"),
        py(SETUP),
        py("from models import two_tanks\ntanks = two_tanks.build()\n"
        "draw_bond_graph(tanks.graph, tanks.configuration_of(tanks.initial_mode));"),
        py("run = tanks.simulate(**two_tanks.RUN)\nprint(run.summary())\nplot_trajectory(run, list(two_tanks.SIGNALS));"),
    ],
}


def build(run: bool = True) -> list[Path]:
    paths = []
    for name, cells in NOTEBOOKS.items():
        nb = new_notebook()
        nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
        for kind, text in cells:
            nb.cells.append(new_code_cell(text) if kind == "py" else new_markdown_cell(text))
        path = HERE / f"{name}.ipynb"
        if run:
            from nbclient import NotebookClient

            NotebookClient(nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(HERE.parent)}}).execute()
        nbformat.write(nb, path)
        paths.append(path)
    return paths


if __name__ == "__main__":
    for p in build(run="--no-run" not in sys.argv):
        print("wrote", p)
