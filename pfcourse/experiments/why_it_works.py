"""The stored study of the chapter "Why it works" (book/part1/why_it_works.py).

The landmark model with drifting landmarks (process noise ``0.05^2`` m^2 on every coordinate,
measurement noise ``0.5^2 I`` m^2, as in Part V), one simulated data set of ``T_MAX + 1``
samples (simulation seed ``DATA_SEED``), and the bootstrap filter of the engine run on its first
``T + 1`` samples with ``N`` particles and resampling threshold ``tau``.  One row per
(``T``, ``N``, ``tau``, seed): the filter's seed is the row's seed (the registry's
``run`` rule: 0, 1, ...), the same for every setting (common random numbers).  Metrics, against the
exact Kalman filter of the same data:

* ``log_ratio``: ``log p^(z_{1:T}) - log p(z_{1:T})``;
* ``error_robot_x``, ``error_landmark_x``: the filter mean of the robot's x and of the first
  landmark's x at the last step minus the Kalman mean (m).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from pfcourse.filter import ParticleFilter
from pfcourse.kalman import kalman_filter
from pfcourse.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.linear_gaussian import LinearGaussianModel
from pfcourse.seeding import data_rng, filter_rng

DATA_SEED = 7
T_MAX = 400
T_VALUES = [25, 50, 100, 200, 400]  # checkpoints: log p^(z_{1:T}) of one run read at these steps
T_FIXED = 50  # the step of the sweeps in N and tau
N_FIXED = 1000
N_VALUES = [250, 500, 1000, 2000, 4000]  # particles, at T = T_FIXED
TAU_VALUES = [0.1, 0.3, 0.5]  # adaptive resampling, at T_FIXED and N_FIXED (tau = 1 is in the sweeps)
N_RUNS = 300
#: (run length T, N, tau): the long runs at N_FIXED, the others stop at T_FIXED.
GRID = ({"T": [T_MAX], "N": [N_FIXED], "tau": [1.0]},
        {"T": [T_FIXED], "N": [n for n in N_VALUES if n != N_FIXED], "tau": [1.0]},
        {"T": [T_FIXED], "N": [N_FIXED], "tau": TAU_VALUES})
COLUMNS = ("T", "N", "tau", "seed", *(f"log_ratio_{t}" for t in T_VALUES), "error_robot_x", "error_landmark_x")


def drifting_scenario(n_samples: int = T_MAX + 1):
    """The quadrant scenario with drifting landmarks and measurement sd 0.5 m (Part V's variant)."""
    return quadrant_scenario().with_(Qw=0.05**2 * np.eye(6), Rv=0.5**2 * np.eye(4), n_samples=n_samples)


@lru_cache(maxsize=1)
def data() -> tuple:
    """``(model, Z, kf)``: the model, the simulated measurements (``T_MAX + 1`` samples), their Kalman filter."""
    scenario = drifting_scenario()
    model, Z = scenario.model(), simulate(scenario, rng=DATA_SEED).measurements
    return model, Z, kalman_filter(model, Z)


def row(seed: int, T: int, N: int, tau: float) -> dict:
    """One bootstrap run on the first ``T + 1`` samples against the exact answer (the study's row function).

    ``log_ratio_t`` is ``log p^(z_{1:t}) - log p(z_{1:t})`` at each checkpoint ``t <= T`` (the filter
    is causal: the first ``t + 1`` increments of a run are those of a run on ``t + 1`` samples), NaN
    beyond ``T``; the errors are those of the filter means at step ``T_FIXED`` (NaN if ``T < T_FIXED``).
    """
    model, Z, kf = data()
    result = ParticleFilter(model, int(N), threshold=float(tau)).run(Z[:T + 1], rng=seed)
    gap = np.cumsum(result.log_likelihood_increments - kf.log_likelihood_increments[:T + 1])
    out = {f"log_ratio_{t}": float(gap[t]) if t <= T else float("nan") for t in T_VALUES}
    error = result.mean[T_FIXED] - kf.mean[T_FIXED] if T >= T_FIXED else np.full(model.dim_x, np.nan)
    return dict(out, error_robot_x=float(error[0]), error_landmark_x=float(error[2]))


# --- var(log p^) against T over many data sets (study why_it_works_growth) ---
GROWTH_N = 500
GROWTH_FILTER_RUNS = [0, 1, 2, 3]  # filter runs per data set: the variance given the data is estimated within
GROWTH_DATASETS = 100
GROWTH_COLUMNS = ("N", "filter_run", "seed", *(f"log_ratio_{t}" for t in T_VALUES))


@lru_cache(maxsize=4)
def _dataset(seed: int) -> tuple:
    scenario = drifting_scenario()
    model, Z = scenario.model(), simulate(scenario, rng=seed).measurements
    return model, Z, kalman_filter(model, Z).log_likelihood_increments


def growth_row(seed: int, N: int, filter_run: int) -> dict:
    """``log p^(z_{1:t}) - log p(z_{1:t})`` at every checkpoint ``t`` of one bootstrap run (threshold 1) on
    data set ``seed`` (simulation seed), the filter's generator ``filter_rng(seed, filter_run)``."""
    model, Z, exact_increments = _dataset(int(seed))
    result = ParticleFilter(model, int(N), threshold=1.0).run(Z, rng=filter_rng(int(seed), int(filter_run)))
    gap = np.cumsum(result.log_likelihood_increments - exact_increments)
    return {f"log_ratio_{t}": float(gap[t]) for t in T_VALUES}


# --- the CLT on a scalar model (study why_it_works_clt) ---
CLT_N_VALUES = [100, 300, 1000, 3000, 10000]
CLT_RUNS = 400
CLT_STEPS = 50
SCALAR = LinearGaussianModel(F=[[0.9]], H=[[1.0]], m0=[0.0], P0=[[1.0]], Q=[[0.5]], R=[[0.5]])


@lru_cache(maxsize=1)
def scalar_data() -> tuple:
    """``(Z, kf)``: ``CLT_STEPS + 1`` samples of :data:`SCALAR` (``z_0`` missing), seed ``DATA_SEED``, and their Kalman filter."""
    rng = data_rng(DATA_SEED, 0)
    x = np.empty(CLT_STEPS + 1)
    x[0] = rng.standard_normal()
    for k in range(1, CLT_STEPS + 1):
        x[k] = 0.9 * x[k - 1] + np.sqrt(0.5) * rng.standard_normal()
    Z = (x + np.sqrt(0.5) * rng.standard_normal(CLT_STEPS + 1))[:, None]
    Z[0] = np.nan
    return Z, kalman_filter(SCALAR, Z)


def clt_row(seed: int, N: int) -> dict:
    """One bootstrap run (threshold 1) on the scalar data: the filter mean's error against Kalman at the
    last step and at step ``CLT_STEPS // 2``, and ``log p^ - log p``."""
    Z, kf = scalar_data()
    result = ParticleFilter(SCALAR, int(N), threshold=1.0).run(Z, rng=seed)
    error = result.mean[:, 0] - kf.mean[:, 0]
    return dict(error_last=float(error[-1]), error_middle=float(error[CLT_STEPS // 2]),
                log_ratio=float(result.log_likelihood_increments.sum() - kf.log_likelihood_increments.sum()))
