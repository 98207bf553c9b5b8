"""A digital elevation model (DEM) in metres, with bilinear heights vectorized over particles.

The map used by the book is the USGS elevation model shipped with matplotlib,
``jacksboro_fault_dem.npz`` (Cumberland Mountains, Tennessee): ``int16`` heights in metres
on a grid of 3 arc-seconds (``dx = dy = 1/1200`` degree), 344 rows by 403 columns.

**Orientation.** Row 0 of the file is the *northern* edge and rows go south.  The file's
``ymax`` (36.446 deg) is the latitude of the northern edge, ``xmin`` / ``xmax`` the western
and eastern edges; its ``ymin`` field is not the southern edge (it equals
``ymax + 344 dy``, north of ``ymax``), so the southern edge is computed as
``ymax - n_rows dy``.  With this reading the highest cell (1076 m) lies at
36.1983 N, 84.2308 W, within 30 m of the published summit of Cross Mountain
(1077 m, 36.19833 N, 84.23056 W); the test suite checks it.

**Metres.** Heights are given at the cell centres.  A degree of latitude is
``R pi / 180`` metres and a degree of longitude ``R pi / 180 cos(phi)`` metres
(spherical Earth of radius ``R = 6 371 000`` m, ``phi`` the latitude of the map's
centre; over 0.29 deg of latitude, ``cos(phi)`` varies by 0.4 %).  Map coordinates
``(x, y)`` are metres east and north of the centre of the south-west cell, so node
``(i, j)`` (row ``i`` counted from the south) lies at ``(j dx, i dy)``.

**Interpolation.** Inside a cell with corners ``h00, h10, h01, h11`` (``h_ab`` at
``x_j + a dx, y_i + b dy``) and fractional position ``(s, t) in [0, 1]^2``,

    h(x, y) = (1-s)(1-t) h00 + s (1-t) h10 + (1-s) t h01 + s t h11,

exact at the nodes and linear along cell edges (:func:`scipy.ndimage.map_coordinates`
with ``order=1``).  Its gradient, used as the EKF's measurement Jacobian, is
``dh/dx = ((1-t)(h10-h00) + t (h11-h01)) / dx`` and ``dh/dy = ((1-s)(h01-h00) + s (h11-h10)) / dy``.

**Outside the map.** A query outside ``[0, width] x [0, height]`` has no height:
:meth:`TerrainMap.height` returns NaN there, :meth:`TerrainMap.contains` says which
points are inside, and :meth:`TerrainMap.height_checked` raises :class:`OffMapError`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter, map_coordinates

from pfcourse.checks import as_matrix, check_real, set_checked
from pfcourse.errors import OffMapError, ParameterError, ShapeError

#: Mean radius of the Earth (m), IUGG value; one degree of latitude is 111.195 km.
EARTH_RADIUS = 6_371_000.0


def metres_per_degree(latitude_deg: float) -> tuple[float, float]:
    """Metres per degree of longitude and of latitude at ``latitude_deg`` (spherical Earth).

    ``(R pi / 180) cos(phi)`` east-west and ``R pi / 180`` north-south.
    """
    per_degree = EARTH_RADIUS * np.pi / 180.0
    return per_degree * float(np.cos(np.radians(latitude_deg))), per_degree


@dataclass(frozen=True)
class TerrainMap:
    """Terrain heights ``heights[i, j]`` (m) at ``(x, y) = (j dx, i dy)``, row 0 to the south.

    Build one with :func:`load_jacksboro` or directly from an array (tests use tiny maps).
    ``west``, ``south`` (degrees) locate node ``(0, 0)`` on the Earth, for labelling only.
    """

    heights: np.ndarray
    dx: float
    dy: float
    west: float = 0.0
    south: float = 0.0
    deg_lon: float = 1.0
    deg_lat: float = 1.0

    def __post_init__(self) -> None:
        h = as_matrix(self.heights, "heights", finite=True)
        if min(h.shape) < 2:
            raise ShapeError(f"heights must be a 2-D grid of at least 2 x 2, got shape {h.shape}")
        for name in ("dx", "dy"):
            if not check_real(getattr(self, name), name) > 0:
                raise ShapeError(f"grid spacings must be positive, got dx={self.dx}, dy={self.dy}")
        set_checked(self, heights=h, **{name: check_real(getattr(self, name), name)
                                        for name in ("dx", "dy", "west", "south", "deg_lon", "deg_lat")})

    @property
    def shape(self) -> tuple[int, int]:
        """``(n_rows, n_cols)`` = ``(ny, nx)``."""
        return self.heights.shape

    @property
    def width(self) -> float:
        """East-west extent between the first and last node (m)."""
        return (self.shape[1] - 1) * self.dx

    @property
    def height_extent(self) -> float:
        """North-south extent between the first and last node (m)."""
        return (self.shape[0] - 1) * self.dy

    @property
    def x_nodes(self) -> np.ndarray:
        """Easting of the grid columns (m)."""
        return np.arange(self.shape[1]) * self.dx

    @property
    def y_nodes(self) -> np.ndarray:
        """Northing of the grid rows (m)."""
        return np.arange(self.shape[0]) * self.dy

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(left, right, bottom, top)`` of the cells (m), for ``imshow(..., origin="lower")``."""
        return (-self.dx / 2, self.width + self.dx / 2, -self.dy / 2, self.height_extent + self.dy / 2)

    def contains(self, x, y) -> np.ndarray:
        """Boolean array: is ``(x, y)`` inside the node hull ``[0, width] x [0, height]``?"""
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        return (x >= 0.0) & (x <= self.width) & (y >= 0.0) & (y <= self.height_extent)

    def _grid_coordinates(self, x, y):
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        x, y = np.broadcast_arrays(x, y)
        return x, y, x / self.dx, y / self.dy

    def height(self, x, y) -> np.ndarray:
        """Bilinear terrain height (m) at ``(x, y)`` (any matching shapes); NaN outside the map."""
        x, y, col, row = self._grid_coordinates(x, y)
        inside = self.contains(x, y)
        out = np.full(x.shape, np.nan)
        if np.any(inside):
            coords = np.vstack([row[inside], col[inside]])
            out[inside] = map_coordinates(self.heights, coords, order=1, mode="nearest", prefilter=False)
        return out

    def height_checked(self, x, y) -> np.ndarray:
        """Like :meth:`height`, but raise :class:`OffMapError` if any point is outside the map."""
        inside = self.contains(x, y)
        if not np.all(inside):
            n_out = int(np.size(inside) - np.count_nonzero(inside))
            raise OffMapError(
                f"{n_out} point(s) outside the map [0, {self.width:.0f}] x [0, {self.height_extent:.0f}] m"
            )
        return self.height(x, y)

    def gradient(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Gradient ``(dh/dx, dh/dy)`` (m/m) of the bilinear interpolant; NaN outside the map.

        On a cell edge the cell to the north-east is used (the one-sided derivative).
        """
        x, y, col, row = self._grid_coordinates(x, y)
        inside = self.contains(x, y)
        gx = np.full(x.shape, np.nan)
        gy = np.full(x.shape, np.nan)
        if np.any(inside):
            ny, nx = self.shape
            c = col[inside]
            r = row[inside]
            j = np.clip(np.floor(c).astype(int), 0, nx - 2)
            i = np.clip(np.floor(r).astype(int), 0, ny - 2)
            s = c - j
            t = r - i
            h = self.heights
            h00, h10, h01, h11 = h[i, j], h[i, j + 1], h[i + 1, j], h[i + 1, j + 1]
            gx[inside] = ((1 - t) * (h10 - h00) + t * (h11 - h01)) / self.dx
            gy[inside] = ((1 - s) * (h01 - h00) + s * (h11 - h10)) / self.dy
        return gx, gy

    def to_lonlat(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Longitude and latitude (degrees) of map points ``(x, y)`` (m)."""
        return (
            self.west + np.asarray(x, dtype=float) / self.deg_lon,
            self.south + np.asarray(y, dtype=float) / self.deg_lat,
        )


def load_jacksboro() -> TerrainMap:
    """Load matplotlib's ``jacksboro_fault_dem.npz`` as a :class:`TerrainMap` in metres.

    Rows are flipped so that row 0 is the southern edge; node ``(0, 0)`` is the centre of the
    south-west cell.  See the module docstring for the orientation and the units.
    """
    from matplotlib import cbook

    with cbook.get_sample_data("jacksboro_fault_dem.npz") as dem:
        elevation = np.asarray(dem["elevation"], dtype=float)
        ddx, ddy = float(dem["dx"]), float(dem["dy"])
        north = float(dem["ymax"])
        west_edge = float(dem["xmin"])
    n_rows = elevation.shape[0]
    south_edge = north - n_rows * ddy
    centre_lat = 0.5 * (north + south_edge)
    deg_lon, deg_lat = metres_per_degree(centre_lat)
    return TerrainMap(
        heights=elevation[::-1].copy(),
        dx=ddx * deg_lon,
        dy=ddy * deg_lat,
        west=west_edge + ddx / 2,
        south=south_edge + ddy / 2,
        deg_lon=deg_lon,
        deg_lat=deg_lat,
    )


#: The filter's map in the map-error study: the world's DEM smoothed by a Gaussian of this many cells
#: (one standard deviation: what a coarser survey or a wide altimeter footprint sees) ...
MAP_SMOOTHING_CELLS = 1.0
#: ... plus a random error field of this standard deviation (m; a modern global DEM's vertical error
#: is of this order) ...
MAP_ERROR_SD = 10.0
#: ... correlated over about this many cells (the standard deviation of the Gaussian that filters white noise).
MAP_ERROR_CORRELATION_CELLS = 2.0


def mismatched_map(terrain: TerrainMap, rng: np.random.Generator, smoothing: float = MAP_SMOOTHING_CELLS,
                   error_sd: float = MAP_ERROR_SD, correlation: float = MAP_ERROR_CORRELATION_CELLS) -> TerrainMap:
    """A map that is not the truth: ``G_s * h + e``, with ``G_s * h`` the heights smoothed by a Gaussian of
    ``smoothing`` cells (0: none) and ``e = error_sd * (G_c * w) / std(G_c * w)``, ``w`` white Gaussian noise
    at the nodes drawn from ``rng`` and ``G_c`` a Gaussian of ``correlation`` cells (0: white), so that the
    error field's sample standard deviation over the map is exactly ``error_sd`` (m).
    """
    for name, value in (("smoothing", smoothing), ("error_sd", error_sd), ("correlation", correlation)):
        if not check_real(value, name) >= 0:
            raise ParameterError(f"{name} must be non-negative, got {value}")
    smooth = gaussian_filter(terrain.heights, smoothing, mode="nearest") if smoothing > 0 else terrain.heights.copy()
    noise = rng.standard_normal(terrain.shape)
    field = gaussian_filter(noise, correlation, mode="wrap") if correlation > 0 else noise
    field = error_sd * field / np.std(field)
    return TerrainMap(heights=smooth + field, dx=terrain.dx, dy=terrain.dy, west=terrain.west, south=terrain.south,
                      deg_lon=terrain.deg_lon, deg_lat=terrain.deg_lat)


def hillshade(terrain: TerrainMap, azimuth: float = 315.0, altitude: float = 45.0) -> np.ndarray:
    """Shaded relief in [0, 1] of the map (light from ``azimuth`` degrees, clockwise from north).

    Uses :class:`matplotlib.colors.LightSource` with the true grid spacings, so slopes are
    not distorted by the different east-west and north-south cell sizes.
    """
    from matplotlib.colors import LightSource

    light = LightSource(azdeg=azimuth, altdeg=altitude)
    # LightSource expects row 0 at the top (north); our row 0 is the south.
    shade = light.hillshade(terrain.heights[::-1], dx=terrain.dx, dy=terrain.dy)
    return shade[::-1]
