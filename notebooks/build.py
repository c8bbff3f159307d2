"""Write (and execute) the tutorial notebooks from the cell sources below.

    python notebooks/build.py            # write and execute all notebooks in place
    python notebooks/build.py --no-run   # only write them
    python notebooks/build.py circuits   # only the notebooks named

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
    "power_and_drives": [
        md("# Power electronics and a drivetrain from netlists\n\n"
           "`models.circuits.Circuit` and `models.mechanics.Mechanism` turn a list of parts into a hybrid bond graph: "
           "nodes become junctions, switches, diodes, clutches and stops become controlled junctions with their own "
           "automata.  Here a PWM buck converter against its closed forms, then a motor driving a load through a "
           "clutch and a gear backlash, with the energy the clutch's engagement dissipates."),
        py(SETUP),
        md("## A buck converter\n\n"
           "An ideal switch S driven by PWM (period T = 1/f, duty D), a freewheeling diode, an LC filter and a "
           "resistive load.  Both could be ideal: where S closes while D conducts, the mode *S closed, D on* would "
           "short the source; it is passed as a mythical mode whose guards are judged in the limit of vanishing "
           "resistances, so the diode's current is driven backwards and D turns off (DESIGN.md §6a).  Here the "
           "diode gets a small on-resistance, as a real one has.  (A rectifier bridge whose diodes all block runs "
           "as the limit of vanishing leaks across them, §6b; `build(gmin=...)` puts finite ones, SPICE's GMIN.)"),
        py("from models.circuits import PWM, Circuit\n"
           "Vin, D, f, L, C, R = 12.0, 0.4, 10e3, 1e-3, 100e-6, 10.0\n"
           "buck = Circuit('buck')\n"
           "buck.V('Vin', 'in', '0', Vin)\n"
           "buck.switch('S', 'in', 'sw', closed_when=PWM(period=1 / f, duty=D))\n"
           "buck.diode('D', '0', 'sw', r_on=1e-3)          # freewheels when S opens\n"
           "buck.L('L', 'sw', 'out', L)\n"
           "buck.C('C', 'out', '0', C)\n"
           "buck.R('Rload', 'out', '0', R)\n"
           "converter = buck.build()\n"
           "draw_bond_graph(converter.graph, converter.configuration_of(converter.initial_mode));"),
        md("The netlist draws itself as a schematic (switches as they are at t = 0):"),
        py("buck"),
        md("Start-up from rest (the LC filter rings at 1/(2π√(LC)) ≈ 500 Hz and settles in a few 2RC = 2 ms; "
           "where the first ring brings the current down to zero, a few periods end in discontinuous conduction, "
           "S open and D off), then the periodic steady state: some 400 switching instants in all."),
        py("run = converter.simulate(20e-3, 'RK45', rtol=1e-8, atol=1e-12)\n"
           "print(run.summary())\n"
           "run.plot(['i_L', 'v_C'], max_instants=0);"),
        md("The last two periods, each instant marked:"),
        py("run.plot(['i_L', 'v_C'], t_range=(18e-3, 20e-3));"),
        md("In continuous conduction the inductor's mean voltage over a period is zero, so the mean output is the "
           "switch node's, Vin·D; the current rises by (Vin − Vout)·D·T/L while S is closed: "
           "ΔI = (Vin − Vout)·D/(L·f), and the capacitor takes that triangle: ΔV = ΔI/(8·C·f)."),
        py("from scipy.integrate import simpson\n"
           "T = 1 / f\n"
           "last = converter.simulate(20e-3, 'RK45', rtol=1e-8, atol=1e-12, t_eval=np.linspace(20e-3 - T, 20e-3, 201))\n"
           "v_mean = simpson(last.signal('v_C'), x=last.t) / T\n"
           "dI = (Vin - Vin * D) * D / (L * f)\n"
           "print(f'mean output     {v_mean:.5f} V    Vin·D = {Vin * D:.5f} V')\n"
           "print(f'current ripple  {np.ptp(last.signal(\"i_L\")):.5f} A    (Vin − Vout)·D/(L·f) = {dI:.5f} A')\n"
           "print(f'voltage ripple  {np.ptp(last.signal(\"v_C\")):.5f} V    ΔI/(8·C·f) = {dI / (8 * C * f):.5f} V')"),
        md("## A drivetrain\n\n"
           "A DC motor (k = 0.1 N·m/A, 12 V through 2 Ω: no-load speed V/k = 120 rad/s) spins its rotor J₁ alone; at "
           "t = 0.1 s a clutch locks it to the shaft J₂, which drives the load J₃ (with viscous drag) through a "
           "backlash of ±0.05 rad with restitution 0.5."),
        py("from models.mechanics import Mechanism\n"
           "J1, J2, J3 = 1e-3, 4e-3, 5e-3\n"
           "drive = Mechanism('drivetrain', 'rotational')\n"
           "drive.motor('M', 'm', 0.1, V=12.0, R=2.0)\n"
           "drive.inertia('J1', 'm', J1)                           # the rotor\n"
           "drive.clutch('K', 'm', 's', engaged_when='t >= 0.1')    # locks the shafts\n"
           "drive.inertia('J2', 's', J2)\n"
           "drive.backlash('B', 's', 'l', 0.05, e=0.5)\n"
           "drive.inertia('J3', 'l', J3)\n"
           "drive.damper('drag', 'l', '0', 2e-4)\n"
           "drivetrain = drive.build()\n"
           "draw_bond_graph(drivetrain.graph, drivetrain.configuration_of(drivetrain.initial_mode));"),
        md("Its lumped diagram, drawn from the same list of parts:"),
        py("drive"),
        py("spin = drivetrain.simulate(0.5, 'RK45', rtol=1e-9, atol=1e-12, max_step=2e-3)\n"
           "print(spin.summary())\n"
           "spin.plot([['omega_J1', 'omega_J2', 'omega_J3'], 'theta_B', 'T_M']);"),
        md("The engagement is a plastic impact between J₁ and J₂ (the motor's torque is finite, so it takes no part "
           "in the instant): momentum J₁ω₁ + J₂ω₂ is kept and the kinetic energy J₁J₂/(J₁+J₂)·Δω²/2 is lost."),
        py("(at,) = np.nonzero(spin.t == spin.events[0].t)\n"
           "before, after = at[0], at[-1]\n"
           "def kinetic(k):\n"
           "    return sum(0.5 * J * spin.signal(f'omega_{n}')[k] ** 2 for n, J in (('J1', J1), ('J2', J2), ('J3', J3)))\n"
           "dw = spin.signal('omega_J1')[before] - spin.signal('omega_J2')[before]\n"
           "print(f'engagement at t = {spin.events[0].t:.6g} s, Δω = ω₁ − ω₂ = {dw:.6f} rad/s')\n"
           "print(f'energy lost     {kinetic(before) - kinetic(after):.12f} J')\n"
           "print(f'J1·J2/(J1+J2)·Δω²/2 = {J1 * J2 / (J1 + J2) * dw ** 2 / 2:.12f} J')"),
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
        md("## Sixteen hundred balls in one call\n\n`simulate_batch` runs one model over many sets of values at once: "
        "each run set up as `simulate` sets it up, all their kernel calls made together over the cores, each run the "
        "same as its own `simulate`, to the bit.  The instants of a ball with a resting rule over its restitution and "
        "drop height:"),
        py("from switching import simulate_batch\nes, heights = np.linspace(0.6, 0.95, 40), np.linspace(0.5, 2.0, 40)\n"
        "sets = [{'e': e, 'y0': h} for e in es for h in heights]\n"
        "batch = simulate_batch(bouncing_ball.build(v_rest=0.3), sets, 3.0, 'RK45-jit', rtol=1e-9)\n"
        "print(len(batch), 'runs,', int(batch.in_kernel.sum()), 'finished in the batch call;', sorted(set(batch.status)))\n"
        "fig, ax = plt.subplots(figsize=(5, 4))\n"
        "mesh = ax.pcolormesh(heights, es, batch.event_counts.reshape(len(es), len(heights)), shading='nearest')\n"
        "ax.set_xlabel('drop height y0 [m]'); ax.set_ylabel('restitution e')\n"
        "fig.colorbar(mesh, label='instants in 3 s');"),
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
    "periodic_orbits": [
        md("# Periodic orbits through jumps: steady state, stability, bifurcations\n\n"
           "`periodic_orbit` finds a switching system's periodic steady state by Newton shooting on its period map, "
           "with the monodromy matrix from forward sensitivities carried through every jump (saltation matrices at "
           "state events).  Its eigenvalues, the Floquet multipliers, say whether the orbit is stable; "
           "`continue_orbit` follows the orbit along a parameter and locates where a multiplier leaves the unit "
           "circle through −1 (period doubling) or +1 (a fold)."),
        py(SETUP + "\nimport math, time\nfrom switching import periodic_orbit, continue_orbit"),
        md("## A boost converter's steady state in one call\n\nFixed duty D = 0.4, switching period T = 100 µs: "
           "the clock switches, so the period is T.  Shooting lands on the orbit in a few Newton steps (here one: in "
           "continuous conduction the period map is affine); waiting for "
           "the transient to die takes hundreds of periods (a multiplier of modulus 0.98)."),
        py("from models import boost_converter\nT = 1 / boost_converter.DEFAULTS['f_sw']\n"
           "boost = boost_converter.build(D=0.4)\nstarted = time.perf_counter()\n"
           "orbit = periodic_orbit(boost, period=T, rtol=1e-10, atol=1e-12, max_step=0.3 * T)\n"
           "print(f'{time.perf_counter() - started:.3f} s, {orbit.iterations} Newton iterations')\n"
           "print('x0 =', dict(zip(boost.state_names, orbit.x0)))\n"
           "print('modes over a period:', ' → '.join(orbit.mode_names))\n"
           "print('multipliers:', np.round(orbit.multipliers, 6), '  |μ| =', np.round(np.abs(orbit.multipliers), 6), "
           "'  stable:', orbit.stable)\n"
           "print(f\"mean v_C = {np.mean(orbit.trajectory.signal('v_C')):.4f} V (ideal Vin/(1 − D) = {12 / 0.6:.4f} V)\")\n"
           "orbit.trajectory.plot(['i_L', 'v_C']);"),
        md("The orbit's small-signal model: how a perturbation of the state, the input voltage or the duty at one "
           "period start moves the next (a discrete-time state space with dt = T; `to_control()` gives the same "
           "as a python-control system for Bode plots and controller design)."),
        py("print(orbit.small_signal(inputs=['Vin', 'D'], outputs=['v_C']))"),
        md("## Peak-current-mode control: the period-doubling route\n\nThe clock turns the switch on, the inductor "
           "current reaching i_ref turns it off.  With the output held, the current's multiplier is "
           "−m₂/m₁ = −D/(1 − D): the orbit loses stability at D = 0.5, here at Vout = 2·Vin = 24 V.  "
           "`switch_branch=True` follows the doubled orbit beyond it."),
        py("from models import current_mode_converter\nTc = 1 / current_mode_converter.DEFAULTS['f_sw']\n"
           "held = current_mode_converter.build(load='source', Vin=12.0, Vout=16.0, i_ref=3.0)\n"
           "route = continue_orbit(held, 'Vout', [16.0, 19.0, 22.0, 25.0, 28.0], period=Tc, x0=[2.5e-3],\n"
           "                       max_step=0.02 * Tc, switch_branch=True, signals=['i_L'])\n"
           "for point in route.points:\n"
           "    D = 1 - 12.0 / point.value\n"
           "    print(f'Vout = {point.value:4.1f} V   μ = {point.multipliers[0].real:+.6f}   −D/(1 − D) = {-D / (1 - D):+.6f}'\n"
           "          f'   stable: {point.stable}')\n"
           "for flip in route.bifurcations:\n    print(flip)\n"
           "route.plot('i_L');"),
        md("## A ball on a vibrating table: its bifurcation diagram\n\nThe table moves as A sin ωt; the ball bounces "
           "with restitution e = 0.5 relative to it.  The period-1 orbit (one impact per table period) exists "
           "for Γ = Aω²/g ≥ π(1 − e)/(1 + e) and doubles its period at "
           "Γ² = π²(1 − e)²/(1 + e)² + 4(1 + e²)²/(1 + e)⁴.  The orbit is found from its apex, where the ball is "
           "at rest half a period after the impact."),
        py("from models import vibrating_table\ne, g, omega = 0.5, 9.81, vibrating_table.DEFAULTS['omega']\n"
           "Tt = 2 * math.pi / omega\n"
           "gamma_flip = math.sqrt((math.pi * (1 - e) / (1 + e))**2 + 4 * (1 + e * e)**2 / (1 + e)**4)\n"
           "A_flip = gamma_flip * g / omega**2\n"
           "theta = math.acos(math.pi * g * (1 - e) / (A_flip * omega**2 * (1 + e)))  # the impact phase\n"
           "t0, y0 = theta / omega + Tt / 2, A_flip * math.sin(theta) + g * Tt**2 / 8  # the apex\n"
           "values = A_flip * np.linspace(0.8, 1.2, 9)\n"
           "table = vibrating_table.build(A=values[0], e=e)\n"
           "diagram = continue_orbit(table, 'A', values, period=Tt, t0=t0, x0=[0.0, y0], rtol=1e-10, atol=1e-13,\n"
           "                         tol=1e-9, switch_branch=True)\n"
           "for flip in diagram.bifurcations:\n"
           "    print(flip, f'   closed form: A = {A_flip:.10f} m')\n"
           "diagram.plot('y', what='x0');"),
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
    "converter_analysis": [
        md("# Converter analysis: closed loops, measurements, losses\n\nA buck converter regulated by a PI "
           "controller through a load step, measured as a converter engineer measures it (undershoot, settling "
           "time, ripple, efficiency, each device's losses); then a diode bridge's input current, its THD and "
           "power factor.  Every figure is integrated exactly over the run's flow, piece by piece, not summed "
           "from samples (`run.measure`, `models.losses`)."),
        py(SETUP),
        md("## A closed-loop buck converter\n\n24 V to 12 V at 100 kHz; the PI controller `PI1` sets the PWM's "
           "duty (`PWM(1e-5, 'PI1')`: its output compared with a triangle carrier), its output limited to "
           "[0, 0.95] with back-calculation anti-windup.  At 10 ms a second resistor steps the load from 1 A to "
           "3 A.  The MOSFET has 50 mΩ, the diode 0.4 V."),
        py("from models.circuits import Circuit, PWM\n"
           "buck = Circuit('closed_loop_buck')\nbuck.V('Vin', 'in', 0, 24.0)\n"
           "buck.switch('S', 'in', 'sw', PWM(1e-5, 'PI1'), r_on=0.05)\nbuck.diode('D1', 0, 'sw', v_f=0.4)\n"
           "buck.L('L', 'sw', 'out', 100e-6)\nbuck.C('C', 'out', 0, 100e-6, v0=12.0)\n"
           "buck.R('R_1A', 'out', 0, 12.0)\nbuck.switch('S_load', 'out', 'x', 't >= t_step')\n"
           "buck.R('R_step', 'x', 0, 6.0)\n"
           "buck.pi('PI1', 'v_out', 12.0, kp=0.003, ki=20.0, limits=(0.0, 0.95), initial=0.52)\n"
           "model = buck.build(parameters={'t_step': 0.01})\n"
           "run = model.simulate(0.02, 'auto')\nprint(run.summary().splitlines()[0])\n"
           "plot_trajectory(run, ['v_out', 'i_L', 'PI1'], max_instants=0);"),
        md("Undershoot after the step, settling into a ±1 % band, and the ripple and efficiency of the last ten "
           "periods:"),
        py("T = 1e-5\nundershoot = 12.0 - run.measure('v_out', 'min', t_from=0.01, t_to=0.02)\n"
           "sampled = model.simulate(0.02, 'auto', samples=20001).without_instants()\n"
           "outside = np.flatnonzero((sampled.t > 0.01) & (np.abs(sampled.signal('v_out') - 12.0) > 0.12))\n"
           "settling = sampled.t[outside[-1]] - 0.01\n"
           "end = dict(periods=10, period=T)\n"
           "print(f'undershoot {undershoot:.3f} V, settled within 1 % after {settling * 1e3:.2f} ms')\n"
           "print('v_out over the last 10 periods:', run.measure('v_out', ['mean', 'ripple'], **end))\n"
           "print('efficiency:', run.measure(['R_1A', 'R_step'], 'efficiency', **end))"),
        md("Each device's losses: conduction from the run (`v·i` integrated), switching from a datasheet's "
           "energies scaled to the voltage switched at each of its instants:"),
        py("from models.losses import SwitchingEnergy, device_losses\n"
           "mosfet = SwitchingEnergy(currents=(0.0, 5.0, 10.0), e_on=(0.0, 8e-6, 20e-6), e_off=(0.0, 5e-6, 12e-6),\n"
           "                         voltage=24.0)\n"
           "for device, table in (('S', mosfet), ('D1', None)):\n"
           "    print(device, device_losses(run, device, table, **end))"),
        md("## The same loop in a DSP\n\nSampled once a period at the carrier's peak (the middle of the off "
           "time), its output held and applied a sample after it is computed (`sample_period`, `sample_delay`); "
           "the PWM modulates the trailing edge of a sawtooth, as a timer's counter does.  Each tick is one "
           "instant: the held values are charged in three pinnacle modes."),
        py("digital = Circuit('digital_buck')\ndigital.V('Vin', 'in', 0, 24.0)\n"
           "digital.switch('S', 'in', 'sw', PWM(1e-5, 'PI1', carrier='sawtooth'), r_on=0.05)\n"
           "digital.diode('D1', 0, 'sw', v_f=0.4)\n"
           "digital.L('L', 'sw', 'out', 100e-6)\ndigital.C('C', 'out', 0, 100e-6, v0=12.0)\n"
           "digital.R('R_1A', 'out', 0, 12.0)\ndigital.switch('S_load', 'out', 'x', 't >= t_step')\n"
           "digital.R('R_step', 'x', 0, 6.0)\n"
           "digital.pi('PI1', 'v_out', 12.0, kp=0.003, ki=20.0, limits=(0.0, 0.95), initial=0.52,\n"
           "           sample_period=1e-5, sample_delay=5e-6)\n"
           "sampled_loop = digital.build(parameters={'t_step': 0.01}).simulate(0.02, 'auto')\n"
           "print('undershoot', 12.0 - sampled_loop.measure('v_out', 'min', t_from=0.01, t_to=0.02), 'V')\n"
           "plot_trajectory(sampled_loop, ['v_out', 'PI1'], t_range=(0.0099, 0.0102));"),
        md("## A diode bridge's input current\n\nA 230 V (325 V peak) line through 1 Ω into a bridge with a "
           "1 mF filter and a 100 Ω load draws its current in short pulses near the peaks: high THD, low "
           "power factor."),
        py("bridge = Circuit('bridge')\nbridge.V('Vs', 's', 0, '325*sin(2*pi*50*t)')\nbridge.R('Rs', 's', 'a', 1.0)\n"
           "for name, p, n in (('D1', 'a', 'p'), ('D2', 0, 'p'), ('D3', 'n', 'a'), ('D4', 'n', 0)):\n"
           "    bridge.diode(name, p, n)\n"
           "bridge.C('C1', 'p', 'n', 1e-3)\nbridge.R('RL', 'p', 'n', 100.0)\n"
           "line = bridge.build().simulate(0.2)\nlast = dict(periods=2, period=0.02)\n"
           "print('input current:', line.measure('i_Vs', ['rms', 'thd', 'crest'], **last))\n"
           "print('power factor:', line.measure('Vs', 'power_factor', **last))\n"
           "amplitudes = line.spectrum('i_Vs', 50.0, 15, **last)\n"
           "fig, ax = plt.subplots(figsize=(7, 3))\nax.bar(np.arange(16) * 50, amplitudes, width=30)\n"
           "ax.set_xlabel('frequency [Hz]')\nax.set_ylabel('|i_Vs| harmonic [A]');"),
    ],
}


def build(run: bool = True, names=None) -> list[Path]:
    """Write (and, with ``run``, execute) the notebooks ``names`` (default: all)."""
    unknown = set(names or ()) - set(NOTEBOOKS)
    if unknown:
        raise SystemExit(f"no notebook named {', '.join(sorted(unknown))}; there are {', '.join(NOTEBOOKS)}")
    paths = []
    for name, cells in NOTEBOOKS.items():
        if names and name not in names:
            continue
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
    chosen = [a for a in sys.argv[1:] if not a.startswith("--")]   # e.g. power_and_drives: only that one
    for p in build(run="--no-run" not in sys.argv, names=chosen):
        print("wrote", p)
