"""Scenario C: mobile-robot localization with range-bearing landmarks.

* :mod:`pfcourse.scenarios.robot.scenario` - the scenario's settings, its simulator and the particle-filter model;
* :mod:`pfcourse.scenarios.robot.kalman` - the EKF and UKF references;
* :mod:`pfcourse.book.figures.robot` - the scenario's figures;
* :mod:`pfcourse.scenarios.robot.association` - anonymous readings with clutter and misses, the mixture
  likelihood over associations and the nearest-neighbour EKF (unknown data association).
"""

from pfcourse.scenarios.robot.kalman import run_ekf, run_ukf
from pfcourse.scenarios.robot.scenario import (
    ANGLE_INDICES,
    INITIAL_STD,
    Q_TRUE,
    R_TRUE,
    RobotModel,
    RobotScenario,
    RobotSimulation,
    motion,
    range_bearing,
    simulate_robot,
    tracking_errors,
    tracking_rmse,
)

__all__ = [
    "ANGLE_INDICES",
    "INITIAL_STD",
    "Q_TRUE",
    "R_TRUE",
    "RobotModel",
    "RobotScenario",
    "RobotSimulation",
    "motion",
    "range_bearing",
    "run_ekf",
    "run_ukf",
    "simulate_robot",
    "tracking_errors",
    "tracking_rmse",
]
