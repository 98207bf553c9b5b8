"""A static parameter learned online: Liu-West, the sufficient-statistic filter, SMC^2.

The problem: a linear-Gaussian model (:class:`~pfcourse.linear_gaussian.LinearGaussianModel`)
whose measurement noise is ``theta R_0`` with ``R_0`` diagonal and ``theta`` unknown, with an
inverse-gamma prior ``theta ~ IG(a_0, b_0)``:

.. math::

   x_k = F x_{k-1} + B + w_k, \\qquad z_k = H x_k + v_k,\\ v_k \\sim \\mathcal N(0, \\theta R_0).

Given the state path, ``theta`` has a conjugate posterior: with ``n_k`` the number of measured
coordinates up to step ``k`` and ``S_k = sum (z_j - H_j x)^2 / r_j`` their scaled squared
residuals, ``theta | x_{0:k}, z_{1:k} ~ IG(a_0 + n_k / 2, b_0 + S_k / 2)``. The exact posterior
``p(theta | z_{1:k})`` comes from the Kalman likelihood on a grid of ``u = log theta``
(:meth:`NoiseScaleProblem.exact_posterior`).

Three online samplers of ``p(theta | z_{1:k})``, each returning a :class:`ThetaPosterior`:

- :func:`liu_west`: particles ``(x, theta)`` and a kernel on ``log theta`` shrunk towards the
  particles' mean (Liu and West 2001), without the auxiliary look-ahead of the original:
  an approximation (the kernel changes the target);
- :func:`sufficient_statistic_filter`: each particle carries ``(x, S, n)`` and is weighted by the
  predictive ``p(z_k | x_k, S_{k-1})`` with ``theta`` integrated out (Storvik 2002, Fearnhead
  2002); exact as ``N -> infinity`` but its statistics are functions of the whole path, so path
  degeneracy eats them when ``K`` grows;
- :func:`smc2`: ``N_theta`` values of ``theta``, each with its own bootstrap filter of ``N_x``
  particles, reweighted by the filters' likelihood increments, resampled and moved by one PMMH
  step when their ESS falls below ``ess_threshold N_theta`` (Chopin, Jacob and Papaspiliopoulos
  2013): exact as ``N_theta -> infinity`` for every ``N_x``.

Every filter here resamples (systematically) at every measured step. Every random number comes
from the generator given. ``ThetaPosterior.evaluations`` counts the evaluations of a measurement
density ``p(z_k | x_k^i, ...)`` (one per particle and measured step), the cost compared.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.special import gammaln, logsumexp

from pfcourse.checks import covariance_factor
from pfcourse.errors import ParameterError, ShapeError
from pfcourse.kalman import kalman_filter
from pfcourse.linear_gaussian import LinearGaussianModel

LOG_2PI = float(np.log(2 * np.pi))


@dataclass(frozen=True)
class InverseGamma:
    """``theta ~ IG(shape, scale)``: density ``b^a / Gamma(a) theta^(-a-1) exp(-b / theta)``."""

    shape: float
    scale: float

    def __post_init__(self) -> None:
        for name in ("shape", "scale"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ParameterError(f"the inverse-gamma {name} must be finite and > 0, got {v!r}")

    def logpdf(self, theta) -> np.ndarray:
        a, b, t = self.shape, self.scale, np.asarray(theta, dtype=float)
        return a * np.log(b) - gammaln(a) - (a + 1) * np.log(t) - b / t

    def sample(self, size, rng: np.random.Generator) -> np.ndarray:
        """``b / Gamma(a, 1)`` draws."""
        return self.scale / rng.gamma(self.shape, 1.0, size)


@dataclass
class ThetaPosterior:
    """What a sampler says of ``theta`` at the last step, and what it cost.

    ``mean`` and ``sd`` are the sampler's posterior mean and sd of ``theta``; ``means``
    the posterior mean after every step (``nan`` before the first measurement);
    ``evaluations`` the measurement densities evaluated; ``extra`` what is particular to
    the sampler (ancestors, moves, acceptance).
    """

    name: str
    mean: float
    sd: float
    means: np.ndarray
    evaluations: int
    theta: np.ndarray  # particle values of theta (Storvik: posterior draws, one per particle)
    log_weights: np.ndarray  # normalised log-weights of theta
    extra: dict = field(default_factory=dict)


@dataclass(frozen=True)
class GridPosterior:
    """The exact ``p(theta | z)`` on a grid of ``u = log theta``: density in ``u``, moments of ``theta``."""

    u: np.ndarray
    density: np.ndarray
    mean: float
    sd: float
    log_evidence: float

    def theta_density(self) -> tuple[np.ndarray, np.ndarray]:
        """``(theta, p(theta | z))`` on the grid (density per unit of theta)."""
        theta = np.exp(self.u)
        return theta, self.density / theta


class NoiseScaleProblem:
    """A linear-Gaussian model whose measurement noise ``theta R_0`` has an unknown scale ``theta``.

    ``model`` is the model at ``theta = 1`` (its ``R`` is ``R_0``, which must be diagonal);
    ``prior`` the inverse-gamma prior of ``theta``. Checked when built.
    """

    def __init__(self, model: LinearGaussianModel, prior: InverseGamma) -> None:
        if not isinstance(model, LinearGaussianModel):
            raise ParameterError(f"model must be a LinearGaussianModel, got {type(model).__name__}")
        if not isinstance(prior, InverseGamma):
            raise ParameterError(f"prior must be an InverseGamma, got {type(prior).__name__}")
        R = model.R
        if np.any(R != np.diag(np.diag(R))):
            raise ParameterError("R_0 must be diagonal: the scale's conjugate update sums scaled squared residuals")
        self.model, self.prior = model, prior
        self.r0 = np.diag(R).copy()
        self.dim_x, self.dim_z = model.dim_x, model.dim_z
        self._P0_factor = covariance_factor(model.P0)
        self._Q_factor = covariance_factor(model.Q)

    # einsum on the last axis (no BLAS call: small products stay fast on a busy machine)
    def sample_initial(self, shape, rng: np.random.Generator) -> np.ndarray:
        """``x_0 ~ N(m_0, P_0)``, an array of ``shape + (dim_x,)``."""
        e = rng.standard_normal((*np.atleast_1d(shape), self.dim_x))
        return self.model.m0 + np.einsum("...j,ij->...i", e, self._P0_factor)

    def sample_transition(self, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """``x_k = F x_{k-1} + B + w_k``, ``w_k ~ N(0, Q)``, for every row of ``x`` (any leading shape)."""
        e = rng.standard_normal(x.shape)
        return (np.einsum("...j,ij->...i", x, self.model.F) + self.model.B
                + np.einsum("...j,ij->...i", e, self._Q_factor))

    def check_measurements(self, Z) -> np.ndarray:
        Z = np.asarray(Z, dtype=float)
        if Z.ndim != 2 or Z.shape[1] != self.dim_z or Z.shape[0] == 0:
            raise ShapeError(f"Z must have shape (K, {self.dim_z}) with K >= 1, got {Z.shape}")
        if np.any(np.isinf(Z)):
            raise ShapeError("Z holds an infinite value (NaN marks a coordinate not measured)")
        return Z

    def residuals(self, x: np.ndarray, z: np.ndarray) -> tuple[int, np.ndarray]:
        """``(n, S)``: the number of measured coordinates of ``z`` and, per particle (any leading
        shape of ``x``), the scaled squared residual ``S = sum_j (z_j - H_j x)^2 / r_j``."""
        mask = ~np.isnan(z)
        resid = z[mask] - np.einsum("...j,ij->...i", x, self.model.H[mask])
        return int(mask.sum()), np.sum(resid**2 / self.r0[mask], axis=-1)

    def log_norm(self, z: np.ndarray) -> float:
        """``-1/2 sum_j log(2 pi r_j)`` over the measured coordinates of ``z``."""
        mask = ~np.isnan(z)
        return -0.5 * float(np.sum(LOG_2PI + np.log(self.r0[mask])))

    def log_likelihood(self, x: np.ndarray, z: np.ndarray, theta) -> np.ndarray:
        """``log N(z_o; H_o x, theta R_0,oo)`` per particle, ``theta`` broadcast against ``x``'s rows."""
        n, S = self.residuals(x, z)
        return self.log_norm(z) - 0.5 * (n * np.log(theta) + S / theta)

    def kalman_log_likelihood(self, Z, theta: float) -> float:
        """Exact ``log p(z_{1:K} | theta)`` (Kalman innovations)."""
        m = self.model
        scaled = LinearGaussianModel(F=m.F, H=m.H, m0=m.m0, P0=m.P0, Q=m.Q, R=theta * m.R, B=m.B)
        return kalman_filter(scaled, self.check_measurements(Z)).log_likelihood

    def exact_posterior(self, Z, u_grid) -> GridPosterior:
        """``p(theta | z_{1:K})`` on the grid ``u = log theta`` (trapezoid rule), prior included."""
        u = np.asarray(u_grid, dtype=float)
        if u.ndim != 1 or u.size < 3 or np.any(np.diff(u) <= 0):
            raise ParameterError("u_grid must be an increasing 1-D grid of at least 3 points")
        theta = np.exp(u)
        log_lik = np.array([self.kalman_log_likelihood(Z, t) for t in theta])
        # density in u: p(z | theta) p(theta) |d theta / d u|
        log_post = log_lik + self.prior.logpdf(theta) + u
        top = log_post.max()
        area = np.trapezoid(np.exp(log_post - top), u)
        density = np.exp(log_post - top) / area
        mean = np.trapezoid(theta * density, u)
        sd = np.sqrt(np.trapezoid((theta - mean) ** 2 * density, u))
        return GridPosterior(u=u, density=density, mean=float(mean), sd=float(sd),
                             log_evidence=float(top + np.log(area)))


def systematic_rows(log_w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Systematic resampling of every row of ``log_w`` (unnormalised log-weights), one uniform a row.

    Returns indices ``(rows, n)`` into each row."""
    log_w = np.atleast_2d(log_w)
    rows, n = log_w.shape
    W = np.exp(log_w - logsumexp(log_w, axis=1, keepdims=True))
    cdf = np.cumsum(W, axis=1)
    cdf[:, -1] = 1.0
    u = (np.arange(n) + rng.random((rows, 1))) / n
    idx = np.empty((rows, n), dtype=np.int64)
    for r in range(rows):  # one searchsorted per row: exact, no offsets added to the cdf
        idx[r] = np.searchsorted(cdf[r], u[r], side="right")
    return np.minimum(idx, n - 1)


def _weighted_moments(values: np.ndarray, log_w: np.ndarray) -> tuple[float, float]:
    W = np.exp(log_w - logsumexp(log_w))
    mean = float(W @ values)
    return mean, float(np.sqrt(max(W @ (values - mean) ** 2, 0.0)))


def _check_sizes(**sizes) -> None:
    for name, v in sizes.items():
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 2:
            raise ParameterError(f"{name} must be an integer >= 2, got {v!r}")


def liu_west(problem: NoiseScaleProblem, Z, n: int, rng: np.random.Generator, delta: float = 0.98) -> ThetaPosterior:
    """Liu and West's kernel shrinkage on ``u = log theta``, with a bootstrap filter for ``x``.

    At each measured step: move ``x``, weight by ``p(z_k | x_k, theta_i)``, resample ``(x, u)``
    together, then move ``u_i <- a u_i + (1 - a) mean(u) + h sd(u) eps`` with
    ``a = (3 delta - 1) / (2 delta)``, ``h^2 = 1 - a^2``: the mean and variance of ``u`` are kept,
    the copies separated."""
    _check_sizes(n=n)
    if not 0 < delta <= 1:
        raise ParameterError(f"delta (the discount factor) must be in (0, 1], got {delta!r}")
    Z = problem.check_measurements(Z)
    a = (3 * delta - 1) / (2 * delta)
    h = np.sqrt(max(1 - a**2, 0.0))
    x = problem.sample_initial(n, rng)
    u = np.log(problem.prior.sample(n, rng))
    log_w = np.full(n, -np.log(n))
    means, evaluations = np.full(len(Z), np.nan), 0
    for k, z in enumerate(Z):
        if k > 0:
            x = problem.sample_transition(x, rng)
        if np.isnan(z).all():
            continue
        log_w = problem.log_likelihood(x, z, np.exp(u))
        evaluations += n
        log_w = log_w - logsumexp(log_w)
        means[k] = _weighted_moments(np.exp(u), log_w)[0]
        if k == len(Z) - 1:
            break  # the last step's weighted sample is the answer
        idx = systematic_rows(log_w, rng)[0]
        x, u = x[idx], u[idx]
        log_w = np.full(n, -np.log(n))
        centre, spread = u.mean(), u.std()
        u = a * u + (1 - a) * centre + h * spread * rng.standard_normal(n)
    mean, sd = _weighted_moments(np.exp(u), log_w)
    return ThetaPosterior("Liu-West", mean, sd, means, evaluations, np.exp(u), log_w - logsumexp(log_w))


def sufficient_statistic_filter(problem: NoiseScaleProblem, Z, n: int, rng: np.random.Generator) -> ThetaPosterior:
    """Each particle carries ``x`` and ``b = b_0 + S / 2``; ``theta`` is integrated out.

    Weight: the predictive ``log p(z_k | x_k, b) = log Gamma(a + m/2) - log Gamma(a) + a log b
    - (a + m/2) log(b + S_k / 2) + log_norm`` (``m`` coordinates measured, ``S_k`` their scaled
    squared residual); then ``a <- a + m/2`` (the same for every particle), ``b <- b + S_k / 2``,
    and resample. The posterior of ``theta`` is the mixture ``sum_i W_i IG(a, b_i)``.
    ``extra["ancestors_of_first_step"]``: how many distinct particles of the first measured step
    the last cloud descends from (path degeneracy)."""
    _check_sizes(n=n)
    Z = problem.check_measurements(Z)
    prior = problem.prior
    x = problem.sample_initial(n, rng)
    a, b = prior.shape, np.full(n, prior.scale)
    origin = np.arange(n)  # which particle of the first measured step each one descends from
    log_w = np.full(n, -np.log(n))
    means, evaluations, first = np.full(len(Z), np.nan), 0, None
    for k, z in enumerate(Z):
        if k > 0:
            x = problem.sample_transition(x, rng)
        if np.isnan(z).all():
            continue
        m, S = problem.residuals(x, z)
        log_w = (gammaln(a + m / 2) - gammaln(a) + a * np.log(b) - (a + m / 2) * np.log(b + S / 2)
                 + problem.log_norm(z))
        evaluations += n
        a, b = a + m / 2, b + S / 2
        log_w = log_w - logsumexp(log_w)
        W = np.exp(log_w)
        means[k] = float(W @ b) / (a - 1) if a > 1 else np.nan
        if first is None:
            first = k
            origin = np.arange(n)
        if k == len(Z) - 1:
            break
        idx = systematic_rows(log_w, rng)[0]
        x, b, origin = x[idx], b[idx], origin[idx]
        log_w = np.full(n, -np.log(n))
    W = np.exp(log_w - logsumexp(log_w))
    if a <= 2:
        raise ParameterError(f"too few measured coordinates for a posterior sd (shape {a} <= 2)")
    mean = float(W @ b) / (a - 1)
    second = float(W @ b**2) / ((a - 1) * (a - 2))
    draws = b / rng.gamma(a, 1.0, n)  # one draw of theta per particle, for pictures
    return ThetaPosterior("sufficient statistics", mean, float(np.sqrt(max(second - mean**2, 0.0))), means,
                          evaluations, draws, log_w - logsumexp(log_w),
                          extra={"shape": a, "scale": b, "ancestors_of_first_step": int(np.unique(origin).size)})


def _inner_filters(problem, Z, theta, n_x, rng, upto):
    """Bootstrap filters for every ``theta_j`` on ``Z[:upto]``: clouds ``(n_theta, n_x, d)`` and log p^."""
    x = problem.sample_initial((theta.size, n_x), rng)
    log_p = np.zeros(theta.size)
    for k in range(upto):
        x, increment = _inner_step(problem, x, Z[k], k, theta, rng)
        log_p += increment
    return x, log_p


def _inner_step(problem, x, z, k, theta, rng):
    """One step of every inner filter: move, weight, log-likelihood increment, resample."""
    if k > 0:
        x = problem.sample_transition(x, rng)
    if np.isnan(z).all():
        return x, np.zeros(x.shape[0])
    log_g = problem.log_likelihood(x, z, theta[:, None])
    increment = logsumexp(log_g, axis=1) - np.log(x.shape[1])
    idx = systematic_rows(log_g, rng)
    return np.take_along_axis(x, idx[:, :, None], axis=1), increment


def smc2(problem: NoiseScaleProblem, Z, n_theta: int, n_x: int, rng: np.random.Generator,
         ess_threshold: float = 0.5, scale: float = 1.0) -> ThetaPosterior:
    """SMC^2 on ``u = log theta``: ``n_theta`` values, each with a bootstrap filter of ``n_x`` particles.

    At each step every inner filter moves, weights and resamples, and ``log W_j`` gains its
    log-likelihood increment. When the ESS of ``W`` falls below ``ess_threshold n_theta`` (and
    the data are not over), the ``theta_j`` are resampled and each is moved by one PMMH step:
    ``u' = u + scale sd(u) eps``, a fresh filter on ``z_{1:k}`` at ``theta'``, accepted with
    probability ``min(1, p^(z | theta') p(theta') theta' / (p^(z | theta) p(theta) theta))``
    (the prior in ``u`` includes the Jacobian ``theta``). ``extra``: the steps where it moved and
    their acceptance rates."""
    _check_sizes(n_theta=n_theta, n_x=n_x)
    if not 0 < ess_threshold <= 1 or not scale > 0:
        raise ParameterError(f"need 0 < ess_threshold <= 1 and scale > 0, got {ess_threshold!r}, {scale!r}")
    Z = problem.check_measurements(Z)
    prior = problem.prior
    theta = prior.sample(n_theta, rng)
    x = problem.sample_initial((n_theta, n_x), rng)
    log_p = np.zeros(n_theta)  # log p^(z_{1:k} | theta_j) of each inner filter
    log_W = np.full(n_theta, -np.log(n_theta))
    means, evaluations, moves, acceptance = np.full(len(Z), np.nan), 0, [], []
    log_evidence = 0.0
    for k, z in enumerate(Z):
        if k == 0 and np.isnan(z).all():
            continue  # x_0 drawn above; nothing measured
        x, increment = _inner_step(problem, x, z, k, theta, rng)
        if not np.isnan(z).all():
            evaluations += n_theta * n_x
        log_p += increment
        log_evidence += logsumexp(log_W + increment)  # log p^(z_k | z_{1:k-1})
        log_W = log_W + increment
        log_W -= logsumexp(log_W)
        means[k] = _weighted_moments(theta, log_W)[0]
        if 1 / np.sum(np.exp(2 * log_W)) >= ess_threshold * n_theta or k == len(Z) - 1:
            continue
        # resample the theta-particles with their filters, then one PMMH move each
        idx = systematic_rows(log_W, rng)[0]
        theta, x, log_p = theta[idx], x[idx], log_p[idx]
        log_W = np.full(n_theta, -np.log(n_theta))
        u = np.log(theta)
        u_new = u + scale * u.std() * rng.standard_normal(n_theta)
        theta_new = np.exp(u_new)
        x_new, log_p_new = _inner_filters(problem, Z, theta_new, n_x, rng, k + 1)
        evaluations += n_theta * n_x * int((~np.isnan(Z[:k + 1])).any(axis=1).sum())
        log_ratio = (log_p_new + prior.logpdf(theta_new) + u_new) - (log_p + prior.logpdf(theta) + u)
        accept = np.log(rng.random(n_theta)) < log_ratio
        theta = np.where(accept, theta_new, theta)
        log_p = np.where(accept, log_p_new, log_p)
        x = np.where(accept[:, None, None], x_new, x)
        moves.append(k)
        acceptance.append(float(accept.mean()))
    mean, sd = _weighted_moments(theta, log_W)
    return ThetaPosterior("SMC²", mean, sd, means, evaluations, theta, log_W - logsumexp(log_W),
                          extra={"moves": moves, "acceptance": acceptance,
                                 "log_evidence": float(log_evidence)})
