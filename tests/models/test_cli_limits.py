"""``hbg`` refuses before running what would end in "this is a bug" (issue 34, items 2 and 3).

Sample and grid counts have documented caps, decided before anything runs;
two outputs may not name one file; a model file's initial value that is not a
finite real number is a model-file error naming the file, line and value.
"""


import matplotlib

matplotlib.use("Agg")

import pytest  # noqa: E402

try:
    import tomllib
except ImportError:  # Python 3.10
    import tomli as tomllib

from models import cli  # noqa: E402

from test_generated_code_safety import RELAY, write_toml  # noqa: E402


def hbg(capsys, *args):
    status = cli.main([str(a) for a in args])
    out = capsys.readouterr()
    assert "Traceback" not in out.err and "this is a bug" not in out.err
    return status, out.out, out.err


@pytest.mark.timeout(30)
def test_a_billion_samples_are_refused_before_the_run(capsys, tmp_path):
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--samples", 10**9, "--csv", tmp_path / "b.csv")
    assert status == 2 and "--samples asks for 1000000000 sample times" in err and "GiB" in err
    assert not (tmp_path / "b.csv").exists()


@pytest.mark.timeout(30)
@pytest.mark.parametrize("grid", [["e=0:1:1000000000"], ["e=0:1:10000", "g=1:10:1000"]])
def test_a_grid_of_a_billion_runs_is_refused_before_the_sweep(capsys, tmp_path, grid):
    pytest.importorskip("pandas")
    args = ["sweep", "bouncing-ball", "--csv", tmp_path / "s.csv"]
    for item in grid:
        args += ["--grid", item]
    status, out, err = hbg(capsys, *args)
    assert status == 2 and f"at most {cli.MAX_RUNS:,}" in err


@pytest.mark.parametrize("first, second", [("--csv", "--plot"), ("--csv", "--npz"), ("--npz", "--plot")])
def test_two_outputs_on_one_file_are_refused(capsys, tmp_path, first, second):
    path = tmp_path / ("same.npz" if "--npz" in (first, second) else "same.png")
    status, out, err = hbg(capsys, "run", "bouncing-ball", first, path, second, path)
    assert status == 2 and "would overwrite" in err and first in err and second in err
    assert not path.exists()


def test_the_sweeps_csv_and_plot_on_one_file_are_refused(capsys, tmp_path):
    pytest.importorskip("pandas")
    status, out, err = hbg(capsys, "sweep", "bouncing-ball", "--grid", "e=0.5:0.9:2", "--csv", tmp_path / "s.png",
                           "--plot", tmp_path / "s.png")
    assert status == 2 and "would overwrite" in err


@pytest.mark.parametrize("value, why", [("1/(V - 10)", "zoo with V = 10, not finite"),
                                        ("sqrt(V - 20)", "not a real number")])
def test_an_initial_value_that_is_not_a_finite_real_number_names_the_file_and_line(capsys, tmp_path, value, why):
    data = tomllib.loads(RELAY.read_text())
    data["initial_state"]["q_C"] = value
    path = tmp_path / "bad_initial.toml"
    write_toml(data, path)
    status, out, err = hbg(capsys, "run", path)
    assert status == 2 and f"{path}:" in err and "initial value of 'q_C'" in err and why in err


def test_an_option_is_spelt_out_not_guessed_from_a_prefix(capsys):
    """``--max-step 100`` was read as ``--max-steps 100`` (argparse's prefix matching): a run cut at 100 steps.
    (``--max-step`` is an option of its own now: the longest step; a prefix of another option is still refused.)"""
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--sample", "100")
    assert status == 2 and "unrecognized arguments: --sample 100" in err
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--max-step", "100", "--t-end", "0.5")
    assert status == 0 and "instants" in out
