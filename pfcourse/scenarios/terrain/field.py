"""The field's terrain-navigation problem: horizontal position only (Bergman 1999).

An aircraft in the field has an inertial navigation system (INS) that gives its heading and speed, so its
dead-reckoned displacement ``u_k`` over each step is known, up to a small drift; a barometer gives its
altitude.  What is left unknown is the horizontal position ``p = (x, y)``:

    p_k = p_{k-1} + u_k + w_k,   w_k ~ N(0, q dt I),
    y_k = h(p_k) + v_k,          v_k ~ N(0, R),

``y_k`` the barometric altitude minus the radar altimeter's height above the ground (a terrain height;
``R`` holds both instruments' errors) and ``w_k`` the INS drift.  Here ``u_k`` is the lab's flight path
(speed ``V``, turn rate ``omega``, initial heading ``psi_0``), and the truth has the drift the filter
assumes, so the filter's model is the world's and the exact posterior is the answer to compare with.

**The point-mass filter** (:class:`FieldPointMass`) holds the posterior of the *dead-reckoning error*
``e_k = p_k - d_k``, ``d_k = x_0 + u_1 + ... + u_k``, on a fixed lattice of ``cell`` metres: the known
motion moves ``d_k``, not the lattice, so the prediction is only the drift's convolution (a discrete
Gaussian kernel of variance ``q dt / cell^2`` cells^2 per axis, exact at any cell size) and the update
multiplies by ``N(y_k; h(d_k + e), R)`` at each lattice point (bilinear heights; zero off the map).  Only
the box that holds all but ``tail`` of the mass at each end of each axis is kept.  As ``cell`` shrinks the
grid's mean converges to the exact posterior mean; the refinement study measures by how much it still
moves.

:class:`FieldModel` is the bootstrap particle filter's model of the same problem (the engine's protocol).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy import ndimage

from pfcourse.checks import Array, as_generator, check_real, set_checked
from pfcourse.errors import DegenerateWeightsError, OffMapError, ParameterError
from pfcourse.scenarios.terrain.compiled import bilinear
from pfcourse.scenarios.terrain.map import TerrainMap
from pfcourse.scenarios.terrain.point_mass import _trimmed, heading_kernel
from pfcourse.scenarios.terrain.scenario import MAX_STEPS

_LOG_2PI = float(np.log(2.0 * np.pi))
#: Most lattice points the point-mass filter may hold.
MAX_POINTS = 20_000_000


@dataclass(frozen=True)
class FieldScenario:
    """The 2-D problem's parameters (m, s, rad); defaults: the lab's flight, prior and altimeter.

    ``drift`` is the INS drift's standard deviation per axis over one second (m), ``R`` the variance of a
    reading (m^2), ``sd0`` the prior's standard deviation per axis (m) about ``x0``.
    """

    speed: float = 100.0
    omega: float = -0.01
    heading0: float = float(np.radians(150.0))
    dt: float = 1.0
    duration: float = 80.0
    x0: Array = field(default_factory=lambda: np.array([21000.0, 11000.0]))
    sd0: float = 5000.0 / 3
    drift: float = 3.0
    R: float = 20.0**2

    def __post_init__(self) -> None:
        for name in ("speed", "omega", "heading0", "dt", "duration", "sd0", "drift", "R"):
            value = check_real(getattr(self, name), name)
            if name in ("dt", "duration", "sd0", "drift", "R") and value <= 0:
                raise ParameterError(f"{name} must be positive, got {value}")
            set_checked(self, **{name: value})
        if not self.duration / self.dt <= MAX_STEPS:
            raise ParameterError(f"duration / dt = {self.duration / self.dt:.3g} steps: at most {MAX_STEPS} "
                                 "steps are simulated")
        x0 = np.asarray(self.x0, dtype=float)
        if x0.shape != (2,) or not np.all(np.isfinite(x0)):
            raise ParameterError(f"x0 must be two finite numbers (m), got {self.x0!r}")
        set_checked(self, x0=x0)

    def with_(self, **changes) -> FieldScenario:
        return replace(self, **changes)

    @property
    def n_steps(self) -> int:
        return int(round(self.duration / self.dt)) + 1

    @property
    def displacements(self) -> Array:
        """``u_k`` ``(K, 2)`` (``u_0 = 0``): the INS's dead-reckoned motion over each step."""
        k = np.arange(self.n_steps - 1)
        psi = self.heading0 + self.omega * self.dt * k
        u = self.speed * self.dt * np.column_stack([np.cos(psi), np.sin(psi)])
        return np.vstack([np.zeros((1, 2)), u])

    @property
    def dead_reckoning(self) -> Array:
        """``d_k = x0 + u_1 + ... + u_k`` ``(K, 2)``."""
        return self.x0 + np.cumsum(self.displacements, axis=0)


@dataclass
class FieldFlight:
    """``truth`` ``(K, 2)`` positions and ``readings`` ``(K,)`` terrain heights measured (NaN at step 0)."""

    truth: Array
    readings: Array


def simulate_field(scenario: FieldScenario, terrain: TerrainMap, rng) -> FieldFlight:
    """Draw ``p_0 ~ N(x0, sd0^2 I)``, fly with the drift, and read ``h(p_k) + N(0, R)`` at ``k >= 1``."""
    rng = as_generator(rng)
    s = scenario
    p0 = s.x0 + s.sd0 * rng.standard_normal(2)
    drift = s.drift * np.sqrt(s.dt) * rng.standard_normal((s.n_steps, 2))
    drift[0] = 0.0
    truth = p0 + np.cumsum(s.displacements + drift, axis=0)
    if not terrain.contains(truth[:, 0], truth[:, 1]).all():
        raise OffMapError("the simulated flight leaves the map")
    ground = terrain.height(truth[:, 0], truth[:, 1])
    readings = ground + np.sqrt(s.R) * rng.standard_normal(s.n_steps)
    readings[0] = np.nan
    return FieldFlight(truth=truth, readings=readings)


class FieldModel:
    """The bootstrap filter's model of the 2-D problem: prior ``N(x0, sd0^2 I)``, ``p + u_k + N(0, q dt I)``,
    ``log N(y; h(p), R)`` (``-inf`` off the map)."""

    dim_x = 2
    angle_indices = ()

    def __init__(self, terrain: TerrainMap, scenario: FieldScenario) -> None:
        if not isinstance(scenario, FieldScenario) or not isinstance(terrain, TerrainMap):
            raise ParameterError("FieldModel needs a TerrainMap and a FieldScenario")
        self.terrain, self.scenario = terrain, scenario
        self._u = scenario.displacements
        self._heights = np.ascontiguousarray(terrain.heights, dtype=float)

    def sample_initial(self, n: int, rng: np.random.Generator) -> Array:
        return self.scenario.x0 + self.scenario.sd0 * rng.standard_normal((n, 2))

    def sample_transition(self, particles: Array, k: int, rng: np.random.Generator) -> Array:
        s = self.scenario
        return particles + self._u[k] + s.drift * np.sqrt(s.dt) * rng.standard_normal(np.shape(particles))

    def log_likelihood(self, particles: Array, z: Array, k: int) -> Array:
        h = bilinear(self._heights, self.terrain.dx, self.terrain.dy, np.ascontiguousarray(particles[:, 0]),
                     np.ascontiguousarray(particles[:, 1]))
        r = self.scenario.R
        nu = float(np.ravel(z)[0]) - h
        return np.where(np.isnan(h), -np.inf, -0.5 * (nu * nu / r + np.log(r) + _LOG_2PI))


@dataclass
class FieldGridResult:
    """``mean`` ``(K, 2)`` posterior means, ``sd`` ``(K, 2)`` standard deviations, ``points`` ``(K,)`` held."""

    mean: Array
    sd: Array
    points: Array


class FieldPointMass:
    """The point-mass filter of the module docstring, on a lattice of ``cell`` metres over ``±sigmas`` prior
    standard deviations of the dead-reckoning error."""

    def __init__(self, terrain: TerrainMap, scenario: FieldScenario, cell: float = 25.0, sigmas: float = 4.0,
                 tail: float = 1e-9) -> None:
        if not isinstance(scenario, FieldScenario) or not isinstance(terrain, TerrainMap):
            raise ParameterError("FieldPointMass needs a TerrainMap and a FieldScenario")
        self.cell, self.tail = check_real(cell, "cell"), check_real(tail, "tail")
        if self.cell <= 0 or not 0 <= self.tail < 0.01:
            raise ParameterError(f"cell must be positive and tail in [0, 0.01), got {cell} and {tail}")
        self.terrain, self.scenario = terrain, scenario
        half = int(np.ceil(sigmas * scenario.sd0 / self.cell))
        self.axis = np.arange(-half, half + 1) * self.cell  # the lattice of e along x and along y
        if len(self.axis) ** 2 > MAX_POINTS:
            raise ParameterError(f"{len(self.axis) ** 2} lattice points (cell = {cell} m): at most {MAX_POINTS}")
        self.kernel = heading_kernel(scenario.drift**2 * scenario.dt / self.cell**2)
        self._heights = np.ascontiguousarray(terrain.heights, dtype=float)

    def _log_likelihood(self, ex: Array, ey: Array, d: Array, reading: float) -> Array:
        X, Y = np.meshgrid(d[0] + ex, d[1] + ey)
        h = bilinear(self._heights, self.terrain.dx, self.terrain.dy, np.ascontiguousarray(X.ravel()),
                     np.ascontiguousarray(Y.ravel())).reshape(X.shape)
        nu = reading - h
        return np.where(np.isnan(h), -np.inf, -0.5 * nu * nu / self.scenario.R)

    def run(self, readings: Array) -> FieldGridResult:
        """Filter ``readings`` ``(K,)`` (NaN: no reading); ``self.w``, ``self.ex``, ``self.ey`` hold the last
        step's probabilities (rows y, columns x) and the error lattice they sit on."""
        s = self.scenario
        z = np.asarray(readings, dtype=float).reshape(-1)
        K = len(z)
        d = s.dead_reckoning
        n = len(self.axis)
        g = -0.5 * (self.axis / s.sd0) ** 2
        w = np.exp(g[:, None] + g[None, :])
        r0, r1, c0, c1 = 0, n, 0, n
        radius = len(self.kernel) // 2
        mean, sd, points = np.empty((K, 2)), np.empty((K, 2)), np.empty(K, dtype=int)
        for k in range(K):
            if k > 0 and radius > 0:  # the drift: pad by the kernel's radius (inside the lattice), convolve
                R0, R1, C0, C1 = max(r0 - radius, 0), min(r1 + radius, n), max(c0 - radius, 0), min(c1 + radius, n)
                big = np.zeros((R1 - R0, C1 - C0))
                big[r0 - R0:r1 - R0, c0 - C0:c1 - C0] = w
                big = ndimage.correlate1d(big, self.kernel, axis=0, mode="constant")
                w = ndimage.correlate1d(big, self.kernel, axis=1, mode="constant")
                r0, r1, c0, c1 = R0, R1, C0, C1
            ex, ey = self.axis[c0:c1], self.axis[r0:r1]
            if not np.isnan(z[k]):
                log_w = np.log(np.maximum(w, 1e-300)) + self._log_likelihood(ex, ey, d[k], z[k])
                log_w[w <= 0] = -np.inf
                top = log_w.max()
                if not np.isfinite(top):
                    raise DegenerateWeightsError(f"step {k}: every lattice point has probability zero")
                w = np.exp(log_w - top)
            w /= w.sum()
            points[k] = w.size
            (lr, hr), (lc, hc) = _trimmed(w.sum(axis=1), self.tail), _trimmed(w.sum(axis=0), self.tail)
            w = w[lr:hr, lc:hc]
            w /= w.sum()
            r0, r1, c0, c1 = r0 + lr, r0 + hr, c0 + lc, c0 + hc
            ex, ey = self.axis[c0:c1], self.axis[r0:r1]
            wx, wy = w.sum(axis=0), w.sum(axis=1)
            mx, my = wx @ ex, wy @ ey
            mean[k] = d[k] + np.array([mx, my])
            sd[k] = np.sqrt(np.maximum([wx @ ex**2 - mx**2, wy @ ey**2 - my**2], 0.0))
        self.w, self.ex, self.ey = w, ex, ey
        return FieldGridResult(mean=mean, sd=sd, points=points)


__all__ = ["FieldFlight", "FieldGridResult", "FieldModel", "FieldPointMass", "FieldScenario",
           "simulate_field"]
