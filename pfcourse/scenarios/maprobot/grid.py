"""The occupancy grid: a map of walls in square cells, and the distance from every cell to the nearest wall.

Cell ``(i, j)`` covers ``[j r, (j + 1) r) x [i r, (i + 1) r)`` (``r`` the resolution in metres, the
origin at the map's lower-left corner; row ``i`` is ``y``, column ``j`` is ``x``) and is occupied or
free.  :attr:`OccupancyGrid.distance` is the Euclidean distance transform of the grid
(``scipy.ndimage.distance_transform_edt``): for every cell, the distance (m) from its centre to the
centre of the nearest occupied cell, ``0`` on a wall.  The likelihood field
(:mod:`pfcourse.scenarios.maprobot.likelihood_field`) reads it.

:func:`rooms_and_corridor` builds the book's map: a corridor between two rows of four identical rooms,
each with a door onto the corridor, and one box in one room: most places have a twin.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.ndimage import distance_transform_edt

from pfcourse.checks import Array, check_count, check_real
from pfcourse.errors import ParameterError, ShapeError


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """A boolean occupancy grid ``occupied[i, j]`` (row ``i`` along ``y``) of square cells of side ``resolution`` (m)."""

    occupied: Array
    resolution: float

    def __post_init__(self) -> None:
        occ = np.asarray(self.occupied)
        if occ.ndim != 2 or min(occ.shape) < 2 or occ.dtype != bool:
            raise ShapeError(f"occupied must be a 2-D boolean array of at least 2 x 2 cells, got "
                             f"shape {occ.shape} and dtype {occ.dtype}")
        if occ.all():
            raise ParameterError("the grid has no free cell: the robot has nowhere to be")
        check_real(self.resolution, "resolution", low=0.0, low_open=True)
        object.__setattr__(self, "occupied", occ.copy())
        object.__setattr__(self, "resolution", float(self.resolution))

    @property
    def width(self) -> float:
        """Extent along ``x`` (m)."""
        return self.occupied.shape[1] * self.resolution

    @property
    def height(self) -> float:
        """Extent along ``y`` (m)."""
        return self.occupied.shape[0] * self.resolution

    @cached_property
    def distance(self) -> Array:
        """Distance (m) from each cell's centre to the nearest occupied cell's centre (0 on a wall)."""
        return distance_transform_edt(~self.occupied) * self.resolution

    @cached_property
    def free_cells(self) -> Array:
        """``(i, j)`` indices of the free cells, shape ``(n_free, 2)``."""
        return np.argwhere(~self.occupied)

    @property
    def free_area(self) -> float:
        """Area of free space (m^2): the number of free cells times ``r^2``."""
        return len(self.free_cells) * self.resolution**2

    def cells(self, xy: Array) -> tuple[Array, Array, Array]:
        """Row and column indices of the points ``xy[..., :2]`` and whether each lies on the map."""
        xy = np.asarray(xy, dtype=float)
        j = np.floor(xy[..., 0] / self.resolution).astype(np.int64)
        i = np.floor(xy[..., 1] / self.resolution).astype(np.int64)
        inside = (i >= 0) & (i < self.occupied.shape[0]) & (j >= 0) & (j < self.occupied.shape[1])
        return np.where(inside, i, 0), np.where(inside, j, 0), inside

    def is_free(self, xy: Array) -> Array:
        """Whether each point ``xy[..., :2]`` lies on the map in a free cell."""
        i, j, inside = self.cells(xy)
        return inside & ~self.occupied[i, j]

    def distance_at(self, xy: Array) -> Array:
        """:attr:`distance` at the cell of each point; ``inf`` off the map."""
        i, j, inside = self.cells(xy)
        return np.where(inside, self.distance[i, j], np.inf)

    def sample_free(self, n: int, rng: np.random.Generator) -> Array:
        """``n`` poses ``(x, y, theta)`` uniform in free space: a free cell uniformly, a point uniformly in
        it, ``theta ~ U(-pi, pi)``; density ``u(x) = 1 / (A_free 2 pi)`` with ``A_free`` = :attr:`free_area`."""
        n = check_count(n, "n", minimum=0)
        u = rng.random((n, 4))
        cell = self.free_cells[np.minimum((u[:, 0] * len(self.free_cells)).astype(np.int64), len(self.free_cells) - 1)]
        x = (cell[:, 1] + u[:, 1]) * self.resolution
        y = (cell[:, 0] + u[:, 2]) * self.resolution
        return np.column_stack([x, y, np.pi * (2.0 * u[:, 3] - 1.0)])


#: The book's map (metres): its size, the corridor's band of y, the rooms' width, the doors' width,
#: the walls' thickness and the box that breaks the symmetry (x0, y0, x1, y1).
MAP_WIDTH, MAP_HEIGHT = 20.0, 11.0
CORRIDOR = (4.4, 6.6)
ROOM_WIDTH, DOOR_WIDTH, WALL = 5.0, 1.2, 0.2
BOX = (8.4, 8.8, 9.2, 9.6)


def rooms_and_corridor(resolution: float = 0.1) -> OccupancyGrid:
    """The book's map: a ``20 x 11`` m floor, a corridor along ``y`` in ``CORRIDOR`` and four rooms of
    ``ROOM_WIDTH`` m on each side of it, each with a door of ``DOOR_WIDTH`` m at its middle; walls
    ``WALL`` m thick; one box (``BOX``) in the second room above the corridor."""
    resolution = check_real(resolution, "resolution", low=0.0, high=0.5, low_open=True)
    nx, ny = check_count(round(MAP_WIDTH / resolution), "cells"), check_count(round(MAP_HEIGHT / resolution), "cells")
    xc = (np.arange(nx) + 0.5) * resolution
    yc = (np.arange(ny) + 0.5) * resolution
    X, Y = np.meshgrid(xc, yc)
    half = WALL / 2
    occ = (X < WALL) | (X > MAP_WIDTH - WALL) | (Y < WALL) | (Y > MAP_HEIGHT - WALL)
    room_walls = np.arange(ROOM_WIDTH, MAP_WIDTH, ROOM_WIDTH)
    for xw in room_walls:  # walls between rooms, not across the corridor
        occ |= (np.abs(X - xw) < half) & ((Y < CORRIDOR[0]) | (Y > CORRIDOR[1]))
    doors = np.zeros_like(occ)
    for xd in np.arange(ROOM_WIDTH / 2, MAP_WIDTH, ROOM_WIDTH):
        doors |= np.abs(X - xd) < DOOR_WIDTH / 2
    for yw in (CORRIDOR[0] - half, CORRIDOR[1] + half):  # the corridor's walls, pierced by the doors
        occ |= (np.abs(Y - yw) < half) & ~doors
    occ |= (X > BOX[0]) & (X < BOX[2]) & (Y > BOX[1]) & (Y < BOX[3])
    return OccupancyGrid(occ, resolution)


#: The drive: waypoints (m) of a loop through the corridor and into three rooms (the box's among them).
ROUTE = np.array([
    [1.5, 5.5], [7.5, 5.5], [7.5, 8.0], [7.5, 5.5], [17.5, 5.5], [17.5, 2.5], [17.5, 5.5],
    [12.5, 5.5], [12.5, 2.5], [12.5, 5.5], [2.5, 5.5], [2.5, 8.5], [2.5, 5.5],
])
