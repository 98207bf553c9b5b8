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

from pfcourse.filter_config import FilterSettings
from pfcourse.kalman import kalman_filter
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.linear_gaussian import LinearGaussianModel
from pfcourse.resampling import get_resampler
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


#: The studies' filter: the bootstrap filter, systematic resampling (``N`` and the threshold ``tau`` from the
#: grid of ``why_it_works``; 1000 and 1/2 nominal), and the same resampling at every step (``why_it_works_growth``,
#: ``why_it_works_clt``).
BOOTSTRAP = FilterSettings(1000, threshold=0.5)
EVERY_STEP = BOOTSTRAP.with_(threshold=1.0)


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
    result = BOOTSTRAP.with_(n_particles=int(N), threshold=float(tau)).build(model).run(Z[:T + 1], rng=seed)
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
    result = EVERY_STEP.with_(n_particles=int(N)).build(model).run(Z, rng=filter_rng(int(seed), int(filter_run)))
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
    result = EVERY_STEP.with_(n_particles=int(N)).build(SCALAR).run(Z, rng=seed)
    error = result.mean[:, 0] - kf.mean[:, 0]
    return dict(error_last=float(error[-1]), error_middle=float(error[CLT_STEPS // 2]),
                log_ratio=float(result.log_likelihood_increments.sum() - kf.log_likelihood_increments.sum()))


def clt_variance(Z: np.ndarray | None = None, k: int | None = None, n_grid: int = 601,
                 half_width: float = 8.0) -> float:
    """The asymptotic variance ``V_k(phi)`` of the bootstrap filter's mean (``phi(x) = x``) on :data:`SCALAR`,
    by quadrature on a grid: multinomial resampling at every step, the estimate after weighting.

    ``V_k = sum_j eta_j([Q_(j,k)(phi - Q_k phi)]^2) / eta_j(Q_(j,k) 1)^2`` with ``eta_j`` the predictive
    law of step ``j`` (the Kalman predictive; ``eta_0 = N(m0, P0)``), ``Q_(j,k) f(x_j) = G_j(x_j) E[G_(j+1)
    ... G_k f(X_k) | x_j]`` computed backwards from ``k`` with the transition on the grid, and ``Q_k phi``
    the Kalman mean.  Defaults: the scalar study's data and its last step.
    """
    from scipy.stats import norm

    if Z is None:
        Z, kf = scalar_data()
    else:
        kf = kalman_filter(SCALAR, Z)
    z = np.asarray(Z, float)[:, 0]
    k = len(z) - 1 if k is None else int(k)
    a, q, r = float(SCALAR.F[0, 0]), float(SCALAR.Q[0, 0]), float(SCALAR.R[0, 0])
    x = np.linspace(-half_width, half_width, n_grid)
    # move[i, l] = p(x_l | x_i) dx: the transition on the grid
    move = norm.pdf(x[None, :], a * x[:, None], np.sqrt(q)) * (x[1] - x[0])

    def potential(j):
        return np.ones_like(x) if np.isnan(z[j]) else norm.pdf(z[j], x, np.sqrt(r))

    # eta_j: the Kalman predictive laws, as grid weights
    m, P, etas = float(SCALAR.m0[0]), float(SCALAR.P0[0, 0]), []
    for j in range(k + 1):
        if j > 0:
            m, P = a * m, a * a * P + q
        etas.append(norm.pdf(x, m, np.sqrt(P)) * (x[1] - x[0]))
        if not np.isnan(z[j]):
            gain = P / (P + r)
            m, P = m + gain * (z[j] - m), (1 - gain) * P
    one, centred = potential(k), potential(k) * (x - kf.mean[k, 0])
    total = 0.0
    for j in range(k, -1, -1):
        if j < k:
            one, centred = potential(j) * (move @ one), potential(j) * (move @ centred)
            scale = one.max()  # the ratio is scale-free: keep the numbers in range
            one, centred = one / scale, centred / scale
        total += float(etas[j] @ centred**2 / (etas[j] @ one) ** 2)
    return total


# --- multinomial against systematic resampling at one N (study why_it_works_resampling) ---
RESAMPLING_N = 1000
RESAMPLING_RUNS = 2000
RESAMPLING_SCHEMES = ["multinomial", "systematic"]


def resampling_row(seed: int, resampling: str, N: int = RESAMPLING_N) -> dict:
    """One bootstrap run (resampling at every step with the named scheme of :mod:`pfcourse.resampling`) on
    the scalar data: the filter mean's error against Kalman at the last step, and ``log p^ - log p``.

    Plain NumPy rather than the engine (the engine gives the same filter; this is ten times faster on
    one dimension): particles from ``N(m0, P0)``, then move, weight by ``p(z_k | x_k)``, resample.
    """
    Z, kf = scalar_data()
    z = Z[:, 0]
    rng = np.random.default_rng(int(seed))
    resample = get_resampler(str(resampling))
    a, q, r = float(SCALAR.F[0, 0]), float(SCALAR.Q[0, 0]), float(SCALAR.R[0, 0])
    x = float(SCALAR.m0[0]) + np.sqrt(float(SCALAR.P0[0, 0])) * rng.standard_normal(int(N))
    log_p = 0.0
    for k in range(len(z)):
        if k > 0:
            x = a * x[resample(W, rng)] + np.sqrt(q) * rng.standard_normal(len(x))
        log_g = np.zeros(len(x)) if np.isnan(z[k]) else -0.5 * ((z[k] - x) ** 2 / r + np.log(2 * np.pi * r))
        top = log_g.max()
        g = np.exp(log_g - top)
        log_p += top + np.log(g.mean())
        W = g / g.sum()
    return dict(error_last=float(W @ x - kf.mean[-1, 0]),
                log_ratio=float(log_p - kf.log_likelihood_increments.sum()))
