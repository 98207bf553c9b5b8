"""What a robot particle-step must cost: the arithmetic any exact implementation performs.

    .venv/bin/python bench/floor.py      # about 20 s

Times, per particle and on one core, the operations a bootstrap particle filter of the
robot model cannot avoid while keeping the book's random streams and float64 arithmetic:
three standard normal draws from NumPy's default generator (PCG64, ziggurat), the sine
and cosine of the heading twice (the motion model and the circular mean), one arctangent
(the bearing) and two exponentials (the weights: once for their sum, once for the
normalised values).  Each is timed in a compiled loop over 1e5 values (median of 30
runs), so the sum is a floor on a particle-step with zero overhead; the script prints it
next to pfcourse's measured particle-step on the benchmark's robot run.
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np

from pfcourse.filter import ParticleFilter
from pfcourse.scenarios.robot.scenario import RobotModel, simulate_robot

N = 100_000


@numba.njit
def sines_and_cosines(x, out):
    for i in range(x.size):
        out[i] = math.sin(x[i]) + math.cos(x[i])


@numba.njit
def arctangents(x, y, out):
    for i in range(x.size):
        out[i] = math.atan2(y[i], x[i])


@numba.njit
def exponentials(x, out):
    for i in range(x.size):
        out[i] = math.exp(x[i])


def per_particle(f, repeats: int = 30) -> float:
    """Median nanoseconds per element of ``f()`` over ``repeats`` runs (after a warm-up)."""
    f()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)) / N * 1e9


def main() -> None:
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-np.pi, np.pi, N), rng.uniform(-50, 50, N)
    out, noise = np.empty(N), np.empty((N, 3))
    costs = {
        "3 standard normals (numpy PCG64)": per_particle(lambda: rng.standard_normal(out=noise)),
        "sin + cos, twice": 2 * per_particle(lambda: sines_and_cosines(x, out)),
        "atan2": per_particle(lambda: arctangents(x, y, out)),
        "exp, twice": 2 * per_particle(lambda: exponentials(-np.abs(y), out)),
    }
    floor = sum(costs.values())
    sim = simulate_robot(rng=0, n_steps=100)
    pf = ParticleFilter(RobotModel.for_simulation(sim), N)
    step = per_particle(lambda: pf.run(sim.measurements, 1), repeats=5) / len(sim.measurements)
    for name, ns in costs.items():
        print(f"{name:36s} {ns:6.1f} ns per particle")
    print(f"{'floor (sum)':36s} {floor:6.1f} ns  -> at most {1e9 / floor:.2e} particle-steps/s")
    print(f"{'pfcourse robot particle-step':36s} {step:6.1f} ns  -> {1e9 / step:.2e} particle-steps/s "
          f"({floor / step:.0%} of it is the floor)")


if __name__ == "__main__":
    main()
