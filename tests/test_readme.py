"""The README's tutorial code runs as printed."""

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run_block(k: int, tmp_path) -> subprocess.CompletedProcess:
    """The README's ``k``-th python block run as a script in a fresh process (its own cache)."""
    text = (ROOT / "README.md").read_text()
    code = re.findall(r"```python\n(.*?)```", text, flags=re.S)[k]
    script = tmp_path / f"block{k}.py"
    script.write_text(code)
    out = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=300,
                         env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path),
                              "HBG_CACHE_DIR": str(tmp_path / "cache")})
    assert out.returncode == 0, out.stderr
    return out


def test_readme_converter_example_runs_and_regulates(tmp_path):
    out = run_block(1, tmp_path)
    mean = float(re.search(r"'mean': ([0-9.e+-]+)", out.stdout).group(1))
    efficiency = float(out.stdout.strip().splitlines()[-1])
    assert abs(mean - 12.0) < 0.1 and 0.9 < efficiency < 1.0


def test_readme_tutorial_runs(tmp_path):
    out = run_block(0, tmp_path)
    assert "dq_C/dt = (V - q_C/C)/R - q_C/(C*R_load)" in out.stdout
    assert "relay=off" in out.stdout and "def rates(x, t, p, u, out):" in out.stdout
    assert (tmp_path / "relay.csv").stat().st_size > 1000


def test_readme_opens_with_the_two_commands_and_ci_runs_the_test_one():
    text = (ROOT / "README.md").read_text()
    block = re.search(r"```sh\n(.*?)```", text, flags=re.S).group(1).strip().splitlines()
    assert len(block) == 2 and "hbg run" in block[0] and "pytest" in block[1]
    assert block[1] in (ROOT / ".ci" / "run").read_text()
