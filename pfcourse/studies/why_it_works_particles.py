"""Cross-check of the chapter "Why it works" against the ``particles`` package (Chopin's library).

Run in a separate environment that has ``particles`` (never a dependency of the book)::

    python3 -m venv /work/venv-particles && /work/venv-particles/bin/pip install particles==0.4
    .venv/bin/python -m pfcourse.studies.why_it_works_particles export      # the data, from the book
    /work/venv-particles/bin/python pfcourse/studies/why_it_works_particles.py run   # particles' runs

``export`` writes the drifting landmark model's matrices and the first ``T_FIXED + 1`` samples of
the study's data (:mod:`pfcourse.studies.why_it_works`) with their exact Kalman log-likelihood
to ``book/data/why_it_works_particles_input.npz``; ``run`` (numpy and ``particles`` only, no
``pfcourse``) writes ``book/data/why_it_works_particles.json``: ``N_RUNS`` bootstrap filters of
``particles`` (its ``SMC`` on a ``FeynmanKac`` model written here, systematic resampling at every
step, ``ESSrmin=1``, NumPy's global seed ``r`` for run ``r``), ``N`` particles, and the
estimates ``log p^ - log p`` of each run.  The chapter compares their variance and mean with the
study's row of the same ``N`` and ``T``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "book" / "data"
INPUT = DATA / "why_it_works_particles_input.npz"
OUTPUT = DATA / "why_it_works_particles.json"
N = 1000
N_RUNS = 300


def export() -> None:
    """Write the model and data of the study's ``T_FIXED`` setting for the other environment."""
    from pfcourse.studies import why_it_works as ww

    model, Z, kf = ww.data()
    T = ww.T_FIXED
    np.savez(INPUT, F=model.F, B=model.B, H=model.H, Q=model.Q, R=model.R, m0=model.m0, P0=model.P0,
             Z=Z[:T + 1], exact=float(kf.log_likelihood_increments[:T + 1].sum()))


def _log_gauss(residual: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """log N(residual; 0, cov) per row."""
    chol = np.linalg.cholesky(cov)
    u = np.linalg.solve(chol, residual.T)
    return -0.5 * np.sum(u**2, axis=0) - np.log(np.diag(chol)).sum() - 0.5 * len(cov) * np.log(2 * np.pi)


def run() -> None:
    """``N_RUNS`` runs of ``particles``' bootstrap filter on the exported data (numpy and particles only)."""
    import particles

    d = dict(np.load(INPUT))
    LQ, L0 = np.linalg.cholesky(d["Q"]), np.linalg.cholesky(d["P0"])

    class Landmarks(particles.FeynmanKac):
        """The bootstrap Feynman-Kac model: M_k the transition, G_k the measurement density."""

        def M0(self, n):
            return d["m0"] + np.random.standard_normal((n, len(d["m0"]))) @ L0.T

        def M(self, t, xp):
            return xp @ d["F"].T + d["B"] + np.random.standard_normal(xp.shape) @ LQ.T

        def logG(self, t, xp, x):
            z = d["Z"][t]
            seen = ~np.isnan(z)
            if not seen.any():
                return np.zeros(len(x))
            H = d["H"][seen]
            return _log_gauss(z[seen] - x @ H.T, d["R"][np.ix_(seen, seen)])

    gaps = []
    for r in range(N_RUNS):
        np.random.seed(r)
        smc = particles.SMC(fk=Landmarks(T=len(d["Z"])), N=N, resampling="systematic", ESSrmin=1.0,
                            store_history=False, verbose=False)
        smc.run()
        gaps.append(float(smc.logLt - d["exact"]))
    from importlib.metadata import version as installed_version

    version = installed_version("particles")  # the package's own __version__ string lags behind (0.3alpha in 0.4)
    OUTPUT.write_text(json.dumps({
        "what": "log p^(z_1:T) - log p(z_1:T) of particles' bootstrap filter (SMC, systematic, ESSrmin=1) on the "
                "study's data, T = len(Z) - 1, one run per NumPy global seed r",
        "particles_version": version, "numpy_version": np.__version__, "N": N, "T": len(d["Z"]) - 1,
        "seeds": f"numpy.random.seed(r), r = 0..{N_RUNS - 1}", "log_ratio": gaps}, indent=1) + "\n")


if __name__ == "__main__":
    {"export": export, "run": run}[sys.argv[1]]()
