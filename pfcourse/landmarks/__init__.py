"""Scenario A: a vehicle with linear Gaussian dynamics seeing fixed landmarks in relative position.

* :mod:`pfcourse.landmarks.scenario` - the scenario's settings and its simulator;
* :mod:`pfcourse.landmarks.model` - the linear Gaussian state-space model and its optimal proposal;
* :mod:`pfcourse.landmarks.kalman` - the exact posterior (Kalman filter);
* :mod:`pfcourse.landmarks.figures` - the scenario's figures;
* :mod:`pfcourse.landmarks.rao_blackwell` - the Rao-Blackwellised filter (a Kalman filter over the map per particle);
* :mod:`pfcourse.landmarks.auxiliary` - the fully adapted auxiliary particle filter.
"""

from pfcourse.landmarks.kalman import KalmanResult, kalman_filter
from pfcourse.landmarks.model import LinearGaussianModel, OptimalProposal
from pfcourse.landmarks.scenario import (
    LandmarkScenario,
    LandmarkSimulation,
    circle_scenario,
    quadrant_scenario,
    rotation,
    simulate,
)

__all__ = [
    "KalmanResult",
    "LandmarkScenario",
    "LandmarkSimulation",
    "LinearGaussianModel",
    "OptimalProposal",
    "circle_scenario",
    "kalman_filter",
    "quadrant_scenario",
    "rotation",
    "simulate",
]
