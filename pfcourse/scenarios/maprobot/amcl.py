"""What AMCL does differently: its sum-of-cubes weighting of the beams, and the beam model.

**AMCL's weighting** (ROS 1 navigation 1.17.3, ``amcl/src/amcl/sensors/amcl_laser.cpp``,
``LikelihoodFieldModel``; the same in nav2 1.3.1, ``nav2_amcl/src/sensors/laser/likelihood_field_model.cpp``):
each beam ``b`` with an echo gets

    p_b = z_hit exp(-d(e_b)^2 / (2 sigma^2)) + z_rand / z_max

(the Gaussian without its normalisation, as a comment in the source notes), and a particle's
weight is multiplied by ``1 + sum_b p_b^3``, not by ``prod_b p_b``: the source calls it "an ad-hoc
weighting scheme for combining beam probs".  :class:`CubesLikelihoodField` returns
``log(1 + sum_b p_b^3)`` with the field's own parameters, so it plugs into the filter where the
likelihood field does.

**The beam model** (Thrun, Burgard and Fox 2005, section 6.3): :func:`beam_log_likelihood` casts
every beam of every particle through the grid (:func:`pfcourse.scenarios.maprobot.scanner.cast_rays`) and
scores the reading by the four-part mixture the scanner draws from.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pfcourse.checks import Array
from pfcourse.errors import MeasurementError
from pfcourse.scenarios.maprobot.grid import OccupancyGrid
from pfcourse.scenarios.maprobot.likelihood_field import LikelihoodField
from pfcourse.scenarios.maprobot.scanner import Scanner, cast_rays


@dataclass(frozen=True, eq=False)
class CubesLikelihoodField(LikelihoodField):
    """AMCL's weighting on the likelihood field: ``log(1 + sum_b p_b^3)`` (see the module)."""

    def beam_probabilities(self, poses: Array, z: Array) -> Array:
        """``p_b`` for every pose and echoed beam, shape ``(N, B')``."""
        z = np.asarray(z, dtype=float)
        if z.shape != self.angles.shape:
            raise MeasurementError(f"a scan must have {len(self.angles)} ranges, got shape {z.shape}")
        if np.any(z < 0):
            raise MeasurementError("a range cannot be negative")
        use = z < self.max_range
        heading = poses[:, 2:3] + self.angles[use]
        ends = np.stack([poses[:, 0:1] + z[use] * np.cos(heading), poses[:, 1:2] + z[use] * np.sin(heading)], axis=-1)
        d = self.grid.distance_at(ends)
        return self.z_hit * np.exp(-0.5 * (d / self.sigma) ** 2) + self.z_rand / self.max_range

    def log_likelihood(self, poses: Array, z: Array) -> Array:
        """``log(1 + sum_b p_b^3)`` for every pose, shape ``(N,)``."""
        return np.log1p((self.beam_probabilities(poses, z) ** 3).sum(axis=1))


def beam_log_likelihood(grid: OccupancyGrid, scanner: Scanner, poses: Array, z: Array) -> Array:
    """``log p(z | x^i)`` by the beam model with ``scanner``'s own mixture, for every pose (``(N, 3)``).

    Each beam is cast from each pose (``z*``), then scored by
    ``z_hit N(z; z*, sigma_hit^2) + z_short lambda e^{-lambda z} / (1 - e^{-lambda z*}) [z < z*]
    + z_max [z = z_max] + z_rand / z_max``; poses in a wall or off the map get ``-inf``.
    """
    poses = np.atleast_2d(np.asarray(poses, dtype=float))
    z = np.asarray(z, dtype=float)
    out = np.full(len(poses), -np.inf)
    free = grid.is_free(poses)
    if not free.any():
        return out
    z_star = cast_rays(grid, poses[free], scanner.angles, scanner.max_range)  # (N', B)
    hit = np.exp(-0.5 * ((z - z_star) / scanner.sigma_hit) ** 2) / (np.sqrt(2 * np.pi) * scanner.sigma_hit)
    lam = scanner.lambda_short
    short = np.where(z < z_star, lam * np.exp(-lam * z) / -np.expm1(-lam * np.maximum(z_star, 1e-12)), 0.0)
    at_max = (z >= scanner.max_range).astype(float)
    p = (scanner.z_hit * hit + scanner.z_short * short + scanner.z_max * at_max
         + scanner.z_rand / scanner.max_range)
    out[free] = np.log(p).sum(axis=1)
    return out
