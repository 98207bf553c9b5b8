"""What the pinned arithmetic (pfcourse/arithmetic.py) costs in speed on this machine.

    .venv/bin/python bench/pinning.py [--repeats 5]

Times the same work in fresh processes with the pinned environment (NumPy without AVX-512,
OpenBLAS's Haswell kernels) and with the CPU's defaults, interleaved (pinned, default, pinned,
...), and prints the median time of each and their ratio:

* the functions the pinning reaches: NumPy's exp/log/sin/cos on 1e6 floats, and small BLAS
  products (the (N, d) @ (d, d) shapes of the filters);
* whole filters: the robot's bootstrap filter (N = 1e5, 100 steps) and the landmark model's
  (N = 1e4, 50 steps).

On a CPU without AVX-512 whose OpenBLAS default is already the Haswell family, both settings run
the same code and the ratios measure only noise. On an AVX-512 CPU they give the price of
reproducibility there.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pfcourse.arithmetic import PINNED_ENVIRONMENT  # noqa: E402  (stdlib-only at import)

WORK = r"""
import json, time
import numpy as np
from pfcourse import ParticleFilter, arithmetic
from pfcourse.scenarios.landmarks import circle_scenario, simulate
from pfcourse.scenarios.robot import RobotModel, simulate_robot

def best(f, n=3):
    times = []
    for _ in range(n):
        t = time.perf_counter(); f(); times.append(time.perf_counter() - t)
    return min(times)

x = np.random.default_rng(0).uniform(-5, 5, 1_000_000)
a, b = np.random.default_rng(1).normal(size=(100_000, 12)), np.random.default_rng(2).normal(size=(12, 12))
robot_sim = simulate_robot(rng=0, n_steps=100)
robot_model = RobotModel.for_simulation(robot_sim)
lm = circle_scenario()
lm_sim = simulate(lm, 0)
out = {
    "numpy exp+log+sin+cos, 1e6": best(lambda: (np.exp(x), np.log(np.abs(x)), np.sin(x), np.cos(x))),
    "BLAS (1e5 x 12) @ (12 x 12)": best(lambda: a @ b),
    "robot filter N=1e5, 100 steps": best(lambda: ParticleFilter(robot_model, 100_000, threshold=0.5).run(robot_sim.measurements, rng=1), 2),
    "landmark filter N=1e4, 50 steps": best(lambda: ParticleFilter(lm.model(), 10_000, threshold=1 / 3).run(lm_sim.measurements, rng=1), 2),
    "pinned": arithmetic.runtime_arithmetic().is_pinned,
}
print(json.dumps(out))
"""


def measure(pinned: bool) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in PINNED_ENVIRONMENT}
    env["OPENBLAS_NUM_THREADS"] = "1"
    if pinned:
        env.update(PINNED_ENVIRONMENT)
        code = WORK
    else:
        code = "import numpy\n" + WORK  # NumPy first, so pfcourse cannot pin it
    out = subprocess.run([sys.executable, "-W", "ignore", "-c", code], env=env, cwd=ROOT,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    runs = {True: [], False: []}
    for _ in range(args.repeats):
        for pinned in (True, False):
            runs[pinned].append(measure(pinned))
    print(f"{args.repeats} interleaved runs per setting; default settings pinned anyway on this CPU: "
          f"{runs[False][0]['pinned']}")
    print(f"{'work':34s} {'pinned (s)':>11s} {'default (s)':>12s} {'pinned / default':>17s}")
    for key in runs[True][0]:
        if key == "pinned":
            continue
        p = statistics.median(r[key] for r in runs[True])
        d = statistics.median(r[key] for r in runs[False])
        print(f"{key:34s} {p:11.4f} {d:12.4f} {p / d:17.3f}")


if __name__ == "__main__":
    main()
