"""Run the `particles` library's bootstrap filter on the benchmark data (runs in bench/.venv-particles).

    python particles_runner.py DATA.npz OUT.json SIZES REPEATS_JSON MEMORY_STEPS [MODEL ...]

``particles`` (Chopin) needs numpy < 2, so this script runs in its own virtual environment
and talks to bench/bench.py through files: it reads the simulated data written by the
benchmark and writes, per model and per N, the wall times of the runs, the weighted means
(for the RMSE) and the tracemalloc peak of one extra run over the first MEMORY_STEPS steps.  The models are written as
``particles.state_space_models.StateSpaceModel`` subclasses, as the library's
documentation teaches (its ``distributions`` for the densities; the robot's transition,
whose noise enters through the controls, is a small ``ProbDist`` with pfcourse's formulas),
and the library's bootstrap filter (``Bootstrap`` + ``SMC``) does the rest: systematic resampling when ``ESS < N / 2``, as in the
other two filters.
"""

from __future__ import annotations

import json
import sys
import time
import tracemalloc

import numpy as np
import particles
from particles import collectors
from particles import distributions as dists
from particles import state_space_models as ssm

TWO_PI = 2.0 * np.pi


def wrap(a):
    return a - TWO_PI * np.ceil((a - np.pi) / TWO_PI)


class NoMeasurement(dists.ProbDist):
    """Log-density 0 for every particle: a step without a measurement."""

    def __init__(self, n):
        self.n = n

    def logpdf(self, y):
        return np.zeros(self.n)


class RobotMotion(dists.ProbDist):
    """``x = f(xp, u~ + w)``, ``w ~ N(0, diag(q_std^2))``: pfcourse.scenarios.robot.scenario's transition, same formulas."""

    dim = 3

    def __init__(self, xp, odometry, q_std, dt):
        self.xp, self.odometry, self.q_std, self.dt = xp, odometry, q_std, dt

    def rvs(self, size=None):
        u = np.random.standard_normal(self.xp.shape) * self.q_std
        u += self.odometry
        xp, dt = self.xp, self.dt
        c, s = np.cos(xp[:, 2]), np.sin(xp[:, 2])
        x = np.empty_like(xp)
        x[:, 0] = xp[:, 0] + (u[:, 0] * c - u[:, 1] * s) * dt
        x[:, 1] = xp[:, 1] + (u[:, 0] * s + u[:, 1] * c) * dt
        x[:, 2] = wrap(xp[:, 2] + u[:, 2] * dt)
        return x


class Robot(ssm.StateSpaceModel):
    """The range-bearing robot as a `particles` state-space model (diagonal Q and R, as in the benchmark).

    The data are the ``(range, bearing)`` pairs; the landmark index of each step is known
    to the model.  The bearing's Gaussian is centred on the predicted bearing moved by a
    multiple of 2 pi to the measurement's side, so its log-density is that of the wrapped
    innovation, as in pfcourse.
    """

    def __init__(self, d):
        self.d = d
        self.q_std = np.sqrt(np.diag(d["q_est"]))
        self.r_std = np.sqrt(np.diag(d["r_est"]))

    def PX0(self):
        m, s = self.d["start"], self.d["initial_std"]
        return dists.IndepProd(*(dists.Normal(loc=m[i], scale=s[i]) for i in range(3)))

    def PX(self, t, xp):
        return RobotMotion(xp, self.d["odometry"][t], self.q_std, float(self.d["dt"]))

    def PY(self, t, xp, x):
        z = self.d["measurements"][t]
        if np.isnan(z[0]):
            return NoMeasurement(x.shape[0])
        lx, ly = self.d["landmarks"][int(z[0])]
        dx, dy = lx - x[:, 0], ly - x[:, 1]
        bearing = wrap(np.arctan2(dy, dx) - x[:, 2])
        return dists.IndepProd(dists.Normal(loc=np.hypot(dx, dy), scale=self.r_std[0]),
                               dists.Normal(loc=z[2] - wrap(z[2] - bearing), scale=self.r_std[1]))


def robot_data(d):
    return [row[1:] for row in d["measurements"]]


def robot_moments(W, X):
    """Weighted mean, circular on the heading."""
    return np.array([W @ X[:, 0], W @ X[:, 1],
                     np.arctan2(W @ np.sin(X[:, 2]), W @ np.cos(X[:, 2]))])


class Landmark(ssm.StateSpaceModel):
    """The linear-Gaussian landmark model with `particles`' multivariate normals; NaN entries are unobserved."""

    def __init__(self, d):
        self.d = d
        self.seen = ~np.isnan(d["Z"])

    def PX0(self):
        return dists.MvNormal(loc=self.d["m0"], cov=self.d["P0"])

    def PX(self, t, xp):
        return dists.MvNormal(loc=xp @ self.d["F"].T + self.d["B"], cov=self.d["Q"])

    def PY(self, t, xp, x):
        seen = self.seen[t]
        if not seen.any():
            return NoMeasurement(x.shape[0])
        return dists.MvNormal(loc=x @ self.d["H"][seen].T, cov=self.d["R"][np.ix_(seen, seen)])


def landmark_data(d):
    return [z[~np.isnan(z)] for z in d["Z"]]


def landmark_moments(W, X):
    return W @ X


MODELS = {"robot": (Robot, robot_data, robot_moments), "landmark": (Landmark, landmark_data, landmark_moments)}


def run_once(model: str, d, n: int, seed: int, steps=None) -> np.ndarray:
    model_class, data, moments = MODELS[model]
    np.random.seed(seed)
    fk = ssm.Bootstrap(ssm=model_class(d), data=data(d)[:steps])
    alg = particles.SMC(fk=fk, N=n, resampling="systematic", ESSrmin=0.5,
                        collect=[collectors.Moments(mom_func=moments)])
    alg.run()
    return np.array(alg.summaries.moments)


def main() -> None:
    data_file, out_file, sizes, repeats = sys.argv[1], sys.argv[2], json.loads(sys.argv[3]), json.loads(sys.argv[4])
    memory_steps = int(sys.argv[5])
    models = sys.argv[6:] or list(MODELS)
    raw = np.load(data_file)
    from importlib.metadata import version

    out = {"numpy": np.__version__, "particles": version("particles")}
    for model in models:
        d = {k[len(model) + 1:]: raw[k] for k in raw.files if k.startswith(model + "_")}
        run_once(model, d, 100, 0)  # warm up (numba compilation of the resampler)
        for n in sizes:
            times, means = [], []
            for seed in range(repeats[str(n)]):
                t0 = time.perf_counter()
                m = run_once(model, d, n, seed)
                times.append(time.perf_counter() - t0)
                means.append(m.tolist())
            tracemalloc.start()
            run_once(model, d, n, 1000, memory_steps)
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            out[f"{model}/{n}"] = {"times": times, "means": means, "peak": peak}
            print(f"particles {model} N={n}: median {np.median(times):.3f} s", flush=True)
    with open(out_file, "w") as f:
        json.dump(out, f)


if __name__ == "__main__":
    main()
