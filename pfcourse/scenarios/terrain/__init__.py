"""Scenario B: terrain-aided navigation of an aircraft over a real elevation model.

* :mod:`pfcourse.scenarios.terrain.map` - the elevation map (bilinear heights and gradients, the Jacksboro DEM);
* :mod:`pfcourse.scenarios.terrain.scenario` - the flight's settings, its simulator and the particle-filter model;
* :mod:`pfcourse.scenarios.terrain.kalman` - the EKF and UKF references;
* :mod:`pfcourse.scenarios.terrain.field` - the field's 2-D problem (INS heading, barometric altitude) and its grid filter.
"""

from pfcourse.scenarios.terrain.field import FieldScenario, simulate_field
from pfcourse.scenarios.terrain.map import TerrainMap, load_jacksboro
from pfcourse.scenarios.terrain.scenario import AircraftScenario, Flight, TerrainModel, simulate

__all__ = ["AircraftScenario", "FieldScenario", "Flight", "TerrainMap", "TerrainModel", "load_jacksboro", "simulate",
           "simulate_field"]
