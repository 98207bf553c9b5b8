"""Run the `particles` library's bootstrap filter on the benchmark data (runs in bench/.venv-particles).

    python particles_runner.py DATA.npz OUT.json SIZES REPEATS_JSON

``particles`` (Chopin) needs numpy < 2, so this script runs in its own virtual environment
and talks to bench/bench.py through files: it reads the simulated data written by the
benchmark and writes, per model and per N, the wall times of the runs, the weighted means
(for the RMSE) and the tracemalloc peak of one extra run.  The models are written as
``particles.FeynmanKac`` subclasses with the same NumPy formulas as pfcourse's models
(bootstrap: ``M`` draws from the transition, ``logG`` is the measurement log-density), and
the library's ``SMC`` does the rest: systematic resampling when ``ESS < N / 2``, as in the
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

TWO_PI = 2.0 * np.pi


def wrap(a):
    return a - TWO_PI * np.ceil((a - np.pi) / TWO_PI)


class RobotFK(particles.FeynmanKac):
    """Range-bearing robot, bootstrap filter (pfcourse.robot.RobotModel's formulas)."""

    def __init__(self, d):
        self.d = d
        self.lq = np.linalg.cholesky(d["q_est"])
        chol = np.linalg.cholesky(d["r_est"])
        self.a = np.linalg.inv(chol)
        self.log_norm = -np.log(TWO_PI) - float(np.sum(np.log(np.diag(chol))))
        super().__init__(T=len(d["measurements"]))

    def M0(self, N):
        x = self.d["start"] + np.random.standard_normal((N, 3)) * self.d["initial_std"]
        x[:, 2] = wrap(x[:, 2])
        return x

    def M(self, t, xp):
        u = np.einsum("ij,kj->ik", np.random.standard_normal(xp.shape), self.lq)
        u += self.d["odometry"][t]
        dt = float(self.d["dt"])
        c, s = np.cos(xp[:, 2]), np.sin(xp[:, 2])
        x = np.empty_like(xp)
        x[:, 0] = xp[:, 0] + (u[:, 0] * c - u[:, 1] * s) * dt
        x[:, 1] = xp[:, 1] + (u[:, 0] * s + u[:, 1] * c) * dt
        x[:, 2] = wrap(xp[:, 2] + u[:, 2] * dt)
        return x

    def logG(self, t, xp, x):
        z = self.d["measurements"][t]
        if np.isnan(z[0]):
            return np.zeros(x.shape[0])
        lx, ly = self.d["landmarks"][int(z[0])]
        dx, dy = lx - x[:, 0], ly - x[:, 1]
        nu_r = z[1] - np.hypot(dx, dy)
        nu_b = wrap(z[2] - wrap(np.arctan2(dy, dx) - x[:, 2]))
        a = self.a
        e0 = a[0, 0] * nu_r
        e1 = a[1, 0] * nu_r + a[1, 1] * nu_b
        return self.log_norm - 0.5 * (e0 * e0 + e1 * e1)


def robot_moments(W, X):
    """Weighted mean, circular on the heading."""
    return np.array([W @ X[:, 0], W @ X[:, 1],
                     np.arctan2(W @ np.sin(X[:, 2]), W @ np.cos(X[:, 2]))])


class LandmarkFK(particles.FeynmanKac):
    """Linear-Gaussian landmark model, bootstrap filter (pfcourse.linear_gaussian's formulas)."""

    def __init__(self, d):
        self.d = d
        self.l0 = np.linalg.cholesky(d["P0"])
        eigval, eigvec = np.linalg.eigh(d["Q"])
        self.lq = eigvec * np.sqrt(np.clip(eigval, 0.0, None))
        super().__init__(T=len(d["Z"]))

    def M0(self, N):
        return self.d["m0"] + np.random.standard_normal((N, len(self.d["m0"]))) @ self.l0.T

    def M(self, t, xp):
        noise = np.random.standard_normal(xp.shape) @ self.lq.T
        return xp @ self.d["F"].T + self.d["B"] + noise

    def logG(self, t, xp, x):
        z = self.d["Z"][t]
        seen = ~np.isnan(z)
        if not seen.any():
            return np.zeros(x.shape[0])
        r = self.d["R"][np.ix_(seen, seen)]
        chol = np.linalg.cholesky(r)
        res = z[seen] - x @ self.d["H"][seen].T
        white = np.linalg.solve(chol, res.T)
        return -0.5 * (np.sum(white * white, axis=0) + 2 * np.sum(np.log(np.diag(chol)))
                       + len(r) * np.log(TWO_PI))


def landmark_moments(W, X):
    return W @ X


MODELS = {"robot": (RobotFK, robot_moments), "landmark": (LandmarkFK, landmark_moments)}


def run_once(model: str, d, n: int, seed: int) -> np.ndarray:
    fk_class, moments = MODELS[model]
    np.random.seed(seed)
    alg = particles.SMC(fk=fk_class(d), N=n, resampling="systematic", ESSrmin=0.5,
                        collect=[collectors.Moments(mom_func=moments)])
    alg.run()
    return np.array(alg.summaries.moments)


def main() -> None:
    data_file, out_file, sizes, repeats = sys.argv[1], sys.argv[2], json.loads(sys.argv[3]), json.loads(sys.argv[4])
    raw = np.load(data_file)
    out = {"numpy": np.__version__, "particles": getattr(particles, "__version__", "?")}
    for model in MODELS:
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
            run_once(model, d, n, 1000)
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            out[f"{model}/{n}"] = {"times": times, "means": means, "peak": peak}
            print(f"particles {model} N={n}: median {np.median(times):.3f} s", flush=True)
    with open(out_file, "w") as f:
        json.dump(out, f)


if __name__ == "__main__":
    main()
