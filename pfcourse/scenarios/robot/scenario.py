"""Mobile robot localization with range-bearing landmarks: simulator and particle-filter model.

The robot state is ``x = (p_x, p_y, theta)`` (metres, metres, radians in (-pi, pi]).
It is driven by a velocity command ``u_k = (v_x, v_y, omega)`` expressed in the
robot frame, integrated over one prediction step ``dt`` (Euler)::

    f(x, u) = ( p_x + (v_x cos theta - v_y sin theta) dt,
                p_y + (v_x sin theta + v_y cos theta) dt,
                wrap(theta + omega dt) ).

**Truth and odometry.**  The true path follows the true commands exactly,
``x_k = f(x_{k-1}, u_k)``.  The robot only knows its *odometry*, the commands
read with an error, ``u~_k = u_k + e_k`` with ``e_k ~ N(0, QTrue)``; integrating
the odometry alone gives the drifting dead-reckoning path.  Since
``x_k = f(x_{k-1}, u~_k - e_k)``, the filter's transition is

    x_k = f(x_{k-1}, u~_k + w_k),   w_k ~ N(0, QEst)        (QEst = QTrue is exact).

**Measurements.**  At a measurement step the robot observes one landmark
``j`` drawn uniformly among the ``M`` landmarks ``l^j`` (it knows which one: the
data association is given) as a range and a bearing relative to its heading::

    h_j(x) = ( ||l^j - p||,  wrap(atan2(l^j_y - p_y, l^j_x - p_x) - theta) ),
    z_k = h_j(x_k) + v_k,   v_k ~ N(0, RTrue),  bearing wrapped.

**How the data reach a filter.**  :func:`simulate_robot` returns the
measurements as an array of shape ``(K, 3)`` whose row ``k`` is
``(j, range, bearing)``, the landmark index stored as a float; a row of NaN
means "no measurement at step k", which :class:`pfcourse.filter.ParticleFilter`
already treats as missing.  The odometry ``u~_k`` is *held by the model*
(:class:`RobotModel` keeps the ``(K, 3)`` array and reads row ``k`` in
``sample_transition(x, k, rng)``), so the same measurement array feeds the
particle filter, the EKF and the UKF (:mod:`pfcourse.scenarios.robot.kalman`).

**Timing.**  Step ``k`` is time ``t_k = k dt``.  A measurement is taken at step
``k >= 1`` when a multiple of ``dt_meas`` falls in ``(t_{k-1}, t_k]`` (so
``dt_meas >= dt``: at most one measurement per prediction step), unless ``t_k``
lies in the measurement gap ``[gap[0], gap[1])``.

Every random draw of :func:`simulate_robot` comes from four independent streams
spawned from the seed (landmarks, odometry errors, measurement errors, landmark
choice), and the errors are drawn for *every* step: changing ``dt_meas``, the
gap or the number of landmarks leaves the other draws of a seeded run unchanged,
so a study that varies one setting compares like with like.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from pfcourse.angles import wrap, wrap_angle
from pfcourse.checks import (
    Array,
    as_float,
    as_generator,
    as_matrix,
    as_points,
    as_vector,
    check_count,
    check_covariance,
    check_fits,
    check_interval,
    check_real,
    check_simulated,
    covariance_factor,
    set_checked,
)
from pfcourse.errors import MeasurementError, ParameterError, ShapeError
from pfcourse.compiled import jit
from pfcourse.gaussian import gaussian_logpdf
from pfcourse import metrics


#: Standard deviations of the odometry error per step: 0.02 m/s, 0.02 m/s, 1 deg/s.
Q_TRUE = np.diag([0.02, 0.02, np.deg2rad(1.0)]) ** 2
#: Standard deviations of the measurement error: 0.5 m in range, 1 deg in bearing.
R_TRUE = np.diag([0.5, np.deg2rad(1.0)]) ** 2
#: Standard deviations of the initial cloud around the truth (tracking): 1 m, 1 m, 0.1 rad.
INITIAL_STD = (1.0, 1.0, 0.1)
#: Indices of angle components of the state (the heading).
ANGLE_INDICES = (2,)


def motion(states: Array, controls: Array, dt: float) -> Array:
    """Apply ``f(x, u)`` (module docstring) row by row; ``states`` and ``controls`` broadcast to ``(..., 3)``.

    The heading of the result is wrapped to (-pi, pi].  Other shapes, non-real arrays and a
    non-finite ``dt`` raise a named error (:mod:`pfcourse.errors`).
    """
    states = as_points(states, "states", 3)
    controls = as_points(controls, "controls", 3)
    dt = check_real(dt, "dt")
    theta = states[..., 2]
    c, s = np.cos(theta), np.sin(theta)
    vx, vy = controls[..., 0], controls[..., 1]
    try:
        shape = np.broadcast_shapes(states.shape, controls.shape)
    except ValueError:
        raise ShapeError(f"states {states.shape} and controls {controls.shape} do not broadcast together") from None
    out = np.empty(shape)
    out[..., 0] = states[..., 0] + (vx * c - vy * s) * dt
    out[..., 1] = states[..., 1] + (vx * s + vy * c) * dt
    out[..., 2] = wrap_angle(theta + controls[..., 2] * dt)
    return out


def range_bearing(states: Array, landmark: Array) -> Array:
    """``h_j(x) = (range, bearing)`` of one landmark ``(2,)`` seen from ``states`` ``(..., 3)``; shape ``(..., 2)``."""
    states = as_points(states, "states", 3)
    landmark = as_vector(landmark, "landmark", 2)
    dx = landmark[0] - states[..., 0]
    dy = landmark[1] - states[..., 1]
    out = np.empty(states.shape[:-1] + (2,))
    out[..., 0] = np.hypot(dx, dy)
    out[..., 1] = wrap_angle(np.arctan2(dy, dx) - states[..., 2])
    return out


@dataclass(frozen=True)
class RobotScenario:
    """Settings of a simulated run (defaults: scenario C of the course, reports 002 and 004).

    ``n_steps`` steps of ``dt`` seconds (step 0 is the start); odometry error
    covariance ``q_true`` and measurement error covariance ``r_true``; start
    ``start``; ``n_landmarks`` landmarks uniform in ``[-half_width, half_width]^2``
    (or the fixed ``(M, 2)`` array ``landmarks``); a measurement every ``dt_meas``
    seconds, none for times in ``[gap[0], gap[1])``.  The true commands are
    ``u_k = (speed[0], speed[1], turn_rate sin(3 pi k / n_steps))``: a sideways
    drift whose heading swings slowly.
    """

    n_steps: int = 1000
    dt: float = 1.0
    dt_meas: float = 1.0
    gap: tuple[float, float] | None = None
    q_true: Array = field(default_factory=lambda: Q_TRUE.copy())
    r_true: Array = field(default_factory=lambda: R_TRUE.copy())
    start: tuple[float, float, float] = (1.0, -50.0, 0.0)
    n_landmarks: int = 5
    half_width: float = 60.0
    landmarks: Array | None = None
    speed: tuple[float, float] = (0.0, 0.025)
    turn_rate: float = np.deg2rad(0.1)

    def __post_init__(self) -> None:
        checked_scenario(self)  # every setting, when the scenario is built (a named error for a bad one)

    def with_(self, **changes) -> RobotScenario:
        """A copy with some settings changed (checked)."""
        return replace(self, **changes)

    def true_controls(self) -> Array:
        """The ``(K, 3)`` true commands ``u_k`` (row 0 is unused and zero)."""
        k = np.arange(self.n_steps)
        u = np.zeros((self.n_steps, 3))
        u[1:, 0] = self.speed[0]
        u[1:, 1] = self.speed[1]
        u[1:, 2] = self.turn_rate * np.sin(3.0 * np.pi * k[1:] / self.n_steps)
        return u

    def measurement_mask(self) -> Array:
        """Boolean ``(K,)``: ``True`` at the steps that carry a measurement (see the module docstring)."""
        t = np.arange(self.n_steps) * self.dt
        ticks = np.floor(t / self.dt_meas + 1e-9)
        mask = np.zeros(self.n_steps, dtype=bool)
        mask[1:] = ticks[1:] > ticks[:-1]
        if self.gap is not None:
            mask &= ~((t >= self.gap[0]) & (t < self.gap[1]))
        return mask


def checked_scenario(s: RobotScenario) -> RobotScenario:
    """Validate a :class:`RobotScenario` and store the checked values (``int`` counts, floats, float
    arrays, tuples of floats); raise ``ParameterError``/``ShapeError``/``CovarianceError``."""
    n_steps = check_count(s.n_steps, "n_steps", minimum=2)
    check_fits(n_steps, "n_steps", 200 * n_steps, "the simulated states, commands and measurements")
    dt = check_real(s.dt, "dt")
    if not dt > 0:
        raise ParameterError(f"dt must be positive, got {dt}")
    if not isinstance(s.dt_meas, (int, float, np.integer, np.floating)) or isinstance(s.dt_meas, bool) \
            or not s.dt_meas >= dt:  # infinite: no measurement at all
        raise ParameterError(
            f"dt_meas must be at least dt = {dt} (one measurement per prediction step at most), "
            f"got {s.dt_meas!r}"
        )
    gap = check_interval(s.gap, "gap")
    landmarks, n_landmarks = s.landmarks, s.n_landmarks
    if landmarks is not None:
        landmarks = as_matrix(landmarks, "landmarks", finite=True)
        if landmarks.shape[1:] != (2,) or len(landmarks) < 1:
            raise ShapeError(f"landmarks must have shape (M, 2), got {landmarks.shape}")
    else:
        n_landmarks = check_count(n_landmarks, "n_landmarks")
        check_fits(n_landmarks, "n_landmarks", 16 * n_landmarks, "the landmark positions")
    half_width = check_real(s.half_width, "half_width")
    if not half_width > 0:
        raise ParameterError(f"half_width must be positive, got {half_width}")
    set_checked(
        s, n_steps=n_steps, dt=dt, dt_meas=as_float(s.dt_meas), gap=gap,
        q_true=check_covariance(s.q_true, "q_true", 3),
        r_true=check_covariance(s.r_true, "r_true", 2),
        start=tuple(float(v) for v in as_vector(s.start, "start", 3, finite=True)),
        speed=tuple(float(v) for v in as_vector(s.speed, "speed", 2, finite=True)),
        turn_rate=check_real(s.turn_rate, "turn_rate"),
        landmarks=landmarks, n_landmarks=n_landmarks, half_width=half_width,
    )
    return s


@dataclass(frozen=True)
class RobotSimulation:
    """One simulated run (``K`` steps, ``M`` landmarks).

    ``truth`` ``(K, 3)`` true states; ``odometry_path`` ``(K, 3)`` dead reckoning from
    the start; ``controls`` ``(K, 3)`` true commands and ``odometry`` ``(K, 3)`` the
    noisy commands ``u~_k`` (row 0 unused); ``measurements`` ``(K, 3)`` rows
    ``(j, range, bearing)`` or NaN; ``landmarks`` ``(M, 2)``; ``scenario`` the settings.
    """

    truth: Array
    odometry_path: Array
    controls: Array
    odometry: Array
    measurements: Array
    landmarks: Array
    scenario: RobotScenario

    @property
    def has_measurement(self) -> Array:
        """Boolean ``(K,)``: which steps carry a measurement."""
        return ~np.isnan(self.measurements[:, 0])

    @property
    def landmark_index(self) -> Array:
        """Integer ``(K,)`` index of the observed landmark, -1 where there is no measurement."""
        j = np.where(self.has_measurement, self.measurements[:, 0], -1)
        return j.astype(int)


def simulate_robot(
    scenario: RobotScenario | None = None, rng: np.random.Generator | int | None = None, **changes
) -> RobotSimulation:
    """Simulate a run of ``scenario`` (default :class:`RobotScenario`, updated by ``changes``).

    ``rng`` is a generator or a seed, and must be given (:class:`~pfcourse.errors.ParameterError`).  See the module docstring for the model,
    the measurement format and how the random streams are laid out.
    """
    base = scenario if scenario is not None else RobotScenario()
    if not isinstance(base, RobotScenario):
        raise ParameterError(f"scenario must be a RobotScenario (or None for the default), got {type(base).__name__}")
    scenario = base.with_(**changes) if changes else base
    landmark_rng, odometry_rng, noise_rng, choice_rng = as_generator(rng).spawn(4)
    K = scenario.n_steps
    if scenario.landmarks is not None:
        landmarks = np.array(scenario.landmarks, dtype=float)
    else:
        w = scenario.half_width
        landmarks = landmark_rng.uniform(-w, w, size=(scenario.n_landmarks, 2))
    M = len(landmarks)

    controls = scenario.true_controls()
    odometry = controls + odometry_rng.standard_normal((K, 3)) @ covariance_factor(scenario.q_true).T
    odometry[0] = 0.0
    truth = np.empty((K, 3))
    odo_path = np.empty((K, 3))
    truth[0] = odo_path[0] = scenario.start
    truth[0, 2] = odo_path[0, 2] = wrap_angle(scenario.start[2])
    for k in range(1, K):
        truth[k] = motion(truth[k - 1], controls[k], scenario.dt)
        odo_path[k] = motion(odo_path[k - 1], odometry[k], scenario.dt)

    noise = noise_rng.standard_normal((K, 2)) @ covariance_factor(scenario.r_true).T
    choice = choice_rng.integers(0, M, size=K)
    mask = scenario.measurement_mask()
    measurements = np.full((K, 3), np.nan)
    steps = np.flatnonzero(mask)
    for k in steps:
        z = range_bearing(truth[k], landmarks[choice[k]]) + noise[k]
        measurements[k] = (choice[k], z[0], wrap_angle(z[1]))
    for name, values in (("states", truth), ("odometry", odometry), ("dead-reckoning path", odo_path)):
        check_simulated(name, values)
    check_simulated("measurements", measurements, missing=True)
    return RobotSimulation(truth, odo_path, controls, odometry, measurements, landmarks, scenario)


class RobotModel:
    """The robot as a :class:`pfcourse.filter.Model` for :class:`~pfcourse.filter.ParticleFilter`.

    Parameters
    ----------
    landmarks:
        ``(M, 2)`` landmark positions (known map).
    odometry:
        ``(K, 3)`` noisy commands ``u~_k``; ``sample_transition(x, k, rng)`` uses row ``k``.
    q_est, r_est:
        The filter's odometry (3x3) and measurement (2x2) error covariances.
    dt:
        Prediction step (s).
    initial:
        ``"tracking"``: ``x_0 ~ start + diag(initial_std) N(0, I)`` (heading wrapped);
        ``"uniform"``: position uniform on ``[-half_width, half_width]^2`` and heading
        uniform on (-pi, pi] (global localization).
    start, initial_std, half_width:
        Parameters of the initial distribution.

    The log-likelihood of a measurement ``(j, r, b)`` is the Gaussian
    ``log N(nu; 0, r_est)`` of the innovation ``nu = (r - range_j(x), wrap(b - bearing_j(x)))``
    including its normalising constant, so that the filter's log-likelihood
    estimate is that of the data.  Cost per step: ``O(N)``, one compiled pass for the
    transition (diagonal ``q_est``, the usual case) and one for the likelihood
    (:func:`_move_diagonal`, :func:`_log_likelihood`; a full ``q_est`` goes through NumPy).
    """

    dim_x = 3
    angle_indices = ANGLE_INDICES

    def __init__(
        self,
        landmarks: Array,
        odometry: Array,
        q_est: Array,
        r_est: Array,
        *,
        dt: float = 1.0,
        initial: str = "tracking",
        start=(1.0, -50.0, 0.0),
        initial_std=INITIAL_STD,
        half_width: float = 60.0,
    ) -> None:
        self.landmarks = as_matrix(landmarks, "landmarks", finite=True)
        if self.landmarks.shape[1] != 2 or len(self.landmarks) == 0:
            raise ShapeError(f"landmarks must have shape (M, 2) with M >= 1, got {self.landmarks.shape}")
        self.odometry = as_matrix(odometry, "odometry", finite=True)
        if self.odometry.shape[1] != 3 or len(self.odometry) == 0:
            raise ShapeError(f"odometry must have shape (K, 3) with K >= 1, got {self.odometry.shape}")
        self.q_est = check_covariance(q_est, "q_est", 3)
        self.r_est = check_covariance(r_est, "r_est", 2, definite=True)
        self._q_factor = covariance_factor(self.q_est)
        # A diagonal factor (the usual case) scales each noise column: the same floats as the
        # einsum below (tested), several times faster.
        off_diagonal = self._q_factor - np.diag(np.diag(self._q_factor))
        self._q_diagonal = np.diag(self._q_factor).copy() if not off_diagonal.any() else None
        self._r_chol = np.linalg.cholesky(self.r_est)
        self._r_inv_chol = np.linalg.inv(self._r_chol)
        self._log_norm = -np.log(2.0 * np.pi) - float(np.sum(np.log(np.diag(self._r_chol))))
        if initial not in ("tracking", "uniform"):
            raise ParameterError(f"initial must be 'tracking' or 'uniform', got {initial!r}")
        self.initial = initial
        self.dt = check_real(dt, "dt", low=0.0, low_open=True)
        self.start = as_vector(start, "start", 3, finite=True)
        self.initial_std = as_vector(initial_std, "initial_std", 3, finite=True)
        if np.any(self.initial_std < 0):
            raise ParameterError(f"initial_std must be non-negative standard deviations, got {self.initial_std}")
        self.half_width = check_real(half_width, "half_width", low=0.0, low_open=True)

    @classmethod
    def for_simulation(
        cls,
        sim: RobotSimulation,
        *,
        q_scale: float = 2.0,
        r_scale: float = 2.0,
        initial: str = "tracking",
        initial_std=INITIAL_STD,
    ) -> RobotModel:
        """The model a filter uses on ``sim``: ``QEst = q_scale QTrue``, ``REst = r_scale RTrue``."""
        for name, value in (("q_scale", q_scale), ("r_scale", r_scale)):
            if not value > 0:
                raise ParameterError(f"{name} must be positive, got {value}")
        s = sim.scenario
        return cls(
            sim.landmarks,
            sim.odometry,
            q_scale * np.asarray(s.q_true),
            r_scale * np.asarray(s.r_true),
            dt=s.dt,
            initial=initial,
            start=sim.truth[0],
            initial_std=initial_std,
            half_width=s.half_width,
        )

    def sample_initial(self, n: int, rng: np.random.Generator) -> Array:
        """Draw ``n`` initial particles (see ``initial``)."""
        if self.initial == "uniform":
            x = np.empty((n, 3))
            x[:, :2] = rng.uniform(-self.half_width, self.half_width, size=(n, 2))
            x[:, 2] = wrap_angle(rng.uniform(-np.pi, np.pi, size=n))
            return x
        x = self.start + rng.standard_normal((n, 3)) * self.initial_std
        x[:, 2] = wrap_angle(x[:, 2])
        return x

    def sample_transition(self, particles: Array, k: int, rng: np.random.Generator) -> Array:
        """Draw ``x_k = f(x_{k-1}, u~_k + w)``, ``w ~ N(0, q_est)``, for every particle."""
        if not 0 <= k < len(self.odometry):
            raise ParameterError(f"step {k} is outside the odometry (K = {len(self.odometry)})")
        if self._q_diagonal is not None:
            # the usual diagonal factor: one compiled pass (same draws and floats as ``motion``)
            noise = rng.standard_normal(particles.shape)
            particles = np.ascontiguousarray(particles, dtype=float)
            return _move_diagonal(particles, noise, self.odometry[k], self._q_diagonal, self.dt)
        # w = L e with L L^T = q_est; einsum is several times faster than ``@`` for an (N, 3) x (3, 3)
        # product here, and allocates nothing beyond the (N, 3) result.
        controls = np.einsum("ij,kj->ik", rng.standard_normal(particles.shape), self._q_factor)
        controls += self.odometry[k]
        return motion(particles, controls, self.dt)

    def log_likelihood(self, particles: Array, z: Array, k: int) -> Array:
        """``log N(nu; 0, r_est)`` for the measurement ``z = (j, range, bearing)`` (module docstring)."""
        z = np.asarray(z, dtype=float)
        if z.shape != (3,):
            raise ShapeError(f"a robot measurement is (landmark, range, bearing), got shape {z.shape}")
        if not np.isfinite(z[0]) or int(z[0]) != z[0] or not 0 <= z[0] < len(self.landmarks):
            raise ParameterError(f"step {k}: landmark index {z[0]} is not one of 0..{len(self.landmarks) - 1}")
        if not np.isfinite(z[1:]).all():
            raise MeasurementError(f"step {k}: range and bearing must be finite, got {z[1:]} (a step without a "
                                   "measurement is a row of NaN)")
        j = int(z[0])
        a = self._r_inv_chol
        landmark = self.landmarks[j]
        return _log_likelihood(
            np.ascontiguousarray(particles, dtype=float), landmark[0], landmark[1], z[1], z[2],
            a[0, 0], a[1, 0], a[1, 1], self._log_norm,
        )


def robot_transition_log_density(model, new: Array, old: Array, k: int) -> Array:
    """``log p(x_k | x_{k-1})`` of :class:`~pfcourse.scenarios.robot.RobotModel` (diagonal or full ``q_est``).

    ``x_k = f(x_{k-1}, u~_k + w)``, ``w ~ N(0, q_est)``, and ``u -> f(x, u)`` is invertible:
    ``u = (R(-theta_{k-1}) (p_k - p_{k-1}) / dt, wrap(theta_k - theta_{k-1}) / dt)``, with
    Jacobian ``|det df/du| = dt^3`` (a rotation times ``dt``).  So
    ``log p = log N(u - u~_k; 0, q_est) - 3 log dt`` (the heading's other branches,
    ``2 pi`` away, are negligible for a small heading noise).
    """
    new = np.asarray(new, dtype=float)
    old = np.asarray(old, dtype=float)
    dt = model.dt
    c, s = np.cos(old[:, 2]), np.sin(old[:, 2])
    dx, dy = new[:, 0] - old[:, 0], new[:, 1] - old[:, 1]
    u = np.column_stack([(c * dx + s * dy) / dt, (-s * dx + c * dy) / dt,
                         wrap_angle(new[:, 2] - old[:, 2]) / dt])
    return gaussian_logpdf(u - model.odometry[k], model.q_est) - 3.0 * np.log(dt)


@jit
def _move_diagonal(particles, noise, odometry, q_std, dt):
    """``x_k = f(x_{k-1}, u~_k + q_std * e)`` for standard normal ``e`` (rows of ``noise``).

    The arithmetic of :func:`motion`, in one pass (tests/test_kernels.py compares the two
    bit for bit).
    """
    n = particles.shape[0]
    out = np.empty((n, 3))
    for i in range(n):
        vx = noise[i, 0] * q_std[0] + odometry[0]
        vy = noise[i, 1] * q_std[1] + odometry[1]
        omega = noise[i, 2] * q_std[2] + odometry[2]
        theta = particles[i, 2]
        c = math.cos(theta)
        s = math.sin(theta)
        out[i, 0] = particles[i, 0] + (vx * c - vy * s) * dt
        out[i, 1] = particles[i, 1] + (vx * s + vy * c) * dt
        out[i, 2] = wrap(theta + omega * dt)
    return out


@jit
def _log_likelihood(particles, lx, ly, z_range, z_bearing, a00, a10, a11, log_norm):
    """``log N(nu; 0, R)`` of the innovations ``nu = (z_r - range, wrap(z_b - bearing))``, ``A = chol(R)^-1``.

    The arithmetic of :func:`range_bearing` (the range as ``sqrt(dx^2 + dy^2)``, within an
    ulp of ``hypot`` and several times cheaper), in one pass: ``log_norm - |A nu|^2 / 2``.
    """
    n = particles.shape[0]
    out = np.empty(n)
    for i in range(n):
        dx = lx - particles[i, 0]
        dy = ly - particles[i, 1]
        nu_r = z_range - math.sqrt(dx * dx + dy * dy)
        nu_b = wrap(z_bearing - wrap(math.atan2(dy, dx) - particles[i, 2]))
        e0 = a00 * nu_r
        e1 = a10 * nu_r + a11 * nu_b
        out[i] = log_norm - 0.5 * (e0 * e0 + e1 * e1)
    return out


def tracking_errors(truth: Array, estimate: Array) -> Array:
    """Errors ``estimate - truth`` of shape ``(K, 3)`` with the heading error wrapped to (-pi, pi]."""
    truth = as_points(truth, "truth", 3)
    estimate = as_points(estimate, "estimate", 3)
    if truth.shape != estimate.shape:
        raise ShapeError(f"truth and estimate must both have shape (K, 3), got {truth.shape} and {estimate.shape}")
    err = estimate - truth
    err[..., 2] = wrap_angle(err[..., 2])
    return err


def tracking_rmse(truth: Array, estimate: Array, start: int = 0) -> tuple[float, float]:
    """Position and heading root-mean-square errors over steps ``k >= start``.

    ``RMSE_pos = sqrt(mean_k (e_x^2 + e_y^2))`` (m) and
    ``RMSE_theta = sqrt(mean_k wrap(e_theta)^2)`` (rad).
    """
    err = tracking_errors(truth, estimate)
    start = check_count(start, "start", minimum=0)
    if err.ndim != 2 or start >= len(err):
        raise ShapeError(f"tracking_rmse needs errors of shape (K, 3) with K > start = {start}, got {err.shape}")
    err = err[start:]
    return float(metrics.rmse(err[:, :2], components=-1)), float(metrics.rmse(err[:, 2]))
