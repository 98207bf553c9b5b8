"""Monte Carlo runs of the terrain scenario: seeded flights, each filtered by the particle filter or the EKF.

Flight ``r`` of a study with seed ``s`` is drawn from :func:`pfcourse.seeding.data_rng` ``(s, r)`` and
its particle filter from :func:`pfcourse.seeding.filter_rng` ``(s, r)``: every setting sees the same
flights (common random numbers).  :func:`flight_study` records each flight
(:class:`~pfcourse.studies.record.RunRecord`); :func:`final_errors`, :func:`average_errors`,
:func:`diverged` and :func:`flight_summary` summarise the records, a lost or failed flight
counting as an infinite error.
"""

from __future__ import annotations

from collections.abc import Sequence
from concurrent.futures import Executor
from functools import cache, partial

import numpy as np

from pfcourse.checks import Array, check_count
from pfcourse.errors import ParameterError
from pfcourse.studies.executor import run_tasks
from pfcourse.studies.record import RunRecord, record_run, scores
from pfcourse.filter_config import FilterSettings
from pfcourse.seeding import data_rng, filter_rng
from pfcourse.scenarios.terrain.map import TerrainMap, load_jacksboro
from pfcourse.metrics import position_error, position_spread
from pfcourse.scenarios.terrain.scenario import AircraftScenario, extended_kalman_filter, simulate


#: A run whose final horizontal error exceeds this (m) is counted as diverged: about five
#: DEM cells, and thirty times the error of a converged particle filter in this scenario.
DIVERGED_ERROR = 500.0
#: A stored study's scores of a flight whose filter failed (every particle impossible: the study
#: runner's ``failed_scores``): lost, with an infinite error.
LOST_FLIGHT = {"final_error": np.inf, "mean_error": np.inf, "lost": True}


def flight_scores(truth: Array, mean: Array) -> dict:
    """A stored study's scores of a flight: final and time-averaged horizontal error (m), and
    ``lost``, a final error above :data:`DIVERGED_ERROR`."""
    e = position_error(truth, mean)
    return {"final_error": float(e[-1]), "mean_error": float(np.mean(e)), "lost": bool(e[-1] > DIVERGED_ERROR)}


@cache
def jacksboro() -> TerrainMap:
    """The Jacksboro map, loaded once per process (shared by the stored studies' row functions)."""
    return load_jacksboro()


def final_errors(flights: Sequence[RunRecord]) -> Array:
    """Final horizontal error of each flight (m; ``inf`` for a lost or failed flight)."""
    return scores(flights, "errors", failed=np.inf)[:, -1]


def average_errors(flights: Sequence[RunRecord]) -> Array:
    """Time-averaged horizontal error of each flight (m; ``inf`` for a lost or failed flight)."""
    return np.mean(scores(flights, "errors", failed=np.inf), axis=1)


def diverged(flights: Sequence[RunRecord]) -> Array:
    """Flights lost, failed or with a final error above :data:`DIVERGED_ERROR`."""
    return final_errors(flights) > DIVERGED_ERROR


def flight_summary(flights: Sequence[RunRecord]) -> dict[str, float]:
    """Median and 10 % / 90 % quantiles of the final and time-averaged errors, divergence rate.

    Quantiles use the ``inverted_cdf`` rule, so a lost flight counts as an infinite error
    without producing NaN.
    """
    out = {}
    for name, values in (("final", final_errors(flights)), ("average", average_errors(flights))):
        q10, q50, q90 = np.quantile(values, [0.1, 0.5, 0.9], method="inverted_cdf")
        out[f"{name}_median"], out[f"{name}_q10"], out[f"{name}_q90"] = q50, q10, q90
    out["diverged"] = float(np.mean(diverged(flights)))
    out["runs"] = float(len(flights))
    return out


def flight_study(
    scenario: AircraftScenario,
    terrain: TerrainMap,
    n_runs: int,
    *,
    n_particles: int = 3000,
    threshold: float = 0.5,
    resampler: str = "multinomial",
    seed: int = 0,
    method: str = "pf",
    executor: Executor | None = None,
    batch_size: int = 10,
) -> list[RunRecord]:
    """Run ``n_runs`` seeded flights of ``scenario`` and filter each one: one record per flight.

    Flight ``r`` is drawn with :func:`~pfcourse.seeding.data_rng` ``(seed, r)``: every setting of a study
    sees the same true flights and altimeter noise (common random numbers), so differences
    between settings are not differences between flights.  ``method`` is ``"pf"``
    (:class:`~pfcourse.filter.ParticleFilter`, seeded with :func:`~pfcourse.seeding.filter_rng`
    ``(seed, r)``) or ``"ekf"``.  The flights are shared out, ``batch_size`` at a time, by
    :func:`~pfcourse.studies.executor.run_tasks` (``executor=None``: a process pool over the
    cores); the result does not depend on the executor.

    A flight's scores: the horizontal position ``errors`` ``(K,)`` (m), ``sigma`` ``(K,)`` the
    filter's ``sqrt(P_xx + P_yy)`` (m), ``n_resamples``. An EKF whose estimate left the map is
    recorded ``"lost"`` and a particle filter that lost every particle ``"failed"``; both have
    NaN errors from the step they were lost (from the start for a failed one).
    """
    if method not in ("pf", "ekf"):
        raise ParameterError(f"method must be 'pf' or 'ekf', got {method!r}")
    n_runs = check_count(n_runs, "n_runs")
    batch_size = check_count(batch_size, "batch_size")
    settings = (n_particles, threshold, resampler, seed, method)
    chunks = [list(range(start, min(start + batch_size, n_runs))) for start in range(0, n_runs, batch_size)]
    return [run for chunk_runs in run_tasks(_flights, [(scenario, terrain, chunk, *settings) for chunk in chunks],
                                            executor=executor)
            for run in chunk_runs]


def _flights(scenario: AircraftScenario, terrain: TerrainMap, runs: list[int], n_particles: int,
             threshold: float, resampler: str, seed: int, method: str) -> list[RunRecord]:
    """Flights ``runs`` of :func:`flight_study`, recorded."""
    model = scenario.model(terrain)
    pf = FilterSettings(n_particles, threshold=threshold, resampler=resampler).build(model)
    out = []
    for r in runs:
        flight = simulate(scenario, terrain, data_rng(seed, r))
        if method == "ekf":
            run = partial(extended_kalman_filter, scenario, terrain, flight.measurements)
        else:
            run = partial(pf.run, flight.measurements, rng=filter_rng(seed, r))
        out.append(record_run(run, lambda res: {"errors": position_error(flight.truth, res.mean),
                                                "sigma": position_spread(res.cov),
                                                "n_resamples": getattr(res, "n_resamples", 0)},
                              setting={"run": r}, shape=(scenario.n_steps, 4, 1)))
    return out
