"""Scenario B: terrain-aided navigation of an aircraft with a radar altimeter.

State ``x = (x, y, z, psi)``: position east and north on the map (m), altitude (m) and
heading ``psi`` (rad, counter-clockwise from east).  The aircraft flies at a known speed
``V`` and turn rate ``omega``; with time step ``dt``,

    x_{k+1} = x_k + V dt cos(psi_k),   y_{k+1} = y_k + V dt sin(psi_k),
    z_{k+1} = z_k,                     psi_{k+1} = psi_k + omega dt,

plus, in the filter, a process noise ``w_k ~ N(0, Qf dt)`` (``Qf`` is the covariance
accumulated over one second).  As in the lab report, the *true* aircraft follows the
dynamics without noise: ``Qf`` is the filter's allowance for model error.

The radar altimeter measures the height above the terrain,

    y_k = z_k - h(x_k, y_k) + v_k,   v_k ~ N(0, R),

with ``h`` the bilinear terrain height of a :class:`~pfcourse.scenarios.terrain.map.TerrainMap`.  The
filter assumes ``v_k ~ N(0, Rf)``.  A particle outside the map has likelihood zero
(log-likelihood ``-inf``); the particle filter raises
:class:`~pfcourse.errors.DegenerateWeightsError` only when every particle is off the map.

Measurements arrive every ``measurement_period`` seconds, except inside an optional gap
``[gap_start, gap_end]``; there is none at ``t = 0``.  Missing ones are NaN.

:class:`TerrainModel` is the particle filter's model (the protocol of
:class:`~pfcourse.filter.ParticleFilter`); :func:`simulate` draws a flight and its
measurements; :func:`kalman_model` is the scenario as the Kalman family reads it and
:func:`extended_kalman_filter` its EKF, with the terrain gradient as measurement Jacobian,
``H = [-dh/dx, -dh/dy, 1, 0]``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from pfcourse.angles import sigma_point_mean, wrap_angle
from pfcourse.checks import (
    Array,
    as_generator,
    as_vector,
    check_covariance,
    check_interval,
    check_real,
    check_simulated,
    covariance_factor,
    set_checked,
)
from pfcourse.errors import ParameterError
from pfcourse.kalman import GaussianModel, Linearised, Measurement, Transition, gaussian_filter
from pfcourse.results import KalmanResult
from pfcourse.scenarios.terrain.map import TerrainMap
from pfcourse.scenarios.terrain.compiled import aircraft_transition, altimeter_log_likelihood

_LOG_2PI = float(np.log(2.0 * np.pi))


#: The most steps a scenario may have (``duration / dt``): a larger number is a typo in ``dt``.
MAX_STEPS = 10**7


@dataclass(frozen=True)
class AircraftScenario:
    """Parameters of a terrain-navigation run (units: m, s, rad).

    ``x0`` is the filter's initial estimate and ``P0`` its covariance; the true initial
    state is drawn from ``N(x0, P0)``.  The defaults are the lab report's, scaled to the
    30 km map: speed 300 -> 100 m/s and horizontal prior standard deviation
    5000 -> 5000/3 m (lengths divided by 3); ``omega``, ``dt``, the 80 s duration, the
    altitude and heading uncertainties and ``Qf`` are the report's (``Qf``'s heading entry is
    the report code's ``0.001 * 180 / pi`` rad per second).  ``Qf`` (covariance per second) and ``Rf`` are the
    filter's noise covariances, ``R`` the altimeter's true noise variance.
    """

    speed: float = 100.0
    omega: float = -0.01
    dt: float = 1.0
    duration: float = 80.0
    x0: Array = field(default_factory=lambda: np.array([21000.0, 11000.0, 1500.0, np.radians(150.0)]))
    P0: Array = field(
        default_factory=lambda: np.diag([5000.0 / 3, 5000.0 / 3, 100.0, np.radians(20.0)]) ** 2
    )
    Qf: Array = field(default_factory=lambda: np.diag([3.0, 3.0, 0.6, 0.001 * 180.0 / np.pi]) ** 2)
    R: float = 20.0**2
    Rf: float = 20.0**2
    measurement_period: float = 1.0
    gap: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        for name in ("speed", "omega", "dt", "duration", "R", "Rf", "measurement_period"):
            value = check_real(getattr(self, name), name)  # a finite real number
            if name != "omega" and (value <= 0 if name != "speed" else value < 0):
                raise ParameterError(f"{name} must be {'non-negative' if name == 'speed' else 'positive'}, got {value}")
            set_checked(self, **{name: value})
        if not self.duration / self.dt <= MAX_STEPS:
            raise ParameterError(f"duration / dt = {self.duration / self.dt:.3g} steps: at most {MAX_STEPS} "
                                 f"(dt = {self.dt} s is too small for duration = {self.duration} s)")
        set_checked(self, gap=check_interval(self.gap, "gap"))
        set_checked(self, x0=as_vector(self.x0, "x0", 4, finite=True), P0=check_covariance(self.P0, "P0", 4),
                    Qf=check_covariance(self.Qf, "Qf", 4))

    def with_(self, **changes) -> AircraftScenario:
        """A copy with some parameters changed (checked again)."""
        return replace(self, **changes)

    @property
    def n_steps(self) -> int:
        """Number of samples ``K``: times ``0, dt, ..., duration``."""
        return int(round(self.duration / self.dt)) + 1

    @property
    def times(self) -> Array:
        """Sampling instants ``t_k = k dt`` (s)."""
        return np.arange(self.n_steps) * self.dt

    def measured(self) -> Array:
        """Boolean mask of the steps with an altimeter measurement.

        ``t_k > 0``, ``t_k`` a multiple of ``measurement_period`` (to 1e-9 s), and outside
        the gap ``[gap_start, gap_end]`` if there is one.
        """
        t = self.times
        ratio = t / self.measurement_period
        on_period = np.abs(ratio - np.round(ratio)) < 1e-9 / self.measurement_period
        mask = (t > 0) & on_period
        if self.gap is not None:
            mask &= ~((t >= self.gap[0] - 1e-9) & (t <= self.gap[1] + 1e-9))
        return mask

    def model(self, terrain: TerrainMap) -> TerrainModel:
        """The particle filter's model of this scenario over ``terrain``."""
        return TerrainModel(terrain, self)


def _check_flight(scenario, terrain) -> None:
    """``scenario`` must be an :class:`AircraftScenario` and ``terrain`` a :class:`TerrainMap` (whose
    fields are checked when they are built): a named ``ParameterError`` otherwise."""
    if not isinstance(scenario, AircraftScenario):
        raise ParameterError(f"scenario must be an AircraftScenario, got {type(scenario).__name__}")
    if not isinstance(terrain, TerrainMap):
        raise ParameterError(f"terrain must be a TerrainMap (load_jacksboro(), or TerrainMap(heights, dx, dy)), "
                             f"got {type(terrain).__name__}")


def propagate(states: Array, speed: float, omega: float, dt: float) -> Array:
    """Noise-free dynamics ``f(x)`` of every row of ``states`` ``(..., 4)``; heading wrapped."""
    states = np.asarray(states, dtype=float)
    out = np.empty_like(states)
    psi = states[..., 3]
    out[..., 0] = states[..., 0] + speed * dt * np.cos(psi)
    out[..., 1] = states[..., 1] + speed * dt * np.sin(psi)
    out[..., 2] = states[..., 2]
    out[..., 3] = wrap_angle(psi + omega * dt)
    return out


def dynamics_jacobian(state: Array, speed: float, dt: float) -> Array:
    """``F = df/dx`` at ``state``: identity plus ``-V dt sin(psi)`` and ``V dt cos(psi)`` in column 4."""
    F = np.eye(4)
    F[0, 3] = -speed * dt * np.sin(state[3])
    F[1, 3] = speed * dt * np.cos(state[3])
    return F


def predicted_measurement(states: Array, terrain: TerrainMap) -> Array:
    """``z - h(x, y)`` for every row of ``states`` ``(..., 4)``; NaN off the map."""
    states = np.asarray(states, dtype=float)
    return states[..., 2] - terrain.height(states[..., 0], states[..., 1])


def measurement_jacobian(state: Array, terrain: TerrainMap) -> Array:
    """``H = d(z - h(x, y))/dx = [-dh/dx, -dh/dy, 1, 0]`` as a ``(1, 4)`` matrix."""
    gx, gy = terrain.gradient(state[0], state[1])
    return np.array([[-float(gx), -float(gy), 1.0, 0.0]])


class TerrainModel:
    """The particle filter's model of scenario B (see the module docstring).

    ``sample_initial`` draws from ``N(x0, P0)``, ``sample_transition`` applies
    :func:`propagate` plus ``N(0, Qf dt)``, ``log_likelihood`` is the Gaussian
    ``log N(y; z - h(x, y), Rf)``, ``-inf`` off the map.
    """

    dim_x = 4
    angle_indices = (3,)

    def __init__(self, terrain: TerrainMap, scenario: AircraftScenario) -> None:
        _check_flight(scenario, terrain)
        self.terrain = terrain
        self.scenario = scenario
        self._init_factor = covariance_factor(scenario.P0)
        self._noise_factor = np.ascontiguousarray(covariance_factor(scenario.Qf * scenario.dt))
        self._heights = np.ascontiguousarray(terrain.heights, dtype=float)

    def sample_initial(self, n: int, rng: np.random.Generator) -> Array:
        x = self.scenario.x0 + rng.standard_normal((n, 4)) @ self._init_factor.T
        x[:, 3] = wrap_angle(x[:, 3])
        return x

    def sample_transition(self, particles: Array, k: int, rng: np.random.Generator) -> Array:
        """``f(x) + N(0, Qf dt)``, one compiled pass (:func:`pfcourse.scenarios.terrain.compiled.aircraft_transition`)."""
        s = self.scenario
        noise = rng.standard_normal(np.shape(particles))
        return aircraft_transition(np.ascontiguousarray(particles, dtype=float), noise,
                                   self._noise_factor, s.speed, s.omega, s.dt)

    def log_likelihood(self, particles: Array, z: Array, k: int) -> Array:
        """``log N(y; z - h(x, y), Rf)``, ``-inf`` off the map (compiled bilinear lookup)."""
        rf = float(self.scenario.Rf)
        return altimeter_log_likelihood(np.ascontiguousarray(particles, dtype=float), self._heights,
                                        self.terrain.dx, self.terrain.dy, float(np.ravel(z)[0]), rf,
                                        -0.5 * (np.log(rf) + _LOG_2PI))


@dataclass
class Flight:
    """One simulated flight: ``T`` ``(K,)`` times (s), ``truth`` ``(K, 4)`` true states,
    ``measurements`` ``(K, 1)`` altimeter readings (NaN when not measured) and ``terrain_height``
    ``(K,)`` the ground height under the aircraft."""

    T: Array
    truth: Array
    measurements: Array
    terrain_height: Array


def simulate(
    scenario: AircraftScenario,
    terrain: TerrainMap,
    rng: np.random.Generator | int | None = None,
    *,
    initial_state: Array | None = None,
) -> Flight:
    """Draw the true initial state from ``N(x0, P0)`` (unless given), fly, and measure.

    ``rng`` (a Generator or an integer seed) must be given: :class:`~pfcourse.errors.ParameterError`
    otherwise.
    The true dynamics have no process noise; readings are ``z - h(x, y) + N(0, R)``.
    The flight must stay on the map: :class:`~pfcourse.errors.OffMapError` otherwise.
    """
    _check_flight(scenario, terrain)
    rng = as_generator(rng)
    s = scenario
    if initial_state is None:
        state = s.x0 + covariance_factor(s.P0) @ rng.standard_normal(4)
    else:
        state = as_vector(initial_state, "initial_state", 4, finite=True).copy()
    state[3] = wrap_angle(state[3])
    K = s.n_steps
    X = np.empty((K, 4))
    X[0] = state
    for k in range(1, K):
        X[k] = propagate(X[k - 1], s.speed, s.omega, s.dt)
    check_simulated("states", X)
    ground = terrain.height_checked(X[:, 0], X[:, 1])
    noise = rng.normal(0.0, np.sqrt(s.R), K)
    Z = np.where(s.measured(), X[:, 2] - ground + noise, np.nan)[:, None]
    check_simulated("altimeter readings", Z, missing=True)
    return Flight(T=s.times, truth=X, measurements=Z, terrain_height=ground)


def state_residual(a: Array, b: Array) -> Array:
    """``a - b`` for aircraft states ``(4,)`` with the heading difference wrapped."""
    y = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    y[3] = wrap_angle(y[3])
    return y


def state_mean(sigmas: Array, weights: Array) -> Array:
    """Weighted mean of sigma points ``(n, 4)``; circular mean of the heading."""
    return sigma_point_mean(sigmas, weights, (3,))


def kalman_model(scenario: AircraftScenario, terrain: TerrainMap) -> GaussianModel:
    """Scenario B as the Kalman family reads it (:class:`pfcourse.kalman.GaussianModel`).

    Prior ``N(x0, P0)``; ``f`` = :func:`propagate`, ``F`` = :func:`dynamics_jacobian` at the
    previous estimate, ``Q = Qf dt``; a reading ``y`` (NaN: none) has ``h(x) = z - h_terrain(x, y)``
    (:func:`predicted_measurement`), ``H = [-dh/dx, -dh/dy, 1, 0]`` (:func:`measurement_jacobian`),
    ``R = Rf``; the heading through :func:`state_residual` and :func:`state_mean`, wrapped in every
    estimate.  ``h`` has no value off the map: a filter whose mean (or, for the UKF, a sigma point)
    leaves it is lost there.
    """
    _check_flight(scenario, terrain)
    s = scenario
    Q, R = s.Qf * s.dt, np.array([[s.Rf]])

    def transition(k: int, m: Array) -> Transition:
        return Transition(lambda x: propagate(x, s.speed, s.omega, s.dt), Q, dynamics_jacobian(m, s.speed, s.dt))

    def measurement(k: int, z: float) -> Measurement | None:
        if np.isnan(z):
            return None
        return Measurement(np.array([z]), lambda x: np.array([predicted_measurement(x, terrain)]), R,
                           lambda x: measurement_jacobian(x, terrain))

    def wrap_heading(x: Array) -> Array:
        x = x.copy()
        x[3] = wrap_angle(x[3])
        return x

    return GaussianModel(s.x0, s.P0, 1, transition, measurement, residual_x=state_residual, mean_x=state_mean,
                         wrap=wrap_heading, on_domain=lambda p: bool(terrain.contains(p[:, 0], p[:, 1]).all()))


def extended_kalman_filter(
    scenario: AircraftScenario, terrain: TerrainMap, measurements: Array
) -> KalmanResult:
    """The EKF of scenario B (:func:`kalman_model`, :class:`pfcourse.kalman.Linearised`).

    Predict: ``x = f(x)``, ``P = F P F^T + Qf dt`` with ``F`` from :func:`dynamics_jacobian`
    at the previous estimate.  Update (when measured): ``H = [-dh/dx, -dh/dy, 1, 0]`` at the
    predicted estimate (:meth:`TerrainMap.gradient`), innovation ``y - (z - h(x, y))``,
    ``R = Rf``.  If the estimate leaves the map the run stops (``lost_at``; :class:`~pfcourse.results.KalmanResult`).
    """
    readings = np.asarray(measurements, dtype=float).reshape(-1)
    return gaussian_filter(kalman_model(scenario, terrain), Linearised(), readings, "EKF", log_likelihood=False)
