"""The ``hbg`` command through a subprocess: every subcommand and bad input."""

import subprocess
import sys

import numpy as np
import pytest


def hbg(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "models.cli", *args], capture_output=True, text=True, timeout=300,
        env={**__import__("os").environ, "MPLBACKEND": "Agg"}, cwd=cwd,
    )


def test_list_shows_models_with_parameters():
    out = hbg("list")
    assert out.returncode == 0, out.stderr
    assert "falling-rod:" in out.stdout and "bouncing-ball:" in out.stdout
    assert "mu=0.005" in out.stdout and "v_rest=0.0" in out.stdout


def test_run_prints_a_summary_and_saves_plot_and_data(tmp_path):
    plot, csv, npz = tmp_path / "ball.png", tmp_path / "ball.csv", tmp_path / "ball.npz"
    out = hbg("run", "bouncing-ball", "--set", "e=0.5", "--t-end", "1.2", "--rtol", "1e-9",
              "--plot", str(plot), "--csv", str(csv), "--npz", str(npz), "--signals", "y,v")
    assert out.returncode == 0, out.stderr
    assert "contact=impact" in out.stdout and "pinnacle" in out.stdout and "wall time" in out.stdout
    assert "error estimate" in out.stdout
    assert plot.stat().st_size > 10_000
    header = csv.read_text().splitlines()[0]
    assert header == "t,p,y,v,mode"
    data = np.load(npz)
    # with e = 0.5 the second bounce is at t1 (1 + 2 e)
    t1 = np.sqrt(2 / 9.81)
    assert data["event_times"][1] == pytest.approx(t1 * 2.0, abs=1e-9)


def test_run_without_the_stiffness_check():
    """A step beyond rk4's stability stops the run with advice naming the option; with
    --no-stiffness-check it runs on (here unstable, as the advice warns)."""
    stiff = hbg("run", "boost-converter", "--method", "rk4", "--dt", "0.01", "--t-end", "0.05", "--samples", "0")
    assert stiff.returncode != 0 and "beyond its stability limit" in stiff.stderr
    assert "stiffness_check=False" in stiff.stderr
    out = hbg("run", "boost-converter", "--method", "rk4", "--dt", "0.01", "--t-end", "0.05", "--samples", "0",
              "--no-stiffness-check")
    assert out.returncode == 0, out.stderr
    assert "method: rk4" in out.stdout


def test_run_with_a_fixed_step_method():
    out = hbg("run", "bouncing-ball", "--method", "rk4", "--dt", "0.01", "--t-end", "1")
    assert out.returncode == 0, out.stderr and "method: rk4" in out.stdout


def test_modes_prints_derived_equations():
    out = hbg("modes", "diode-circuit")
    assert out.returncode == 0, out.stderr
    assert "mode switch=open, diode=off" in out.stdout and "p_L⁺ = 0" in out.stdout
    one = hbg("modes", "falling-rod", "--mode", "contact|stuck", "--latex")
    assert one.returncode == 0 and r"\frac{d}{dt}" in one.stdout


def test_verify_reports_loops_with_exit_status():
    good = hbg("verify", "bouncing-ball", "--samples", "3")
    assert good.returncode == 0 and "no divergence of time found" in good.stdout
    bad = hbg("verify", "diode-circuit", "--set", "I_th=5", "--samples", "30")
    assert bad.returncode == 1 and "divergence-of-time loop" in bad.stdout


def test_codegen_exports_a_standalone_module(tmp_path):
    out = hbg("codegen", "bouncing-ball", "-o", str(tmp_path))
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "bouncing_ball_modes.py").stat().st_size > 1000
    check = subprocess.run([sys.executable, "-c", "import sys; sys.modules['sympy'] = None; "
                            f"sys.path.insert(0, {str(tmp_path)!r}); import bouncing_ball_modes as m; print(sorted(m.MODES))"],
                           capture_output=True, text=True, timeout=60)
    assert check.returncode == 0, check.stderr
    assert "flight" in check.stdout and "impact" in check.stdout


def test_draw_writes_the_bond_graph(tmp_path):
    target = tmp_path / "rod.png"
    out = hbg("draw", "falling-rod", "--mode", "contact|stuck", "-o", str(target))
    assert out.returncode == 0, out.stderr
    assert target.stat().st_size > 10_000


def test_plain_graph_equations():
    out = hbg("equations", "pivoting_rod")
    assert out.returncode == 0
    assert "drod/p_J/dt = -J*g*l*m*cos(rod/theta)/(J + l**2*m)" in out.stdout
    assert hbg("equations", "switched_rl", "--off", "switch").stdout.count("R_fw") >= 1


@pytest.mark.parametrize(
    "args, message",
    [
        (("run", "nope"), "unknown model 'nope'"),
        (("run", "falling-rod", "--set", "muu=1"), "unknown parameter or state 'muu' (did you mean 'mu'?)"),
        (("run", "falling-rod", "--set", "mu=abc"), "needs a number"),
        (("run", "falling-rod", "--set", "mu"), "expects name=value"),
        (("run", "bouncing-ball", "--method", "euler"), "fixed-step: give --dt"),
        (("run", "bouncing-ball", "--dt", "0.1"), "adaptive: give --rtol"),
        (("run", "bouncing-ball", "--dt", "0.1", "--rtol", "1e-3"), "not allowed with argument"),
        (("run", "bouncing-ball", "--method", "RK99"), "unknown method 'RK99'"),
        (("run", "bouncing-ball", "--signals", "y,zz"), "unknown signal 'zz'"),
        (("modes", "falling-rod", "--mode", "nope|stuck"), "no state 'nope'"),
        (("equations", "nope"), "unknown graph 'nope'"),
        ((), "required"),
    ],
)
def test_bad_input_is_one_clear_line(args, message):
    out = hbg(*args)
    assert out.returncode == 2
    assert message in out.stderr and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1


def test_run_takes_auto_by_default_and_says_what_it_chose_and_why(tmp_path):
    """Issue 29, item 4: no --method and none in the model's RUN: ``auto``, whose choice and reason the
    summary prints; a method given is taken as it is."""
    chosen = hbg("run", "bouncing-ball", "--samples", "0")
    assert chosen.returncode == 0, chosen.stderr
    line = next(line for line in chosen.stdout.splitlines() if "method chosen by auto:" in line)
    assert line.split("method chosen by auto:")[1].strip().split(":")[0] in ("RK45", "RK45-jit")
    named = hbg("run", "bouncing-ball", "--samples", "0", "--method", "RK23")
    assert named.returncode == 0 and "method: RK23" in named.stdout and "chosen by auto" not in named.stdout


def test_the_console_command_exits_with_the_status_of_main_its_objects_frozen(monkeypatch, capsys):
    """``hbg`` (the console script, ``python -m models.cli``) exits with ``main``'s status, the objects of
    the run frozen first (the interpreter's exit then does not walk them with the cyclic collector)."""
    import gc

    from models import cli

    monkeypatch.setattr(sys, "argv", ["hbg", "run", "no-such-model"])
    try:
        with pytest.raises(SystemExit) as info:
            cli.command()
        assert info.value.code == cli.EXIT_USAGE and gc.get_freeze_count() > 0
    finally:
        gc.unfreeze()
    assert "unknown model 'no-such-model'" in capsys.readouterr().err
