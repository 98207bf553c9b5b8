"""Diagnostics of a weighted particle cloud and of an estimator.

* effective sample size (Kong 1992; Liu 1996)
  ``ESS = 1 / sum_i W_i^2`` for normalised weights ``W``;
* weighted mean ``m = sum_i W_i x_i`` (circular for angle components) and
  covariance ``P = sum_i W_i (x_i - m)(x_i - m)^T`` (angle deviations wrapped);
* the normalised estimation error squared (Bar-Shalom, Li and Kirubarajan 2001)
  ``NEES_k = (x_k - m_k)^T P_k^{-1} (x_k - m_k)``, chi-square with ``d`` degrees
  of freedom for a consistent Gaussian estimator, and its acceptance band;
* the confidence ellipse of a 2-D Gaussian;
* for several MCMC chains of one quantity, the split potential scale reduction factor
  ``R-hat`` and the effective sample size (:func:`split_rhat`, :func:`chain_ess`;
  Gelman et al. 2013, ch. 11, and Geyer's initial monotone sequence).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import stats
from scipy.special import logsumexp

from pfcourse.angles import circular_mean, wrap_angle
from pfcourse.checks import check_moments
from pfcourse.errors import CovarianceError, DegenerateWeightsError, ShapeError, WeightError


def normalize_log_weights(log_weights: np.ndarray) -> tuple[np.ndarray, float]:
    """Return the normalised weights ``W_i = exp(l_i - logsumexp(l))`` and ``logsumexp(l)``.

    Works in the log domain so that log-weights of -1e4 (a likelihood of
    ``e^{-10000}``, zero in floating point) still normalise correctly.  Raises
    :class:`DegenerateWeightsError` when every weight is zero (all ``-inf``).
    """
    log_weights = _real_array(log_weights, "log_weights", ndim=1)
    if np.isnan(log_weights).any() or (log_weights == np.inf).any():
        raise WeightError("normalize_log_weights: log_weights contain NaN or +inf")
    log_total = _logsumexp(log_weights)
    if not np.isfinite(log_total):
        raise DegenerateWeightsError(
            "all particle weights are zero (every log-weight is -inf): no particle is "
            "compatible with the measurement"
        )
    return np.exp(log_weights - log_total), log_total


def _logsumexp(a: np.ndarray) -> float:
    """``log sum_i exp(a_i)``, the same float as ``scipy.special.logsumexp(a)`` but faster.

    scipy (1.17) takes the largest value ``a*`` out of the sum, once per copy ``m``
    of it: ``log1p(sum_{a_i < a*} exp(a_i - a*) / m) + log(m) + a*``, and falls back
    on ``log(sum exp(a))`` when that is not finite (every ``a_i = -inf``).  This is
    the same sequence of NumPy operations for a 1-D float array, without scipy's
    array-API dispatch and its extra passes over the data (a test checks that the
    results are identical, bit for bit, on many vectors with ties and ``-inf``).
    """
    if a.ndim != 1 or a.size == 0:
        return float(logsumexp(a))
    a_max = a.max(keepdims=True)
    at_max = a == a_max
    m = np.sum(at_max, keepdims=True, dtype=a.dtype)
    rest = a.copy()
    rest[at_max] = -np.inf
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        s = np.sum(np.exp(rest - a_max), keepdims=True, dtype=a.dtype)
        s = np.where(s == 0, s, s / m)
        out = np.log1p(s) + np.log(m) + a_max
    if not np.isfinite(out[0]):
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return float(np.log(np.sum(np.exp(a))))
    return float(out[0])


def _real_array(value, name: str, ndim: int | None = None) -> np.ndarray:
    """``value`` as a float array; refuses None, complex, object, bool and empty input (named errors)."""
    raw = np.asarray(value) if value is not None else None
    if raw is None or raw.dtype.kind not in "fiu" or raw.dtype == bool:
        kind = "None" if raw is None else f"dtype {raw.dtype}"
        raise WeightError(f"{name} must be a real array, got {kind}")
    if ndim is not None and raw.ndim != ndim:
        raise ShapeError(f"{name} must have {ndim} dimension(s), got shape {raw.shape}")
    if raw.size == 0:
        raise ShapeError(f"{name} must not be empty")
    return raw.astype(float, copy=False)


def _check_weights(weights, name: str = "weights") -> np.ndarray:
    """Normalised weights: 1-D, finite, non-negative, summing to 1 (to 1e-6)."""
    w = _real_array(weights, name, ndim=1)
    if not np.isfinite(w).all() or (w < 0).any():
        raise WeightError(f"{name} must be finite and non-negative")
    if abs(w.sum() - 1.0) > 1e-6:
        raise WeightError(f"{name} must sum to 1, got {w.sum():.6g}; normalise them first")
    return w


def effective_sample_size(weights: np.ndarray) -> float:
    """Effective sample size ``1 / sum W_i^2`` of normalised weights ``W`` (between 1 and N)."""
    weights = _check_weights(weights)
    return float(1.0 / np.sum(weights**2))


def weighted_mean(
    particles: np.ndarray, weights: np.ndarray, angle_indices: Sequence[int] = ()
) -> np.ndarray:
    """Weighted mean ``sum_i W_i x_i`` of ``(N, d)`` particles; circular mean on ``angle_indices``."""
    particles = _real_array(particles, "particles", ndim=2)
    weights = _check_weights(weights)
    if weights.shape[0] != particles.shape[0]:
        raise ShapeError(f"weights have length {weights.shape[0]} but there are {particles.shape[0]} particles")
    mean = weights @ particles
    for j in angle_indices:
        mean[j] = circular_mean(particles[:, j], weights)
    return mean


def weighted_covariance(
    particles: np.ndarray,
    weights: np.ndarray,
    mean: np.ndarray | None = None,
    angle_indices: Sequence[int] = (),
) -> np.ndarray:
    """Weighted covariance ``sum_i W_i (x_i - m)(x_i - m)^T`` (angle deviations wrapped)."""
    particles = _real_array(particles, "particles", ndim=2)
    weights = _check_weights(weights)
    if weights.shape[0] != particles.shape[0]:
        raise ShapeError(f"weights have length {weights.shape[0]} but there are {particles.shape[0]} particles")
    if mean is None:
        mean = weighted_mean(particles, weights, angle_indices)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is refused below, by name
        dev = particles - mean
        for j in angle_indices:
            dev[:, j] = wrap_angle(dev[:, j])
        cov = (dev * weights[:, None]).T @ dev
        cov = 0.5 * (cov + cov.T)
    linear = np.ones(particles.shape[1], dtype=bool)
    linear[list(angle_indices)] = False
    check_moments(particles, cov, linear)
    return cov


def _chains(chains, name: str = "chains") -> np.ndarray:
    x = _real_array(chains, name, 2)
    if x.shape[0] < 1 or x.shape[1] < 4:
        raise ShapeError(f"{name} must be (m chains, n >= 4 draws), got shape {x.shape}")
    return x


def split_rhat(chains) -> float:
    """Split ``R-hat`` of ``chains`` ``(m, n)``: each chain cut in two halves, then
    ``sqrt(var+ / W)`` with ``W`` the mean within-half variance and
    ``var+ = (n' - 1) / n' W + B / n'`` (``B / n'`` the variance of the half means, ``n'`` a half's
    length).  Near 1 when the chains agree; above about 1.01 they have not mixed (Vehtari et al. 2021).
    """
    x = _chains(chains)
    half = x.shape[1] // 2
    halves = np.concatenate([x[:, :half], x[:, x.shape[1] - half:]])
    n = halves.shape[1]
    W = halves.var(axis=1, ddof=1).mean()
    if W == 0:
        raise ShapeError("split_rhat needs chains that move (a within-chain variance > 0)")
    var_plus = (n - 1) / n * W + halves.mean(axis=1).var(ddof=1)
    return float(np.sqrt(var_plus / W))


def chain_ess(chains) -> float:
    """Effective sample size of ``chains`` ``(m, n)`` together: ``m n / tau``.

    ``tau = -1 + 2 sum_k (rho_2k + rho_2k+1)`` over Geyer's initial positive, monotone sequence of
    pair sums; the autocorrelations ``rho_t = 1 - (W - mean_j gamma_jt) / var+`` combine the chains'
    autocovariances ``gamma_jt`` with the between-chain variance, so chains that disagree have a
    small ESS (Gelman et al. 2013, ch. 11).  One chain: ``chains[None]``.
    """
    x = _chains(chains)
    m, n = x.shape
    centred = x - x.mean(axis=1, keepdims=True)
    size = 1 << int(np.ceil(np.log2(2 * n)))
    f = np.fft.rfft(centred, size, axis=1)
    acov = np.fft.irfft(f * np.conj(f), size, axis=1)[:, :n] / n  # biased autocovariances
    W = (acov[:, 0] * n / (n - 1)).mean()
    if W == 0:
        raise ShapeError("chain_ess needs chains that move (a within-chain variance > 0)")
    var_plus = (n - 1) / n * W + (x.mean(axis=1).var(ddof=1) if m > 1 else 0.0)
    rho = 1.0 - (W - acov.mean(axis=0)) / var_plus
    rho[0] = 1.0
    pairs = rho[: 2 * (n // 2)].reshape(-1, 2).sum(axis=1)
    positive = np.flatnonzero(pairs <= 0)
    pairs = pairs[: positive[0]] if positive.size else pairs
    pairs = np.minimum.accumulate(pairs)  # initial monotone sequence
    tau = max(-1.0 + 2.0 * pairs.sum(), 1.0 / np.log10(m * n))
    return float(m * n / tau)


def nees(
    truth: np.ndarray,
    estimate: np.ndarray,
    covariance: np.ndarray,
    angle_indices: Sequence[int] = (),
) -> np.ndarray:
    """Normalised estimation error squared ``e^T P^{-1} e`` with ``e = m - x`` (estimate minus truth,
    the book's one sign convention; the NEES does not depend on the sign), per time step.

    ``truth`` and ``estimate`` have shape ``(K, d)``, ``covariance`` ``(K, d, d)``;
    returns shape ``(K,)``.  Angle components of ``e`` are wrapped.  A step whose covariance
    is not positive definite in floating point (a particle cloud collapsed onto one point,
    or in some directions) gets NEES ``+inf``: the estimator claims a certainty that the
    error contradicts.  The value is computed as ``|L^{-1} e|^2`` with the Cholesky factor
    ``L`` of ``P``, so it is never negative.
    """
    truth = np.atleast_2d(np.asarray(truth, dtype=float))
    estimate = np.atleast_2d(np.asarray(estimate, dtype=float))
    covariance = np.asarray(covariance, dtype=float)
    if covariance.ndim == 2:
        covariance = covariance[None]
    if truth.shape != estimate.shape or covariance.shape != truth.shape + truth.shape[-1:]:
        raise ShapeError(
            f"nees needs truth and estimate of shape (K, d) and covariance (K, d, d); got "
            f"{truth.shape}, {estimate.shape} and {covariance.shape}"
        )
    err = estimate - truth
    for j in angle_indices:
        err[:, j] = wrap_angle(err[:, j])
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        try:
            chol = np.linalg.cholesky(covariance)
        except np.linalg.LinAlgError:  # some step is not positive definite: step by step
            return np.array([_nees_one(e, c) for e, c in zip(err, covariance)])
        whitened = np.linalg.solve(chol, err[..., None])[..., 0]
        values = np.sum(whitened**2, axis=1)
    finite_err = np.all(np.isfinite(err), axis=1)
    return np.where(finite_err, np.where(np.isfinite(values), values, np.inf), np.nan)


def _nees_one(err: np.ndarray, cov: np.ndarray) -> float:
    """``|L^{-1} e|^2`` with ``L L^T = P`` (Cholesky): never negative, whatever the round-off.

    A covariance that is not positive definite in floating point (a collapsed cloud, or
    one collapsed in some directions) gets ``+inf``.  Solving with such a matrix directly
    would return round-off, small or even negative, and a collapsed cloud would then
    count as covering the truth by chance.
    """
    if not np.all(np.isfinite(err)):
        return float("nan")
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        try:
            chol = np.linalg.cholesky(cov)
        except np.linalg.LinAlgError:
            return float("inf")
        whitened = np.linalg.solve(chol, err)
        value = float(whitened @ whitened)
    return value if np.isfinite(value) else float("inf")


def chi2_band(dof: int, n_runs: int = 1, probability: float = 0.95) -> tuple[float, float]:
    """Two-sided acceptance band of the average of ``n_runs`` independent chi2(dof) values.

    ``n_runs * mean`` is chi2 with ``n_runs * dof`` degrees of freedom, so the band
    is ``chi2.ppf([a/2, 1 - a/2], n_runs dof) / n_runs`` with ``a = 1 - probability``.
    """
    alpha = 1.0 - probability
    lo, hi = stats.chi2.ppf([alpha / 2, 1 - alpha / 2], n_runs * dof) / n_runs
    return float(lo), float(hi)


def confidence_ellipse(
    mean: np.ndarray, cov: np.ndarray, probability: float = 0.95
) -> tuple[np.ndarray, float, float, float]:
    """Centre, width, height and angle (degrees) of a 2-D Gaussian's confidence ellipse.

    The ellipse ``(x - m)^T P^{-1} (x - m) = c`` with ``c = chi2.ppf(probability, 2)``
    has semi-axes ``sqrt(c lambda_j)`` along the eigenvectors of ``P``.
    """
    cov = np.asarray(cov, dtype=float)
    if cov.shape != (2, 2):
        raise ShapeError(f"confidence_ellipse needs a 2x2 covariance, got {cov.shape}")
    eigval, eigvec = np.linalg.eigh(cov)
    eigval = np.clip(eigval, 0.0, None)
    scale = stats.chi2.ppf(probability, 2)
    width, height = 2.0 * np.sqrt(scale * eigval[::-1])
    angle = float(np.degrees(np.arctan2(eigvec[1, 1], eigvec[0, 1])))
    return np.asarray(mean, dtype=float), float(width), float(height), angle


def nis(innovation: np.ndarray, innovation_cov: np.ndarray) -> np.ndarray:
    """Normalised innovation squared ``NIS_k = y_k^T S_k^{-1} y_k`` per time step.

    ``innovation`` has shape ``(K, m)`` (``y_k = z_k - z^_k``, angle components already
    wrapped by the caller) and ``innovation_cov`` ``(K, m, m)`` (``S_k``, the covariance
    of the filter's predictive distribution of ``z_k``).  For a consistent filter
    ``NIS_k`` is chi-square with ``m`` degrees of freedom (Bar-Shalom, Li and
    Kirubarajan 2001, sec. 5.4).  Steps without a measurement (a NaN row of
    ``innovation``) give NaN; returns shape ``(K,)``.  An ``S_k`` that is not symmetric
    positive definite (a predictive covariance cannot be) raises
    :class:`~pfcourse.errors.CovarianceError` naming the first such step.
    """
    innovation = np.asarray(innovation, dtype=float)
    innovation_cov = np.asarray(innovation_cov, dtype=float)
    if innovation.ndim == 1:
        innovation = innovation[:, None]
    if innovation_cov.ndim == 1:
        innovation_cov = innovation_cov[:, None, None]
    if innovation.ndim != 2 or innovation_cov.shape != innovation.shape + innovation.shape[-1:]:
        raise ShapeError(
            f"nis needs innovations of shape (K, m) and covariances (K, m, m); got "
            f"{innovation.shape} and {innovation_cov.shape}"
        )
    out = np.full(innovation.shape[0], np.nan)
    ok = ~np.any(np.isnan(innovation), axis=1)
    if np.any(ok):
        y, S = innovation[ok], innovation_cov[ok]
        steps = np.flatnonzero(ok)
        # symmetric up to round-off relative to the matrix's scale (products like H P H^T + R drift by ulps)
        scale = np.max(np.abs(S), axis=(1, 2))
        with np.errstate(invalid="ignore"):
            asymmetric = np.max(np.abs(S - np.swapaxes(S, 1, 2)), axis=(1, 2)) > 1e-9 * scale
        with np.errstate(invalid="ignore"):
            smallest = np.array([np.linalg.eigvalsh(s)[0] if np.all(np.isfinite(s)) else np.nan for s in S])
        bad = asymmetric | ~(smallest > 0)
        if np.any(bad):
            k = int(steps[np.argmax(bad)])
            why = "not symmetric" if asymmetric[np.argmax(bad)] else "not positive definite (or not finite)"
            raise CovarianceError(f"nis: the innovation covariance S_k at step {k} is {why}")
        out[ok] = np.einsum("ki,ki->k", y, np.linalg.solve(S, y[..., None])[..., 0])
    return out


def predictive_moments(
    predicted_measurements: np.ndarray,
    weights: np.ndarray,
    noise_cov: np.ndarray,
    angle_indices: Sequence[int] = (),
) -> tuple[np.ndarray, np.ndarray]:
    """Mean and covariance of a particle filter's predictive distribution of ``z_k``.

    With predicted particles ``x_k^i`` (propagated, not yet weighted by ``z_k``), their
    weights ``W_{k-1}^i`` and additive measurement noise ``N(0, R)``, the predictive
    density ``p^(z_k | z_{0:k-1}) = sum_i W_{k-1}^i N(z_k; h(x_k^i), R)`` is a Gaussian
    mixture whose moments are

    .. math::

       \\bar z = \\sum_i W^i h(x^i), \\qquad
       S = \\sum_i W^i (h(x^i) - \\bar z)(h(x^i) - \\bar z)^T + R .

    ``predicted_measurements`` is ``h(x_k^i)`` of shape ``(N, m)``; components in
    ``angle_indices`` get a circular mean and wrapped deviations.  ``S`` is the
    innovation covariance used in :func:`nis` for the particle filter.
    """
    h = np.asarray(predicted_measurements, dtype=float)
    if h.ndim == 1:
        h = h[:, None]
    weights = np.asarray(weights, dtype=float)
    noise_cov = np.atleast_2d(np.asarray(noise_cov, dtype=float))
    if weights.shape != h.shape[:1] or noise_cov.shape != (h.shape[1], h.shape[1]):
        raise ShapeError(
            f"predictive_moments needs h(x) (N, m), weights (N,) and R (m, m); got "
            f"{h.shape}, {weights.shape} and {noise_cov.shape}"
        )
    mean = weighted_mean(h, weights, angle_indices)
    cov = weighted_covariance(h, weights, mean, angle_indices) + noise_cov
    return mean, cov


def fraction_in_band(values: np.ndarray, band: tuple[float, float]) -> float:
    """Fraction of the finite-or-infinite, non-NaN ``values`` with ``lo <= v <= hi``.

    An infinite value (a lost filter) counts as outside the band; NaN entries (steps
    without a measurement) are left out.
    """
    values = np.asarray(values, dtype=float).ravel()
    values = values[~np.isnan(values)]
    if values.size == 0:
        return float("nan")
    lo, hi = band
    return float(np.mean((values >= lo) & (values <= hi)))
