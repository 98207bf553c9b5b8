"""Part V's stored studies (``book/data/likelihood/``): their settings and row functions.

Registered in :mod:`pfcourse.experiments.registry` as the group ``likelihood``
(``python3 tasks.py study likelihood``); the PMMH chains (``pmmh.csv``, ``pmmh2.csv``:
:func:`pmmh_chain`, :func:`pmmh2_chain`; a chain is not a table of independent seeded runs)
are computed by ``tools/studies/pmmh.py`` from the same settings.

* ``bias``: the particle estimate of log p(z | theta = 1) minus the exact (Kalman) value, on the
  chapter's dataset, for N in ``N_BIAS``, ``N_BIAS_RUNS`` seeded filters each;
* ``ml``: on ``N_ML_DATASETS`` simulated datasets (seed = the run's seed), the maximum-likelihood
  noise scale from the Kalman likelihood and from the particle likelihood (``N_ML`` particles,
  common random numbers: one filter seed per dataset for every theta);
* ``grid2``: the exact log-likelihood (Kalman) on a ``GRID2 x GRID2`` grid of
  (log theta_q, log theta_r) over the prior's support, for the exact posterior;
* ``terrain_rf``: on ``N_TERRAIN_FLIGHTS`` flights of the terrain scenario (the flights of the
  terrain chapters), the maximum-likelihood scale of the altimeter noise R_f from the particle
  likelihood of the regularised filter (``N_TERRAIN`` particles, one filter seed per flight for
  every scale);
* ``robot_noise``: on ``ROBOT_NOISE_RUNS`` seeded robot runs (scenario C, truth scales 1), the
  maximum-likelihood scales (q, r) from the particle likelihood (``N_ROBOT_ML`` particles, start at
  Part III's hand-tuned (2, 2)); then the position RMSE (after 20 s) and the mean NEES of a filter
  with ``N_ROBOT_EVAL`` particles (a fresh seed) run with the ML scales, the hand-tuned ones and
  the truth;
* ``smoothing_landmarks``: scenario A (noise on every component): RMS distance of the FFBSm mean
  to the exact RTS mean and of the filter mean to the Kalman mean, in exact standard deviations;
* ``smoothing_robot``: the robot with a measurement gap: mean position error of the filter and
  of the FFBSm smoother inside the gap and outside it.
"""

from __future__ import annotations

from functools import partial

import numpy as np
from scipy import stats

from pfcourse.diagnostics import nees
from pfcourse.experiments.likelihood import (kalman_log_likelihood, max_likelihood_scale, max_likelihood_scales,
                                             pf_log_likelihood, robot_log_likelihood, terrain_log_likelihood)
from pfcourse.pmmh import pmmh
from pfcourse.smoothing import ffbsm, linear_gaussian_log_transition, pairwise, rts_smoother
from pfcourse.robot.scenario import robot_transition_log_density
from pfcourse.experiments.terrain import jacksboro
from pfcourse.filter import ParticleFilter
from pfcourse.landmarks import quadrant_scenario, simulate
from pfcourse.kalman import kalman_filter
from pfcourse.robot import ANGLE_INDICES, RobotModel, RobotScenario, rmse, simulate_robot
from pfcourse.seeding import data_rng, likelihood_rng, replicate_seed, run_filter_seed
from pfcourse.terrain.scenario import AircraftScenario
from pfcourse.terrain.scenario import simulate as simulate_flight

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
SCENARIO_TEXT = "quadrant_scenario().with_(Qw=0.05**2 I6, Rv=0.5**2 I4), 50 samples; theta scales Rv"

ROBOT = RobotScenario().with_(n_steps=200)
ROBOT_NOISE_RUNS, ROBOT_NOISE_SEED = 100, 6
N_ROBOT_ML, N_ROBOT_EVAL, ROBOT_START = 300, 1000, (2.0, 2.0)

N_A, N_A_RUNS, A_SEED = [100, 400], 100, 4
ROBOT_GAP = RobotScenario().with_(n_steps=160, gap=(60.0, 110.0))
N_ROBOT_GAP, ROBOT_GAP_RUNS, ROBOT_GAP_SEED = 300, 100, 5


def chapter_data():
    return simulate(SCENARIO, DATA_SEED)


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


def grid2_cell(seed: int, i: int, j: int) -> dict:
    """Exact log-likelihood at cell ``(i, j)`` of the (log theta_q, log theta_r) grid (``seed`` unused)."""
    Z = chapter_data().measurements
    u = np.linspace(np.log(BOUNDS[0]), np.log(BOUNDS[1]), GRID2)
    return {"log_theta_q": u[i], "log_theta_r": u[j],
            "log_likelihood": kalman_log_likelihood(SCENARIO, Z, (np.exp(u[i]), np.exp(u[j])), ("Qw", "Rv"))}


def terrain_rf_run(seed: int, flight: int, n_particles: int) -> dict:
    """ML scale of R_f on flight ``flight`` (the terrain chapters' data_rng(0, flight)); ``seed`` unused."""
    terrain, scenario = jacksboro(), AircraftScenario()
    sim = simulate_flight(scenario, terrain, data_rng(0, flight))

    def log_lik(scale: float) -> float:
        return terrain_log_likelihood(scenario, terrain, sim.measurements, scale, n_particles, likelihood_rng(0, flight))

    theta, nfev = max_likelihood_scale(lambda t: max(log_lik(t), -1e300), TERRAIN_BOUNDS, XATOL)
    return {"rf_scale_ml": theta, "nfev": nfev, "log_lik_ml": log_lik(theta), "log_lik_truth": log_lik(1.0)}


def robot_noise_run(seed: int, n_particles: int) -> dict:
    sim = simulate_robot(ROBOT, seed)
    scales, nfev = max_likelihood_scales(
        lambda t: robot_log_likelihood(sim, t[0], t[1], n_particles, run_filter_seed(seed)), np.array(ROBOT_START))
    out = {"q_ml": float(scales[0]), "r_ml": float(scales[1]), "nfev": nfev}
    for name, (q, r) in {"ml": scales, "hand": ROBOT_START, "truth": (1.0, 1.0)}.items():
        model = RobotModel.for_simulation(sim, q_scale=float(q), r_scale=float(r))
        res = ParticleFilter(model, N_ROBOT_EVAL).run(sim.measurements, seed + 2)
        out[f"rmse_{name}"] = rmse(sim.truth, res.mean, start=20)[0]
        out[f"nees_{name}"] = float(np.mean(nees(sim.truth[20:], res.mean[20:], res.cov[20:], ANGLE_INDICES)))
    return out


def landmarks_run(seed: int, n_particles: int) -> dict:
    sim = simulate(SCENARIO, seed)
    model = SCENARIO.model()
    kf = kalman_filter(model, sim.measurements)
    m_s, P_s = rts_smoother(model, kf)
    r = ParticleFilter(model, n_particles).run(sim.measurements, run_filter_seed(seed), store_particles=True)
    s = ffbsm(r.particles, r.weights, linear_gaussian_log_transition(model))
    sd_s = np.sqrt(np.diagonal(P_s, axis1=1, axis2=2))
    sd_f = np.sqrt(np.diagonal(kf.cov, axis1=1, axis2=2))
    return {"smoother_vs_rts": float(np.sqrt(np.mean(((s.mean - m_s) / sd_s) ** 2))),
            "filter_vs_kalman": float(np.sqrt(np.mean(((r.mean - kf.mean) / sd_f) ** 2))),
            "rts_truth_error": float(np.sqrt(np.mean((m_s - sim.truth) ** 2))),
            "kalman_truth_error": float(np.sqrt(np.mean((kf.mean - sim.truth) ** 2))),
            "smoother_ess_median": float(np.median(1.0 / np.sum(s.weights**2, axis=1)))}


def robot_gap_run(seed: int, n_particles: int) -> dict:
    sim = simulate_robot(ROBOT_GAP, seed)
    model = RobotModel.for_simulation(sim)
    r = ParticleFilter(model, n_particles).run(sim.measurements, run_filter_seed(seed), store_particles=True)
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
