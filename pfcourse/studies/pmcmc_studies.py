"""Part V's particle MCMC chains (``book/data/pmcmc/``): settings and row functions.

Registered in :mod:`pfcourse.studies.registry` as the group ``pmcmc``
(``python3 tasks.py study pmcmc``).  One row is one chain on the likelihood chapter's dataset
(theta scales the measurement noise ``Rv``; prior flat in ``log theta`` on ``BOUNDS``), its draws
kept in the table's ``.npz``; the chains of a setting differ by their seed, and each starts at a
point drawn from its own generator, log-uniform on ``START`` (over-dispersed against the posterior,
as R-hat needs).

* ``tuning``: plain PMMH (Algorithm 23.2, the engine's bootstrap filter resampling at every
  measured step) for each ``N`` in ``N_TUNING``;
* ``correlated``: PMMH with the filter's normals moved by Crank-Nicolson (``rho > 0``) or drawn
  afresh (``rho = 0``), the same Hilbert-sorted estimator (:mod:`pfcourse.correlated`);
* ``pairs``: no chain, pairs of estimates before and after a Crank-Nicolson move of the normals
  for each ``rho`` in ``PAIR_RHOS`` (the correlation the correlated chains can use);
* ``pgas``: particle Gibbs, conditional SMC with and without ancestor sampling, then the noise
  scale from its inverse-gamma conditional (:mod:`pfcourse.csmc`).

Every study also stores, with the same seeds, short chains of ``CHECK_ITERATIONS`` iterations
of one setting: the registry's test re-computes those (a long chain takes minutes), and
``tests/test_pmcmc.py`` checks that each is the start of the stored long chain of its seed.
"""

from __future__ import annotations

import numpy as np

from pfcourse.correlated import correlated_log_likelihood, crank_nicolson, normals_needed
from pfcourse.csmc import noise_scale_draw, particle_gibbs
from pfcourse.likelihood import pf_log_likelihood, scaled_model
from pfcourse.studies.likelihood_studies import BOUNDS, DATA_SEED, PRIOR, SCENARIO, SCENARIO_TEXT, chapter_data
from pfcourse.pmmh import correlated_pmmh, pmmh

START = (0.5, 2.0)
STEP = 0.25              # random walk on log theta (the likelihood chapter's)
N_TUNING = [100, 200, 400, 800]
N_CHAINS = 4
ITERATIONS = 600
N_CORRELATED, RHOS = 200, [0.0, 0.99]
N_PGAS, PGAS_SWEEPS = 50, 400
CHECK_ITERATIONS = 20
SEEDS = {"tuning": 43, "correlated": 44, "pgas": 45}
#: the correlation of the Hilbert-sorted estimate before and after a Crank-Nicolson move, on the landmark model
PAIR_RHOS, PAIR_RUNS, PAIR_SEED = [0.99, 0.999, 0.9999], 40, 46


def _start(rng: np.random.Generator) -> float:
    return float(np.exp(rng.uniform(np.log(START[0]), np.log(START[1]))))


def _chain_columns(theta0: float, theta: np.ndarray, accepted: np.ndarray | None = None) -> dict:
    row = {"theta0": theta0, "theta": np.asarray(theta, dtype=float)}
    if accepted is not None:
        row["acceptance"] = float(np.mean(accepted))
        row["accepted"] = np.asarray(accepted, dtype=float)
    return row


def tuning_row(seed: int, n_particles: int, iterations: int) -> dict:
    """One PMMH chain with ``n_particles``: its start, draws of theta, acceptance flags."""
    Z = chapter_data().measurements
    rng = np.random.default_rng(seed)
    theta0 = _start(rng)
    chain = pmmh(lambda t, r: pf_log_likelihood(SCENARIO, Z, t, n_particles, r), PRIOR, theta0, iterations, STEP, rng)
    return _chain_columns(theta0, chain.theta, chain.accepted)


def correlated_row(seed: int, rho: float, iterations: int, n_particles: int = N_CORRELATED) -> dict:
    """One correlated PMMH chain (``rho = 0``: fresh normals at every proposal)."""
    Z = chapter_data().measurements
    rng = np.random.default_rng(seed)
    theta0 = _start(rng)
    chain = correlated_pmmh(
        lambda t, u: correlated_log_likelihood(scaled_model(SCENARIO, t), Z, n_particles, u), PRIOR, theta0,
        normals_needed(SCENARIO.model().dim_x, n_particles, len(Z)), iterations, STEP, rho, rng)
    return _chain_columns(theta0, chain.theta, chain.accepted)


def pgas_row(seed: int, ancestor_sampling: bool, iterations: int, n_particles: int = N_PGAS) -> dict:
    """One particle Gibbs chain: CSMC (with or without ancestor sampling), then theta | path."""
    Z = chapter_data().measurements
    model = SCENARIO.model()
    rng = np.random.default_rng(seed)
    theta0 = _start(rng)
    chain = particle_gibbs(lambda t: scaled_model(SCENARIO, t),
                           lambda path, r: noise_scale_draw(model.H, SCENARIO.Rv, Z, path, BOUNDS, r),
                           Z, theta0, n_particles, iterations, rng, ancestor_sampling)
    return _chain_columns(theta0, chain.theta)


def pair_row(seed: int, rho: float, n_particles: int = N_CORRELATED) -> dict:
    """One pair of Hilbert-sorted estimates at theta = 1: log p^(U) and log p^(U') with U' = rho U + sqrt(1 - rho^2) e.

    ``U`` and ``e`` come from ``default_rng(seed)`` in that order, so the pairs of one seed share them across rho.
    """
    Z = chapter_data().measurements
    model = SCENARIO.model()
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(normals_needed(model.dim_x, n_particles, len(Z)))
    return {"log_p": correlated_log_likelihood(model, Z, n_particles, u),
            "log_p_moved": correlated_log_likelihood(model, Z, n_particles, crank_nicolson(u, rho, rng))}


PROVENANCE_FIELDS = {
    "tuning": {"scenario": SCENARIO_TEXT, "data_seed": DATA_SEED, "prior": f"flat in log theta on {BOUNDS}",
               "start": f"log-uniform on {START}, drawn from the chain's generator", "step_log_theta": STEP,
               "filter": "bootstrap, systematic resampling at every measured step (pf_log_likelihood)"},
    "correlated": {"scenario": SCENARIO_TEXT, "data_seed": DATA_SEED, "prior": f"flat in log theta on {BOUNDS}",
                   "start": f"log-uniform on {START}", "step_log_theta": STEP, "n_particles": N_CORRELATED,
                   "filter": "bootstrap on pfcourse.correlated.NormalStream, clouds in Hilbert order, systematic "
                             "resampling at every measured step; rho = 0: fresh normals at every proposal"},
    "pairs": {"scenario": SCENARIO_TEXT, "data_seed": DATA_SEED, "theta": 1.0, "n_particles": N_CORRELATED,
              "estimator": "pfcourse.correlated.correlated_log_likelihood (Hilbert order, systematic resampling at "
                           "every measured step)",
              "seeds": f"pair r: numpy.random.default_rng({PAIR_SEED} + r) draws U, then the Crank-Nicolson normals; "
                       "the same U and normals for every rho"},
    "pgas": {"scenario": SCENARIO_TEXT, "data_seed": DATA_SEED, "prior": f"flat in log theta on {BOUNDS}",
             "start": f"log-uniform on {START}; first path from an unconditional run", "n_particles": N_PGAS,
             "theta_given_path": "inverse-gamma(m/2, S/2) truncated to the prior's support"},
}
