"""Extended and unscented Kalman filters for the robot of :mod:`pfcourse.scenarios.robot.scenario`: its model
as the Kalman family reads it (:func:`kalman_model`), run by the one loop of :mod:`pfcourse.kalman`.

Both filters read exactly the data the particle filter reads: the odometry
``u~_k`` (row ``k`` of the model's ``odometry``) and the measurement rows
``(j, range, bearing)`` (NaN when absent).

**EKF** (:class:`pfcourse.kalman.Linearised`, filterpy's ``ExtendedKalmanFilter`` step for step).  Prediction with the
Jacobians of ``f(x, u + w)`` at the current estimate ``m``::

    F = df/dx = [[1, 0, -(v_x s + v_y c) dt], [0, 1, (v_x c - v_y s) dt], [0, 0, 1]],
    G = df/dw = [[c dt, -s dt, 0], [s dt, c dt, 0], [0, 0, dt]],   (c, s) = (cos, sin) of m_theta,
    m <- f(m, u~),   P <- F P F^T + G QEst G^T;

update with ``H = dh_j/dx`` at ``m``, for ``(d_x, d_y) = l^j - p`` and ``q = d_x^2 + d_y^2``::

    H = [[-d_x / sqrt(q), -d_y / sqrt(q), 0], [d_y / q, -d_x / q, -1]],

and the residual function ``z - h_j(m)`` with the bearing wrapped to (-pi, pi]
(without it a bearing of 179 deg compared with a prediction of -179 deg is an
innovation of 358 deg instead of -2 deg).  The heading estimate is wrapped after
every step.

**UKF** (:class:`pfcourse.kalman.Unscented`, filterpy's ``UnscentedKalmanFilter`` step for step,
Van der Merwe's scaled sigma points).  The sigma points go through ``f(., u~)`` and ``h_j``; the
additive process noise is ``G QEst G^T`` at the current estimate; means of
headings and bearings are circular means, and every difference of angles
(state residual, measurement residual) is wrapped.
"""

from __future__ import annotations

import math

import numpy as np

from pfcourse.angles import sigma_point_mean, wrap, wrap_angle
from pfcourse.checks import Array, as_vector, check_covariance, check_measurements
from pfcourse.errors import MeasurementError, ModelError, ShapeError
from pfcourse.kalman import GaussianModel, Linearised, Measurement, Transition, Unscented, gaussian_filter
from pfcourse.results import KalmanResult
from pfcourse.scenarios.robot.scenario import INITIAL_STD, RobotModel, motion


def range_bearing_one(state: Array, landmark: Array) -> Array:
    """:func:`pfcourse.scenarios.robot.scenario.range_bearing` of one state ``(3,)``, with the range as
    :func:`math.hypot`: the floats the Kalman filters' published numbers were computed with.

    ``range_bearing`` itself (``np.hypot``, the C library's) differs from ``math.hypot`` in the
    last bit of about one range in 200, which moves the EKF and UKF results by up to ~1e-13;
    the bearing is the same float.  The motion has no such copy: the filters call
    :func:`~pfcourse.scenarios.robot.scenario.motion` on the one state (the same floats).
    """
    dx, dy = float(landmark[0] - state[0]), float(landmark[1] - state[1])
    return np.array([math.hypot(dx, dy), wrap(math.atan2(dy, dx) - float(state[2]))])


def motion_jacobians(state: Array, control: Array, dt: float) -> tuple[Array, Array]:
    """``F = df/dx`` and ``G = df/du`` of the motion model at ``(state, control)`` (module docstring)."""
    c, s = np.cos(state[2]), np.sin(state[2])
    vx, vy = control[0], control[1]
    F = np.array([[1.0, 0.0, -(vx * s + vy * c) * dt], [0.0, 1.0, (vx * c - vy * s) * dt], [0.0, 0.0, 1.0]])
    G = np.array([[c * dt, -s * dt, 0.0], [s * dt, c * dt, 0.0], [0.0, 0.0, dt]])
    return F, G


def measurement_jacobian(state: Array, landmark: Array) -> Array:
    """``H = dh_j/dx`` (2x3) of range and bearing to ``landmark`` at ``state``."""
    dx, dy = landmark[0] - state[0], landmark[1] - state[1]
    q = dx * dx + dy * dy
    r = np.sqrt(q)
    return np.array([[-dx / r, -dy / r, 0.0], [dy / q, -dx / q, -1.0]])


def measurement_residual(z: Array, z_pred: Array) -> Array:
    """``z - z_pred`` with the bearing component (index 1) wrapped to (-pi, pi]; any leading shape."""
    y = np.array(z, dtype=float) - np.asarray(z_pred, dtype=float)
    y[1] = wrap(y[1].item()) if y[1].size == 1 else wrap_angle(y[1])
    return y


def state_residual(a: Array, b: Array) -> Array:
    """``a - b`` for robot states ``(3,)`` with the heading difference wrapped."""
    y = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    y[2] = wrap(float(y[2]))
    return y


def state_mean(sigmas: Array, weights: Array) -> Array:
    """Weighted mean of sigma points ``(n, 3)``; circular mean of the heading (weights may be negative)."""
    return sigma_point_mean(sigmas, weights, (2,))


def measurement_mean(sigmas: Array, weights: Array) -> Array:
    """Weighted mean of predicted measurements ``(n, 2)``; circular mean of the bearing."""
    return sigma_point_mean(sigmas, weights, (1,))


def _initial(model: RobotModel, initial_cov: Array | None) -> tuple[Array, Array]:
    if not isinstance(model, RobotModel):
        raise ModelError(f"the robot's Kalman filters need a RobotModel, got {type(model).__name__}")
    x0 = as_vector(model.start, "start", 3, finite=True).copy()
    if initial_cov is None:
        initial_cov = np.diag(np.asarray(model.initial_std, dtype=float) ** 2)
    return x0, check_covariance(initial_cov, "initial_cov", 3, definite=True)


def _check_measurements(measurements: Array, model: RobotModel) -> Array:
    """``(K, 3)`` rows ``(j, range, bearing)``: NaN ``j`` is a missing step; otherwise ``j`` must
    be a landmark index of the map and the range and bearing finite."""
    measurements = check_measurements(measurements)
    try:
        measurements = np.asarray(measurements, dtype=float)
    except (TypeError, ValueError):
        raise MeasurementError("measurements must be one (landmark, range, bearing) row per step, "
                               "NaN rows where nothing was measured") from None
    if measurements.ndim != 2 or measurements.shape[1] != 3:
        raise ShapeError(f"measurements must have shape (K, 3), got {measurements.shape}")
    if len(measurements) > len(model.odometry):
        raise ShapeError(
            f"{len(measurements)} measurements but only {len(model.odometry)} odometry rows"
        )
    present = ~np.isnan(measurements[:, 0])
    j = measurements[present, 0]
    bad_index = (j != np.round(j)) | (j < 0) | (j >= len(model.landmarks))
    bad_value = ~np.isfinite(measurements[present, 1:]).all(axis=1)
    bad = bad_index | bad_value
    if bad.any():
        i = int(np.argmax(bad))
        k = int(np.flatnonzero(present)[i])
        z = measurements[k]
        what = (f"landmark index {z[0]} is not one of 0..{len(model.landmarks) - 1}" if bad_index[i]
                else f"range and bearing must be finite, got {z[1:]}")
        raise MeasurementError(f"step {k}: {what}")
    return measurements


def kalman_model(model: RobotModel, initial_cov: Array | None = None) -> GaussianModel:
    """The robot as the Kalman family reads it (:class:`pfcourse.kalman.GaussianModel`; module docstring).

    ``f = motion(., u~_k)``, ``F`` and ``Q = G QEst G^T`` at the current estimate
    (:func:`motion_jacobians`); at a step with a reading of landmark ``j``, ``h = h_j``
    (:func:`range_bearing_one`), ``H`` from :func:`measurement_jacobian`, ``R = REst``;
    headings and bearings through the residuals and means of this module.  The prior is
    ``N(model.start, initial_cov)`` (default ``diag(model.initial_std)^2``, the particle filter's
    tracking cloud).  The measurements are rows ``(j, range, bearing)``, NaN rows where nothing was
    measured.
    """
    x0, P0 = _initial(model, initial_cov)

    def transition(k: int, m: Array) -> Transition:
        u = model.odometry[k]
        F, G = motion_jacobians(m, u, model.dt)
        return Transition(lambda x: motion(x, u, model.dt), G @ model.q_est @ G.T, F)

    def measurement(k: int, z: Array) -> Measurement | None:
        if np.isnan(z[0]):
            return None
        landmark = model.landmarks[int(z[0])]
        return Measurement(z[1:].copy(), lambda x: range_bearing_one(x, landmark), model.r_est,
                           lambda x: measurement_jacobian(x, landmark))

    return GaussianModel(x0, P0, 2, transition, measurement, state_residual, measurement_residual,
                         state_mean, measurement_mean, wrap=_wrap_heading)


def _wrap_heading(x: Array) -> Array:
    x = x.copy()
    x[2] = wrap(float(x[2]))
    return x


def run_ekf(model: RobotModel, measurements: Array, initial_cov: Array | None = None) -> KalmanResult:
    """Run the EKF (:class:`pfcourse.kalman.Linearised`) on ``measurements`` ``(K, 3)`` with ``model``'s
    odometry, ``q_est`` and ``r_est`` (:func:`kalman_model`)."""
    gaussian = kalman_model(model, initial_cov)
    return gaussian_filter(gaussian, Linearised(), _check_measurements(measurements, model), "EKF", log_likelihood=False)


def run_ukf(
    model: RobotModel,
    measurements: Array,
    initial_cov: Array | None = None,
    *,
    alpha: float = 1.0,
    beta: float = 2.0,
    kappa: float = 0.0,
) -> KalmanResult:
    """Run the UKF (:class:`pfcourse.kalman.Unscented`) on ``measurements`` ``(K, 3)``; sigma points
    ``MerweScaledSigmaPoints(3, alpha, beta, kappa)``.

    With the defaults (``alpha = 1``, ``kappa = 0``) the six outer sigma points sit at
    ``m +/- sqrt(3 P)`` columns with weight 1/6 each and the centre point has mean
    weight 0: every weight used for means is non-negative.
    """
    gaussian = kalman_model(model, initial_cov)
    measurements = _check_measurements(measurements, model)
    steps = Unscented(gaussian, alpha=alpha, beta=beta, kappa=kappa)
    return gaussian_filter(gaussian, steps, measurements, "UKF", log_likelihood=False)


__all__ = [
    "INITIAL_STD",
    "kalman_model",
    "measurement_jacobian",
    "measurement_mean",
    "measurement_residual",
    "motion_jacobians",
    "range_bearing_one",
    "run_ekf",
    "run_ukf",
    "state_mean",
    "state_residual",
]
