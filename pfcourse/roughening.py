"""Roughening: Gaussian jitter added to a resampled cloud (Gordon, Salmond and Smith 1993).

After resampling, several particles are exact copies of one ancestor.  When the
dynamics add (almost) no noise to some components, those copies never separate
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
that the posterior does not have.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

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
