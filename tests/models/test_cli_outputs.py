"""The command line's output files (issue 44, item 3): checked on the files actually written, refused
before the run when they cannot be, and written even when the reader of stdout goes away."""

import os
import subprocess
import sys

import pytest

from models import cli


@pytest.mark.parametrize("command", [["run", "bouncing-ball", "--t-end", "0.5"],
                                     ["orbit", "boost-converter", "--period", "1e-4"]])
def test_a_plot_whose_file_is_another_outputs_is_refused_before_the_run(command, tmp_path, capsys):
    """``--csv r.png --plot r``: matplotlib writes ``r.png``, which replaced the CSV (exit 0)."""
    csv = tmp_path / "r.png"
    assert cli.main([*command, "--csv", str(csv), "--plot", str(tmp_path / "r")]) == cli.EXIT_USAGE
    assert "both name" in capsys.readouterr().err and not csv.exists()


def test_a_sweep_plot_whose_file_is_the_csv_is_refused(tmp_path, capsys):
    code = cli.main(["sweep", "bouncing-ball", "--grid", "e=0.5,0.6", "--csv", str(tmp_path / "s.png"),
                     "--plot", str(tmp_path / "s"), "--workers", "1"])
    assert code == cli.EXIT_USAGE and "both name" in capsys.readouterr().err


@pytest.mark.parametrize("option", ["--csv", "--npz", "--plot"])
def test_an_empty_path_or_a_directory_is_refused_before_the_run(option, tmp_path, capsys):
    """``--csv ""`` wrote nothing and exited 0; ``--npz out/`` wrote a hidden ``out/.npz``."""
    run = ["run", "bouncing-ball", "--t-end", "0.5"]
    assert cli.main([*run, option, ""]) == cli.EXIT_USAGE
    assert "empty" in capsys.readouterr().err
    assert cli.main([*run, option, str(tmp_path) + os.sep]) == cli.EXIT_USAGE
    assert "is a directory" in capsys.readouterr().err
    assert os.listdir(tmp_path) == []


def test_a_scheduler_address_that_is_no_address_is_the_toolkits_error(tmp_path, capsys):
    """``--scheduler "not a url"`` printed "internal error … this is a bug"."""
    code = cli.main(["sweep", "bouncing-ball", "--grid", "e=0.5,0.6", "--csv", str(tmp_path / "s.csv"),
                     "--scheduler", "not a url"])
    err = capsys.readouterr().err
    assert code == cli.EXIT_USAGE and "cannot reach a Dask scheduler at 'not a url'" in err and "bug" not in err


def test_a_reader_that_closes_the_pipe_leaves_the_files_written_and_the_exit_status_zero(tmp_path):
    """``hbg run … --plot d.png | head -1`` printed "[Errno 32] Broken pipe", exited 2 and wrote no PNG."""
    plot = tmp_path / "d.png"
    process = subprocess.Popen([sys.executable, "-m", "models.cli", "run", "bouncing-ball", "--t-end", "0.5",
                                "--plot", str(plot)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               env={**os.environ, "MPLBACKEND": "Agg"}, cwd=tmp_path)
    first = process.stdout.readline()
    process.stdout.close()  # (as head does after its line)
    err = process.stderr.read().decode()
    assert process.wait(timeout=300) == 0, err
    assert first.startswith(b"trajectory of") and "Broken pipe" not in err
    assert plot.stat().st_size > 10_000


def test_modes_and_codegen_say_which_run_found_their_modes_and_take_t_end(tmp_path, capsys):
    """``hbg modes buck.toml`` ran the whole default run (1 s of a 100 kHz converter: 8 minutes) and said
    nothing of it."""
    assert cli.main(["modes", "bouncing-ball", "--t-end", "0.1"]) == 0
    out, err = capsys.readouterr()
    assert "the 1 mode(s) the default run passes to t = 0.1 s (--t-end)" in err
    assert out.count("equations of") == 1  # (the ball is in flight until t = 0.45 s)
    assert cli.main(["codegen", "bouncing-ball", "--t-end", "0.1", "-o", str(tmp_path)]) == 0
    assert "(--t-end)" in capsys.readouterr().err and list(tmp_path.glob("*_modes.py"))
    assert cli.main(["modes", "bouncing-ball", "--t-end", "-1"]) == cli.EXIT_USAGE


def test_without_t_end_the_modes_come_from_a_run_bounded_in_computing_time(monkeypatch, capsys):
    monkeypatch.setattr("models.cli.modes.EXPLORATION_SECONDS", 0.0)
    assert cli.main(["modes", "boost-converter"]) == 0
    out, err = capsys.readouterr()
    assert "stopped after 0 s of computing (give --t-end to choose the run)" in err
    assert "equations of" in out


@pytest.mark.parametrize("given, canonical", [("rk45", "RK45"), ("RODAS-JIT", "rodas-jit"), ("Auto", "auto"),
                                              (" radau", "Radau")])
def test_method_names_are_taken_in_any_case(given, canonical, capsys):
    """``rk45`` was refused ("unknown method 'rk45'")."""
    from models import bouncing_ball
    from switching.simulate.methods import canonical_method

    assert canonical_method(given) == canonical
    run = bouncing_ball.build().simulate(0.5, given)
    assert run.stats["method"].startswith(canonical) or canonical == "auto"
    assert cli.main(["run", "bouncing-ball", "--t-end", "0.5", "--method", given]) == 0


def test_an_unknown_method_is_still_refused_with_the_names():
    from models import bouncing_ball
    from switching.errors import OptionValueError

    with pytest.raises(OptionValueError, match="unknown method 'rk46'; choose one of"):
        bouncing_ball.build().simulate(0.5, "rk46")


def test_the_equations_name_the_junctions_states_as_junctions(capsys):
    """``mode S1=closed`` above ``equations of 'buck' [S1=on]`` read as two words for one switch: the bracket
    is the controlled junctions' configuration, and says so."""
    assert cli.main(["modes", "bouncing-ball", "--t-end", "0.1"]) == 0
    out = capsys.readouterr().out
    assert "mode contact=flight\nequations of 'bouncing_ball' [junctions: floor off]" in out and "floor=off" not in out


def test_the_equations_say_the_junctions_and_law_states_in_the_words_of_the_modes(tmp_path, capsys):
    """Issue 44: ``hbg modes`` of a saved circuit and of a friction clutch: the mode and the equations'
    junctions say closed/open, conducting/blocking, engaged, stuck; the old words read as input."""
    from models.circuits import Circuit
    from models.mechanics import Mechanism

    c = Circuit("freewheel")
    c.V("V", "s", "0", 10.0)
    c.switch("S1", "s", "n", closed_when="t < 0.5")
    c.R("R", "n", "m", 1.0)
    c.L("L", "m", "0", 0.1)
    c.diode("D1", "0", "n", v_f=0.7)
    c.build().save(tmp_path / "freewheel.toml")
    assert cli.main(["modes", str(tmp_path / "freewheel.toml"), "--mode", "S1=open, D1=on"]) == 0
    out = capsys.readouterr().out
    assert "mode S1=open, D1=conducting\nequations of 'freewheel' [junctions: S1 open, D1 conducting]" in out
    assert "D1: conducting → blocking when" in out
    drive = Mechanism("drive", "rotational")
    drive.inertia("J1", "a", 2.0, omega0=10.0)
    drive.clutch("K", "a", "b", engaged_when="t >= 0.5", T_max=5.0)
    drive.inertia("J2", "b", 3.0)
    drive.build().save(tmp_path / "drive.toml")
    assert cli.main(["modes", str(tmp_path / "drive.toml"), "--mode", "K=engaged, K_law=sliding"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("mode K=engaged, K_law=stuck\n") and "K_law: stuck → slipping_pos when" in out

