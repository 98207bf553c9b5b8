"""Part III's resampling study against an exact answer: the capstone's Poisson-count model.

The model (the Part III capstone's, ``pfcourse.book.exercises.CountModel``, written out here
because a study does not import the book): ``x_0 ~ N(0, sigma^2 / (1 - phi^2))``,
``x_k = phi x_{k-1} + sigma v_k``, ``y_k | x_k ~ Poisson(exp(mu + x_k))``, ``phi = 0.95``,
``sigma = 0.3``, ``mu = 1``, the 50 counts simulated with ``default_rng(2027)``.  Its filtering
means are computed exactly (to 1e-8) on a grid, so a bootstrap filter's own Monte Carlo error is
the RMS distance of its means to the grid's.  ``tests/test_count_resampling.py`` checks that the
data and the grid here are the capstone's.

:func:`row` runs one bootstrap filter (``N`` particles, adaptive resampling at threshold ``tau``
with one of the four schemes of :mod:`pfcourse.resampling`) drawing every number from
``default_rng(seed)``: the same seed for every setting (common random numbers).
"""

from __future__ import annotations

import numpy as np
from scipy.special import logsumexp

from pfcourse.errors import ParameterError
from pfcourse.filter_config import FilterSettings
from pfcourse.metrics import rmse
from pfcourse.resampling import get_resampler

PHI, SIGMA, MU = 0.95, 0.3, 1.0
N_STEPS, DATA_SEED = 50, 2027
N_PARTICLES = 100
N_RUNS = 300
SCHEMES = ("multinomial", "residual", "stratified", "systematic")
TAUS = (0.1, 1 / 3, 0.5, 1.0)
#: tau = 0 never resamples, so the scheme does not matter there: one setting.  The four schemes are compared at
#: tau = 1 (resampling at every step, where the scheme's noise counts most), and the thresholds with the
#: default scheme (systematic) and with multinomial resampling.
GRID = ({"scheme": ["systematic"], "tau": [0.0]},
        {"scheme": ["multinomial", "systematic"], "tau": [0.1, 1 / 3, 0.5]},
        {"scheme": list(SCHEMES), "tau": [1.0]})
STATIONARY_SD = SIGMA / np.sqrt(1.0 - PHI ** 2)


def count_data() -> np.ndarray:
    """The 50 counts ``y_1..y_50`` (as ``CountModel().simulate(50, default_rng(2027))``)."""
    rng = np.random.default_rng(DATA_SEED)
    x = np.empty(N_STEPS + 1)
    x[0] = STATIONARY_SD * rng.standard_normal()
    for k in range(1, N_STEPS + 1):
        x[k] = PHI * x[k - 1] + SIGMA * rng.standard_normal()
    return rng.poisson(np.exp(MU + x[1:]))


def exact_means(y: np.ndarray, n_grid: int = 1601, width: float = 8.0) -> np.ndarray:
    """The filtering means ``E[x_k | y_1..y_k]`` on a grid over ``+-width`` stationary sds."""
    x = np.linspace(-width * STATIONARY_SD, width * STATIONARY_SD, n_grid)
    log_k = -0.5 * ((x[:, None] - PHI * x[None, :]) / SIGMA) ** 2
    kernel = np.exp(log_k - logsumexp(log_k, axis=0, keepdims=True))
    log_p = -0.5 * (x / STATIONARY_SD) ** 2
    p = np.exp(log_p - logsumexp(log_p))
    means = np.empty(len(y))
    for k, yk in enumerate(np.asarray(y, dtype=float)):
        log_g = yk * (MU + x) - np.exp(MU + x)
        post = (kernel @ p) * np.exp(log_g - log_g.max())
        p = post / post.sum()
        means[k] = x @ p
    return means


_DATA: dict[str, np.ndarray] = {}


def _data_and_exact() -> tuple[np.ndarray, np.ndarray]:
    if not _DATA:
        _DATA["y"] = count_data()
        _DATA["exact"] = exact_means(_DATA["y"])
    return _DATA["y"], _DATA["exact"]


def bootstrap_means(y: np.ndarray, n: int, tau: float, scheme: str,
                    rng: np.random.Generator) -> tuple[np.ndarray, int]:
    """A bootstrap filter's means (log-domain weights; resample when ``ESS < tau n``) and its resamplings."""
    if not 0.0 <= tau <= 1.0:
        raise ParameterError(f"tau = {tau} must lie in [0, 1]")
    resample = get_resampler(scheme)
    x = STATIONARY_SD * rng.standard_normal(n)
    log_w = np.full(n, -np.log(n))
    means, resamples = np.empty(len(y)), 0
    for k, yk in enumerate(y):
        x = PHI * x + SIGMA * rng.standard_normal(n)
        log_w = log_w + yk * (MU + x) - np.exp(MU + x)
        log_w = log_w - logsumexp(log_w)
        w = np.exp(log_w)
        means[k] = w @ x
        if 1.0 / np.sum(w ** 2) < tau * n:
            x = x[resample(w, rng)]
            log_w = np.full(n, -np.log(n))
            resamples += 1
    return means, resamples


def row(seed: int, scheme: str, tau: float, n_particles: int = N_PARTICLES) -> dict:
    """One run: RMS over the 50 steps of the filter's mean minus the exact mean, and its resamplings."""
    y, exact = _data_and_exact()
    means, resamples = bootstrap_means(y, n_particles, tau, scheme, np.random.default_rng(seed))
    return {"rmse": float(rmse(means - exact)), "resamples": resamples}


# ----------------------------------------------------------------------------------------------------------------
# Exercise 21.4's study: the linear landmark model (Part I), whose exact answer is the Kalman filter.
# ----------------------------------------------------------------------------------------------------------------

#: Exercise 21.4's sizes, threshold and landmark process-noise variances (0: the static landmarks of Part I).
LINEAR_N = (30, 100, 300, 1000)
LINEAR_THRESHOLD = 0.5
LANDMARK_NOISES = (0.0, 0.0025)
LINEAR_RUNS = 50  # the exercise's own number of runs (N = 1000 on the linear model is the costly part)
#: Its filter: the bootstrap filter, systematic resampling at ESS < N/2 (``N`` from the grid; 100 nominal).
LINEAR_FILTER = FilterSettings(100, threshold=LINEAR_THRESHOLD)
LINEAR_GRID = {"landmark_noise": list(LANDMARK_NOISES), "n_particles": list(LINEAR_N)}
_KALMAN: dict[tuple[int, float], tuple] = {}


def linear_scenario(landmark_noise: float):
    """Part I's two-landmark model; ``landmark_noise > 0`` gives the landmarks that process-noise variance (m^2)."""
    from pfcourse.scenarios.landmarks.scenario import quadrant_scenario

    scenario = quadrant_scenario()
    if landmark_noise > 0:
        scenario = scenario.with_(Qw=np.diag([0.05 ** 2, 0.05 ** 2] + [landmark_noise] * 4))
    return scenario


def linear_row(seed: int, landmark_noise: float, n_particles: int) -> dict:
    """RMS over the steps of the particle mean minus the Kalman mean (robot, and landmark per coordinate
    pair), simulation ``simulate(scenario, seed)``, filter stream ``filter_rng(0, seed)`` for every N."""
    from pfcourse.kalman import kalman_filter
    from pfcourse.scenarios.landmarks.scenario import simulate
    from pfcourse.seeding import filter_rng

    scenario = linear_scenario(landmark_noise)
    model = scenario.model()
    data = simulate(scenario, seed)
    if (seed, landmark_noise) not in _KALMAN:
        _KALMAN[(seed, landmark_noise)] = kalman_filter(model, data.measurements).mean
    pf = LINEAR_FILTER.with_(n_particles=n_particles).build(model).run(data.measurements,
                                                                            rng=filter_rng(0, seed))
    gap = pf.mean - _KALMAN[(seed, landmark_noise)]
    return {"robot_gap": float(rmse(gap[:, :2], components=1)),
            "landmark_gap": float(rmse(gap[:, 2:], components=1, points=2))}
