"""Scenario D: a robot that drives through rooms and a corridor, on a map it reads with a range scanner.

* :mod:`pfcourse.scenarios.maprobot.grid` - the occupancy grid (rooms and a corridor that look alike) and its
  distance transform;
* :mod:`pfcourse.scenarios.maprobot.motion` - the odometry motion model rot1-trans-rot2 (Thrun, Burgard and Fox
  2005, table 5.6) and the simulated drive;
* :mod:`pfcourse.scenarios.maprobot.scanner` - a fan of beams ray-cast on the grid, with the four-part beam noise;
* :mod:`pfcourse.scenarios.maprobot.likelihood_field` - the likelihood-field sensor model (table 6.3);
* :mod:`pfcourse.scenarios.maprobot.model` - the particle filter's model (Monte Carlo localization), with the
  optional uniform injection of the kidnap model;
* :mod:`pfcourse.book.figures.maprobot` - the map drawn.
"""

from pfcourse.scenarios.maprobot.grid import OccupancyGrid, rooms_and_corridor
from pfcourse.scenarios.maprobot.likelihood_field import LikelihoodField
from pfcourse.scenarios.maprobot.model import MapRobotModel
from pfcourse.scenarios.maprobot.motion import OdometryModel, odometry_increments, simulate_drive
from pfcourse.scenarios.maprobot.scanner import Scanner, cast_rays

__all__ = ["LikelihoodField", "MapRobotModel", "OccupancyGrid", "OdometryModel", "Scanner", "cast_rays",
           "odometry_increments", "rooms_and_corridor", "simulate_drive"]
