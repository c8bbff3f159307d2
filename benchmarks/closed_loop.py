"""The closed-loop buck through a load step: 20 ms at 100 kHz (2 000 periods, 4 000 instants).

    python benchmarks/closed_loop.py

Two controllers: ``analog``, a continuous PI against the triangle carrier; ``digital``, the same PI
sampled once a period at the carrier's peak (``sample_period=1e-5``, ``sample_delay=5e-6``: its
output held, applied a sample after it is computed, three pinnacle stages an instant;
models/sampled_controllers.py).

A 24 V → 12 V buck whose PWM duty is a PI controller's output (models/controllers.py), its load stepped
from 1 A to 3 A at 10 ms, simulated with ``auto`` (the compiled kernel where numba is installed).  Each
row is a new process: ``cold`` with an empty code cache (every mode derived, generated and compiled: a
user's first command), ``warm`` with the cache the cold run filled (the modes loaded from it), and the
same process's second run (``again``: nothing left to prepare).  Issue 42's target: under 2 s on the
compiled path.  Times depend on the machine and its load; numba's kernel itself is compiled once per
installation and is not in these figures (run any compiled model first).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = """
import time
start = time.perf_counter()
from models.circuits import Circuit, PWM
buck = Circuit("closed_loop_buck")
buck.V("Vin", "in", 0, 24.0)
buck.switch("S", "in", "sw", PWM(1e-5, "PI1"), r_on=0.05)
buck.diode("D1", 0, "sw", v_f=0.4)
buck.L("L", "sw", "out", 100e-6)
buck.C("C", "out", 0, 100e-6, v0=12.0)
buck.R("R_1A", "out", 0, 12.0)
buck.switch("S_load", "out", "x", "t >= t_step")
buck.R("R_step", "x", 0, 6.0)
buck.pi("PI1", "v_out", 12.0, kp=0.003, ki=20.0, limits=(0.0, 0.95), initial=0.52, **SAMPLING)
model = buck.build(parameters={"t_step": 0.01})
built = time.perf_counter()
run = model.simulate(0.02, "auto")
first = time.perf_counter()
again = model.simulate(0.02, "auto")
second = time.perf_counter()
undershoot = 12.0 - run.measure("v_out", "min", t_from=0.01, t_to=0.02)
print(f"{built - start:.2f} {first - built:.2f} {second - first:.2f} {len(run.events)} {run.stats['method']} "
      f"{undershoot:.4f}")
"""


#: the controllers compared: keyword options of ``pi``
CONTROLLERS = {"analog": {}, "digital": {"sample_period": 1e-5, "sample_delay": 5e-6}}


def one(cache: str, sampling: dict) -> list[str]:
    env = {**os.environ, "HBG_CACHE_DIR": cache, "PYTHONPATH": str(ROOT)}
    script = f"SAMPLING = {sampling!r}\n" + SCRIPT
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, check=True)
    return done.stdout.split()


def main() -> None:
    print(f"{'controller':10} {'process':8} {'import+build [s]':>17} {'run [s]':>8} {'again [s]':>10} "
          f"{'instants':>9} {'method':>10} {'undershoot [V]':>15}")
    for controller, sampling in CONTROLLERS.items():
        with tempfile.TemporaryDirectory() as cache:
            for label in ("cold", "warm"):
                built, first, second, instants, method, undershoot = one(cache, sampling)
                print(f"{controller:10} {label:8} {built:>17} {first:>8} {second:>10} {instants:>9} {method:>10} "
                      f"{undershoot:>15}")


if __name__ == "__main__":
    main()
