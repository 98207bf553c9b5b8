"""The likelihood-field sensor model (Thrun, Burgard and Fox 2005, table 6.3).

A beam ``b`` of reading ``z`` shorter than ``z_max``, taken from pose ``x = (x, y, theta)``, ends at

    e_b = (x + z_b cos(theta + a_b),  y + z_b sin(theta + a_b)).

The model scores the end point by its distance ``d(e_b)`` to the nearest wall (the grid's distance
transform, :attr:`~pfcourse.scenarios.maprobot.grid.OccupancyGrid.distance`; infinite off the map) and treats the
beams as independent:

    log p(z | x) = sum_{b: z_b < z_max} log( z_hit N(d(e_b); 0, sigma^2) + z_rand / z_max ).

Beams at ``z_max`` are left out.  No ray is cast: the cost is one look-up per beam and particle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pfcourse.checks import Array, check_real
from pfcourse.errors import MeasurementError, ShapeError
from pfcourse.scenarios.maprobot.grid import OccupancyGrid


@dataclass(frozen=True, eq=False)
class LikelihoodField:
    """``p(z | x)`` of a reading ``z`` (``(B,)``) with beam angles ``angles`` on ``grid``."""

    grid: OccupancyGrid
    angles: Array
    max_range: float = 8.0
    z_hit: float = 0.9
    z_rand: float = 0.1
    sigma: float = 0.2

    def __post_init__(self) -> None:
        angles = np.asarray(self.angles, dtype=float)
        if angles.ndim != 1 or len(angles) == 0 or not np.all(np.isfinite(angles)):
            raise ShapeError(f"angles must be a non-empty 1-D array of finite beam angles, got shape {angles.shape}")
        object.__setattr__(self, "angles", angles)
        check_real(self.max_range, "max_range", low=0.0, low_open=True)
        check_real(self.sigma, "sigma", low=0.0, low_open=True)
        check_real(self.z_hit, "z_hit", low=0.0, high=1.0)
        check_real(self.z_rand, "z_rand", low=0.0, high=1.0, low_open=True)

    def beam_log_density(self, distance: Array) -> Array:
        """``log(z_hit N(d; 0, sigma^2) + z_rand / z_max)`` for end-point distances ``d`` (m)."""
        d = np.asarray(distance, dtype=float)
        gauss = np.exp(-0.5 * (d / self.sigma) ** 2) / (np.sqrt(2 * np.pi) * self.sigma)
        return np.log(self.z_hit * gauss + self.z_rand / self.max_range)

    def log_likelihood(self, poses: Array, z: Array) -> Array:
        """``log p(z | x^i)`` for every pose (rows of ``(N, 3)``), shape ``(N,)``."""
        z = np.asarray(z, dtype=float)
        if z.shape != self.angles.shape:
            raise MeasurementError(f"a scan must have {len(self.angles)} ranges, got shape {z.shape}")
        if np.any(z < 0):
            raise MeasurementError("a range cannot be negative")
        use = z < self.max_range  # NaN (not measured) and max-range beams are left out
        heading = poses[:, 2:3] + self.angles[use]  # (N, B')
        ends = np.stack([poses[:, 0:1] + z[use] * np.cos(heading), poses[:, 1:2] + z[use] * np.sin(heading)], axis=-1)
        return self.beam_log_density(self.grid.distance_at(ends)).sum(axis=1)
