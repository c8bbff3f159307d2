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
from switching.simulate.plotting import plot_trajectory, phase_portrait, mode_graph, draw_bond_graph"""

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
    "fitting": [
        md("# Sensitivities through jumps, and fitting parameters\n\n"
           "`simulate(..., sensitivities=[...])` also integrates ∂x/∂p for model parameters p (and `x0:<state>` "
           "for initial states), and carries it across every instant with the jump maps' Jacobians and the moving "
           "event time (the saltation update).  Finite differences across an event that moves are unreliable; "
           "these are exact to the integration's tolerance.  `switching.fit` uses them as the Jacobian of a "
           "least-squares fit."),
        py(SETUP),
        md("## The bouncing ball\n\nHow the height depends on the restitution e: nothing before the first impact, "
           "then a ramp that the second impact amplifies.  The bounce times move too: ∂t_k/∂e against the closed "
           "form 2t₁(1 + 2e + … + (k−1)e^(k−2))."),
        py("from models import bouncing_ball\nfrom switching import fit\n"
           "ball = bouncing_ball.build(e=0.8)\n"
           "run = ball.simulate(2.2, 'RK45', rtol=1e-10, atol=1e-12, max_step=0.01, sensitivities=['e', 'g', 'x0:y'])\n"
           "fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)\n"
           "axes[0].plot(run.t, run.signal('y'))\naxes[0].set_ylabel('y [m]')\n"
           "for p, label in (('e', 'e'), ('g', 'g'), ('x0:y', 'y₀')):\n"
           "    axes[1].plot(run.t, run.sensitivity('y', p), label=f'∂y/∂{label}')\n"
           "axes[1].legend()\naxes[1].set_xlabel('t [s]')\n"
           "for ax in axes:\n    for t in run.event_times:\n        ax.axvline(t, color='0.8', lw=0.8)\n"
           "t1 = np.sqrt(2 / 9.81)\n"
           "for k in range(len(run.events)):\n"
           "    exact = 2 * t1 * sum(j * 0.8 ** (j - 1) for j in range(1, k + 1))\n"
           "    print(f'bounce {k + 1}: ∂t/∂e = {run.event_time_sensitivity(k, \"e\"):.12f}   closed form {exact:.12f}')"),
        md("### Fitting e from noisy heights\n\nForty heights with 1 cm of noise, before the bounces pile up; "
           "the fit starts from e = 0.6 and needs a handful of runs."),
        py("times = np.linspace(0.05, 1.5, 40)\n"
           "truth = bouncing_ball.build(e=0.7).simulate(1.5, 'RK45', t_eval=times, rtol=1e-10, atol=1e-12)\n"
           "rng = np.random.default_rng(1)\n"
           "heights = truth.state('y') + rng.normal(0, 0.01, times.size)\n"
           "result = fit(bouncing_ball.build, {'y': (times, heights)}, {'e': 0.6, 'g': 9.5}, sigma=0.01, "
           "absolute_sigma=True)\nprint(result)"),
        py("best = bouncing_ball.build(**result.values).simulate(1.5, 'RK45', rtol=1e-10, atol=1e-12, max_step=0.01)\n"
           "fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True, gridspec_kw={'height_ratios': [3, 1]})\n"
           "axes[0].plot(times, heights, '.', label='measured (σ = 1 cm)')\n"
           "axes[0].plot(best.t, best.signal('y'), label=f\"fit: e = {result.values['e']:.4f} ± "
           "{result.standard_errors['e']:.4f}\")\n"
           "axes[0].set_ylabel('y [m]')\naxes[0].legend()\n"
           "axes[1].plot(times, result.residuals['y'], '.')\naxes[1].axhline(0, color='0.5')\n"
           "axes[1].set_ylabel('residual [m]')\naxes[1].set_xlabel('t [s]');"),
        md("## The falling rod's friction\n\nAfter the impact the tip slides (μ = 0.002) and friction decelerates the rod: "
           "∂x_cm/∂μ grows from the impact on.  The sensitivity agrees with central differences of runs whose modes "
           "and instants are the same."),
        py("from models import falling_rod\nfrom switching.sweep.batch import shared_model\n"
           "times = np.linspace(0.2, 0.45, 12)\n"
           "with shared_model(falling_rod.build, {'mu': 0.002}) as rod:  # later runs share its derived modes\n"
           "    run = rod.simulate(0.45, 'RK45', rtol=1e-10, atol=1e-12, max_step=0.01, sensitivities=['mu'])\n"
           "    dx = run.sensitivity('x_cm', 'mu')\n"
           "    truth = rod.simulate(0.45, 'RK45', t_eval=times, rtol=1e-10, atol=1e-12)\n"
           "    x_true = truth.signal('x_cm')  # t_eval: one row per time, exactly\n"
           "def x_at(mu):\n    with shared_model(falling_rod.build, {'mu': mu}) as m:\n"
           "        r = m.simulate(0.45, 'RK45', t_eval=times, rtol=1e-12, atol=1e-14)\n"
           "        return r.signal('x_cm')\n"
           "central = (x_at(0.002 + 1e-6) - x_at(0.002 - 1e-6)) / 2e-6\n"
           "fig, ax = plt.subplots(figsize=(7, 3.5))\n"
           "ax.plot(run.t, dx, label='∂x_cm/∂μ (sensitivity)')\nax.plot(times, central, 'o', mfc='none', "
           "label='central differences')\n"
           "ax.axvline(run.event_times[0], color='0.8')\nax.set_xlabel('t [s]')\nax.set_ylabel('∂x_cm/∂μ [m]')\nax.legend();"),
        md("### Fitting μ from the centre's positions\n\nTwelve positions with 10 µm of noise while the rod slides."),
        py("rng = np.random.default_rng(2)\nmeasured = x_true + rng.normal(0, 1e-5, times.size)\n"
           "result = fit(falling_rod.build, {'x_cm': (times, measured)}, {'mu': 0.001}, sigma=1e-5, absolute_sigma=True,\n"
           "             bounds={'mu': (0.0, 0.0045)})\nprint(result)\n"
           "fig, ax = plt.subplots(figsize=(7, 3))\n"
           "ax.errorbar(times, (measured - x_true) * 1e6, yerr=10, fmt='.', label='measured − true')\n"
           "ax.plot(times, result.residuals['x_cm'] * 1e6 + (measured - x_true) * 1e6, label='fit − true')\n"
           "ax.set_ylabel('µm')\nax.set_xlabel('t [s]')\nax.legend();"),
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
