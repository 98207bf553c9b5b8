"""Occupancy grid mapping with known poses (Thrun, Burgard and Fox 2005, table 9.1), in log-odds.

Each cell ``m`` holds the log-odds ``l(m) = log p(m occupied) / p(m free)`` of being occupied,
``0`` (probability one half) before any scan.  A scan taken at a known pose updates every cell a
beam passes through or ends in by the *inverse sensor model*:

    l(m) <- l(m) + L_OCC    for the cell where a beam with an echo ends,
    l(m) <- l(m) + L_FREE   for each cell the beam crosses before it,

each cell at most once per scan.  Beams with no echo (range at or beyond ``max_range``) are
left out.  A cell is then *occupied* where ``l > 0``, *free* where ``l < 0`` and *unknown* where
no beam reached it.  The beam is sampled every ``resolution / 2`` m from the robot up to one
cell short of its end, so each crossed cell is visited (the cost is a few points per cell).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pfcourse.checks import Array, check_real
from pfcourse.errors import ShapeError
from pfcourse.scenarios.maprobot.grid import OccupancyGrid

#: The inverse sensor model's log-odds: an end point (p = 0.7) and a crossed cell (p = 0.4).
L_OCC = float(np.log(0.7 / 0.3))
L_FREE = float(np.log(0.4 / 0.6))


@dataclass(frozen=True, eq=False)
class LogOddsMap:
    """Log-odds ``log_odds[i, j]`` (row ``i`` along ``y``) of square cells of side ``resolution`` (m),
    the cell ``(0, 0)``'s corner at ``origin`` ``(x0, y0)`` in the log's frame."""

    log_odds: Array
    resolution: float
    origin: Array

    def grid(self) -> OccupancyGrid:
        """The occupancy grid (occupied where ``l > 0``), in the map's frame (origin at its corner)."""
        return OccupancyGrid(self.log_odds > 0, self.resolution)

    def free_grid(self) -> OccupancyGrid:
        """A grid whose only free cells are those seen free (``l < 0``): to draw poses in known free space."""
        return OccupancyGrid(~(self.log_odds < 0), self.resolution)

    def to_map(self, poses: Array) -> Array:
        """Poses ``(..., 3)`` of the log's frame moved into the map's frame (its corner at the origin)."""
        poses = np.array(poses, dtype=float)
        poses[..., :2] -= self.origin
        return poses


def end_points(poses: Array, ranges: Array, angles: Array) -> Array:
    """End points ``(K, B, 2)`` of every beam of scans ``ranges`` ``(K, B)`` taken at ``poses`` ``(K, 3)``."""
    heading = poses[:, 2:3] + angles
    return np.stack([poses[:, 0:1] + ranges * np.cos(heading), poses[:, 1:2] + ranges * np.sin(heading)], axis=-1)


def build_map(poses: Array, ranges: Array, angles: Array, *, max_range: float, resolution: float = 0.1,
              margin: float = 1.0, l_occ: float = L_OCC, l_free: float = L_FREE) -> LogOddsMap:
    """The log-odds map of scans ``ranges`` ``(K, B)`` taken at the known ``poses`` ``(K, 3)``, beam angles
    ``angles`` ``(B,)``; the grid covers every end point with ``margin`` m to spare."""
    poses, ranges = np.asarray(poses, dtype=float), np.asarray(ranges, dtype=float)
    angles = np.asarray(angles, dtype=float)
    if poses.ndim != 2 or poses.shape[1] != 3 or ranges.shape != (len(poses), len(angles)):
        raise ShapeError(f"poses must be (K, 3) and ranges (K, B) with B = len(angles), got {poses.shape}, "
                         f"{ranges.shape} and {angles.shape}")
    max_range = check_real(max_range, "max_range", low=0.0, low_open=True)
    resolution = check_real(resolution, "resolution", low=0.0, low_open=True)
    echo = ranges < max_range
    ends = end_points(poses, ranges, angles)
    pts = np.concatenate([ends[echo], poses[:, :2]])
    origin = np.floor((pts.min(axis=0) - margin) / resolution) * resolution
    shape = tuple(np.ceil((pts.max(axis=0) + margin - origin) / resolution).astype(int)[::-1])
    log_odds = np.zeros(shape)
    for free_flat, ends_flat in scan_cells(poses, ranges, angles, origin, shape, max_range=max_range,
                                           resolution=resolution):
        log_odds.flat[free_flat] += l_free
        log_odds.flat[ends_flat] += l_occ
    return LogOddsMap(log_odds=log_odds, resolution=resolution, origin=origin)


def scan_cells(poses: Array, ranges: Array, angles: Array, origin: Array, shape: tuple[int, int], *,
               max_range: float, resolution: float = 0.1):
    """Per scan, the flat indices of the cells its beams cross (``free``) and end in (``ends``) on the grid
    of ``shape`` with its corner at ``origin``: what :func:`build_map` adds ``L_FREE`` and ``L_OCC`` to, each
    cell once per scan (yields ``(free, ends)`` pairs, one a scan; beams with no echo left out)."""
    echo = ranges < max_range
    steps = np.arange(0.0, max_range, resolution / 2)
    for pose, z, hit in zip(poses, ranges, echo):
        z = z[hit]
        heading = pose[2] + angles[hit]
        cells = np.floor((ends_of(pose, z, heading) - origin) / resolution).astype(np.int64)
        ends_flat = np.unique(cells[:, 1] * shape[1] + cells[:, 0])
        # points along each beam, up to one cell short of its end
        s = steps[None, :] * np.ones((len(z), 1))
        along = s < (z[:, None] - resolution)
        px = pose[0] + s[along] * np.repeat(np.cos(heading), along.sum(axis=1))
        py = pose[1] + s[along] * np.repeat(np.sin(heading), along.sum(axis=1))
        j = np.floor((px - origin[0]) / resolution).astype(np.int64)
        i = np.floor((py - origin[1]) / resolution).astype(np.int64)
        yield np.setdiff1d(np.unique(i * shape[1] + j), ends_flat), ends_flat


def ends_of(pose: Array, z: Array, heading: Array) -> Array:
    """End points ``(B, 2)`` of beams of ranges ``z`` in absolute directions ``heading`` from ``pose``."""
    return np.column_stack([pose[0] + z * np.cos(heading), pose[1] + z * np.sin(heading)])
