"""A simulated range scanner: a fan of beams ray-cast on the occupancy grid, with the beam model's noise.

Beam ``b`` leaves the robot at ``(x, y)`` in direction ``theta + a_b`` (``a_b`` evenly spread over the
field of view).  :func:`cast_rays` marches along it in steps ``s`` and returns the distance to the
first point in an occupied cell (or off the map), ``z*``, within ``s / 2``, or ``z_max`` when there is
none within range.

:meth:`Scanner.sample` draws a reading ``z`` from the four-part beam model (Thrun, Burgard and Fox
2005, section 6.3): with probabilities ``z_hit, z_short, z_max, z_rand`` (summing to 1),

* *hit*: ``z ~ N(z*, sigma_hit^2)``, clipped to ``[0, z_max]``;
* *short* (something unmapped in the way): ``z ~ Exp(lambda_short)`` truncated to ``[0, z*]``;
* *max* (no echo): ``z = z_max``;
* *rand* (a spurious echo): ``z ~ U(0, z_max)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import erfinv

from pfcourse.checks import Array, check_count, check_real
from pfcourse.errors import OffMapError, ParameterError, ShapeError
from pfcourse.scenarios.maprobot.grid import OccupancyGrid


def cast_rays(grid: OccupancyGrid, poses: Array, angles: Array, max_range: float, step: float | None = None) -> Array:
    """Distances ``z*`` (m) from each pose (rows of ``(N, 3)``) along each beam angle (relative to the
    heading, ``(B,)``) to the first occupied cell or the edge of the map, ``max_range`` if none is
    nearer; shape ``(N, B)``.  Marching step ``step`` (``resolution / 4`` by default): the error is at
    most ``step / 2``."""
    poses = np.atleast_2d(np.asarray(poses, dtype=float))
    if poses.ndim != 2 or poses.shape[1] != 3:
        raise ShapeError(f"poses must have shape (N, 3), got {poses.shape}")
    if not grid.is_free(poses).all():
        raise OffMapError("a pose lies in a wall or off the map: a scanner there sees nothing")
    max_range = check_real(max_range, "max_range", low=0.0, low_open=True)
    step = grid.resolution / 4 if step is None else check_real(step, "step", low=0.0, low_open=True)
    s = np.arange(step, max_range + step, step)  # (S,)
    heading = poses[:, 2:3] + np.asarray(angles, dtype=float)[None, :]  # (N, B)
    px = poses[:, 0, None, None] + np.cos(heading)[..., None] * s  # (N, B, S)
    py = poses[:, 1, None, None] + np.sin(heading)[..., None] * s
    i, j, inside = grid.cells(np.stack([px, py], axis=-1))
    blocked = ~inside | grid.occupied[i, j]
    first = blocked.argmax(axis=-1)
    hit = blocked.any(axis=-1)
    return np.where(hit, np.minimum(s[first] - step / 2, max_range), max_range)


@dataclass(frozen=True)
class Scanner:
    """A fan of ``n_beams`` beams over ``fov`` radians (centred on the heading), range ``max_range`` (m),
    and the beam model's mixture weights and parameters."""

    n_beams: int = 24
    fov: float = 2 * np.pi
    max_range: float = 8.0
    z_hit: float = 0.85
    z_short: float = 0.05
    z_max: float = 0.05
    z_rand: float = 0.05
    sigma_hit: float = 0.05
    lambda_short: float = 1.0

    def __post_init__(self) -> None:
        check_count(self.n_beams, "n_beams")
        check_real(self.fov, "fov", low=0.0, high=2 * np.pi, low_open=True)
        check_real(self.max_range, "max_range", low=0.0, low_open=True)
        check_real(self.sigma_hit, "sigma_hit", low=0.0, low_open=True)
        check_real(self.lambda_short, "lambda_short", low=0.0, low_open=True)
        weights = [check_real(getattr(self, n), n, low=0.0, high=1.0) for n in ("z_hit", "z_short", "z_max", "z_rand")]
        if abs(sum(weights) - 1.0) > 1e-9:
            raise ParameterError(f"z_hit + z_short + z_max + z_rand must be 1, got {sum(weights)}")

    @property
    def angles(self) -> Array:
        """Beam directions relative to the heading (rad), shape ``(n_beams,)``."""
        full = np.isclose(self.fov, 2 * np.pi)
        return np.linspace(-self.fov / 2, self.fov / 2, self.n_beams, endpoint=not full)

    def true_ranges(self, grid: OccupancyGrid, pose: Array) -> Array:
        """``z*`` for one pose, shape ``(n_beams,)``."""
        return cast_rays(grid, np.asarray(pose, dtype=float)[None], self.angles, self.max_range)[0]

    def sample(self, true_ranges: Array, rng: np.random.Generator) -> Array:
        """A noisy reading for the true ranges ``z*`` (``(B,)``), by the four-part beam model."""
        z_star = np.asarray(true_ranges, dtype=float)
        u = rng.random((4, len(z_star)))
        part = np.searchsorted(np.cumsum([self.z_hit, self.z_short, self.z_max]), u[0], side="right")
        hit = np.clip(z_star + self.sigma_hit * np.sqrt(2.0) * erfinv(2.0 * u[1] - 1.0), 0.0, self.max_range)
        short = -np.log1p(-u[2] * -np.expm1(-self.lambda_short * z_star)) / self.lambda_short
        rand = u[3] * self.max_range
        return np.choose(part, [hit, short, np.full_like(z_star, self.max_range), rand])

