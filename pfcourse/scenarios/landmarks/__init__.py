"""Scenario A: a vehicle with linear Gaussian dynamics seeing fixed landmarks in relative position.

* :mod:`pfcourse.scenarios.landmarks.scenario` - the scenario's settings and its simulator;
* :mod:`pfcourse.book.figures.landmarks` - the scenario's figures;
* :mod:`pfcourse.scenarios.landmarks.rao_blackwell` - the Rao-Blackwellised filter (a Kalman filter over the map per particle).

The scenario's model is the core's :class:`~pfcourse.linear_gaussian.LinearGaussianModel`, its exact
posterior the core's :func:`~pfcourse.kalman.kalman_filter`; its optimal and fully adapted
auxiliary proposals are the core's (:mod:`pfcourse.proposals`).
"""

from pfcourse.scenarios.landmarks.scenario import (
    LandmarkScenario,
    LandmarkSimulation,
    circle_scenario,
    quadrant_scenario,
    rotation,
    simulate,
)

__all__ = [
    "LandmarkScenario",
    "LandmarkSimulation",
    "circle_scenario",
    "quadrant_scenario",
    "rotation",
    "simulate",
]
