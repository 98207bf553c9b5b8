"""Part V's stored studies (``book/data/likelihood/``): their settings and row functions.

Registered in :mod:`pfcourse.studies.registry` as the group ``likelihood``
(``python3 tasks.py study likelihood``):

* ``pmmh``: one PMMH chain per N in ``N_PMMH`` on the chapter's dataset (theta scales R_v), a row
  each (:func:`pmmh_row`: the chain's per-iteration arrays in ``pmmh.npz``; :func:`chain_rows` gives
  them one row per iteration).  A long chain takes minutes, so the test re-computes the first
  iterations of one (``tests/test_likelihood_data.py``: a chain's start does not depend on its length);
* ``bias``: the particle estimate of log p(z | theta = 1) minus the exact (Kalman) value, on the
  chapter's dataset, for N in ``N_BIAS``, ``N_BIAS_RUNS`` seeded filters each;
* ``ml``: on ``N_ML_DATASETS`` simulated datasets (seed = the run's seed), the maximum-likelihood
  noise scale from the Kalman likelihood and from the particle likelihood (``N_ML`` particles,
  common random numbers: one filter seed per dataset for every theta);
* ``terrain_rf``: on ``N_TERRAIN_FLIGHTS`` flights of the terrain scenario (the flights of the
  terrain chapters), the maximum-likelihood scale of the altimeter noise R_f from the particle
  likelihood of the regularised filter (``N_TERRAIN`` particles, one filter seed per flight for
  every scale);
* ``smoothing_robot``: the robot with a measurement gap: mean position error of the filter and
  of the FFBSm smoother inside the gap and outside it.
"""

from __future__ import annotations

from functools import partial

import numpy as np
import pandas as pd
from scipy import stats

# grid_posterior, kalman_log_likelihood, max_likelihood_scale: also what the likelihood chapter imports from here
# with its problem (landmark_likelihood_problem), on one line of its visible code
from pfcourse.likelihood import (grid_posterior, kalman_log_likelihood, max_likelihood_scale, pf_log_likelihood,
                                 terrain_log_likelihood)
from pfcourse.pmmh import pmmh
from pfcourse.smoothing import ffbsm, pairwise
from pfcourse.scenarios.robot.scenario import robot_transition_log_density
from pfcourse.studies.terrain import jacksboro
from pfcourse.collectors import Clouds
from pfcourse.filter_config import FilterSettings
from pfcourse.scenarios.landmarks import quadrant_scenario, simulate
from pfcourse.scenarios.robot import RobotModel, RobotScenario, simulate_robot
from pfcourse.seeding import data_rng, likelihood_rng, replicate_seed, run_filter_seed
from pfcourse.scenarios.terrain.scenario import AircraftScenario
from pfcourse.scenarios.terrain.scenario import simulate as simulate_flight

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
N_TERRAIN, N_TERRAIN_FLIGHTS, TERRAIN_BOUNDS = 10000, 100, (0.1, 10.0)
PRIOR = stats.uniform(np.log(BOUNDS[0]), np.log(BOUNDS[1]) - np.log(BOUNDS[0]))  # of u = log theta
SCENARIO_TEXT = "quadrant_scenario().with_(Qw=0.05**2 I6, Rv=0.5**2 I4), 50 samples; theta scales Rv"

ROBOT_GAP = RobotScenario().with_(n_steps=160, gap=(60.0, 110.0))
N_ROBOT_GAP, ROBOT_GAP_RUNS, ROBOT_GAP_SEED = 300, 100, 5

#: What each study's provenance record says of its scenario and seeds, study by study: each row
#: function's own model (the scripts these studies came from stamped the landmark scenario on every
#: table, the altimeter study's included).
PROVENANCE_FIELDS = {
    "pmmh": {"scenario": SCENARIO_TEXT, "data_seed": DATA_SEED, "step_log_theta": PMMH_STEP, "theta0": PMMH_THETA0,
             "prior": f"log-uniform on {BOUNDS}", "chain_seed": "replicate_seed(the row's seed, n_particles)"},
    "bias": {"scenario": SCENARIO_TEXT, "data_seed": DATA_SEED, "theta": 1.0},
    "ml": {"scenario": SCENARIO_TEXT, "bounds": BOUNDS, "xatol_log_theta": XATOL,
           "filter_seed": "run_filter_seed(the run's seed), the same for every theta (common random numbers)"},
    "smoothing_robot": {"scenario": "RobotScenario().with_(n_steps=160, gap=(60.0, 110.0))",
                        "filter_seed": "run_filter_seed(the run's seed)"},
    "terrain_rf": {"scenario": "AircraftScenario() over jacksboro(): the terrain chapters' flights; "
                               "rf_scale multiplies the altimeter variance R_f",
                   "filter": "terrain_log_likelihood: regularised filter (kernel_scale 0.2), multinomial "
                             "resampling at every reading",
                   "bounds": TERRAIN_BOUNDS, "xatol_log_theta": XATOL, "truth": 1.0,
                   "seeds": "flight r: pfcourse.seeding.data_rng(0, r); filter: pfcourse.seeding.likelihood_rng(0, r) "
                            "for every scale (the row's seed column is unused)"},
}


def chapter_data():
    return simulate(SCENARIO, DATA_SEED)


def pmmh_chain(n_particles: int, n_iterations: int = PMMH_ITERATIONS, seed: int = PMMH_SEED):
    """The PMMH chain of ``n_particles`` on the chapter's data, its generator ``replicate_seed(seed, n_particles)``."""
    Z = chapter_data().measurements
    chain_seed = replicate_seed(seed, n_particles)
    chain = pmmh(lambda t, rng: pf_log_likelihood(SCENARIO, Z, t, n_particles, rng, NOISE),
                 PRIOR, PMMH_THETA0, n_iterations, PMMH_STEP, chain_seed)
    return chain, chain_seed


def pmmh_row(seed: int, n_particles: int, iterations: int) -> dict:
    """The study ``likelihood/pmmh``'s row: one chain (:func:`pmmh_chain`), its per-iteration ``theta``,
    ``log_likelihood`` and ``accepted`` (1.0 or 0.0)."""
    chain, _ = pmmh_chain(n_particles, iterations, seed)
    return {"theta": chain.theta, "log_likelihood": chain.log_likelihood,
            "accepted": np.asarray(chain.accepted, dtype=float)}


def chain_rows(table):
    """The stored chains (``STUDIES["likelihood/pmmh"].load()``) one row per iteration: ``n_particles``,
    ``iteration``, ``theta``, ``log_likelihood``, ``accepted`` (bool)."""
    return pd.concat([pd.DataFrame({"n_particles": row.n_particles, "iteration": np.arange(len(row.theta)),
                                    "theta": row.theta, "log_likelihood": row.log_likelihood,
                                    "accepted": np.asarray(row.accepted) == 1.0})
                      for row in table.itertuples()], ignore_index=True)


def bias_run(seed: int, n_particles: int) -> dict:
    Z = chapter_data().measurements
    estimate = pf_log_likelihood(SCENARIO, Z, 1.0, n_particles, seed, NOISE)
    return {"log_ratio": estimate - kalman_log_likelihood(SCENARIO, Z, 1.0, NOISE)}


def ml_run(seed: int, n_particles: int) -> dict:
    Z = simulate(SCENARIO, seed).measurements
    filter_seed = run_filter_seed(seed)  # one filter seed for every theta: common random numbers
    theta_k, nfev_k = max_likelihood_scale(lambda t: kalman_log_likelihood(SCENARIO, Z, t, NOISE), BOUNDS, XATOL)
    theta_p, nfev_p = max_likelihood_scale(
        lambda t: pf_log_likelihood(SCENARIO, Z, t, n_particles, filter_seed, NOISE), BOUNDS, XATOL)
    return {"theta_kalman": theta_k, "theta_pf": theta_p, "nfev_kalman": nfev_k, "nfev_pf": nfev_p}


def terrain_rf_run(seed: int, flight: int, n_particles: int) -> dict:
    """ML scale of R_f on flight ``flight`` (the terrain chapters' data_rng(0, flight)); ``seed`` unused."""
    terrain, scenario = jacksboro(), AircraftScenario()
    sim = simulate_flight(scenario, terrain, data_rng(0, flight))

    def log_lik(scale: float) -> float:
        return terrain_log_likelihood(scenario, terrain, sim.measurements, scale, n_particles, likelihood_rng(0, flight))

    theta, nfev = max_likelihood_scale(lambda t: max(log_lik(t), -1e300), TERRAIN_BOUNDS, XATOL)
    return {"rf_scale_ml": theta, "nfev": nfev, "log_lik_ml": log_lik(theta), "log_lik_truth": log_lik(1.0)}


#: The filter of ``likelihood/smoothing_robot``: bootstrap, systematic resampling at ESS < N/2 (``N`` from the grid).
ROBOT_GAP_FILTER = FilterSettings(300)


def robot_gap_run(seed: int, n_particles: int) -> dict:
    sim = simulate_robot(ROBOT_GAP, seed)
    model = RobotModel.for_simulation(sim)
    r = ROBOT_GAP_FILTER.with_(n_particles=n_particles).build(model).run(sim.measurements, run_filter_seed(seed),
                                                                       collect=[Clouds()])
    s = ffbsm(r.particles, r.weights, pairwise(partial(robot_transition_log_density, model)), model.angle_indices)
    t = np.arange(ROBOT_GAP.n_steps) * ROBOT_GAP.dt
    gap = (t >= ROBOT_GAP.gap[0]) & (t < ROBOT_GAP.gap[1])
    after = t >= 20  # outside the gap, after the first 20 s of convergence
    ef = np.linalg.norm(r.mean[:, :2] - sim.truth[:, :2], axis=1)
    es = np.linalg.norm(s.mean[:, :2] - sim.truth[:, :2], axis=1)
    return {"filter_gap_error": float(ef[gap].mean()), "smoother_gap_error": float(es[gap].mean()),
            "filter_outside_error": float(ef[after & ~gap].mean()),
            "smoother_outside_error": float(es[after & ~gap].mean()),
            "smoother_gap_ess_median": float(np.median(1.0 / np.sum(s.weights[gap] ** 2, axis=1)))}


def landmark_likelihood_problem(seed: int = 7):
    """The model and data of the likelihood chapter (``book/part5/likelihood.py``): the two-landmark scenario
    of Part I with process noise ``0.05^2`` on every coordinate (the landmarks drift slowly) and
    ``R_0 = 0.5^2 I``, and its ``K = 50`` steps of measurements simulated at ``theta = 1`` (``seed``).
    Returns ``(scenario, Z)``; ``scenario.model(Rv=theta * scenario.Rv)`` is the model at scale ``theta``."""
    scenario = quadrant_scenario().with_(Qw=0.05**2 * np.eye(6), Rv=0.5**2 * np.eye(4))
    return scenario, simulate(scenario, seed).measurements
