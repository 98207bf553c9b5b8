"""The likelihood of a noise scale, estimated by the particle filter and computed by Kalman.

A parameter ``theta`` of the model (here a scale of a noise covariance, ``R = theta R_0``
or ``Q = theta Q_0``) is learned from the data through the marginal likelihood

.. math::

   p(z_{0:K-1} \\mid \\theta) = \\prod_k p(z_k \\mid z_{0:k-1}, \\theta),

which the particle filter estimates without bias (Del Moral 2004) by
``Z^ = prod_k sum_i W_{k-1}^i w_k^i`` (:attr:`~pfcourse.filter.FilterResult.log_likelihood`
is ``log Z^``), and which the Kalman filter computes exactly on a linear-Gaussian model.

**Common random numbers.** :func:`pf_log_likelihood` runs the filter with the same seed
for every ``theta`` and resamples at every step with a measurement (``threshold = 1``):
the random stream is then consumed identically for every ``theta`` (same initial draws,
same transition noise, same resampling uniforms), so ``theta -> log Z^(theta)`` changes
only through the weights: it is continuous except where a resampled index jumps (which,
over a wide range of ``theta``, happens often: the curve is smooth only piecewise).
:func:`max_likelihood_scale` maximises it with scipy's bounded Brent search on ``log theta``.

**Particle marginal Metropolis-Hastings** (Andrieu, Doucet and Holenstein 2010),
:func:`pmmh`: a random walk on ``u = log theta`` whose acceptance ratio uses the
estimated likelihood in place of the exact one,

.. math::

   \\alpha = \\min\\Big(1, \\frac{\\hat Z(\\theta')\\, p(u')}{\\hat Z(\\theta)\\, p(u)}\\Big),

with a fresh, independent particle filter for every proposal and the current estimate
``Z^(theta)`` kept (never re-estimated).  Because ``Z^`` is unbiased the chain targets the
exact posterior ``p(theta | z)`` for any number of particles; ``N`` only changes how
well it mixes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import integrate, signal, stats
from scipy.optimize import minimize, minimize_scalar

from typing import TYPE_CHECKING

from pfcourse import ParameterError, ParticleFilter, kalman_filter
from pfcourse.checks import check_count

if TYPE_CHECKING:
    from pfcourse.landmarks import LandmarkScenario

NOISES = ("Rv", "Qw")


def scaled_model(scenario: LandmarkScenario, theta: float, noise: str = "Rv"):
    """The filter's model with ``noise`` (``"Rv"`` or ``"Qw"``) multiplied by ``theta > 0``."""
    if noise not in NOISES:
        raise ParameterError(f"noise must be one of {NOISES}, got {noise!r}")
    theta = float(theta)
    if not np.isfinite(theta) or theta <= 0:
        raise ParameterError(f"the noise scale theta must be finite and > 0, got {theta}")
    return scenario.model(**{noise: theta * getattr(scenario, noise)})


def kalman_log_likelihood(scenario: LandmarkScenario, Z: np.ndarray, theta: float, noise: str = "Rv") -> float:
    """Exact ``log p(z_{0:K-1} | theta) = sum_k log N(y_k; 0, S_k(theta))`` (Kalman innovations)."""
    return kalman_filter(scaled_model(scenario, theta, noise), Z).log_likelihood


def pf_log_likelihood(
    scenario: LandmarkScenario,
    Z: np.ndarray,
    theta: float,
    n_particles: int,
    seed: int | np.random.Generator,
    noise: str = "Rv",
) -> float:
    """Particle estimate ``log Z^(theta)`` from a bootstrap filter resampling at every step.

    The same ``seed`` for two values of ``theta`` gives common random numbers (see the
    module docstring); ``threshold = 1`` keeps the random streams aligned.
    """
    model = scaled_model(scenario, theta, noise)
    return ParticleFilter(model, n_particles, threshold=1.0).run(Z, seed).log_likelihood


def max_likelihood_scale(
    log_likelihood: Callable[[float], float], bounds: tuple[float, float] = (0.1, 10.0), xatol: float = 1e-3
) -> tuple[float, int]:
    """``argmax_theta log_likelihood(theta)`` over ``bounds``, searched on ``log theta``.

    scipy's bounded Brent method (``minimize_scalar(method="bounded")``); returns
    ``(theta_hat, number of likelihood evaluations)``.
    """
    lo, hi = bounds
    if not 0 < lo < hi:
        raise ParameterError(f"bounds must satisfy 0 < low < high, got {bounds}")
    result = minimize_scalar(
        lambda u: -log_likelihood(float(np.exp(u))), bounds=(np.log(lo), np.log(hi)),
        method="bounded", options={"xatol": xatol},
    )
    return float(np.exp(result.x)), int(result.nfev)


def grid_posterior(log_likelihood: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Normalised posterior density on a grid of ``u = log theta`` under a flat prior in ``u``.

    ``p(u | z) = exp(l(u) - max l) / int exp(l - max l) du`` (trapezoid rule).  Returns
    ``(density on the grid, posterior mean of theta, posterior sd of theta)``.
    """
    u = np.asarray(u, dtype=float)
    log_likelihood = np.asarray(log_likelihood, dtype=float)
    if u.shape != log_likelihood.shape or u.ndim != 1 or np.any(np.diff(u) <= 0):
        raise ParameterError("u must be an increasing 1-D grid with one log-likelihood per point")
    density = np.exp(log_likelihood - log_likelihood.max())
    density /= integrate.trapezoid(density, u)
    theta = np.exp(u)
    mean = integrate.trapezoid(theta * density, u)
    var = integrate.trapezoid((theta - mean) ** 2 * density, u)
    return density, float(mean), float(np.sqrt(var))


@dataclass
class PMMHChain:
    """Output of :func:`pmmh`: ``theta`` and ``log_likelihood`` per iteration, ``accepted`` flags."""

    theta: np.ndarray
    log_likelihood: np.ndarray
    accepted: np.ndarray

    @property
    def acceptance_rate(self) -> float:
        return float(np.mean(self.accepted))


def pmmh(
    log_likelihood_estimate: Callable[[float, np.random.Generator], float],
    prior: stats.rv_continuous,
    theta0: float,
    n_iterations: int,
    step: float,
    rng: np.random.Generator | int,
) -> PMMHChain:
    """Particle marginal Metropolis-Hastings on ``u = log theta`` (module docstring).

    ``log_likelihood_estimate(theta, rng)`` returns ``log Z^(theta)`` from a fresh filter
    drawing from ``rng``; ``prior`` is a frozen scipy distribution of ``u = log theta``
    (e.g. ``stats.uniform(log a, log b - log a)``: log-uniform in ``theta``); the proposal
    is ``u' = u + step * e``, ``e ~ N(0, 1)`` (symmetric, so it cancels in the ratio).
    """
    n_iterations = check_count(n_iterations, "n_iterations")
    if not step > 0:
        raise ParameterError(f"step must be > 0, got {step}")
    rng = np.random.default_rng(rng)
    u = float(np.log(theta0))
    log_prior = float(prior.logpdf(u))
    if not np.isfinite(log_prior):
        raise ParameterError(f"theta0 = {theta0} has zero prior density")
    log_lik = float(log_likelihood_estimate(float(np.exp(u)), rng))
    thetas = np.empty(n_iterations)
    lls = np.empty(n_iterations)
    accepted = np.zeros(n_iterations, dtype=bool)
    for i in range(n_iterations):
        u_new = u + step * rng.standard_normal()
        log_prior_new = float(prior.logpdf(u_new))
        if np.isfinite(log_prior_new):
            log_lik_new = float(log_likelihood_estimate(float(np.exp(u_new)), rng))
            if np.log(rng.uniform()) < log_lik_new + log_prior_new - log_lik - log_prior:
                u, log_prior, log_lik, accepted[i] = u_new, log_prior_new, log_lik_new, True
        thetas[i], lls[i] = np.exp(u), log_lik
    return PMMHChain(theta=thetas, log_likelihood=lls, accepted=accepted)


def integrated_autocorrelation_time(x: np.ndarray, c: float = 5.0) -> float:
    """``tau = 1 + 2 sum_{t=1}^{M} rho_t`` with Sokal's window (smallest ``M >= c tau(M)``).

    The autocorrelations ``rho_t`` come from scipy's FFT correlation; the effective sample
    size of the chain is ``n / tau``.
    """
    x = np.asarray(x, dtype=float) - np.mean(x)
    n = x.size
    if n < 2 or not np.any(x):
        raise ParameterError("need a non-constant chain of at least 2 values")
    acf = signal.correlate(x, x, mode="full", method="fft")[n - 1:]
    rho = acf / acf[0]
    taus = 2.0 * np.cumsum(rho) - 1.0
    window = np.arange(n) >= c * taus
    m = int(np.argmax(window)) if window.any() else n - 1
    return float(taus[m])


def max_likelihood_scales(
    log_likelihood: Callable[[np.ndarray], float], start: np.ndarray, bounds: tuple[float, float] = (0.1, 10.0),
    xatol: float = 1e-3,
) -> tuple[np.ndarray, int]:
    """``argmax`` of ``log_likelihood(theta)`` over several scales ``theta`` in ``bounds``, on ``log theta``.

    scipy's bounded Nelder-Mead (``minimize(method="Nelder-Mead", bounds=...)``), which needs
    no gradient (a particle estimate has none that is reliable).  Returns
    ``(theta_hat, number of likelihood evaluations)``.
    """
    lo, hi = bounds
    if not 0 < lo < hi:
        raise ParameterError(f"bounds must satisfy 0 < low < high, got {bounds}")
    start = np.asarray(start, dtype=float)
    if np.any(start <= lo) or np.any(start >= hi):
        raise ParameterError(f"the start {start} must lie inside the bounds {bounds}")
    result = minimize(lambda u: -log_likelihood(np.exp(u)), np.log(start), method="Nelder-Mead",
                      bounds=[(np.log(lo), np.log(hi))] * start.size, options={"xatol": xatol, "fatol": 1e-3})
    return np.exp(result.x), int(result.nfev)


def robot_log_likelihood(sim, q_scale: float, r_scale: float, n_particles: int,
                         seed: int | np.random.Generator) -> float:
    """Particle estimate of ``log p(z | Q_est = q_scale Q_true, R_est = r_scale R_true)`` for a robot run.

    Resamples at every measured step (``threshold = 1``), so one ``seed`` gives common random
    numbers across the scales (the odometry noise is ``q_std * e`` with the same ``e``).
    """
    from pfcourse.robot import RobotModel

    model = RobotModel.for_simulation(sim, q_scale=q_scale, r_scale=r_scale)
    return ParticleFilter(model, n_particles, threshold=1.0).run(sim.measurements, seed).log_likelihood
