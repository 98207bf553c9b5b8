"""The Kalman filters of terrain-aided navigation (scenario B): the EKF
(:func:`~pfcourse.scenarios.terrain.scenario.extended_kalman_filter`) and the UKF, the one loop of
:mod:`pfcourse.kalman` on :func:`~pfcourse.scenarios.terrain.scenario.kalman_model`.

The state, dynamics and altimeter model are those of :mod:`pfcourse.scenarios.terrain.scenario`: the
sigma points go through :func:`~pfcourse.scenarios.terrain.scenario.propagate` (``f``) and
:func:`~pfcourse.scenarios.terrain.scenario.predicted_measurement` (``h(x) = z - h_terrain(x, y)``).
The unscented step (:class:`pfcourse.kalman.Unscented`, Van der Merwe's scaled
sigma points ``MerweScaledSigmaPoints(4, alpha, beta, kappa)``) computes

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
:func:`~pfcourse.scenarios.terrain.scenario.extended_kalman_filter` does for its estimate; so does it when
the updated mean leaves the map (the step's row is then NaN, its innovation unrecorded).

With the defaults ``alpha = 1``, ``beta = 2``, ``kappa = 0``: ``lambda = 0``, the eight
outer sigma points sit at ``m +/- sqrt(4 P)`` columns with mean weight 1/8 each and the
centre point has mean weight 0 (every mean weight is non-negative, so the circular
mean is well defined).
"""

from __future__ import annotations

import numpy as np

from pfcourse.checks import Array
from pfcourse.kalman import Unscented, gaussian_filter
from pfcourse.results import KalmanResult
from pfcourse.scenarios.terrain.map import TerrainMap
from pfcourse.scenarios.terrain.scenario import AircraftScenario, extended_kalman_filter, kalman_model, state_mean, state_residual


def unscented_kalman_filter(
    scenario: AircraftScenario,
    terrain: TerrainMap,
    measurements: Array,
    *,
    alpha: float = 1.0,
    beta: float = 2.0,
    kappa: float = 0.0,
) -> KalmanResult:
    """The UKF of scenario B (:func:`~pfcourse.scenarios.terrain.scenario.kalman_model`, :class:`pfcourse.kalman.Unscented`).

    Starts from ``N(x0, P0)``; predicts with ``Q = Qf dt`` at every step ``k > 0`` and
    updates with ``R = Rf`` when ``measurements[k]`` is not NaN.
    """
    gaussian = kalman_model(scenario, terrain)
    readings = np.asarray(measurements, dtype=float).reshape(-1)
    return gaussian_filter(gaussian, Unscented(gaussian, alpha=alpha, beta=beta, kappa=kappa), readings, "UKF", log_likelihood=False)


__all__ = ["extended_kalman_filter", "state_mean", "state_residual", "unscented_kalman_filter"]
