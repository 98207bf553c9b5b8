"""Monte Carlo localization on the map: the particle filter's model (``pfcourse.filter.Model``).

State ``x_k = (x, y, theta)``; the transition is the odometry model with the odometry ``u_k`` of the
drive (:class:`~pfcourse.scenarios.maprobot.motion.OdometryModel`); the likelihood is the likelihood field
(:class:`~pfcourse.scenarios.maprobot.likelihood_field.LikelihoodField`).  The initial cloud is uniform in free
space (global localization) or Gaussian around a known pose (tracking).

**Uniform injection, weighted correctly.**  With ``inject = eps > 0`` the transition is that of a
robot that may be carried anywhere at each step (the kidnap model):

    p(x_k | x_{k-1}) = (1 - eps) p_odo(x_k | x_{k-1}, u_k) + eps u(x_k),   u(x) = 1 / (A_free 2 pi).

The bootstrap filter of that model draws each particle from the odometry with probability
``1 - eps`` and uniformly in free space with probability ``eps``, and weights it by ``p(z_k | x_k)``
alone: since the proposal is the model's own transition, no other factor enters the weight, and the
filter targets the posterior of the kidnap model without bias.
"""

from __future__ import annotations

import numpy as np

from pfcourse.checks import Array, check_probability
from pfcourse.errors import ShapeError
from pfcourse.scenarios.maprobot.grid import OccupancyGrid
from pfcourse.scenarios.maprobot.likelihood_field import LikelihoodField
from pfcourse.scenarios.maprobot.motion import OdometryModel


class MapRobotModel:
    """The model of one drive: ``odometry`` ``(K, 3)`` (row ``k`` moves the robot from step ``k - 1``
    to ``k``), the motion model, the likelihood field, the initial cloud (``start=None``: uniform in
    free space; else a pose ``(3,)`` with standard deviations ``start_std``) and the injection ``eps``."""

    dim_x = 3
    angle_indices = (2,)

    def __init__(self, grid: OccupancyGrid, field: LikelihoodField, odometry: Array, *,
                 motion: OdometryModel = OdometryModel(), start: Array | None = None,
                 start_std: tuple[float, float, float] = (0.2, 0.2, 0.05), inject: float = 0.0) -> None:
        self.grid, self.field, self.motion = grid, field, motion
        self.odometry = np.asarray(odometry, dtype=float)
        if self.odometry.ndim != 2 or self.odometry.shape[1] != 3:
            raise ShapeError(f"odometry must have shape (K, 3), got {self.odometry.shape}")
        self.start = None if start is None else np.asarray(start, dtype=float)
        if self.start is not None and self.start.shape != (3,):
            raise ShapeError(f"start must be a pose (x, y, theta), got shape {self.start.shape}")
        self.start_std = np.asarray(start_std, dtype=float)
        self.inject = check_probability(inject, "inject")

    def sample_initial(self, n: int, rng: np.random.Generator) -> Array:
        """``x_0^i``: uniform in free space, or ``N(start, diag(start_std^2))``."""
        if self.start is None:
            return self.grid.sample_free(n, rng)
        return self.start + rng.standard_normal((n, 3)) * self.start_std

    def sample_transition(self, particles: Array, k: int, rng: np.random.Generator) -> Array:
        """``x_k^i`` from the odometry model with ``u_k``; with ``inject > 0``, each particle is replaced by
        a uniform pose in free space with probability ``inject`` (the kidnap model's transition)."""
        new = self.motion.sample(particles, self.odometry[k], rng)
        if self.inject > 0.0:
            carried = rng.random(len(new)) < self.inject
            new[carried] = self.grid.sample_free(int(carried.sum()), rng)
        return new

    def log_likelihood(self, particles: Array, z: Array, k: int) -> Array:
        """``log p(z_k | x_k^i)``, the likelihood field."""
        return self.field.log_likelihood(particles, z)
