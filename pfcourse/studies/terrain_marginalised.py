"""Seeded runs of the marginalised particle filter and of the point-mass filter on the terrain flights.

The flights are those of :mod:`pfcourse.studies.terrain_remedies` (flight ``r`` from
:func:`pfcourse.seeding.data_rng` ``(0, r)``, the filter from :func:`pfcourse.seeding.filter_rng` ``(0, r)``),
and so is the divergence rule: a flight is *lost* when the final horizontal error exceeds
:data:`pfcourse.studies.terrain.DIVERGED_ERROR` (500 m) or every particle died (recorded by the
study runner, as in the remedies study).  The filter is
the engine with :class:`pfcourse.scenarios.terrain.marginalised.AltitudeKalmanProposal`, resampling as the
bootstrap rows of the remedies study (multinomial, at ESS < N/2), so the two are paired flight by flight.

The study ``terrain_mpf`` stores :func:`row` in ``book/data/terrain_mpf.csv``; the study
``terrain_grid`` stores :func:`grid_row` (the point-mass filter of :mod:`pfcourse.scenarios.terrain.point_mass`
at each resolution of :data:`CELLS`, with its final posterior mean and standard deviations, and the grid
points it held: ``cells`` on average over the steps, ``max_cells`` at most) in ``book/data/terrain_grid.csv``.
"""

from __future__ import annotations

import numpy as np

from pfcourse.studies.terrain import flight_scores, jacksboro
from pfcourse.seeding import data_rng, filter_rng
from pfcourse.filter_config import FilterSettings
from pfcourse.scenarios.terrain.marginalised import AltitudeKalmanProposal, MarginalisedTerrainModel
from pfcourse.scenarios.terrain.point_mass import PointMassFilter
from pfcourse.scenarios.terrain.scenario import AircraftScenario, simulate

#: The marginalised filter's sizes, in the order they are stored.
SIZES = [3000, 10000, 30000]
COLUMNS = ("setting", "flight", "status", "error_message", "N", "final_error", "mean_error", "lost", "final_x", "final_y",
           "seconds")
#: The point-mass filter's cell sizes (m) and heading bins (degrees), coarse to fine: each step divides both by
#: sqrt(2) (the number of grid points grows by about 2.8).
CELLS = [(400.0, 8.0), (283.0, 5.66), (200.0, 4.0), (141.0, 2.83), (100.0, 2.0)]
#: Flights 0 to GRID_FLIGHTS - 1 (the finest grid costs tens of seconds a flight on the shared machine).
GRID_FLIGHTS = 12
GRID_COLUMNS = ("cell", "heading_deg", "flight", "final_error", "mean_error", "lost", "final_x", "final_y",
                "final_sd_x", "final_sd_y", "cells", "max_cells", "seconds")


class Marginalised:
    """The model change of the marginalised filter: the terrain model with the altitude integrated out
    (:class:`~pfcourse.scenarios.terrain.marginalised.MarginalisedTerrainModel`, a scalar Kalman filter of the
    altitude in each particle), on the model's map and scenario."""

    label = "altitude marginalised"

    def apply(self, model) -> MarginalisedTerrainModel:
        return MarginalisedTerrainModel(model.terrain, model.scenario)


#: The marginalised filter as a settings record: the altitude's Kalman update as the proposal, multinomial
#: resampling at ESS < N/2 (``N`` from the grid; 3000 nominal): ``MPF.with_(n_particles=N).build(scenario.model(terrain))``.
MPF = FilterSettings(3000, threshold=0.5, resampler="multinomial", proposal=AltitudeKalmanProposal(),
                     model_change=Marginalised())


def run_mpf(n: int, run: int, terrain, scenario: AircraftScenario | None = None) -> dict:
    """The marginalised filter with ``n`` particles on flight ``run``: errors (m), lost flag, final mean."""
    scenario = scenario or AircraftScenario()
    flight = simulate(scenario, terrain, data_rng(0, run))
    pf = MPF.with_(n_particles=n).build(scenario.model(terrain))
    res = pf.run(flight.measurements, rng=filter_rng(0, run))
    return {"setting": f"marginalised N={n}", "flight": run, "N": n, **flight_scores(flight.truth, res.mean),
            "final_x": float(res.mean[-1, 0]), "final_y": float(res.mean[-1, 1])}


def row(seed: int, N: int) -> dict:
    """The study's row function: :func:`run_mpf` of flight ``seed`` with ``N`` particles."""
    return run_mpf(N, seed, jacksboro())


def run_grid(cell: float, heading_step_deg: float, run: int, terrain,
             scenario: AircraftScenario | None = None) -> dict:
    """The point-mass filter at ``cell`` metres and ``heading_step_deg`` degrees on flight ``run``."""
    scenario = scenario or AircraftScenario()
    flight = simulate(scenario, terrain, data_rng(0, run))
    pmf = PointMassFilter(terrain, scenario, cell=cell, heading_step=np.radians(heading_step_deg))
    res = pmf.run(flight.measurements)
    return {"cell": cell, "heading_deg": heading_step_deg, "flight": run, **flight_scores(flight.truth, res.mean),
            "final_x": float(res.mean[-1, 0]),
            "final_y": float(res.mean[-1, 1]), "final_sd_x": float(res.sd[-1, 0]), "final_sd_y": float(res.sd[-1, 1]),
            "cells": float(np.mean(res.cells)), "max_cells": int(res.cells.max())}


def grid_row(seed: int, cell: float) -> dict:
    """The grid study's row function: :func:`run_grid` of flight ``seed`` at cell size ``cell`` (m)."""
    heading = dict(CELLS)[cell]
    return run_grid(cell, heading, seed, jacksboro())
