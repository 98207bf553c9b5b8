"""Jitters: moves applied to a resampled cloud (the engine's ``jitter`` hook).

After resampling, several particles are exact copies of one ancestor.  A jitter moves every
particle by a random amount after each resampling, so that the copies separate.  Two rules:

**Roughening** (Gordon, Salmond and Smith 1993).  When the
dynamics add (almost) no noise to some components, the copies never separate
again and the cloud collapses onto a few values (sample impoverishment).
Roughening adds an independent jitter to every particle,

.. math::

   \\tilde x^i_j = x^i_j + \\epsilon^i_j, \\qquad
   \\epsilon^i_j \\sim \\mathcal N\\!\\left(0, \\sigma_j^2\\right), \\qquad
   \\sigma_j = K\\, E_j\\, N^{-1/d},

where ``E_j = max_i x^i_j - min_i x^i_j`` is the range of component ``j`` over the
cloud, ``N`` the number of particles, ``d`` the state dimension and ``K`` a
tuning constant (Gordon et al. used ``K = 0.2``).  The jitter shrinks as the cloud
shrinks and as ``N`` grows; it is not part of the model, so it adds variance
that the posterior does not have (:class:`Roughening`).

**Regularised particle filter** (Musso, Oudjane and Le Gland 2001): after each resampling,
every particle is moved by a draw of a Gaussian kernel,

    x^i <- x^i + h S^{1/2} eps^i,   eps^i ~ N(0, I_d),
    h_opt = A N^{-1/(d+4)},   A = (4 / (d + 2))^{1/(d+4)},

with ``S`` the covariance of the resampled cloud (angles as deviations from the circular
mean, wrapped) and ``h_opt`` the bandwidth minimising the mean integrated squared error
when the density is Gaussian.  ``scale`` multiplies ``h_opt`` (``scale < 1`` is common)
(:class:`RegularisedJitter`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pfcourse.angles import circular_mean, wrap_angle
from pfcourse.checks import Array
from pfcourse.errors import ParameterError, ShapeError


def roughening_scale(particles: np.ndarray, K: float = 0.2) -> np.ndarray:
    """Per-component jitter standard deviations ``sigma_j = K E_j N^(-1/d)`` of an ``(N, d)`` cloud."""
    particles = np.asarray(particles, dtype=float)
    if particles.ndim != 2:
        raise ShapeError(f"particles must have shape (N, d), got {particles.shape}")
    if not (np.isfinite(K) and K >= 0):
        raise ParameterError(f"K must be a finite number >= 0, got {K}")
    n, d = particles.shape
    spread = particles.max(axis=0) - particles.min(axis=0)
    return K * spread * n ** (-1.0 / d)


@dataclass(frozen=True)
class Roughening:
    """A jitter rule for :class:`~pfcourse.filter.ParticleFilter` (its ``jitter`` argument).

    ``Roughening(K)(particles, rng)`` returns ``particles + sigma * e`` with
    ``sigma = roughening_scale(particles, K)`` and ``e ~ N(0, I)``.  ``indices``,
    if given, restricts the jitter to those state components (the others are
    returned unchanged); ``d`` in the rule stays the full state dimension.
    """

    K: float = 0.2
    indices: Sequence[int] | None = None

    def __call__(self, particles: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        sigma = roughening_scale(particles, self.K)
        if self.indices is not None:
            keep = np.ones(sigma.shape[0], dtype=bool)
            keep[list(self.indices)] = False
            sigma[keep] = 0.0
        return particles + rng.standard_normal(particles.shape) * sigma


def optimal_bandwidth(n: int, d: int) -> float:
    """``h_opt = (4 / (d + 2))^{1/(d+4)} N^{-1/(d+4)}`` (Gaussian kernel, Gaussian density)."""
    if n < 1 or d < 1:
        raise ParameterError(f"need n >= 1 and d >= 1, got n={n}, d={d}")
    return (4.0 / (d + 2)) ** (1.0 / (d + 4)) * n ** (-1.0 / (d + 4))


def cloud_covariance(particles: Array, angle_indices=()) -> Array:
    """Equal-weight covariance of an ``(N, d)`` cloud; angles as wrapped deviations from the circular mean."""
    x = np.array(particles, dtype=float)
    for j in angle_indices:
        mean = circular_mean(x[:, j])
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
