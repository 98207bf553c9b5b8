"""Remedies for a particle filter started from a wide prior, through the engine's hooks.

**Regularised particle filter** (Musso, Oudjane and Le Gland 2001): after each resampling,
every particle is moved by a draw of a Gaussian kernel,

    x^i <- x^i + h S^{1/2} eps^i,   eps^i ~ N(0, I_d),
    h_opt = A N^{-1/(d+4)},   A = (4 / (d + 2))^{1/(d+4)},

with ``S`` the covariance of the resampled cloud (angles as deviations from the circular
mean, wrapped) and ``h_opt`` the bandwidth minimising the mean integrated squared error
when the density is Gaussian.  ``scale`` multiplies ``h_opt`` (``scale < 1`` is common).
It is the filter's ``jitter`` hook.

**Progressive correction** (Oudjane and Musso 2000), as an importance function
(:class:`~pfcourse.filter.Proposal`): at the first ``n_tempered`` readings the likelihood
is brought in by powers ``l(x)^{lambda_1}, ..., l(x)^{lambda_m}`` with
``lambda_1 + ... + lambda_m = 1``; each ``lambda_j`` is the largest that keeps the effective
sample size of the stage at ``ess_fraction N`` or more (bisection), and between stages the
cloud is resampled and regularised.  The final stage's weights ``l^{lambda_m}`` are returned,
so the target of the last stage is ``p(z | x) p(x | z_{0:k-1})``, the posterior.  Each stage
restarts from equal weights, so the engine must hand it an equally weighted cloud: use it
with ``threshold=1`` (resample whenever the weights are not uniform).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pfcourse.angles import wrap_angle
from pfcourse.checks import Array
from pfcourse.errors import ParameterError
from pfcourse.kernels import gather_rows


def optimal_bandwidth(n: int, d: int) -> float:
    """``h_opt = (4 / (d + 2))^{1/(d+4)} N^{-1/(d+4)}`` (Gaussian kernel, Gaussian density)."""
    if n < 1 or d < 1:
        raise ParameterError(f"need n >= 1 and d >= 1, got n={n}, d={d}")
    return (4.0 / (d + 2)) ** (1.0 / (d + 4)) * n ** (-1.0 / (d + 4))


def cloud_covariance(particles: Array, angle_indices=()) -> Array:
    """Equal-weight covariance of an ``(N, d)`` cloud; angles as wrapped deviations from the circular mean."""
    x = np.array(particles, dtype=float)
    for j in angle_indices:
        mean = np.arctan2(np.mean(np.sin(x[:, j])), np.mean(np.cos(x[:, j])))
        x[:, j] = wrap_angle(x[:, j] - mean)
    return np.atleast_2d(np.cov(x, rowvar=False))


@dataclass(frozen=True)
class RegularisedJitter:
    """The regularised filter's kernel move, for ``ParticleFilter(..., jitter=RegularisedJitter())``."""

    scale: float = 1.0
    angle_indices: tuple[int, ...] = ()

    def bandwidth(self, n: int, d: int) -> float:
        return self.scale * optimal_bandwidth(n, d)

    def __call__(self, particles: Array, rng: np.random.Generator) -> Array:
        n, d = particles.shape
        S = cloud_covariance(particles, self.angle_indices)
        # a collapsed cloud (some component constant) gets no move in that direction
        w, V = np.linalg.eigh(S)
        root = V * np.sqrt(np.clip(w, 0.0, None))
        out = particles + self.bandwidth(n, d) * rng.standard_normal((n, d)) @ root.T
        for j in self.angle_indices:
            out[:, j] = wrap_angle(out[:, j])
        return out


def tempering_exponent(loglik: Array, remaining: float, ess_fraction: float) -> float:
    """Largest ``lam`` in ``(0, remaining]`` with ESS of weights ``exp(lam * loglik)`` >= ``ess_fraction N``."""
    n = loglik.size
    finite = np.isfinite(loglik)
    if not finite.any():
        return remaining
    ll = np.where(finite, loglik, -np.inf)

    def ess(lam):
        a = lam * ll
        a = a - np.max(a)
        w = np.exp(a)
        return w.sum() ** 2 / np.sum(w * w)

    if ess(remaining) >= ess_fraction * n:
        return remaining
    lo, hi = 0.0, remaining
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if ess(mid) >= ess_fraction * n:
            lo = mid
        else:
            hi = mid
    return max(lo, 1e-12)


@dataclass
class ProgressiveCorrection:
    """Importance function doing progressive correction at the first ``n_tempered`` readings.

    Afterwards it is the transition (bootstrap).  ``stages`` records how many likelihood
    evaluations each step cost (the price in particle-steps).
    """

    n_tempered: int = 5
    ess_fraction: float = 0.5
    kernel: RegularisedJitter = field(default_factory=lambda: RegularisedJitter(0.5, (3,)))
    max_stages: int = 50
    stages: list = field(default_factory=list)
    _seen: int = 0

    def reset(self) -> None:
        self.stages, self._seen = [], 0

    def propose(self, model, particles, z, k, rng):
        new = model.sample_transition(particles, k, rng)
        loglik = model.log_likelihood(new, z, k)
        self._seen += 1
        if self._seen > self.n_tempered:
            self.stages.append(1)
            return new, loglik
        remaining, constant, n_stages = 1.0, 0.0, 1
        while True:
            lam = tempering_exponent(loglik, remaining, self.ess_fraction)
            if lam >= remaining or n_stages >= self.max_stages:
                self.stages.append(n_stages)
                return new, remaining * loglik + constant
            a = lam * loglik
            top = np.max(a)
            w = np.exp(a - top)
            constant += top + np.log(np.mean(w))
            idx = rng.choice(len(w), size=len(w), p=w / w.sum())
            new = self.kernel(gather_rows(new, idx), rng)
            remaining -= lam
            loglik = model.log_likelihood(new, z, k)
            n_stages += 1
