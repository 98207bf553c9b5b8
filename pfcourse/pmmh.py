"""Particle marginal Metropolis-Hastings: the posterior of a parameter from a particle filter's likelihood.

**Particle marginal Metropolis-Hastings** (Andrieu, Doucet and Holenstein 2010),
:func:`pmmh`, a random walk on ``u = log theta`` whose acceptance ratio uses the
estimated likelihood in place of the exact one,

.. math::

   \\alpha = \\min\\Big(1, \\frac{\\hat Z(\\theta')\\, p(u')}{\\hat Z(\\theta)\\, p(u)}\\Big),

with a fresh, independent particle filter for every proposal and the current estimate
``Z^(theta)`` kept (never re-estimated).  Because ``Z^`` is unbiased the chain targets the
exact posterior ``p(theta | z)`` for any number of particles; ``N`` only changes how
well it mixes.

:func:`correlated_pmmh` is the correlated pseudo-marginal version (Deligiannidis, Doucet and
Pitt 2018): the filter's random numbers ``U`` (standard normals, :mod:`pfcourse.correlated`) are
part of the chain's state and move with ``theta`` by a Crank-Nicolson step
``U' = rho U + sqrt(1 - rho^2) e``, which keeps ``N(0, I)`` invariant, so the acceptance ratio is
the same as above; ``rho = 0`` gives back plain PMMH (fresh numbers at every proposal).

:func:`integrated_autocorrelation_time` measures how well a chain mixes: ``n / tau`` is its
effective sample size (several chains: :func:`pfcourse.diagnostics.chain_ess`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import signal, stats

from pfcourse.checks import check_count
from pfcourse.errors import ParameterError


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
    theta0,
    n_iterations: int,
    step: float,
    rng: np.random.Generator | int,
) -> PMMHChain:
    """Particle marginal Metropolis-Hastings on ``u = log theta`` (module docstring).

    ``log_likelihood_estimate(theta, rng)`` returns ``log Z^(theta)`` from a fresh filter
    drawing from ``rng``; ``prior`` is a frozen scipy distribution of ``u = log theta``
    (e.g. ``stats.uniform(log a, log b - log a)``: log-uniform in ``theta``); the proposal
    is ``u' = u + step * e``, ``e ~ N(0, 1)`` (symmetric, so it cancels in the ratio).

    A vector ``theta0`` (several scales) runs the random walk on the vector ``u``, ``e ~ N(0, I)``,
    with ``step`` a scalar or one step per component and the prior applied to each component
    independently (log prior = sum of ``prior.logpdf(u_j)``); ``chain.theta`` is then
    ``(n_iterations, d)``. A scalar ``theta0`` keeps scalars (and the same random stream).
    """
    n_iterations = check_count(n_iterations, "n_iterations")
    vector = np.ndim(theta0) > 0
    steps = np.asarray(step, dtype=float)
    if not np.all(steps > 0) or (not vector and steps.ndim > 0):
        raise ParameterError(f"step must be > 0 (one per component for a vector theta), got {step}")
    rng = np.random.default_rng(rng)
    if vector:
        u = np.log(np.asarray(theta0, dtype=float))
        if steps.ndim and steps.shape != u.shape:
            raise ParameterError(f"step has shape {steps.shape}, theta0 has {u.shape}")
    else:
        u = float(np.log(theta0))

    def log_prior_of(v) -> float:
        return float(np.sum(prior.logpdf(v)))

    def theta_of(v):
        return np.exp(v) if vector else float(np.exp(v))

    log_prior = log_prior_of(u)
    if not np.isfinite(log_prior):
        raise ParameterError(f"theta0 = {theta0} has zero prior density")
    log_lik = float(log_likelihood_estimate(theta_of(u), rng))
    thetas = np.empty((n_iterations,) + np.shape(u))
    lls = np.empty(n_iterations)
    accepted = np.zeros(n_iterations, dtype=bool)
    for i in range(n_iterations):
        u_new = u + steps * (rng.standard_normal(u.shape) if vector else rng.standard_normal())
        if not vector:
            u_new = float(u_new)
        log_prior_new = log_prior_of(u_new)
        if np.isfinite(log_prior_new):
            log_lik_new = float(log_likelihood_estimate(theta_of(u_new), rng))
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


def correlated_pmmh(
    log_likelihood_estimate: Callable[[float, np.ndarray], float],
    prior: stats.rv_continuous,
    theta0: float,
    n_normals: int,
    n_iterations: int,
    step: float,
    rho: float,
    rng: np.random.Generator | int,
) -> PMMHChain:
    """Correlated PMMH on ``u = log theta`` (module docstring): a scalar ``theta``.

    ``log_likelihood_estimate(theta, normals)`` returns ``log Z^(theta)`` computed from the
    ``n_normals`` standard normals it is given (e.g.
    :func:`pfcourse.correlated.correlated_log_likelihood`); the proposal is
    ``u' = u + step e`` and ``U' = rho U + sqrt(1 - rho^2) e'``; a ``u'`` outside the prior's
    support is rejected without a filter run (``U`` stays).
    """
    from pfcourse.correlated import crank_nicolson

    n_iterations = check_count(n_iterations, "n_iterations")
    n_normals = check_count(n_normals, "n_normals")
    if not step > 0:
        raise ParameterError(f"step must be > 0, got {step}")
    if not 0.0 <= rho <= 1.0:
        raise ParameterError(f"rho must be in [0, 1], got {rho}")
    rng = np.random.default_rng(rng)
    u = float(np.log(theta0))
    log_prior = float(prior.logpdf(u))
    if not np.isfinite(log_prior):
        raise ParameterError(f"theta0 = {theta0} has zero prior density")
    normals = rng.standard_normal(n_normals)
    log_lik = float(log_likelihood_estimate(float(np.exp(u)), normals))
    thetas, lls = np.empty(n_iterations), np.empty(n_iterations)
    accepted = np.zeros(n_iterations, dtype=bool)
    for i in range(n_iterations):
        u_new = float(u + step * rng.standard_normal())
        log_prior_new = float(prior.logpdf(u_new))
        if np.isfinite(log_prior_new):
            normals_new = crank_nicolson(normals, rho, rng)
            log_lik_new = float(log_likelihood_estimate(float(np.exp(u_new)), normals_new))
            if np.log(rng.uniform()) < log_lik_new + log_prior_new - log_lik - log_prior:
                u, log_prior, log_lik, normals, accepted[i] = u_new, log_prior_new, log_lik_new, normals_new, True
        thetas[i], lls[i] = np.exp(u), log_lik
    return PMMHChain(theta=thetas, log_likelihood=lls, accepted=accepted)
