"""Scenario B: terrain-aided navigation of an aircraft over a real elevation model.

* :mod:`pfcourse.terrain.map` - the elevation map (bilinear heights and gradients, the Jacksboro DEM);
* :mod:`pfcourse.terrain.scenario` - the flight's settings, its simulator and the particle-filter model;
* :mod:`pfcourse.terrain.kalman` - the EKF and UKF references;
* :mod:`pfcourse.terrain.field` - the field's 2-D problem (INS heading, barometric altitude) and its grid filter.
"""

from pfcourse.terrain.field import FieldScenario, simulate_field
from pfcourse.terrain.map import TerrainMap, load_jacksboro
from pfcourse.terrain.scenario import AircraftScenario, Flight, TerrainModel, simulate

__all__ = ["AircraftScenario", "FieldScenario", "Flight", "TerrainMap", "TerrainModel", "load_jacksboro", "simulate",
           "simulate_field"]
