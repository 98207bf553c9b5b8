"""Scenario A: a robot and ``M`` fixed landmarks, everything linear and Gaussian.

The state stacks the robot position and the landmark positions in the world
frame, ``x = (r_x, r_y, l^1_x, l^1_y, ..., l^M_x, l^M_y)``.  The robot turns by
``omega`` per step about a centre ``c`` while the landmarks stay put:

.. math::

   x_k = F x_{k-1} + B + w_k, \\quad
   F = \\mathrm{blkdiag}(R_\\omega, I_{2M}), \\quad
   B = ((I - R_\\omega) c, 0), \\quad w_k \\sim \\mathcal N(0, Q_w),

with ``R_omega`` the rotation by ``omega``.  Landmark ``j``, when in the robot's
field of view, is measured relative to the robot, ``z^j_k = l^j_k - r_k + v^j_k``,
``v^j_k ~ N(0, Rv_j)``; otherwise its two entries of ``z_k`` are NaN.

Two variants, after the lab reports (see the course specification):

* :func:`quadrant_scenario`: two landmarks, rotation by ``pi/4`` about the
  origin (``B = 0``), a landmark is seen when it lies up and to the right of the
  robot (``l_x - r_x > 0`` and ``l_y - r_y > 0``); 50 time samples.
* :func:`circle_scenario`: ``M`` landmarks (5 by default) around a circle
  centred at ``c != 0`` (so ``B != 0``), seen inside a triangular field of view
  that points along the robot's direction of travel.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from pfcourse.checks import (
    as_generator,
    as_vector,
    check_count,
    check_covariance,
    check_fits,
    check_real,
    check_simulated,
    covariance_factor,
    set_checked,
)
from pfcourse.errors import ParameterError
from pfcourse.linear_gaussian import LinearGaussianModel


def rotation(angle: float) -> np.ndarray:
    """The 2-D rotation matrix ``[[cos a, -sin a], [sin a, cos a]]`` (``angle`` a finite real number)."""
    angle = check_real(angle, "angle")
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True)
class LandmarkScenario:
    """Parameters of one variant of scenario A (units: metres, seconds, radians).

    ``field_of_view`` is ``"quadrant"`` or ``"triangle"``; the triangle has its
    apex at the robot, opens by ``fov_half_angle`` on each side of the direction
    of travel and reaches ``fov_range`` ahead.
    """

    n_landmarks: int
    n_samples: int
    dt: float
    omega: float
    centre: np.ndarray
    mX0: np.ndarray
    PX0: np.ndarray
    Qw: np.ndarray
    Rv: np.ndarray
    field_of_view: str
    fov_half_angle: float = np.pi / 4
    fov_range: float = 6.0

    def __post_init__(self) -> None:
        _checked(self)  # every field, when the scenario is built (a named error for a bad one)

    @property
    def dim_x(self) -> int:
        return 2 + 2 * self.n_landmarks

    @property
    def F(self) -> np.ndarray:
        F = np.eye(self.dim_x)
        F[:2, :2] = rotation(self.omega * self.dt)
        return F

    @property
    def B(self) -> np.ndarray:
        B = np.zeros(self.dim_x)
        B[:2] = (np.eye(2) - rotation(self.omega * self.dt)) @ self.centre
        return B

    @property
    def H(self) -> np.ndarray:
        """Full measurement matrix ``(2M, 2+2M)``: rows ``2j, 2j+1`` give ``l^j - r``."""
        m = self.n_landmarks
        H = np.zeros((2 * m, self.dim_x))
        H[:, :2] = np.tile(-np.eye(2), (m, 1))
        H[:, 2:] = np.eye(2 * m)
        return H

    @property
    def times(self) -> np.ndarray:
        """Sampling instants ``T = (0, dt, ..., (n_samples - 1) dt)``."""
        return np.arange(self.n_samples) * self.dt

    def with_(self, **changes) -> LandmarkScenario:
        """A copy with some parameters changed (checked again)."""
        return replace(self, **changes)

    def model(self, Qw=None, Rv=None) -> LinearGaussianModel:
        """The filter's model; ``Qw`` / ``Rv`` may differ from the simulator's (mismatch studies)."""
        return LinearGaussianModel(
            F=self.F,
            H=self.H,
            m0=self.mX0,
            P0=self.PX0,
            Q=self.Qw if Qw is None else Qw,
            R=self.Rv if Rv is None else Rv,
            B=self.B,
        )

    def heading(self, robot: np.ndarray) -> np.ndarray:
        """Direction of travel (radians) at robot positions ``(..., 2)``: the circle's tangent."""
        rel = np.asarray(robot, dtype=float) - self.centre
        return np.arctan2(rel[..., 1], rel[..., 0]) + np.sign(self.omega) * np.pi / 2

    def visible(self, x: np.ndarray) -> np.ndarray:
        """Which landmarks the robot sees in state(s) ``x`` (``(..., dim_x)`` -> ``(..., M)`` bool)."""
        x = np.asarray(x, dtype=float)
        robot = x[..., :2]
        rel = x[..., 2:].reshape(x.shape[:-1] + (self.n_landmarks, 2)) - robot[..., None, :]
        if self.field_of_view == "quadrant":
            return (rel[..., 0] > 0) & (rel[..., 1] > 0)
        heading = self.heading(robot)[..., None]
        ahead = rel[..., 0] * np.cos(heading) + rel[..., 1] * np.sin(heading)
        across = -rel[..., 0] * np.sin(heading) + rel[..., 1] * np.cos(heading)
        return (
            (ahead > 0)
            & (ahead <= self.fov_range)
            & (np.abs(across) <= ahead * np.tan(self.fov_half_angle))
        )

    def fov_polygon(self, robot: np.ndarray, extent: float = 5.0) -> np.ndarray:
        """Corners ``(n, 2)`` of the field of view at one robot position, for drawing."""
        robot = np.asarray(robot, dtype=float)
        if self.field_of_view == "quadrant":
            return np.array(
                [robot, [extent, robot[1]], [extent, extent], [robot[0], extent]]
            )
        h = float(self.heading(robot))
        reach = self.fov_range / np.cos(self.fov_half_angle)
        left = robot + reach * np.array([np.cos(h + self.fov_half_angle), np.sin(h + self.fov_half_angle)])
        right = robot + reach * np.array([np.cos(h - self.fov_half_angle), np.sin(h - self.fov_half_angle)])
        return np.array([robot, left, right])


def _checked(s: LandmarkScenario) -> LandmarkScenario:
    """Check every field of ``s`` (a named error naming it) and store the checked values."""
    m = check_count(s.n_landmarks, "n_landmarks")
    n = check_count(s.n_samples, "n_samples")
    check_fits(n, "n_samples", 24 * n * (2 + 4 * m), "the simulated states, measurements and noise")
    if not isinstance(s.field_of_view, str) or s.field_of_view not in ("quadrant", "triangle"):
        raise ParameterError(f"field_of_view must be 'quadrant' or 'triangle', got {s.field_of_view!r}")
    d = 2 + 2 * m
    set_checked(
        s, n_landmarks=m, n_samples=n,
        dt=check_real(s.dt, "dt", low=0.0, low_open=True),
        omega=check_real(s.omega, "omega"),
        fov_half_angle=check_real(s.fov_half_angle, "fov_half_angle", low=0.0, high=np.pi, low_open=True),
        fov_range=check_real(s.fov_range, "fov_range", low=0.0, low_open=True),
        centre=as_vector(s.centre, "centre", 2, finite=True),
        mX0=as_vector(s.mX0, "mX0", d, finite=True),
        PX0=check_covariance(s.PX0, "PX0", d),
        Qw=check_covariance(s.Qw, "Qw", d),
        Rv=check_covariance(s.Rv, "Rv", 2 * m, definite=True),
    )
    return s


def quadrant_scenario() -> LandmarkScenario:
    """Report 000's set-up: 2 landmarks, quarter turn per 2 steps, quadrant field of view.

    ``mX0 = (2, 0, -1, 4, 4, -1)``, ``PX0 = diag(0.1, 0.2, 0.2, 0.2, 0.2, 0.2)``
    (variances, m^2), ``Qw = diag(0.05^2, 0.05^2, 1e-20, 1e-20, 1e-20, 1e-20)``
    (the landmarks are static up to 1e-10 m per step), ``Rv = 0.1^2 I_4``,
    ``omega = pi/4`` rad per step, ``dt = 1`` s, 50 samples.
    """
    return LandmarkScenario(
        n_landmarks=2,
        n_samples=50,
        dt=1.0,
        omega=np.pi / 4,
        centre=np.zeros(2),
        mX0=np.array([2.0, 0.0, -1.0, 4.0, 4.0, -1.0]),
        PX0=np.diag([0.1, 0.2, 0.2, 0.2, 0.2, 0.2]),
        Qw=np.diag([0.05**2, 0.05**2] + [1e-20] * 4),
        Rv=0.1**2 * np.eye(4),
        field_of_view="quadrant",
    )


def circle_scenario(n_landmarks: int = 5) -> LandmarkScenario:
    """Report 003's set-up: ``M`` landmarks, a perturbed circle about ``c = (2, 1)``, triangular view.

    The robot starts 3 m east of the centre and goes anticlockwise round it once
    every 40 steps (``omega = 2 pi / 40``); the landmarks sit evenly on a circle of
    radius 4.5 m about the centre (offset by half a spacing).  The field of view
    opens 45 deg either side of the direction of travel, up to 6 m ahead.  Noise
    levels are those of :func:`quadrant_scenario`.
    """
    m = check_count(n_landmarks, "n_landmarks")
    check_fits(m, "n_landmarks", 32 * (2 + 2 * m) ** 2, "the covariances of a state of 2 + 2 n_landmarks entries")
    centre = np.array([2.0, 1.0])
    angles = 2 * np.pi * (np.arange(m) + 0.5) / m
    landmarks = centre + 4.5 * np.column_stack([np.cos(angles), np.sin(angles)])
    return LandmarkScenario(
        n_landmarks=m,
        n_samples=50,
        dt=1.0,
        omega=2 * np.pi / 40,
        centre=centre,
        mX0=np.concatenate([centre + [3.0, 0.0], landmarks.ravel()]),
        PX0=np.diag([0.1, 0.1] + [0.2] * (2 * m)),
        Qw=np.diag([0.05**2, 0.05**2] + [1e-20] * (2 * m)),
        Rv=0.1**2 * np.eye(2 * m),
        field_of_view="triangle",
    )


@dataclass(frozen=True)
class LandmarkSimulation:
    """One simulated run: times ``T`` ``(K,)``, true states ``truth`` ``(K, 2+2M)``, ``measurements`` ``(K, 2M)``.

    ``measurements[k]`` holds NaN for the landmarks not seen at time ``k`` (all of them at
    ``k = 0``: the first measurement comes after the first move); ``seen[k, j]``
    says whether landmark ``j`` was seen.
    """

    T: np.ndarray
    truth: np.ndarray
    measurements: np.ndarray
    seen: np.ndarray


def simulate(scenario: LandmarkScenario, rng: np.random.Generator | int | None = None) -> LandmarkSimulation:
    """Draw ``x_0 ~ N(mX0, PX0)``, then ``x_k = F x_{k-1} + B + w_k`` and the measurements.

    ``rng`` (a Generator or an integer seed) must be given: :class:`~pfcourse.errors.ParameterError`
    otherwise, as for a ``scenario`` that is not a :class:`LandmarkScenario`."""
    if not isinstance(scenario, LandmarkScenario):
        raise ParameterError(f"scenario must be a LandmarkScenario (quadrant_scenario(), circle_scenario()), "
                             f"got {type(scenario).__name__}")
    rng = as_generator(rng)
    s = scenario
    K, d, m = s.n_samples, s.dim_x, s.n_landmarks
    F, B, H = s.F, s.B, s.H
    X = np.empty((K, d))
    X[0] = s.mX0 + covariance_factor(s.PX0) @ rng.standard_normal(d)
    process = rng.standard_normal((K, d)) @ covariance_factor(s.Qw).T
    for k in range(1, K):
        X[k] = F @ X[k - 1] + B + process[k]
    noise = rng.standard_normal((K, 2 * m)) @ covariance_factor(s.Rv).T
    seen = s.visible(X)
    seen[0] = False
    Z = X @ H.T + noise
    Z[~np.repeat(seen, 2, axis=1)] = np.nan
    check_simulated("states", X)
    check_simulated("measurements", Z, missing=True)
    return LandmarkSimulation(T=s.times, truth=X, measurements=Z, seen=seen)
