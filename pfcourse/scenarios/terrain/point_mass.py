"""A point-mass (grid) filter for terrain navigation, altitude integrated out (after Bergman 1999).

The posterior over the horizontal position ``p = (x, y)`` and the heading ``psi`` is held as
probabilities ``w[j, r, c]`` on a regular grid: points ``x = c cell``, ``y = r cell`` of one lattice
over the whole map, and heading bins ``psi_j = psi_0 + omega t_k + (j - J) dpsi``, a grid that turns
with the known turn rate, so the deterministic part of the heading's motion is exact.  Only a box of
the lattice is held, the smallest that keeps all but ``tail`` of the mass at either end of each axis,
so the cost follows the posterior: the prior's box early, a few kilometres once the readings agree.
Each grid point also carries a Gaussian ``N(m, P)`` for the altitude (the linear part of the state,
as in the marginalised particle filter of :mod:`pfcourse.scenarios.terrain.marginalised`), stored as the
moments ``a = w m`` and ``b = w (m^2 + P)``.

**Prediction** (a convolution).  Heading layer ``j`` flies the dead-reckoned path of its heading;
its displacement since ``t_0`` is summed exactly,

    D_j(k) = sum_{i < k} V dt (cos psi_j(t_i), sin psi_j(t_i)),

and the layer's array is moved by whole cells, ``n_j(k) - n_j(k-1)`` with ``n_j(k) = round(D_j(k) / cell)``
(per axis), while its points are taken to lie at the lattice plus the residual
``rho_j(k) = D_j(k) - n_j(k) cell`` (less than half a cell): layer ``j``'s point ``(r, c)`` is at
``(x_c, y_r) + rho_j(k)``.  The shift is exact (no interpolation, no numerical diffusion): mass that
keeps its heading bin is where the dynamics put it, at every step, and the map is read there.
Mass that changes bin (the heading noise) keeps its lattice point and takes the other layer's
residual, a move of less than a cell;
the resolution study measures what these moves leave.  The heading noise
``N(0, Qf_psi dt)`` is a convolution along the heading axis with the discrete Gaussian kernel
``T(n) = exp(-s) I_n(s)``, ``s = Qf_psi dt / dpsi^2`` (``scipy.special.ive``), whose variance is exactly
``s`` bins squared at any bin size; the altitude variance grows by ``Qf_z dt`` (``b += w Qf_z dt``).
Convolving ``w``, ``w m`` and ``w (m^2 + P)`` with the same kernel merges the Gaussians that land on
a grid point into one with the mixture's mean and variance (moment matching).  The horizontal
process noise (``sqrt(Qf_xx dt)``, a few metres) is far below a cell and is left out.

**Update** (a product): at every grid point ``m = a / w``, ``P = b / w - m^2`` and, with the ground
height ``h(p)`` of the point (:func:`ground_on_lattice`, the map's bilinear height), the scalar Kalman update of :func:`pfcourse.scenarios.terrain.marginalised.altitude_kalman_update`;
``w`` is multiplied by the predictive density ``N(y_k; m - h(p), P + Rf)`` and renormalised.
The lattice covers the map only: mass moved off the map is dropped, and a point whose residual puts
it off the map has probability zero at the next reading.

The first box covers the prior's ``±position_sigmas`` standard deviations in position, cut to the
map; the heading grid covers ``±heading_sigmas`` standard deviations of the heading's prior plus its
random walk over the flight.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage, special

from pfcourse.angles import resultant_direction, wrap_angle
from pfcourse.checks import Array, check_real
from pfcourse.errors import DegenerateWeightsError, ParameterError
from pfcourse.scenarios.terrain.map import TerrainMap
from pfcourse.scenarios.terrain.marginalised import altitude_kalman_update
from pfcourse.scenarios.terrain.scenario import AircraftScenario, _check_flight

#: Most grid points a filter may hold at one step (three float arrays of this size, and temporaries).
MAX_CELLS = 20_000_000


@dataclass
class GridResult:
    """``mean`` ``(K, 4)``: posterior mean of ``(x, y, z, psi)`` at each step (circular for ``psi``);
    ``sd`` ``(K, 2)``: posterior standard deviations of ``x`` and ``y``; ``cells`` ``(K,)``: grid points held."""

    mean: Array
    sd: Array
    cells: Array


def heading_kernel(variance_bins: float) -> Array:
    """The discrete Gaussian kernel ``T(n) = exp(-s) I_n(s)``, ``|n| <= ceil(4 sqrt(s)) + 1``, renormalised:
    a kernel of variance ``s`` (bins squared), exactly, even when ``s`` is below one."""
    radius = int(np.ceil(4.0 * np.sqrt(variance_bins))) + 1
    kernel = special.ive(np.arange(-radius, radius + 1), variance_bins)
    return kernel / kernel.sum()


def _axis_weights(coords: Array, spacing: float, n_nodes: int) -> tuple[Array, Array, Array]:
    """Bilinear weights along one axis: node ``i`` below each coordinate, its fraction ``f`` to the next
    node, and whether the coordinate is on the map (``0 <= coord <= (n_nodes - 1) spacing``)."""
    u = coords / spacing
    inside = (u >= 0) & (u <= n_nodes - 1)
    i = np.clip(np.floor(u).astype(int), 0, n_nodes - 2)
    return i, np.clip(u - i, 0.0, 1.0), inside


def ground_on_lattice(terrain: TerrainMap, x: Array, y: Array) -> Array:
    """``terrain.height`` at every ``(x[c], y[r])``, as an ``(len(y), len(x))`` array, NaN off the map: the same
    bilinear formula, done one axis after the other (rows first, then columns)."""
    ny, nx = terrain.shape
    i, fx, in_x = _axis_weights(np.asarray(x, dtype=float), terrain.dx, nx)
    r, fy, in_y = _axis_weights(np.asarray(y, dtype=float), terrain.dy, ny)
    h = terrain.heights
    rows = (1.0 - fy)[:, None] * h[r] + fy[:, None] * h[r + 1]  # (len(y), nx): along y at every map column
    out = (1.0 - fx) * rows[:, i] + fx * rows[:, i + 1]
    out[~(in_y[:, None] & in_x[None, :])] = np.nan
    return out


def _trimmed(mass: Array, tail: float) -> tuple[int, int]:
    """``(lo, hi)``: the shortest range of ``mass`` (a marginal) leaving at most ``tail`` of the total at each end."""
    c = np.cumsum(mass) / mass.sum()
    lo = int(np.searchsorted(c, tail, side="right"))
    hi = int(np.searchsorted(c, 1.0 - tail, side="left")) + 1
    return lo, max(min(hi, len(mass)), lo + 1)


class PointMassFilter:
    """The point-mass filter of the module docstring, on the grid fixed by ``cell`` (m) and ``heading_step`` (rad).

    ``position_sigmas`` and ``heading_sigmas`` set how many prior standard deviations the grid covers;
    ``tail`` is the mass the box may leave out at each end of each axis.
    """

    def __init__(self, terrain: TerrainMap, scenario: AircraftScenario, cell: float = 100.0,
                 heading_step: float = np.radians(2.0), position_sigmas: float = 3.5,
                 heading_sigmas: float = 3.0, tail: float = 1e-9) -> None:
        _check_flight(scenario, terrain)
        self.cell = check_real(cell, "cell")
        self.heading_step = check_real(heading_step, "heading_step")
        self.tail = check_real(tail, "tail")
        if self.cell <= 0 or self.heading_step <= 0:
            raise ParameterError(f"cell and heading_step must be positive, got {cell} and {heading_step}")
        if not 0 <= self.tail < 0.01:
            raise ParameterError(f"tail must be in [0, 0.01), got {tail}")
        s = scenario
        if np.any(np.diag(np.diag(s.P0)) != s.P0) or np.any(np.diag(np.diag(s.Qf)) != s.Qf):
            raise ParameterError("the point-mass filter needs diagonal P0 and Qf (independent components)")
        self.terrain, self.scenario = terrain, s
        self.step = 0  # the step k the arrays held describe
        sd_psi = float(np.sqrt(s.P0[3, 3] + s.Qf[3, 3] * s.duration))
        half = int(np.ceil(heading_sigmas * sd_psi / self.heading_step))
        self.offsets = np.arange(-half, half + 1) * self.heading_step  # psi_j - (psi_0 + omega t_k)
        # Each layer's dead-reckoned displacement D_j(k), summed exactly, and its rounding n_j(k) in cells.
        psi = s.x0[3] + s.omega * s.times[None, :-1] + self.offsets[:, None]
        zero = np.zeros((len(self.offsets), 1))
        self.displacement = np.stack([np.hstack([zero, np.cumsum(s.speed * s.dt * np.cos(psi), axis=1)]),
                                      np.hstack([zero, np.cumsum(s.speed * s.dt * np.sin(psi), axis=1)])])
        self.steps = np.rint(self.displacement / self.cell).astype(int)  # (2, J, K): n_j(k) along x and y
        # The lattice over the map, and the ground height at each of its points.
        self.x_all = np.arange(0.0, terrain.width + 1e-9, self.cell)
        self.y_all = np.arange(0.0, terrain.height_extent + 1e-9, self.cell)
        box = position_sigmas * np.sqrt(np.diag(s.P0)[:2])
        c0, c1 = np.searchsorted(self.x_all, [s.x0[0] - box[0], s.x0[0] + box[0]], side="left")
        r0, r1 = np.searchsorted(self.y_all, [s.x0[1] - box[1], s.x0[1] + box[1]], side="left")
        if c1 <= c0 or r1 <= r0:
            raise ParameterError("the prior's grid window does not meet the map")
        self.first_box = (0, len(self.offsets), int(r0), int(r1), int(c0), int(c1))  # layers, rows, columns
        self.box = self.first_box  # the box held now
        self.n_cells = self._size(self.box)
        if self.n_cells > MAX_CELLS:
            raise ParameterError(f"{self.n_cells} grid points (cell={cell} m, heading_step={heading_step} rad): "
                                 f"at most {MAX_CELLS}; take coarser cells")
        self.kernel = heading_kernel(float(s.Qf[3, 3] * s.dt) / self.heading_step**2)

    @staticmethod
    def _size(box: tuple[int, ...]) -> int:
        j0, j1, r0, r1, c0, c1 = box
        return (j1 - j0) * (r1 - r0) * (c1 - c0)

    @property
    def residual(self) -> Array:
        """``(2, layers)``: ``D_j(k) - n_j(k) cell`` along x and y for the layers held, at the step held: layer
        ``j``'s point ``(r, c)`` lies at ``(x_c, y_r)`` plus this (within half a cell of the lattice)."""
        j0, j1 = self.box[:2]
        return self.displacement[:, j0:j1, self.step] - self.steps[:, j0:j1, self.step] * self.cell

    @property
    def x(self) -> Array:
        """Eastings of the columns held (m)."""
        return self.x_all[self.box[4]:self.box[5]]

    @property
    def y(self) -> Array:
        """Northings of the rows held (m)."""
        return self.y_all[self.box[2]:self.box[3]]

    def initial(self) -> tuple[Array, Array, Array]:
        """``(w, a, b)`` of the prior: ``w`` the Gaussian prior's probabilities at the grid points,
        every altitude ``N(x0_z, P0_zz)``."""
        s = self.scenario
        self.step = 0
        gx = -0.5 * (self.x - s.x0[0]) ** 2 / s.P0[0, 0]
        gy = -0.5 * (self.y - s.x0[1]) ** 2 / s.P0[1, 1]
        gpsi = -0.5 * self.offsets**2 / s.P0[3, 3]
        log_w = gpsi[:, None, None] + gy[None, :, None] + gx[None, None, :]
        w = np.exp(log_w - log_w.max())
        w /= w.sum()
        return w, w * s.x0[2], w * (s.x0[2] ** 2 + s.P0[2, 2])

    def predict(self, w: Array, a: Array, b: Array, k: int) -> tuple[Array, Array, Array]:
        """From step ``k - 1`` to ``k``: move each heading layer by whole cells, convolve along the
        heading, grow the altitude variance.  The box grows to hold the moved mass (cut to the map)."""
        s = self.scenario
        j0, j1, r0, r1, c0, c1 = self.box
        move = self.steps[:, j0:j1, k] - self.steps[:, j0:j1, k - 1]  # (2, layers): whole cells along x, y
        radius = len(self.kernel) // 2
        J0, J1 = max(j0 - radius, 0), min(j1 + radius, len(self.offsets))
        R0, R1 = max(r0 + move[1].min(), 0), min(r1 + move[1].max(), len(self.y_all))
        C0, C1 = max(c0 + move[0].min(), 0), min(c1 + move[0].max(), len(self.x_all))
        new_box = (J0, J1, int(R0), int(R1), int(C0), int(C1))
        if self._size(new_box) > MAX_CELLS:
            raise ParameterError(f"{self._size(new_box)} grid points at step {k}: at most {MAX_CELLS}; take coarser cells")
        moved = np.zeros((3, J1 - J0, R1 - R0, C1 - C0))
        stack = (w, a, b)
        for i in range(j1 - j0):
            # rows r0..r1 go to r0 + dy..r1 + dy, cut to the new box (which is cut to the map)
            dst_r0, dst_c0 = r0 + move[1, i], c0 + move[0, i]
            lo_r, hi_r = max(dst_r0, R0), min(dst_r0 + r1 - r0, R1)
            lo_c, hi_c = max(dst_c0, C0), min(dst_c0 + c1 - c0, C1)
            if hi_r <= lo_r or hi_c <= lo_c:
                continue
            for q in range(3):
                moved[q, j0 + i - J0, lo_r - R0:hi_r - R0, lo_c - C0:hi_c - C0] = \
                    stack[q][i, lo_r - dst_r0:hi_r - dst_r0, lo_c - dst_c0:hi_c - dst_c0]
        if radius > 0:
            moved = ndimage.correlate1d(moved, self.kernel, axis=1, mode="constant", cval=0.0)
        self.box, self.step = new_box, k
        w, a, b = moved
        b = b + w * s.Qf[2, 2] * s.dt
        return w, a, b

    def update(self, w: Array, a: Array, b: Array, reading: float) -> tuple[Array, Array, Array]:
        """Multiply by ``N(y_k; m - h(p), P + Rf)`` and update each grid point's altitude (Kalman)."""
        live = w > 0
        m = np.where(live, a / np.where(live, w, 1.0), 0.0)
        P = np.where(live, np.maximum(b / np.where(live, w, 1.0) - m * m, 1e-9), 1.0)
        rx, ry = self.residual
        ground = np.stack([ground_on_lattice(self.terrain, self.x + dx, self.y + dy) for dx, dy in zip(rx, ry)])
        m, P, log_lik = altitude_kalman_update(m, P, ground, reading, float(self.scenario.Rf))
        log_w = np.where(live, np.log(np.where(live, w, 1.0)) + log_lik, -np.inf)
        top = log_w.max()
        if not np.isfinite(top):
            raise DegenerateWeightsError("every grid point has probability zero after the update")
        w = np.exp(log_w - top)
        w /= w.sum()
        return w, w * m, w * (m * m + P)

    def trim(self, w: Array, a: Array, b: Array) -> tuple[Array, Array, Array]:
        """Cut the box to the shortest ranges that leave at most ``tail`` of the mass at each end of each axis."""
        if w.sum() <= 0:
            raise DegenerateWeightsError("every grid point has probability zero (all the mass left the map)")
        j0, _, r0, _, c0, _ = self.box
        (lj, hj), (lr, hr), (lc, hc) = (_trimmed(w.sum(axis=other), self.tail)
                                        for other in ((1, 2), (0, 2), (0, 1)))
        self.box = (j0 + lj, j0 + hj, r0 + lr, r0 + hr, c0 + lc, c0 + hc)
        return tuple(arr[lj:hj, lr:hr, lc:hc] for arr in (w, a, b))

    def moments(self, w: Array, a: Array, k: int) -> tuple[Array, Array]:
        """Posterior mean ``(x, y, z, psi)`` and the standard deviations of ``x`` and ``y``."""
        s = self.scenario
        total = w.sum()
        wx, wy, wpsi = w.sum(axis=(0, 1)) / total, w.sum(axis=(0, 2)) / total, w.sum(axis=(1, 2)) / total
        rx, ry = self.residual
        # each layer's points lie at the lattice plus the layer's residual
        mx, my = wx @ self.x + wpsi @ rx, wy @ self.y + wpsi @ ry
        ex = (w.sum(axis=1) @ self.x) / total  # (layers,): sum over the layer of w x
        ey = (w.sum(axis=2) @ self.y) / total
        vx = wx @ self.x**2 + 2 * ex @ rx + wpsi @ rx**2 - mx**2
        vy = wy @ self.y**2 + 2 * ey @ ry + wpsi @ ry**2 - my**2
        psi = s.x0[3] + s.omega * s.times[k] + self.offsets[self.box[0]:self.box[1]]
        mpsi = resultant_direction(psi, wpsi)
        sd = np.sqrt(np.maximum([vx, vy], 0.0))
        return np.array([mx, my, a.sum() / total, wrap_angle(mpsi)]), sd

    def run(self, measurements: Array, keep: int | None = None) -> GridResult:
        """Filter the altimeter readings (NaN when missing); ``keep``: a step whose ``w`` is kept in
        ``self.kept`` (heading, rows, columns), its eastings and northings in ``self.kept_x``, ``self.kept_y``.
        ``self.n_cells`` is then the most grid points held at one step."""
        z = np.asarray(measurements, dtype=float).reshape(-1)
        K = len(z)
        mean, sd, cells = np.empty((K, 4)), np.empty((K, 2)), np.empty(K, dtype=int)
        self.box = self.first_box
        w, a, b = self.initial()
        for k in range(K):
            if k > 0:
                w, a, b = self.predict(w, a, b, k)
            if not np.isnan(z[k]):
                w, a, b = self.update(w, a, b, z[k])
            cells[k] = w.size
            w, a, b = self.trim(w, a, b)
            mean[k], sd[k] = self.moments(w, a, k)
            if keep == k:
                self.kept, self.kept_x, self.kept_y = w.copy(), self.x.copy(), self.y.copy()
        self.n_cells = int(cells.max())
        return GridResult(mean=mean, sd=sd, cells=cells)
