"""Kalman-filter references through :mod:`filterpy`.

For a linear-Gaussian model the Kalman filter computes the exact filtering
distribution ``p(x_k | z_{0:k}) = N(m_k, P_k)`` and the exact log-likelihood
``log p(z_{0:K}) = sum_k log N(y_k; 0, S_k)`` (innovation ``y_k``, its covariance
``S_k``).  Every particle filter in the book on such a model is measured against
these numbers.  Missing (NaN) entries of ``z_k`` are handled as in
:class:`~pfcourse.linear_gaussian.LinearGaussianModel`: the update uses the
observed rows ``H_o`` and block ``R_oo`` only, so ``H`` and ``R`` change with time.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from filterpy.kalman import KalmanFilter

from pfcourse.checks import check_estimate, check_measurements, is_missing, numerical_step
from pfcourse.errors import MeasurementError, ModelError
from pfcourse.linear_gaussian import LinearGaussianModel
from pfcourse.results import KalmanResult


def kalman_filter(model: LinearGaussianModel, measurements: Sequence | np.ndarray) -> KalmanResult:
    """Run filterpy's ``KalmanFilter`` on ``model`` with the time-varying observed rows.

    Time 0 starts from ``N(m0, P0)`` and is updated by ``z_0`` if present; every
    later step predicts ``x_k = F x_{k-1} + B`` then updates with ``z_k``.  The measurements
    are checked as the particle filter's are (:func:`~pfcourse.checks.check_measurements`:
    ``None``, empty or all-NaN is a missing step, NaN entries unobserved components), and each
    present one must have the model's ``dim_z`` components
    (:class:`~pfcourse.errors.MeasurementError` naming the step otherwise; a 1-D series is read as
    ``(K, 1)``, an empty one refused).  A mean, covariance or log-likelihood increment that
    overflows to NaN or infinity raises :class:`~pfcourse.errors.NumericalError` with its step.
    """
    if not isinstance(model, LinearGaussianModel):
        raise ModelError(f"kalman_filter needs a LinearGaussianModel, got {type(model).__name__}")
    measurements = check_measurements(measurements)
    for k, z in enumerate(measurements):
        if not is_missing(z) and np.shape(z) != (model.dim_z,):
            raise MeasurementError(
                f"step {k}: the measurement has shape {np.shape(z)}, the model measures ({model.dim_z},)"
            )
    d = model.dim_x
    kf = KalmanFilter(dim_x=d, dim_z=model.dim_z)
    kf.x = model.m0.copy()
    kf.P = model.P0.copy()
    kf.F = model.F
    kf.Q = model.Q
    kf.B = model.B.reshape(d, 1)
    n_steps = len(measurements)
    out = KalmanResult.empty(n_steps, d, model.dim_z, "Kalman")
    for k, z in enumerate(measurements):
        with numerical_step(k, "Kalman filter"):
            if k > 0:
                kf.predict(u=np.ones(1))
                check_estimate(k, "Kalman filter's prediction", kf.x, kf.P)
            if not is_missing(z):
                mask, z_o, H_o, R_o = model.observed(z)
                predicted = kf.x.copy()
                kf.update(z_o, R=R_o, H=H_o)
                check_estimate(k, "Kalman filter's update", kf.x, kf.P, kf.S)
                out.log_likelihood_increments[k] = kf.log_likelihood
                observed = np.flatnonzero(mask)
                out.predicted[k] = np.ravel(predicted)
                out.innovation[k, observed] = np.ravel(kf.y)
                out.innovation_cov[k][np.ix_(observed, observed)] = kf.S
                out.gain[k][:, observed] = kf.K
        check_estimate(k, "Kalman filter", kf.x, kf.P, out.log_likelihood_increments[k])
        out.mean[k] = np.ravel(kf.x)
        out.cov[k] = kf.P
    return out
