"""Monte Carlo runs of the terrain scenario: seeded flights, each filtered by the particle filter or the EKF.

Flight ``r`` of a study with seed ``s`` is drawn from :func:`pfcourse.seeding.data_rng` ``(s, r)`` and
its particle filter from :func:`pfcourse.seeding.filter_rng` ``(s, r)``: every setting sees the same
flights (common random numbers).
"""

from __future__ import annotations

from concurrent.futures import Executor
from dataclasses import dataclass
from functools import cache

import numpy as np

from pfcourse.checks import Array, check_count
from pfcourse.errors import DegenerateWeightsError, ParameterError
from pfcourse.executor import run_tasks
from pfcourse.filter import ParticleFilter
from pfcourse.seeding import data_rng, filter_rng
from pfcourse.terrain.map import TerrainMap, load_jacksboro
from pfcourse.metrics import position_error, position_spread
from pfcourse.terrain.scenario import AircraftScenario, extended_kalman_filter, simulate


#: A run whose final horizontal error exceeds this (m) is counted as diverged: about five
#: DEM cells, and thirty times the error of a converged particle filter in this scenario.
DIVERGED_ERROR = 500.0


@cache
def jacksboro() -> TerrainMap:
    """The Jacksboro map, loaded once per process (shared by the stored studies' row functions)."""
    return load_jacksboro()


@dataclass
class MonteCarloResult:
    """Horizontal position errors of ``R`` seeded runs: ``errors`` ``(R, K)`` (m).

    A run that lost every particle (``DegenerateWeightsError``) or whose EKF estimate left
    the map has NaN errors from that step on; ``lost`` ``(R,)`` marks it.
    ``sigma`` ``(R, K)`` is ``sqrt(P_xx + P_yy)`` of the filter, ``n_resamples`` ``(R,)``.
    """

    errors: Array
    sigma: Array
    lost: Array
    n_resamples: Array

    @property
    def final(self) -> Array:
        """Final horizontal error of each run (``inf`` for a lost run)."""
        return np.where(self.lost, np.inf, self.errors[:, -1])

    @property
    def time_average(self) -> Array:
        """Time-averaged horizontal error of each run (``inf`` for a lost run)."""
        return np.where(self.lost, np.inf, np.mean(self.errors, axis=1))

    @property
    def diverged(self) -> Array:
        """Runs lost or with a final error above :data:`DIVERGED_ERROR`."""
        return self.final > DIVERGED_ERROR

    def first(self, n: int) -> MonteCarloResult:
        """The first ``n`` runs (the same flights as a study of ``n`` runs with the same seed)."""
        return MonteCarloResult(self.errors[:n], self.sigma[:n], self.lost[:n], self.n_resamples[:n])

    def summary(self) -> dict[str, float]:
        """Median and 10 % / 90 % quantiles of the final and time-averaged errors, divergence rate.

        Quantiles use the ``inverted_cdf`` rule, so a lost run counts as an infinite error
        without producing NaN.
        """
        out = {}
        for name, values in (("final", self.final), ("average", self.time_average)):
            q10, q50, q90 = np.quantile(values, [0.1, 0.5, 0.9], method="inverted_cdf")
            out[f"{name}_median"], out[f"{name}_q10"], out[f"{name}_q90"] = q50, q10, q90
        out["diverged"] = float(np.mean(self.diverged))
        out["runs"] = float(len(self.final))
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
) -> MonteCarloResult:
    """Run ``n_runs`` seeded flights of ``scenario`` and filter each one.

    Flight ``r`` is drawn with :func:`~pfcourse.seeding.data_rng` ``(seed, r)``: every setting of a study
    sees the same true flights and altimeter noise (common random numbers), so differences
    between settings are not differences between flights.  ``method`` is ``"pf"``
    (:class:`~pfcourse.filter.ParticleFilter`, seeded with :func:`~pfcourse.seeding.filter_rng`
    ``(seed, r)``) or ``"ekf"``.  The flights are shared out, ``batch_size`` at a time, by
    :func:`~pfcourse.executor.run_tasks` (``executor=None``: a process pool over the
    cores); the result does not depend on the executor.
    """
    if method not in ("pf", "ekf"):
        raise ParameterError(f"method must be 'pf' or 'ekf', got {method!r}")
    n_runs = check_count(n_runs, "n_runs")
    batch_size = check_count(batch_size, "batch_size")
    settings = (n_particles, threshold, resampler, seed, method)
    chunks = [list(range(start, min(start + batch_size, n_runs))) for start in range(0, n_runs, batch_size)]
    runs = [run for chunk_runs in run_tasks(_flights, [(scenario, terrain, chunk, *settings) for chunk in chunks],
                                            executor=executor)
            for run in chunk_runs]
    errors, sigma, lost, n_resamples = (np.array(column) for column in zip(*runs))
    return MonteCarloResult(errors=errors, sigma=sigma, lost=lost, n_resamples=n_resamples)


def _flights(scenario: AircraftScenario, terrain: TerrainMap, runs: list[int], n_particles: int,
             threshold: float, resampler: str, seed: int, method: str) -> list[tuple[Array, Array, bool, int]]:
    """Flights ``runs`` of :func:`flight_study`: per run, the errors, ``sigma``, lost and resampling count."""
    K = scenario.n_steps
    model = scenario.model(terrain)
    pf = ParticleFilter(model, n_particles, threshold=threshold, resampler=resampler)
    out = []
    for r in runs:
        flight = simulate(scenario, terrain, data_rng(seed, r))
        n_resamples = 0
        if method == "ekf":
            res = extended_kalman_filter(scenario, terrain, flight.measurements)
            lost = res.lost_at is not None
        else:
            try:
                res = pf.run(flight.measurements, rng=filter_rng(seed, r))
            except DegenerateWeightsError:
                out.append((np.full(K, np.nan), np.full(K, np.nan), True, 0))
                continue
            lost, n_resamples = False, res.n_resamples
        out.append((position_error(flight.truth, res.mean), position_spread(res.cov),
                    lost, n_resamples))
    return out
