"""The particle MCMC chapter's cross-check against the ``particles`` package (Chopin's library).

    python -m pfcourse.studies.pmcmc_crosscheck /path/to/venv-with-particles/bin/python

What is compared: the distribution of the log-likelihood estimate ``log p^(z | theta = 1)`` on the
chapter's dataset, from ``particles``' bootstrap filter (``particles.SMC`` on a ``Bootstrap``
Feynman-Kac model, systematic resampling at every step, ``ESSrmin = 1``) and from this package's
engine (:func:`pfcourse.likelihood.pf_log_likelihood`), ``N_RUNS`` seeded runs each at
``N`` particles, both against the exact Kalman value.  The model is written for ``particles`` below
(its ``PY`` a Gaussian over the measured coordinates, since the data have missing ones); no code
of ``particles`` is copied here, it runs in its own environment and its numbers come back as JSON.
The result is stored in ``book/data/pmcmc/particles_check.json`` with its provenance.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np

from pfcourse.likelihood import kalman_log_likelihood, pf_log_likelihood
from pfcourse.studies.likelihood_studies import SCENARIO, SCENARIO_TEXT, chapter_data
from pfcourse.studies.provenance import launch_commit, write_provenance
from pfcourse.studies.store import DATA

N, N_RUNS = 200, 100

SCRIPT = r'''
import json, sys
import numpy as np
import particles
from particles import distributions as dists, state_space_models as ssm

a = json.loads(sys.stdin.read())
F, H, Q, R = (np.array(a[k]) for k in ("F", "H", "Q", "R"))
m0, P0 = np.array(a["m0"]), np.array(a["P0"])
Z = [np.array([np.nan if v is None else v for v in z]) for z in a["Z"]]


class Observed(dists.ProbDist):
    """N(z_o; H_o x, R_oo) over the measured coordinates o of z (all missing: density 1)."""
    def __init__(self, x):
        self.x = x
    def logpdf(self, z):
        o = ~np.isnan(z)
        if not o.any():
            return np.zeros(len(self.x))
        r = z[o] - self.x @ H[o].T
        S = R[np.ix_(o, o)]
        sol = np.linalg.solve(S, r.T).T
        return -0.5 * (np.sum(r * sol, axis=1) + np.linalg.slogdet(2 * np.pi * S)[1])


class Landmarks(ssm.StateSpaceModel):
    def PX0(self):
        return dists.MvNormal(loc=m0, cov=P0)
    def PX(self, t, xp):
        return dists.MvNormal(loc=xp @ F.T, cov=Q)
    def PY(self, t, xp, x):
        return Observed(x)


out = []
for seed in a["seeds"]:
    np.random.seed(seed)
    fk = ssm.Bootstrap(ssm=Landmarks(), data=Z)
    alg = particles.SMC(fk=fk, N=a["N"], resampling="systematic", ESSrmin=1.0, collect=None, verbose=False)
    alg.run()
    out.append(float(alg.logLt))
print(json.dumps({"log_likelihood": out, "particles_version": particles.__version__, "numpy": np.__version__}))
'''


def run_particles(python: str) -> dict:
    model = SCENARIO.model()
    if np.any(model.B):
        raise ValueError("the cross-check's model has no input B")
    Z = chapter_data().measurements
    args = {"F": model.F.tolist(), "H": model.H.tolist(), "Q": model.Q.tolist(), "R": model.R.tolist(),
            "m0": model.m0.tolist(), "P0": model.P0.tolist(), "N": N, "seeds": list(range(N_RUNS)),
            "Z": [[None if np.isnan(v) else float(v) for v in z] for z in Z]}
    done = subprocess.run([python, "-c", SCRIPT], input=json.dumps(args), capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


def main(python: str) -> None:
    start, commit = time.time(), launch_commit()
    theirs = run_particles(python)
    Z = chapter_data().measurements
    ours = [pf_log_likelihood(SCENARIO, Z, 1.0, N, seed) for seed in range(N_RUNS)]
    (DATA / "pmcmc").mkdir(parents=True, exist_ok=True)
    write_provenance(DATA / "pmcmc" / "particles_check.json", code="pfcourse/studies/pmcmc_crosscheck.py",
                     commit=commit, seconds=time.time() - start, scenario=SCENARIO_TEXT, theta=1.0, n_particles=N,
                     n_runs=N_RUNS, exact_log_likelihood=kalman_log_likelihood(SCENARIO, Z, 1.0),
                     particles_log_likelihood=theirs["log_likelihood"], particles_version=theirs["particles_version"],
                     particles_numpy=theirs["numpy"], pfcourse_log_likelihood=ours,
                     compared="log p^(z | theta = 1): particles.SMC(Bootstrap, systematic, ESSrmin = 1), seeds "
                              "np.random.seed(0..99), against pfcourse's engine (threshold 1, systematic), seeds 0..99")


if __name__ == "__main__":
    main(sys.argv[1])
