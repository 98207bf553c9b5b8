"""Smoothing: where was the state at time k, given every measurement up to the end?

**Forward filtering, backward smoothing** (FFBSm, the marginal smoother of Doucet, Godsill
and Andrieu 2000 and Godsill, Doucet and West 2004).  The filter's weighted clouds
``{x_k^i, W_k^i}`` (``FilterResult`` of ``run(..., collect=[Clouds()])``) are reweighted backwards,
from ``W_{K-1|K-1} = W_{K-1}``:

.. math::

   W_{k|K}^i = W_k^i \\sum_j W_{k+1|K}^j
      \\frac{f(x_{k+1}^j \\mid x_k^i)}{\\sum_l W_k^l f(x_{k+1}^j \\mid x_k^l)},

with ``f`` the transition density.  The particles stay where the filter put them; only
their weights change.  Cost: ``N^2`` transition densities per step, ``O(K N^2)`` in all
(against ``O(K N)`` for the filter).  Computed in the log domain (``logsumexp``).

**Backward simulation** (FFBSi, Godsill, Doucet and West 2004) draws whole trajectories from the
same clouds: ``b_{K-1} ~ W_{K-1}``, then backwards ``P(b_k = i) \\propto W_k^i f(x_{k+1}^{b_{k+1}} \\mid x_k^i)``.
Cost: ``N`` densities per step and per trajectory, ``O(K M N)`` for ``M`` trajectories.

**Ancestral lines** (the naive smoother and its fixed-lag version): following the resampling's
ancestor indices (``run(..., collect=[Ancestors()])``, :class:`pfcourse.collectors.Ancestors`) back from step ``t``, the weighted paths ``{x_{0:t}^{(i)}, W_t^i}`` estimate
``p(x_{0:t} | z_{0:t})``; the fixed-lag estimate of ``x_k`` uses them at ``t = min(k + L, K - 1)``.

**Rauch-Tung-Striebel** (1965): the exact smoother of a linear-Gaussian model, from the
Kalman filter's means and covariances (filterpy's ``KalmanFilter.rts_smoother``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from filterpy.kalman import KalmanFilter
from scipy.linalg import solve_triangular
from scipy.spatial.distance import cdist
from scipy.special import logsumexp

from pfcourse.errors import ParameterError, ShapeError
from pfcourse.checks import Array
from pfcourse.diagnostics import weighted_covariance, weighted_mean


@dataclass
class SmootherResult:
    """Smoothed weights ``(K, N)`` on the filter's particles, and the smoothed mean ``(K, d)`` and cov ``(K, d, d)``."""

    weights: Array
    mean: Array
    cov: Array


def pairwise(transition_log_density: Callable[[Array, Array, int], Array]) -> Callable[[Array, Array, int], Array]:
    """Turn a row-by-row ``log f(new_i | old_i)`` into the matrix ``[log f(new_j | old_i)]_{j, i}`` (all ``N^2`` pairs)."""

    def matrix(new: Array, old: Array, k: int) -> Array:
        n_new, n_old = len(new), len(old)
        rows = transition_log_density(np.repeat(new, n_old, axis=0), np.tile(old, (n_new, 1)), k)
        return np.asarray(rows, dtype=float).reshape(n_new, n_old)

    return matrix


def linear_gaussian_log_transition(model) -> Callable[[Array, Array, int], Array]:
    """``[log N(x_k^j; F x_{k-1}^i + B, Q)]_{j, i}`` by whitening with ``Q = L L^T`` and scipy's ``cdist``.

    Same numbers as ``pairwise(model.transition_log_density)``, without forming ``N^2`` rows.
    """
    chol = np.linalg.cholesky(model.Q)
    log_norm = -0.5 * model.dim_x * np.log(2 * np.pi) - float(np.sum(np.log(np.diag(chol))))

    def matrix(new: Array, old: Array, k: int) -> Array:
        a = solve_triangular(chol, np.asarray(new, dtype=float).T, lower=True).T
        b = solve_triangular(chol, model.predict_mean(np.asarray(old, dtype=float)).T, lower=True).T
        return log_norm - 0.5 * cdist(a, b, "sqeuclidean")

    return matrix


def ffbsm(
    particles: Array,
    weights: Array,
    log_transition: Callable[[Array, Array, int], Array],
    angle_indices: tuple[int, ...] = (),
) -> SmootherResult:
    """FFBSm marginal smoother (module docstring) on stored clouds ``particles`` ``(K, N, d)``, ``weights`` ``(K, N)``.

    ``log_transition(new, old, k)`` returns the ``(N, N)`` matrix ``[log f(new_j | old_i)]_{j, i}``
    for ``x_k = new``, ``x_{k-1} = old`` (:func:`pairwise` builds it from a row-by-row density).
    """
    particles, weights = _check_clouds(particles, weights)
    K, n, d = particles.shape
    with np.errstate(divide="ignore"):
        log_w = np.log(weights)
    smoothed = np.empty((K, n))
    smoothed[-1] = weights[-1]
    for k in range(K - 2, -1, -1):
        log_f = np.asarray(log_transition(particles[k + 1], particles[k], k + 1), dtype=float)  # [j, i]
        if log_f.shape != (n, n):
            raise ShapeError(f"step {k + 1}: log_transition returned shape {log_f.shape}, expected {(n, n)}")
        if np.any(np.isnan(log_f) | (log_f == np.inf)):
            raise ParameterError(f"step {k + 1}: the transition log-density returned NaN or +inf")
        log_den = logsumexp(log_f + log_w[k][None, :], axis=1)           # [j]
        with np.errstate(divide="ignore"):
            log_next = np.log(smoothed[k + 1])
        log_s = log_w[k] + logsumexp(log_next[:, None] + log_f - log_den[:, None], axis=0)
        smoothed[k] = np.exp(log_s - logsumexp(log_s))
    mean = np.empty((K, d))
    cov = np.empty((K, d, d))
    for k in range(K):
        mean[k] = weighted_mean(particles[k], smoothed[k], angle_indices)
        cov[k] = weighted_covariance(particles[k], smoothed[k], mean[k], angle_indices)
    return SmootherResult(weights=smoothed, mean=mean, cov=cov)


def rts_smoother(model, kalman_result) -> tuple[Array, Array]:
    """Exact smoothed means ``(K, d)`` and covariances ``(K, d, d)`` of a linear-Gaussian model.

    filterpy's ``rts_smoother``: ``G_k = P_k F^T (F P_k F^T + Q)^{-1}``,
    ``m_{k|K} = m_k + G_k (m_{k+1|K} - F m_k)``,
    ``P_{k|K} = P_k + G_k (P_{k+1|K} - F P_k F^T - Q) G_k^T``.  It has no control input, so
    the model must have ``B = 0``.
    """
    if np.any(model.B != 0):
        raise ParameterError("rts_smoother needs a model without the constant input B (B = 0)")
    K = kalman_result.mean.shape[0]
    kf = KalmanFilter(dim_x=model.dim_x, dim_z=model.dim_z)
    mean, cov, _, _ = kf.rts_smoother(kalman_result.mean, kalman_result.cov,
                                      Fs=[model.F] * K, Qs=[model.Q] * K)
    return mean, cov


def _check_clouds(particles: Array, weights: Array) -> tuple[Array, Array]:
    particles = np.asarray(particles, dtype=float)
    weights = np.asarray(weights, dtype=float)
    if particles.ndim != 3 or weights.shape != particles.shape[:2]:
        raise ShapeError(
            f"particles must be (K, N, d) and weights (K, N); got {particles.shape} and {weights.shape} "
            "(run the filter with collect=[Clouds()], pfcourse.collectors)")
    return particles, weights


def ffbsi(
    particles: Array,
    weights: Array,
    log_transition: Callable[[Array, Array, int], Array],
    n_draws: int,
    rng: np.random.Generator,
) -> Array:
    """FFBSi backward simulation: ``n_draws`` trajectories ``(K, M, d)`` drawn from the stored clouds.

    ``b_{K-1}^m ~ W_{K-1}``; for ``k = K-2 .. 0``:
    ``P(b_k^m = i) = W_k^i f(x_{k+1}^{b_{k+1}^m} | x_k^i) / sum_l W_k^l f(x_{k+1}^{b_{k+1}^m} | x_k^l)``,
    each index by inversion of one uniform ``u ~ rng.random(M)`` (the last step's too).  Their
    average estimates the smoothed mean; ``log_transition`` as for :func:`ffbsm` (``M x N`` here).
    """
    particles, weights = _check_clouds(particles, weights)
    if int(n_draws) != n_draws or n_draws < 1:
        raise ParameterError(f"n_draws must be a positive integer, got {n_draws!r}")
    K, n, _ = particles.shape
    b = np.empty((K, int(n_draws)), dtype=np.int64)
    b[-1] = _invert(np.log(weights[-1])[None, :], rng.random(n_draws))
    with np.errstate(divide="ignore"):
        log_w = np.log(weights)
    for k in range(K - 2, -1, -1):
        log_f = np.asarray(log_transition(particles[k + 1][b[k + 1]], particles[k], k + 1), dtype=float)
        if log_f.shape != (n_draws, n):
            raise ShapeError(f"step {k + 1}: log_transition returned shape {log_f.shape}, expected {(n_draws, n)}")
        b[k] = _invert(log_w[k][None, :] + log_f, rng.random(n_draws))
    return particles[np.arange(K)[:, None], b]


def _invert(log_p: Array, u: Array) -> Array:
    """Row ``m``'s index drawn by inversion of ``u_m``: the first ``i`` with ``cumsum(P_m)_i > u_m``."""
    p = np.exp(log_p - logsumexp(log_p, axis=1, keepdims=True))
    cdf = np.cumsum(p, axis=1)
    return np.minimum((cdf < u[:, None] * cdf[:, -1:]).sum(axis=1), log_p.shape[1] - 1)


def fixed_lag_means(particles: Array, weights: Array, ancestors: Array, lag: int) -> Array:
    """Fixed-lag smoothed means ``(K, d)`` from the ancestral lines: with ``t = min(k + L, K - 1)``,
    ``m_{k|t} = sum_i W_t^i x_k^{a(i, t -> k)}``, ``a`` the ancestor at ``k`` of particle ``i`` at ``t``.
    ``lag = 0`` is the filter's mean; ``lag >= K - 1`` the naive (ancestral) smoother at every step."""
    particles, weights = _check_clouds(particles, weights)
    ancestors = np.asarray(ancestors)
    if ancestors.shape != weights.shape:
        raise ShapeError(f"ancestors must be (K, N) like the weights, got {ancestors.shape}")
    if int(lag) != lag or lag < 0:
        raise ParameterError(f"lag must be a non-negative integer, got {lag!r}")
    K, n, d = particles.shape
    means = np.empty((K, d))
    for k in range(K):
        t = min(k + int(lag), K - 1)
        idx = np.arange(n)
        for j in range(t, k, -1):
            idx = ancestors[j][idx]
        means[k] = weights[t] @ particles[k][idx]
    return means
