"""An unscented Kalman filter for terrain-aided navigation (scenario B), through filterpy.

The state, dynamics and altimeter model are those of :mod:`pfcourse.terrain.scenario`: the
sigma points go through :func:`~pfcourse.terrain.scenario.propagate` (``f``) and
:func:`~pfcourse.terrain.scenario.predicted_measurement` (``h(x) = z - h_terrain(x, y)``).
filterpy's :class:`~filterpy.kalman.UnscentedKalmanFilter` with Van der Merwe's scaled
sigma points ``MerweScaledSigmaPoints(4, alpha, beta, kappa)`` computes

.. math::

   \\chi^{(j)} = m \\pm \\text{columns of } \\sqrt{(n + \\lambda) P}, \\quad
   m^- = \\textstyle\\sum_j W^{(j)}_m f(\\chi^{(j)}), \\quad
   P^- = \\textstyle\\sum_j W^{(j)}_c (f(\\chi^{(j)}) - m^-)(\\cdot)^T + Q_f\\,dt,

   \\hat z = \\textstyle\\sum_j W^{(j)}_m h(\\chi^{(j)}_f), \\quad
   S = \\textstyle\\sum_j W^{(j)}_c (h(\\chi^{(j)}_f) - \\hat z)^2 + R_f, \\quad
   K = P_{xz} S^{-1}, \\quad m = m^- + K (y - \\hat z).

**Heading.** The heading ``psi`` (index 3) is an angle: sigma points are built with a
wrapped difference, their mean heading is the circular mean (weighted by ``W_m``), every
state residual wraps its heading, and the estimate is wrapped after each step.

**Leaving the map.** ``h`` has no value off the map.  If the predicted mean, or any sigma
point, lies off the map at a step, the filter stops there (``lost_at``), as
:func:`~pfcourse.terrain.scenario.extended_kalman_filter` does for its estimate.

With the defaults ``alpha = 1``, ``beta = 2``, ``kappa = 0``: ``lambda = 0``, the eight
outer sigma points sit at ``m +/- sqrt(4 P)`` columns with mean weight 1/8 each and the
centre point has mean weight 0 (every mean weight is non-negative, so the circular
mean is well defined).
"""

from __future__ import annotations


import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from pfcourse.checks import Array
from pfcourse.terrain.scenario import AircraftScenario, predicted_measurement, propagate
from pfcourse.angles import sigma_point_mean, wrap_angle
from pfcourse.results import KalmanResult
from pfcourse.terrain.map import TerrainMap


def state_residual(a: Array, b: Array) -> Array:
    """``a - b`` for aircraft states ``(4,)`` with the heading difference wrapped."""
    y = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    y[3] = wrap_angle(y[3])
    return y


def state_mean(sigmas: Array, weights: Array) -> Array:
    """Weighted mean of sigma points ``(n, 4)``; circular mean of the heading."""
    return sigma_point_mean(sigmas, weights, (3,))


def unscented_kalman_filter(
    scenario: AircraftScenario,
    terrain: TerrainMap,
    measurements: Array,
    *,
    alpha: float = 1.0,
    beta: float = 2.0,
    kappa: float = 0.0,
) -> KalmanResult:
    """Run filterpy's ``UnscentedKalmanFilter`` on scenario B (see the module docstring).

    Starts from ``N(x0, P0)``; predicts with ``Q = Qf dt`` at every step ``k > 0`` and
    updates with ``R = Rf`` when ``measurements[k]`` is not NaN.
    """
    s = scenario
    measurements = np.asarray(measurements, dtype=float).reshape(-1)
    K = len(measurements)
    points = MerweScaledSigmaPoints(4, alpha=alpha, beta=beta, kappa=kappa, subtract=state_residual)

    def fx(x, dt):
        return propagate(x, s.speed, s.omega, dt)

    def hx(x):
        return np.array([predicted_measurement(x, terrain)])

    ukf = UnscentedKalmanFilter(
        dim_x=4, dim_z=1, dt=s.dt, hx=hx, fx=fx, points=points,
        x_mean_fn=state_mean, residual_x=state_residual,
    )
    ukf.x = s.x0.copy()
    ukf.P = s.P0.copy()
    ukf.Q = s.Qf * s.dt
    ukf.R = np.array([[s.Rf]])
    out = KalmanResult.empty(K, 4, 1, "UKF")
    for k in range(K):
        if k > 0:
            ukf.predict()
            ukf.x[3] = wrap_angle(ukf.x[3])
        if not np.isnan(measurements[k]):
            if k == 0:
                # No prediction yet: the sigma points of the prior are the ones to transform.
                ukf.sigmas_f = points.sigma_points(ukf.x, ukf.P)
            on_map = terrain.contains(ukf.sigmas_f[:, 0], ukf.sigmas_f[:, 1])
            if not (np.all(on_map) and terrain.contains(ukf.x[0], ukf.x[1])):
                out.lost_at = k
                break
            predicted = ukf.x.copy()
            ukf.update(np.array([measurements[k]]))
            ukf.x[3] = wrap_angle(ukf.x[3])
            out.record_update(k, predicted, ukf.y, ukf.S, ukf.K)
        if not terrain.contains(ukf.x[0], ukf.x[1]):
            out.lost_at = k
            break
        out.mean[k] = ukf.x
        out.cov[k] = ukf.P
    return out
