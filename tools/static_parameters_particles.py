"""Cross-check of the static-parameters chapter's SMC^2 against Chopin's `particles` library (its SMC2).

A scalar model, x_k = 0.9 x_{k-1} + w_k (w_k ~ N(0, 0.3^2), x_0 ~ N(0, 1)), z_k = x_k + v_k with
v_k ~ N(0, theta) and theta ~ inverse-gamma(3, 2), 50 steps simulated with theta = 1 (seed 3). On
these data: the exact posterior of theta (Kalman likelihood on a grid), pfcourse.static_parameters.smc2
(N_theta = 200, N_x = 50) and particles' SMC2 (N = 200 theta-particles, N_x = 50, its default
waste-free moves), 8 seeds each; stored in book/data/static_parameters/particles_check.json.

`particles` needs numpy < 2, so it runs in its own environment (default /work/venv-particles-sp,
made with `python3 -m venv ... && .../pip install -r bench/requirements-particles.txt`; or
--python PATH). Run from the repository root with the project's Python:

    .venv/bin/python tools/static_parameters_particles.py [--python /path/to/venv/bin/python]

Nothing of `particles` is copied here: the library is called through its public API in a
child process that reads the data and prints its answers as JSON.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import pfcourse  # noqa: F401  (pins the arithmetic before NumPy)
import numpy as np

from pfcourse import LinearGaussianModel
from pfcourse.studies.provenance import launch_commit, write_provenance
from pfcourse.static_parameters import InverseGamma, NoiseScaleProblem, smc2

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "book" / "data" / "static_parameters" / "particles_check.json"
PHI, SIGMA_X, K, SEED, SEEDS, N_THETA, N_X = 0.9, 0.3, 50, 3, range(8), 200, 50

CHILD = r"""
import json, sys
import numpy as np
import particles
from particles import distributions as dists, smc_samplers as ssp, state_space_models as ssm

args = json.loads(sys.stdin.read())


class Scalar(ssm.StateSpaceModel):
    default_params = {"theta": 1.0}

    def PX0(self):
        return dists.Normal(loc=0.0, scale=args["sd0"])

    def PX(self, t, xp):
        return dists.Normal(loc=args["phi"] * xp, scale=args["sigma_x"])

    def PY(self, t, xp, x):
        return dists.Normal(loc=x, scale=np.sqrt(self.theta))


prior = dists.StructDist({"theta": dists.InvGamma(a=3.0, b=2.0)})
out = []
for seed in args["seeds"]:
    np.random.seed(seed)
    fk = ssp.SMC2(ssm_cls=Scalar, data=np.array(args["z"]), prior=prior, init_Nx=args["n_x"])
    alg = particles.SMC(fk=fk, N=args["n_theta"], collect="off", verbose=False)
    alg.run()
    theta, W = alg.X.theta["theta"], alg.W
    mean = float(W @ theta)
    out.append({"seed": seed, "mean": mean, "sd": float(np.sqrt(W @ (theta - mean) ** 2)),
                "log_evidence": float(alg.logLt)})
print(json.dumps({"runs": out, "particles_version": getattr(particles, "__version__", "?")}))
"""


def scalar_problem() -> NoiseScaleProblem:
    model = LinearGaussianModel(F=[[PHI]], H=[[1.0]], m0=[0.0], P0=[[1.0]], Q=[[SIGMA_X**2]], R=[[1.0]])
    return NoiseScaleProblem(model, InverseGamma(3.0, 2.0))


def scalar_data() -> np.ndarray:
    """K steps of the scalar model with theta = 1; z_0 is not measured (as the landmark data)."""
    rng = np.random.default_rng(SEED)
    x = np.empty(K)
    x[0] = rng.standard_normal()
    for k in range(1, K):
        x[k] = PHI * x[k - 1] + SIGMA_X * rng.standard_normal()
    z = x + rng.standard_normal(K)
    z[0] = np.nan
    return z[:, None]


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--python", default="/work/venv-particles-sp/bin/python")
    options = parser.parse_args(argv)
    start = time.time()
    problem, Z = scalar_problem(), scalar_data()
    exact = problem.exact_posterior(Z, np.linspace(np.log(0.2), np.log(5.0), 201))
    ours = []
    for s in SEEDS:
        r = smc2(problem, Z, N_THETA, N_X, np.random.default_rng(s))
        ours.append({"seed": s, "mean": r.mean, "sd": r.sd, "log_evidence": r.extra["log_evidence"]})
    # particles' filters start at the first measurement: z_1..z_{K-1} with x_1 ~ N(0, 1) would differ from
    # x_1 ~ N(0, phi^2 + sigma_x^2); so it gets the measured steps and its X_0 is the model's x_1 prior below
    payload = {"z": Z[1:, 0].tolist(), "phi": PHI, "sigma_x": SIGMA_X, "seeds": list(SEEDS), "n_theta": N_THETA,
               "n_x": N_X}
    payload["sd0"] = float(np.sqrt(PHI**2 + SIGMA_X**2))
    done = subprocess.run([options.python, "-c", CHILD],
                          input=json.dumps(payload), capture_output=True, text=True, check=True)
    theirs = json.loads(done.stdout)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    write_provenance(OUT, code="tools/static_parameters_particles.py", commit=launch_commit(), seconds=time.time() - start,
                     model=f"x_k = {PHI} x_(k-1) + N(0, {SIGMA_X}^2), x_0 ~ N(0, 1), z_k = x_k + N(0, theta), "
                           f"theta ~ IG(3, 2); {K} steps (z_0 not measured), theta = 1, seed {SEED}",
                     exact={"mean": exact.mean, "sd": exact.sd, "log_evidence": exact.log_evidence},
                     pfcourse_smc2={"n_theta": N_THETA, "n_x": N_X, "runs": ours},
                     particles_smc2={"N": N_THETA, "init_Nx": N_X, "version": theirs["particles_version"],
                                     "moves": "library default (waste-free, len_chain 10)", "runs": theirs["runs"]})
    print(f"exact mean {exact.mean:.4f} sd {exact.sd:.4f} log evidence {exact.log_evidence:.3f}")
    for name, runs in (("pfcourse", ours), ("particles", theirs["runs"])):
        means = np.array([r["mean"] for r in runs])
        print(f"{name}: mean of means {means.mean():.4f} (sd {means.std(ddof=1):.4f}); "
              f"log evidence {np.mean([r['log_evidence'] for r in runs]):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
