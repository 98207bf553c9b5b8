"""Heavy studies of Part V (the likelihood of a noise scale), stored under book/data/likelihood/.

    .venv/bin/python tools/studies/likelihood.py [bias] [ml] [pmmh]

* ``bias.csv``: the particle estimate of log p(z | theta = 1) minus the exact (Kalman) value,
  on the chapter's dataset, for N in N_BIAS, N_BIAS_RUNS seeded filters each (run_study);
* ``ml.csv``: on N_ML_DATASETS simulated datasets (seed = the run's seed), the maximum-likelihood
  noise scale from the Kalman likelihood and from the particle likelihood (N_ML particles,
  common random numbers: one filter seed per dataset for every theta);
* ``pmmh.csv``: one PMMH chain per N in N_PMMH on the chapter's dataset.
* ``terrain_rf.csv``: on N_TERRAIN_FLIGHTS flights of the terrain scenario (the flights of the
  terrain chapters), the maximum-likelihood scale of the altimeter noise R_f from the particle
  likelihood of the regularised filter (N_TERRAIN particles, one filter seed per flight for every
  scale), the final error of the filter run at that estimate and at the truth (scale 1).
* ``pmmh2.csv``: PMMH over the two scales (theta_q of Qw, theta_r of Rv) at once, one chain per N
  in N_PMMH2; ``grid2.csv``: the exact log-likelihood (Kalman) on a GRID2 x GRID2 grid of
  (log theta_q, log theta_r) over the prior's support, for the exact posterior.

Each file has a ``.json`` beside it with its provenance (git commit, seeds, parameters, code).
``tests/test_likelihood_data.py`` re-computes a seeded sample of the stored rows.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

import pfcourse  # noqa: F401  (pins the arithmetic before numpy computes anything)
from pfcourse.landmarks import quadrant_scenario, simulate
from pfcourse.experiments.likelihood import kalman_log_likelihood, max_likelihood_scale, pf_log_likelihood
from pfcourse.pmmh import pmmh
from pfcourse.experiments.provenance import launch_commit, write_provenance
from pfcourse.experiments.study import run_study
from pfcourse.seeding import replicate_seed

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "book" / "data" / "likelihood"
# the commit the study is launched from (recorded in the provenance, whatever is committed meanwhile)
LAUNCH_COMMIT = launch_commit()

# Scenario A with noise on every component (the particle filter's working regime) and a
# moderately informative measurement; theta multiplies Rv.
SCENARIO = quadrant_scenario().with_(Qw=0.05**2 * np.eye(6), Rv=0.5**2 * np.eye(4))
NOISE = "Rv"
DATA_SEED = 7            # the chapter's dataset
BOUNDS = (0.1, 10.0)     # search interval and prior support of theta
XATOL = 1e-3             # on log theta

N_BIAS, N_BIAS_RUNS, BIAS_SEED = [100, 300, 1000], 200, 1
N_ML, N_ML_DATASETS, ML_SEED = [300, 1000], 100, 2
N_PMMH, PMMH_ITERATIONS, PMMH_STEP, PMMH_THETA0, PMMH_SEED = [100, 300, 1000], 1500, 0.25, 2.0, 3
N_PMMH2, PMMH2_ITERATIONS, PMMH2_STEP, PMMH2_THETA0, PMMH2_SEED = [100, 300, 1000], 6000, 0.3, (2.0, 2.0), 8
GRID2 = 61
N_TERRAIN, N_TERRAIN_FLIGHTS, TERRAIN_BOUNDS = 10000, 100, (0.1, 10.0)
PRIOR = stats.uniform(np.log(BOUNDS[0]), np.log(BOUNDS[1]) - np.log(BOUNDS[0]))  # of u = log theta


def chapter_data():
    return simulate(SCENARIO, DATA_SEED)


def bias_run(seed: int, n_particles: int) -> dict:
    Z = chapter_data().measurements
    estimate = pf_log_likelihood(SCENARIO, Z, 1.0, n_particles, seed, NOISE)
    return {"log_ratio": estimate - kalman_log_likelihood(SCENARIO, Z, 1.0, NOISE)}


def ml_run(seed: int, n_particles: int) -> dict:
    Z = simulate(SCENARIO, seed).measurements
    filter_seed = seed + 1  # one filter seed for every theta: common random numbers
    theta_k, nfev_k = max_likelihood_scale(lambda t: kalman_log_likelihood(SCENARIO, Z, t, NOISE), BOUNDS, XATOL)
    theta_p, nfev_p = max_likelihood_scale(
        lambda t: pf_log_likelihood(SCENARIO, Z, t, n_particles, filter_seed, NOISE), BOUNDS, XATOL)
    return {"theta_kalman": theta_k, "theta_pf": theta_p, "nfev_kalman": nfev_k, "nfev_pf": nfev_p}


def pmmh_chain(n_particles: int, n_iterations: int = PMMH_ITERATIONS):
    Z = chapter_data().measurements
    seed = replicate_seed(PMMH_SEED, n_particles)
    chain = pmmh(lambda t, rng: pf_log_likelihood(SCENARIO, Z, t, n_particles, rng, NOISE),
                 PRIOR, PMMH_THETA0, n_iterations, PMMH_STEP, seed)
    return chain, seed


def pmmh2_chain(n_particles: int, n_iterations: int = PMMH2_ITERATIONS):
    Z = chapter_data().measurements
    seed = replicate_seed(PMMH2_SEED, n_particles)
    chain = pmmh(lambda t, rng: pf_log_likelihood(SCENARIO, Z, t, n_particles, rng, ("Qw", "Rv")),
                 PRIOR, np.array(PMMH2_THETA0), n_iterations, PMMH2_STEP, seed)
    return chain, seed


def grid2_row(i: int) -> list[dict]:
    """Exact log-likelihood along row ``i`` of the (log theta_q, log theta_r) grid."""
    Z = chapter_data().measurements
    u = np.linspace(np.log(BOUNDS[0]), np.log(BOUNDS[1]), GRID2)
    return [{"i": i, "j": j, "log_theta_q": u[i], "log_theta_r": u[j],
             "log_likelihood": kalman_log_likelihood(SCENARIO, Z, (np.exp(u[i]), np.exp(u[j])), ("Qw", "Rv"))}
            for j in range(GRID2)]


def terrain_rf_run(seed: int, flight: int, n_particles: int) -> dict:
    """ML scale of R_f on flight ``flight`` (the terrain chapters' data_rng(0, flight)); ``seed`` unused."""
    from pfcourse.experiments.likelihood import terrain_log_likelihood
    from pfcourse.seeding import data_rng, likelihood_rng
    from pfcourse.terrain.map import load_jacksboro
    from pfcourse.terrain.scenario import AircraftScenario, simulate

    terrain, scenario = load_jacksboro(), AircraftScenario()
    sim = simulate(scenario, terrain, data_rng(0, flight))

    def log_lik(scale: float) -> float:
        return terrain_log_likelihood(scenario, terrain, sim.measurements, scale, n_particles, likelihood_rng(0, flight))

    theta, nfev = max_likelihood_scale(lambda t: max(log_lik(t), -1e300), TERRAIN_BOUNDS, XATOL)
    return {"rf_scale_ml": theta, "nfev": nfev, "log_lik_ml": log_lik(theta), "log_lik_truth": log_lik(1.0)}


def provenance(name: str, parameters: dict, seconds: float) -> None:
    write_provenance(OUT / f"{name}.json", code="tools/studies/likelihood.py", commit=LAUNCH_COMMIT, seconds=seconds,
                     file=f"{name}.csv", **parameters,
                     scenario="quadrant_scenario().with_(Qw=0.05**2 I6, Rv=0.5**2 I4), 50 samples; theta scales Rv")


def main(parts: list[str]) -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    if "bias" in parts:
        start = time.perf_counter()
        table = run_study(bias_run, {"n_particles": N_BIAS}, N_BIAS_RUNS, base_seed=BIAS_SEED, progress=False)
        table.drop(columns=["seconds"]).to_csv(OUT / "bias.csv", index=False)
        provenance("bias", {"data_seed": DATA_SEED, "base_seed": BIAS_SEED, "n_runs": N_BIAS_RUNS,
                            "n_particles": N_BIAS, "theta": 1.0,
                            "seeds": "pfcourse.seeding.replicate_seed(base_seed, run)"},
                   time.perf_counter() - start)
    if "ml" in parts:
        start = time.perf_counter()
        table = run_study(ml_run, {"n_particles": N_ML}, N_ML_DATASETS, base_seed=ML_SEED, progress=False)
        table.drop(columns=["seconds"]).to_csv(OUT / "ml.csv", index=False)
        provenance("ml", {"base_seed": ML_SEED, "n_datasets": N_ML_DATASETS, "n_particles": N_ML,
                          "bounds": BOUNDS, "xatol_log_theta": XATOL, "truth": 1.0,
                          "seeds": "dataset: replicate_seed(base_seed, run); filter: dataset seed + 1"},
                   time.perf_counter() - start)
    if "pmmh" in parts:
        start = time.perf_counter()
        frames, seeds = [], {}
        for n in N_PMMH:
            chain, seeds[n] = pmmh_chain(n)
            frames.append(pd.DataFrame({"n_particles": n, "iteration": np.arange(chain.theta.size),
                                        "theta": chain.theta, "log_likelihood": chain.log_likelihood,
                                        "accepted": chain.accepted}))
        pd.concat(frames).to_csv(OUT / "pmmh.csv", index=False)
        provenance("pmmh", {"data_seed": DATA_SEED, "n_particles": N_PMMH, "iterations": PMMH_ITERATIONS,
                            "step_log_theta": PMMH_STEP, "theta0": PMMH_THETA0,
                            "prior": f"log-uniform on {BOUNDS}", "chain_seeds": seeds,
                            "seeds": "replicate_seed(3, n_particles)"},
                   time.perf_counter() - start)
    if "terrain_rf" in parts:
        start = time.perf_counter()
        table = run_study(terrain_rf_run, {"flight": list(range(N_TERRAIN_FLIGHTS)), "n_particles": [N_TERRAIN]}, 1,
                          base_seed=0, progress=False)
        table.drop(columns=["seconds"]).to_csv(OUT / "terrain_rf.csv", index=False)
        provenance("terrain_rf", {"n_particles": N_TERRAIN, "n_flights": N_TERRAIN_FLIGHTS, "bounds": TERRAIN_BOUNDS,
                                  "xatol_log_theta": XATOL, "truth": 1.0, "kernel_scale": 0.2,
                                  "seeds": "flight r: pfcourse.seeding.data_rng(0, r) = default_rng([0, r, 0]) (the terrain "
                                           "chapters' flights); filter: pfcourse.seeding.likelihood_rng(0, r) = "
                                           "default_rng([0, r, 2]) for every scale"},
                   time.perf_counter() - start)
    if "pmmh2" in parts:
        start = time.perf_counter()
        pd.DataFrame([r for i in range(GRID2) for r in grid2_row(i)]).to_csv(OUT / "grid2.csv", index=False)
        provenance("grid2", {"data_seed": DATA_SEED, "grid": f"{GRID2} x {GRID2}, log theta in log {BOUNDS}",
                             "noises": ["Qw", "Rv"], "seeds": "none (exact Kalman likelihood)"},
                   time.perf_counter() - start)
        start = time.perf_counter()
        frames, seeds = [], {}
        for n in N_PMMH2:
            chain, seeds[n] = pmmh2_chain(n)
            frames.append(pd.DataFrame({"n_particles": n, "iteration": np.arange(len(chain.theta)),
                                        "theta_q": chain.theta[:, 0], "theta_r": chain.theta[:, 1],
                                        "log_likelihood": chain.log_likelihood, "accepted": chain.accepted}))
        pd.concat(frames).to_csv(OUT / "pmmh2.csv", index=False)
        provenance("pmmh2", {"data_seed": DATA_SEED, "n_particles": N_PMMH2, "iterations": PMMH2_ITERATIONS,
                             "step_log_theta": PMMH2_STEP, "theta0": PMMH2_THETA0, "noises": ["Qw", "Rv"],
                             "prior": f"log-uniform on {BOUNDS} for each scale, independent", "chain_seeds": seeds,
                             "seeds": f"replicate_seed({PMMH2_SEED}, n_particles)"},
                   time.perf_counter() - start)


if __name__ == "__main__":
    main(sys.argv[1:] or ["bias", "ml", "pmmh", "pmmh2", "terrain_rf"])
