"""The Kalman family: one loop for the Kalman filter (KF), the extended (EKF) and the unscented (UKF).

A Gaussian filter carries ``N(m_k, P_k)``, an approximation of ``p(x_k | z_{0:k})`` (exact for
the KF), for a model given as functions (:class:`GaussianModel`)::

    x_k = f_k(x_{k-1}) + w_k,   w_k ~ N(0, Q_k),        z_k = h_k(x_k) + v_k,   v_k ~ N(0, R_k),

step by step a :class:`Transition` (``f``, ``Q`` and the Jacobian ``F = df/dx`` at the estimate)
and a :class:`Measurement` (``z``, ``h``, ``R`` and ``H(x) = dh/dx``; ``None``: nothing measured),
with the residuals ``a (-) b`` of states and of measurements (angle differences wrapped), the
means of sigma points (circular means of angles), the wrapping of an estimate, and the domain of
``h`` (an estimate that leaves it is lost).  :func:`gaussian_filter` is the one loop: at step ``k``

1. predict (``k > 0``);
2. if ``z_k`` is present: stop (``lost_at = k``) if a point the update evaluates ``h`` at lies
   off its domain, else update, and record ``m^-_k``, ``y_k``, ``S_k``, the gain ``G_k`` and the
   log-likelihood increment ``log N(y_k; 0, S_k)`` (:func:`filterpy.stats.logpdf`; the exact
   ``log p(z_k | z_{0:k-1})`` for the KF, an approximation for the EKF and the UKF, whose
   scenario wrappers skip it);
3. stop if the mean has left the domain, else record ``N(m_k, P_k)``.

The two kinds of step (``(-)`` the residual, ``(+)`` plain addition):

**Linearised** (:class:`Linearised`: the KF when ``f`` and ``h`` are linear, the EKF otherwise)::

    m^- = f(m),   P^- = F P F^T + Q,
    H = dh/dx(m^-),   S = H P^- H^T + R,   G = P^- H^T S^-1,   y = z (-) h(m^-),
    m = m^- + G y,    P = (I - G H) P^- (I - G H)^T + G R G^T   (Joseph form).

**Unscented** (:class:`Unscented`: Van der Merwe's scaled sigma points ``chi_i`` of ``N(m, P)``
with weights ``W^m_i``, ``W^c_i``, filterpy's :class:`~filterpy.kalman.MerweScaledSigmaPoints`
and :func:`~filterpy.kalman.unscented_transform`)::

    m^- = mean_x(f(chi_i), W^m),   P^- = sum_i W^c_i (f(chi_i) (-) m^-)(.)^T + Q,
    chi_i of N(m^-, P^-),   z^ = mean_z(h(chi_i), W^m),   S = sum_i W^c_i (h(chi_i) (-) z^)(.)^T + R,
    P_xz = sum_i W^c_i (chi_i (-) m^-)(h(chi_i) (-) z^)^T,   G = P_xz S^-1,   y = z (-) z^,
    m = m^- + G y,    P = P^- - G S G^T.

These are filterpy's ``KalmanFilter``, ``ExtendedKalmanFilter`` and ``UnscentedKalmanFilter``
step for step, float for float (tests/test_kalman.py; ``S^-1`` with NumPy for the KF and the UKF,
with SciPy for the EKF, as filterpy inverts it).  A mean, covariance or log-likelihood increment
that overflows to NaN or infinity raises :class:`~pfcourse.errors.NumericalError` with its step.

:func:`kalman_filter` is the KF of a :class:`~pfcourse.linear_gaussian.LinearGaussianModel`,
the reference of every particle filter on such a model; the scenarios' EKFs and UKFs
(:mod:`pfcourse.scenarios.robot.kalman`, :mod:`pfcourse.scenarios.terrain.kalman`) give the loop their model.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import scipy.linalg

from pfcourse.checks import Array, check_estimate, check_measurements, check_real, is_missing, numerical_step
from pfcourse.errors import MeasurementError, ModelError
from pfcourse.linear_gaussian import LinearGaussianModel
from pfcourse.results import KalmanResult


@dataclass(frozen=True)
class Transition:
    """One step's prediction model ``x_k = f(x_{k-1}) + w_k``, ``w_k ~ N(0, Q)``; ``F = df/dx`` at the
    previous estimate (the linearised step's; the unscented step does not use it)."""

    f: Callable[[Array], Array]
    Q: Array
    F: Array | None = None


@dataclass(frozen=True)
class Measurement:
    """One step's measurement ``z = h(x) + v``, ``v ~ N(0, R)``; ``H(x) = dh/dx`` (the linearised
    step's); ``components``: which of the model's ``dim_z`` components ``z`` holds (``None``: all)."""

    z: Array
    h: Callable[[Array], Array]
    R: Array
    H: Callable[[Array], Array] | None = None
    components: Array | None = None


@dataclass(frozen=True)
class GaussianModel:
    """A state-space model as the Kalman family reads it (module docstring).

    ``transition(k, m)`` gives step ``k``'s :class:`Transition` at the current estimate ``m``;
    ``measurement(k, z)`` the :class:`Measurement` of ``z_k``, or ``None`` when nothing was
    measured.  ``residual_x(a, b)`` and ``residual_z(a, b)`` are ``a (-) b`` (``np.subtract``
    unless angles must be wrapped), ``mean_x`` and ``mean_z`` the weighted means of sigma points
    ``(n, d)`` (``None``: ``W^m @ points``), ``wrap(m)`` the estimate with its angles wrapped, and
    ``on_domain(points)`` whether every row ``(n, d)`` lies where ``h`` is defined.
    """

    m0: Array
    P0: Array
    dim_z: int
    transition: Callable[[int, Array], Transition]
    measurement: Callable[[int, object], Measurement | None]
    residual_x: Callable[[Array, Array], Array] = np.subtract
    residual_z: Callable[[Array, Array], Array] = np.subtract
    mean_x: Callable[[Array, Array], Array] | None = None
    mean_z: Callable[[Array, Array], Array] | None = None
    wrap: Callable[[Array], Array] | None = None
    on_domain: Callable[[Array], bool] | None = None


#: What an update returns: the posterior mean and covariance, the innovation ``y``, its covariance ``S``, the gain.
Update = tuple[Array, Array, Array, Array, Array]


@lru_cache
def _identity(n: int) -> Array:
    identity = np.eye(n)
    identity.flags.writeable = False
    return identity


@dataclass(frozen=True)
class Linearised:
    """The KF's and the EKF's predict and update (module docstring); ``inverse`` inverts ``S``."""

    inverse: Callable[[Array], Array] = scipy.linalg.inv

    def predict(self, model: GaussianModel, m: Array, P: Array, t: Transition) -> tuple[Array, Array]:
        return t.f(m), np.dot(np.dot(t.F, P), t.F.T) + t.Q

    def points(self, m: Array, P: Array) -> Array:
        """Where the update evaluates ``h``: the predicted mean."""
        return m[None, :]

    def update(self, model: GaussianModel, m: Array, P: Array, points: Array, e: Measurement) -> Update:
        H = e.H(m)
        PHT = np.dot(P, H.T)
        S = np.dot(H, PHT) + e.R
        gain = np.dot(PHT, self.inverse(S))
        y = model.residual_z(e.z, e.h(m))
        I_GH = _identity(len(m)) - np.dot(gain, H)
        mean = m + np.dot(gain, y)
        cov = np.dot(np.dot(I_GH, P), I_GH.T) + np.dot(np.dot(gain, e.R), gain.T)
        return mean, cov, y, S, gain


class Unscented:
    """The UKF's predict and update with ``MerweScaledSigmaPoints(n, alpha, beta, kappa)`` (module
    docstring); the sigma points of ``N(m, P)`` are ``m`` and ``m (-) -/+ columns of sqrt((n + lambda) P)``."""

    def __init__(self, model: GaussianModel, alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0) -> None:
        n = len(model.m0)
        check_real(alpha, "alpha", low=0.0, high=1e100, low_open=True)  # beyond, alpha**2 overflows
        check_real(beta, "beta")
        check_real(kappa, "kappa", low=-float(n), low_open=True)  # alpha^2 (n + kappa) > 0: the points' spread
        # filterpy is imported where it is used, not by ``import pfcourse`` (it takes about a second to load)
        from filterpy.kalman import MerweScaledSigmaPoints, unscented_transform

        self.transform = unscented_transform
        self.sigma = MerweScaledSigmaPoints(n, alpha=alpha, beta=beta, kappa=kappa,
                                            subtract=model.residual_x)

    def predict(self, model: GaussianModel, m: Array, P: Array, t: Transition) -> tuple[Array, Array]:
        moved = np.array([t.f(point) for point in self.sigma.sigma_points(m, P)])
        return self.transform(moved, self.sigma.Wm, self.sigma.Wc, t.Q, model.mean_x, model.residual_x)

    def points(self, m: Array, P: Array) -> Array:
        """Where the update evaluates ``h``: the sigma points of ``N(m, P)`` (the first is ``m``)."""
        return self.sigma.sigma_points(m, P)

    def update(self, model: GaussianModel, m: Array, P: Array, points: Array, e: Measurement) -> Update:
        seen = np.atleast_2d([e.h(point) for point in points])
        Wm, Wc = self.sigma.Wm, self.sigma.Wc
        z_hat, S = self.transform(seen, Wm, Wc, e.R, model.mean_z, model.residual_z)
        Pxz = np.zeros((len(m), seen.shape[1]))
        for w, point, z in zip(Wc, points, seen):
            Pxz += w * np.outer(model.residual_x(point, m), model.residual_z(z, z_hat))
        gain = np.dot(Pxz, np.linalg.inv(S))
        y = model.residual_z(e.z, z_hat)
        return np.add(m, np.dot(gain, y)), P - np.dot(gain, np.dot(S, gain.T)), y, S, gain


def gaussian_filter(model: GaussianModel, steps: Linearised | Unscented, measurements: Sequence,
                    name: str, label: str | None = None, *, log_likelihood: bool = True) -> KalmanResult:
    """Run the Gaussian filter ``steps`` on ``model`` over ``measurements`` (module docstring).

    Time 0 starts from ``N(m0, P0)`` and is updated by ``z_0`` if present.  ``name`` is the
    result's, ``label`` how error messages name the filter (default ``name``).  With
    ``log_likelihood=False`` the increments are left at 0 (SciPy's Gaussian log-density costs
    about 0.2 ms a step, as much as the rest of an EKF step).
    """
    label = name if label is None else label
    if log_likelihood:
        from filterpy.stats import logpdf  # imported when used: ``import pfcourse`` does not load filterpy
    m, P = np.array(model.m0, dtype=float), np.array(model.P0, dtype=float)
    out = KalmanResult.empty(len(measurements), len(m), model.dim_z, name)
    on_domain = model.on_domain if model.on_domain is not None else (lambda points: True)
    wrap = model.wrap if model.wrap is not None else (lambda x: x)
    for k, z in enumerate(measurements):
        with numerical_step(k, label):
            if k > 0:
                m, P = steps.predict(model, m, P, model.transition(k, m))
                m = wrap(m)
                check_estimate(k, f"{label}'s prediction", m, P)
            e = model.measurement(k, z)
            if e is not None:
                points = steps.points(m, P)
                if not on_domain(points):
                    out.lost_at = k
                    break
                predicted = m
                m, P, y, S, gain = steps.update(model, m, P, points, e)
                m = wrap(m)
                check_estimate(k, f"{label}'s update", m, P, S)
                if log_likelihood:
                    increment = logpdf(x=y, cov=S)
                    check_estimate(k, label, increment)
        if not on_domain(m[None, :]):
            out.lost_at = k
            break
        if e is not None:
            if log_likelihood:
                out.log_likelihood_increments[k] = increment
            out.record_update(k, predicted, y, S, gain, e.components)
        out.mean[k] = m
        out.cov[k] = P
    return out


def kalman_filter(model: LinearGaussianModel, measurements: Sequence | np.ndarray) -> KalmanResult:
    """The Kalman filter of ``model``: :func:`gaussian_filter` with ``f(x) = F x + B``, ``h(x) = H_o x``.

    Time 0 starts from ``N(m0, P0)`` and is updated by ``z_0`` if present; every later step
    predicts ``x_k = F x_{k-1} + B`` then updates with ``z_k``.  Missing (NaN) entries of ``z_k``
    are handled as in :class:`~pfcourse.linear_gaussian.LinearGaussianModel`: the update uses the
    observed rows ``H_o`` and block ``R_oo`` only, so ``H`` and ``R`` change with time, and the
    innovation fills the observed components.  The measurements are checked as the particle
    filter's are (:func:`~pfcourse.checks.check_measurements`: ``None``, empty or all-NaN is a
    missing step, NaN entries unobserved components), and each present one must have the model's
    ``dim_z`` components (:class:`~pfcourse.errors.MeasurementError` naming the step otherwise; a
    1-D series is read as ``(K, 1)``, an empty one refused).  The log-likelihood increments sum
    to the exact ``log p(z_{0:K-1}) = sum_k log N(y_k; 0, S_k)``.
    """
    if not isinstance(model, LinearGaussianModel):
        raise ModelError(f"kalman_filter needs a LinearGaussianModel, got {type(model).__name__}")
    measurements = check_measurements(measurements)
    for k, z in enumerate(measurements):
        if not is_missing(z) and np.shape(z) != (model.dim_z,):
            raise MeasurementError(
                f"step {k}: the measurement has shape {np.shape(z)}, the model measures ({model.dim_z},)"
            )
    moved = Transition(lambda x: np.dot(model.F, x) + model.B, model.Q, model.F)

    def measurement(k: int, z) -> Measurement | None:
        if is_missing(z):
            return None
        mask, z_o, H_o, R_o = model.observed(z)
        return Measurement(z_o, lambda x: np.dot(H_o, x), R_o, lambda x: H_o, np.flatnonzero(mask))

    gaussian = GaussianModel(model.m0, model.P0, model.dim_z, lambda k, m: moved, measurement)
    return gaussian_filter(gaussian, Linearised(np.linalg.inv), measurements, "Kalman", "Kalman filter")


__all__ = ["GaussianModel", "Linearised", "Measurement", "Transition", "Unscented", "gaussian_filter",
           "kalman_filter"]
