"""The map robot's figures: the occupancy grid drawn, with a route, poses and a scan."""

from __future__ import annotations

import numpy as np

from pfcourse.scenarios.maprobot.grid import OccupancyGrid


def draw_map(ax, grid: OccupancyGrid, *, values: np.ndarray | None = None, cmap: str = "Greys", **kwargs):
    """Draw ``grid`` (walls dark) on ``ax`` in metres, or ``values`` (one per cell) with ``cmap``;
    returns the image."""
    image = grid.occupied.astype(float) if values is None else values
    im = ax.imshow(image, origin="lower", extent=(0, grid.width, 0, grid.height), cmap=cmap,
                   interpolation="nearest", **kwargs)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.grid(False)
    return im


def draw_scan(ax, pose: np.ndarray, z: np.ndarray, angles: np.ndarray, max_range: float, color: str = "tab:red") -> None:
    """The beams of a scan ``z`` from ``pose``: a line to each end point, the end points of echoes as dots."""
    heading = pose[2] + angles
    ends = pose[:2] + z[:, None] * np.column_stack([np.cos(heading), np.sin(heading)])
    for e in ends:
        ax.plot([pose[0], e[0]], [pose[1], e[1]], color=color, lw=0.6, alpha=0.6)
    echo = z < max_range
    ax.plot(ends[echo, 0], ends[echo, 1], "o", color=color, ms=3)
