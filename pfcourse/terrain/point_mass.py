"""A point-mass (grid) filter for terrain navigation, altitude integrated out (after Bergman 1999).

The posterior over the horizontal position ``p = (x, y)`` and the heading ``psi`` is held as
probabilities ``w[j, r, c]`` on a regular grid: cells of ``cell`` metres (``x = x_lo + c cell``,
``y = y_lo + r cell``) and heading bins ``psi_j = psi_0 + omega t_k + (j - J) dpsi``, a grid that
turns with the known turn rate, so the deterministic part of the heading's motion is exact.  Each
grid point also carries a Gaussian ``N(m, P)`` for the altitude (the linear part of the state, as in
the marginalised particle filter of :mod:`pfcourse.terrain.marginalised`), stored as the moments
``a = w m`` and ``b = w (m^2 + P)``.

**Prediction** (a convolution, one per heading layer): each layer ``j`` moves by
``V dt (cos psi_j, sin psi_j)``, a shift of the three arrays ``(w, a, b)`` with bilinear interpolation
(:func:`bilinear_shift`, which is ``scipy.ndimage.shift`` of order 1); the heading noise ``N(0, Qf_psi dt)`` is a Gaussian convolution
along the heading axis (``scipy.ndimage.gaussian_filter1d``); the altitude variance grows by
``Qf_z dt`` (``b += w Qf_z dt``).  Convolving ``w``, ``w m`` and ``w (m^2 + P)`` with the same
kernel merges the Gaussians that land on a grid point into one with the mixture's mean and
variance (moment matching).  The horizontal process noise (``sqrt(Qf_xx dt)``, a few metres) is
far below a cell and is left out: the interpolation of the shift already spreads each layer by up to
half a cell per step, which is why the cell size must be checked by refining it.

**Update** (a product): at every grid point ``m = a / w``, ``P = b / w - m^2`` and, with the ground
height ``h(p)`` of the point, the scalar Kalman update of :func:`pfcourse.terrain.marginalised.altitude_kalman_update`;
``w`` is multiplied by the predictive density ``N(y_k; m - h(p), P + Rf)`` and renormalised.
Grid points off the map get probability zero.

The grid covers the prior's ``±3.5`` standard deviations in position, translated along every nominal
track with a heading within the heading grid, cut to the map; the heading grid covers ``±3``
standard deviations of the heading's prior plus its random walk over the flight.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from pfcourse.angles import wrap_angle
from pfcourse.checks import Array, check_real
from pfcourse.errors import DegenerateWeightsError, ParameterError
from pfcourse.terrain.map import TerrainMap
from pfcourse.terrain.marginalised import altitude_kalman_update
from pfcourse.terrain.scenario import AircraftScenario, _check_flight

#: Most grid points a filter may hold (three float arrays of this size, and temporaries).
MAX_CELLS = 20_000_000


@dataclass
class GridResult:
    """``mean`` ``(K, 4)``: posterior mean of ``(x, y, z, psi)`` at each step (circular for ``psi``);
    ``sd`` ``(K, 2)``: posterior standard deviations of ``x`` and ``y``."""

    mean: Array
    sd: Array


def _integer_shift(arr: Array, n: int, axis: int) -> Array:
    """``out[..., i, ...] = arr[..., i - n, ...]`` along ``axis``, zero where ``i - n`` is outside."""
    out = np.zeros_like(arr)
    size = arr.shape[axis]
    if abs(n) >= size:
        return out
    src = [slice(None)] * arr.ndim
    dst = [slice(None)] * arr.ndim
    src[axis] = slice(max(-n, 0), size - max(n, 0))
    dst[axis] = slice(max(n, 0), size - max(-n, 0))
    out[tuple(dst)] = arr[tuple(src)]
    return out


def bilinear_shift(arr: Array, shift_rows: float, shift_cols: float) -> Array:
    """``arr`` ``(..., ny, nx)`` moved by ``(shift_rows, shift_cols)`` cells, bilinear, zero outside
    (the result of ``scipy.ndimage.shift(arr, (0, .., shift_rows, shift_cols), order=1, mode="grid-constant")``):
    with ``n = floor(shift)`` and ``f = shift - n``, ``out[i] = (1 - f) arr[i - n] + f arr[i - n - 1]`` on each axis."""
    out = arr
    for axis, shift in ((-2, shift_rows), (-1, shift_cols)):
        n = int(np.floor(shift))
        f = shift - n
        out = (1.0 - f) * _integer_shift(out, n, axis % arr.ndim) + f * _integer_shift(out, n + 1, axis % arr.ndim)
    return out


class PointMassFilter:
    """The point-mass filter of the module docstring, on the grid fixed by ``cell`` (m) and ``heading_step`` (rad).

    ``heading_sigmas`` and ``position_sigmas`` set how many prior standard deviations the grid covers.
    """

    def __init__(self, terrain: TerrainMap, scenario: AircraftScenario, cell: float = 100.0,
                 heading_step: float = np.radians(2.0), position_sigmas: float = 3.5,
                 heading_sigmas: float = 3.0) -> None:
        _check_flight(scenario, terrain)
        self.cell = check_real(cell, "cell")
        self.heading_step = check_real(heading_step, "heading_step")
        if self.cell <= 0 or self.heading_step <= 0:
            raise ParameterError(f"cell and heading_step must be positive, got {cell} and {heading_step}")
        s = scenario
        if np.any(np.diag(np.diag(s.P0)) != s.P0) or np.any(np.diag(np.diag(s.Qf)) != s.Qf):
            raise ParameterError("the point-mass filter needs diagonal P0 and Qf (independent components)")
        self.terrain, self.scenario = terrain, s
        sd_psi = float(np.sqrt(s.P0[3, 3] + s.Qf[3, 3] * s.duration))
        half = int(np.ceil(heading_sigmas * sd_psi / self.heading_step))
        self.offsets = np.arange(-half, half + 1) * self.heading_step  # psi_j - (psi_0 + omega t_k)
        # Every nominal track with a heading offset on the grid, from the prior box.
        t = s.times
        psi = s.x0[3] + s.omega * t[None, :] + self.offsets[:, None]
        dx = np.cumsum(np.hstack([np.zeros((len(self.offsets), 1)), s.speed * s.dt * np.cos(psi[:, :-1])]), axis=1)
        dy = np.cumsum(np.hstack([np.zeros((len(self.offsets), 1)), s.speed * s.dt * np.sin(psi[:, :-1])]), axis=1)
        box = position_sigmas * np.sqrt(np.diag(s.P0)[:2])
        lo = np.maximum([s.x0[0] + dx.min() - box[0], s.x0[1] + dy.min() - box[1]], 0.0)
        hi = np.minimum([s.x0[0] + dx.max() + box[0], s.x0[1] + dy.max() + box[1]],
                        [terrain.width, terrain.height_extent])
        if np.any(hi <= lo):
            raise ParameterError("the prior's grid window does not meet the map")
        self.x = np.arange(lo[0], hi[0] + 1e-9, self.cell)
        self.y = np.arange(lo[1], hi[1] + 1e-9, self.cell)
        self.n_cells = len(self.offsets) * len(self.x) * len(self.y)
        if self.n_cells > MAX_CELLS:
            raise ParameterError(f"{self.n_cells} grid points (cell={cell} m, heading_step={heading_step} rad): "
                                 f"at most {MAX_CELLS}; take coarser cells")
        X, Y = np.meshgrid(self.x, self.y)
        self.ground = terrain.height(X, Y)  # (ny, nx); NaN off the map

    def initial(self) -> tuple[Array, Array, Array]:
        """``(w, a, b)`` of the prior: ``w`` the Gaussian prior's probabilities at the grid points,
        every altitude ``N(x0_z, P0_zz)``."""
        s = self.scenario
        gx = -0.5 * (self.x - s.x0[0]) ** 2 / s.P0[0, 0]
        gy = -0.5 * (self.y - s.x0[1]) ** 2 / s.P0[1, 1]
        gpsi = -0.5 * self.offsets**2 / s.P0[3, 3]
        log_w = gpsi[:, None, None] + gy[None, :, None] + gx[None, None, :]
        w = np.exp(log_w - log_w.max())
        w[:, np.isnan(self.ground)] = 0.0
        w /= w.sum()
        return w, w * s.x0[2], w * (s.x0[2] ** 2 + s.P0[2, 2])

    def predict(self, w: Array, a: Array, b: Array, k: int) -> tuple[Array, Array, Array]:
        """From step ``k - 1`` to ``k``: shift each heading layer, blur along the heading, grow the altitude variance."""
        s = self.scenario
        psi = s.x0[3] + s.omega * s.times[k - 1] + self.offsets
        stack = np.stack([w, a, b])  # (3, J, ny, nx)
        moved = np.empty_like(stack)
        for j, angle in enumerate(psi):
            moved[:, j] = bilinear_shift(stack[:, j], s.speed * s.dt * np.sin(angle) / self.cell,
                                         s.speed * s.dt * np.cos(angle) / self.cell)
        sigma = float(np.sqrt(s.Qf[3, 3] * s.dt)) / self.heading_step
        if sigma > 0:
            moved = ndimage.gaussian_filter1d(moved, sigma, axis=1, mode="constant", cval=0.0, truncate=4.0)
        w, a, b = moved
        b = b + w * s.Qf[2, 2] * s.dt
        return w, a, b

    def update(self, w: Array, a: Array, b: Array, reading: float) -> tuple[Array, Array, Array]:
        """Multiply by ``N(y_k; m - h(p), P + Rf)`` and update each grid point's altitude (Kalman)."""
        live = w > 0
        m = np.where(live, a / np.where(live, w, 1.0), 0.0)
        P = np.where(live, np.maximum(b / np.where(live, w, 1.0) - m * m, 1e-9), 1.0)
        ground = np.broadcast_to(self.ground, w.shape)
        m, P, log_lik = altitude_kalman_update(m, P, ground, reading, float(self.scenario.Rf))
        log_w = np.where(live, np.log(np.where(live, w, 1.0)) + log_lik, -np.inf)
        top = log_w.max()
        if not np.isfinite(top):
            raise DegenerateWeightsError("every grid point has probability zero after the update")
        w = np.exp(log_w - top)
        w /= w.sum()
        return w, w * m, w * (m * m + P)

    def moments(self, w: Array, a: Array, k: int) -> tuple[Array, Array]:
        """Posterior mean ``(x, y, z, psi)`` and the standard deviations of ``x`` and ``y``."""
        s = self.scenario
        total = w.sum()
        wx, wy, wpsi = w.sum(axis=(0, 1)) / total, w.sum(axis=(0, 2)) / total, w.sum(axis=(1, 2)) / total
        mx, my = wx @ self.x, wy @ self.y
        psi = s.x0[3] + s.omega * s.times[k] + self.offsets
        mpsi = np.arctan2(wpsi @ np.sin(psi), wpsi @ np.cos(psi))
        sd = np.sqrt([wx @ (self.x - mx) ** 2, wy @ (self.y - my) ** 2])
        return np.array([mx, my, a.sum() / total, wrap_angle(mpsi)]), sd

    def run(self, measurements: Array, keep: int | None = None) -> GridResult:
        """Filter the altimeter readings (NaN when missing); ``keep``: a step whose ``w`` is kept in ``self.kept``."""
        z = np.asarray(measurements, dtype=float).reshape(-1)
        K = len(z)
        mean, sd = np.empty((K, 4)), np.empty((K, 2))
        w, a, b = self.initial()
        for k in range(K):
            if k > 0:
                w, a, b = self.predict(w, a, b, k)
            if not np.isnan(z[k]):
                w, a, b = self.update(w, a, b, z[k])
            mean[k], sd[k] = self.moments(w, a, k)
            if keep == k:
                self.kept = w.copy()
        return GridResult(mean=mean, sd=sd)
