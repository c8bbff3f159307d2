"""``hbg``'s arguments speak for themselves (issue 29, item 5): help for every
argument, ``--version``, the tolerances ``--atol`` and ``--max-step``, and any
initial state set by its state name with ``--set``."""

import argparse
import csv

import matplotlib

matplotlib.use("Agg")

import pytest  # noqa: E402

from bondgraph import __version__  # noqa: E402
from models import cli, parallel_capacitors  # noqa: E402


def hbg(capsys, *args):
    status = cli.main([str(a) for a in args])
    out = capsys.readouterr()
    assert "Traceback" not in out.err and "this is a bug" not in out.err
    return status, out.out, out.err


def test_every_argument_of_every_command_has_help():
    parser = cli.build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, sub in commands.choices.items():
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            assert action.help, f"hbg {name}: {action.dest} has no help"
        assert sub.description or commands._choices_actions, name
    assert all(choice.help for choice in commands._choices_actions)


def test_version(capsys):
    with pytest.raises(SystemExit) as stop:
        cli.main(["--version"])
    assert stop.value.code == 0 and capsys.readouterr().out.strip() == f"hbg {__version__}"


def last_row(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))[-1]


def test_initial_states_are_set_by_their_names(capsys, tmp_path):
    """Two capacitors joined at ``t_close`` (no resistance) share the charge
    in the ratio of their capacitances: ``q1 = C1/(C1 + C2)·(q1₀ + q2₀)``."""
    C1, C2 = parallel_capacitors.DEFAULTS["C1"], parallel_capacitors.DEFAULTS["C2"]
    q1, q2 = 1e-3, 4e-3
    out = tmp_path / "caps.csv"
    status, _, err = hbg(capsys, "run", "parallel-capacitors", "--set", f"q1={q1}", "--set", f"q2={q2}",
                         "--t-end", 0.02, "--csv", out)
    assert status == 0, err
    assert float(last_row(out)["q_total"]) == pytest.approx(q1 + q2, rel=1e-9)
    assert float(last_row(out)["v1"]) == pytest.approx((q1 + q2) / (C1 + C2), rel=1e-6)


@pytest.mark.parametrize("name, hint", [("q3", "states: q1, q2"), ("t_clos", "did you mean 't_close'")])
def test_an_unknown_parameter_or_state_is_named(capsys, name, hint):
    status, _, err = hbg(capsys, "run", "parallel-capacitors", "--set", f"{name}=1")
    assert status == 2 and f"unknown parameter or state {name!r}" in err and hint in err


def test_a_state_value_must_be_a_finite_number(capsys):
    status, _, err = hbg(capsys, "run", "parallel-capacitors", "--set", "q1=inf")
    assert status == 2 and "initial state 'q1' must be a finite number" in err


def test_atol_and_max_step_reach_the_run(capsys, tmp_path, monkeypatch):
    seen = {}
    from models.cli import common

    original = common.load

    def spy(name):
        module = original(name)
        build = module.build

        class Spied:
            def __getattr__(self, key):
                return getattr(module, key)

            def build(self, **parameters):
                model = build(**parameters)
                simulate = model.simulate
                model.simulate = lambda t_end, method, **options: seen.update(options) or simulate(t_end, method,
                                                                                                    **options)
                return model
        return Spied()

    monkeypatch.setattr(common, "load", spy)
    status, out, err = hbg(capsys, "run", "parallel-capacitors", "--atol", 1e-13, "--max-step", 1e-3, "--rtol", 1e-8,
                           "--t-end", 0.02, "--samples", 0, "--csv", tmp_path / "c.csv")
    assert status == 0, err
    assert seen["atol"] == 1e-13 and seen["max_step"] == 1e-3 and seen["rtol"] == 1e-8
    with open(tmp_path / "c.csv") as f:
        assert sum(1 for _ in f) > 20  # steps no longer than 1 ms over 20 ms


@pytest.mark.parametrize("option", ["--atol", "--max-step"])
def test_tolerances_of_adaptive_methods_are_refused_with_a_fixed_step(capsys, option):
    status, _, err = hbg(capsys, "run", "two-tanks", "--method", "euler", "--dt", 1, option, 1e-3)
    assert status == 2 and f"{option} is for adaptive methods; euler is fixed-step" in err


@pytest.mark.parametrize("option", ["--atol", "--max-step"])
def test_tolerances_must_be_positive(capsys, option):
    status, _, err = hbg(capsys, "run", "two-tanks", option, -1)
    assert status == 2 and f"{option} must be a finite positive number" in err


def test_graphs_print_plain_text_not_markup(capsys):
    status, out, _ = hbg(capsys, "graphs")
    assert status == 0 and "``" not in out and ":func:" not in out
    assert "Voltage source V0 driving R, L and C in series" in out


def test_a_warning_names_its_kind_not_a_line_of_the_toolkit(capsys):
    status, out, err = hbg(capsys, "run", "bouncing-ball", "--set", "e=1.5", "--t-end", 0.5)
    assert status == 0
    assert "hbg: warning: PhysicalRangeWarning: bouncing_ball: e = 1.5 is outside the physical range" in err
    assert "cli.py" not in err and "warnings.warn" not in err


def test_the_summary_says_what_the_kinds_of_modes_at_instants_mean(capsys):
    status, out, _ = hbg(capsys, "run", "falling-rod", "--set", "mu=0.002")
    assert status == 0 and "flowed [s]  at instants" in out
    assert "mythical: passed through without its jump" in out and "start: the mode the instant began in" in out


@pytest.mark.parametrize("cached", [False, True])
def test_a_notice_says_the_kernel_is_compiled_once(capsys, monkeypatch, cached):
    """A compiled method's first run on an installation compiles the kernel for
    half a minute: one line says so first (and nothing when it is cached)."""
    from switching.library import jit_model

    monkeypatch.setattr(jit_model, "kernel_compiled", lambda implicit=False: cached)
    status, _, err = hbg(capsys, "run", "bouncing-ball", "--method", "RK45-jit", "--t-end", 0.5)
    assert status == 0
    assert ("compiling the simulation kernel for this installation (once, about" in err) is not cached
