"""The likelihood of a noise scale, estimated by the particle filter and computed by Kalman.

A parameter ``theta`` of the model (here a scale of a noise covariance, ``R = theta R_0``
or ``Q = theta Q_0``) is learned from the data through the marginal likelihood

.. math::

   p(z_{0:K-1} \\mid \\theta) = \\prod_k p(z_k \\mid z_{0:k-1}, \\theta),

which the particle filter estimates without bias (Del Moral 2004) by
``Z^ = prod_k sum_i W_{k-1}^i w_k^i`` (:attr:`~pfcourse.results.FilterResult.log_likelihood`
is ``log Z^``), and which the Kalman filter computes exactly on a linear-Gaussian model.

**Common random numbers.** :func:`pf_log_likelihood` runs the filter with the same seed
for every ``theta`` and resamples at every step with a measurement (``threshold = 1``):
the random stream is then consumed identically for every ``theta`` (same initial draws,
same transition noise, same resampling uniforms), so ``theta -> log Z^(theta)`` changes
only through the weights: it is continuous except where a resampled index jumps (which,
over a wide range of ``theta``, happens often: the curve is smooth only piecewise).
:func:`max_likelihood_scale` maximises it with scipy's bounded Brent search on ``log theta``.
Particle marginal Metropolis-Hastings, which samples ``theta`` from its posterior with this
estimate, is the core's :mod:`pfcourse.pmmh`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import integrate
from scipy.optimize import minimize_scalar

from typing import Any, Protocol

from pfcourse import ParameterError, ParticleFilter, kalman_filter

NOISES = ("Rv", "Qw")


class NoiseScaledScenario(Protocol):
    """What these methods need of a scenario (scenario A's ``LandmarkScenario`` is one): its noise
    covariances ``Rv`` and ``Qw``, and ``model(**noises)``, its linear-Gaussian model with them replaced."""

    Rv: np.ndarray
    Qw: np.ndarray

    def model(self, **noises: Any) -> Any: ...


def scaled_model(scenario: NoiseScaledScenario, theta, noise: str | tuple[str, ...] = "Rv"):
    """The filter's model with ``noise`` (``"Rv"`` or ``"Qw"``) multiplied by ``theta > 0``.

    Several scales at once: ``noise=("Qw", "Rv")`` with ``theta = (theta_q, theta_r)``.
    """
    names = (noise,) if isinstance(noise, str) else tuple(noise)
    thetas = np.atleast_1d(np.asarray(theta, dtype=float))
    if not names or any(n not in NOISES for n in names) or len(set(names)) != len(names):
        raise ParameterError(f"noise must be one of {NOISES} or a tuple of distinct ones, got {noise!r}")
    if thetas.shape != (len(names),):
        raise ParameterError(f"need one scale per noise {names}, got theta = {theta!r}")
    if not np.all(np.isfinite(thetas)) or np.any(thetas <= 0):
        raise ParameterError(f"the noise scale theta must be finite and > 0, got {theta}")
    return scenario.model(**{n: float(t) * getattr(scenario, n) for n, t in zip(names, thetas)})


def kalman_log_likelihood(scenario: NoiseScaledScenario, Z: np.ndarray, theta, noise: str | tuple[str, ...] = "Rv") -> float:
    """Exact ``log p(z_{0:K-1} | theta) = sum_k log N(y_k; 0, S_k(theta))`` (Kalman innovations)."""
    return kalman_filter(scaled_model(scenario, theta, noise), Z).log_likelihood


def pf_log_likelihood(
    scenario: NoiseScaledScenario,
    Z: np.ndarray,
    theta,
    n_particles: int,
    seed: int | np.random.Generator,
    noise: str | tuple[str, ...] = "Rv",
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


def grid_posterior_2d(log_likelihood: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> dict:
    """Posterior of two scales on a grid of ``(u1, u2) = (log theta_1, log theta_2)``, flat prior in ``u``.

    ``p(u | z) = exp(l(u) - max l) / iint exp(l - max l) du1 du2`` (trapezoid rule); returns the
    normalised density ``(len(u1), len(u2))`` and, for each ``theta_j``, its posterior mean and sd.
    """
    u1, u2 = np.asarray(u1, dtype=float), np.asarray(u2, dtype=float)
    ll = np.asarray(log_likelihood, dtype=float)
    if ll.shape != (u1.size, u2.size) or np.any(np.diff(u1) <= 0) or np.any(np.diff(u2) <= 0):
        raise ParameterError("u1, u2 must be increasing grids and log_likelihood of shape (len(u1), len(u2))")
    density = np.exp(ll - ll.max())
    density /= integrate.trapezoid(integrate.trapezoid(density, u2, axis=1), u1)
    out = {"density": density}
    for name, u, marginal in (("theta1", u1, integrate.trapezoid(density, u2, axis=1)),
                              ("theta2", u2, integrate.trapezoid(density, u1, axis=0))):
        t = np.exp(u)
        mean = integrate.trapezoid(t * marginal, u)
        out[f"{name}_mean"] = float(mean)
        out[f"{name}_sd"] = float(np.sqrt(integrate.trapezoid((t - mean) ** 2 * marginal, u)))
    return out


def terrain_log_likelihood(scenario, terrain, Z: np.ndarray, rf_scale: float, n_particles: int,
                           seed: int | np.random.Generator, kernel_scale: float = 0.2) -> float:
    """Particle estimate of ``log p(z | R_f = rf_scale R_f0)`` for a flight of the terrain scenario.

    The regularised filter of the terrain chapters (Gaussian kernel at ``kernel_scale`` times the
    optimal bandwidth), resampling at every reading (``threshold = 1``) so that one ``seed``
    gives common random numbers across the scales. A filter that loses every particle has
    likelihood zero: ``-inf``.
    """
    from pfcourse.errors import DegenerateWeightsError
    from pfcourse.jitter import RegularisedJitter

    rf_scale = float(rf_scale)
    if not np.isfinite(rf_scale) or rf_scale <= 0:
        raise ParameterError(f"rf_scale must be finite and > 0, got {rf_scale}")
    model = scenario.with_(Rf=rf_scale * scenario.Rf).model(terrain)
    pf = ParticleFilter(model, n_particles, threshold=1.0, resampler="multinomial",
                        jitter=RegularisedJitter(kernel_scale, (3,)))
    try:
        return pf.run(Z, seed).log_likelihood
    except DegenerateWeightsError:
        return -np.inf
