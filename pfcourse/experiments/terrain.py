"""Monte Carlo runs of the terrain scenario: seeded flights, each filtered by the particle filter or the EKF.

Flight ``r`` of a study with seed ``s`` is drawn from :func:`pfcourse.seeding.data_rng` ``(s, r)`` and
its particle filter from :func:`pfcourse.seeding.filter_rng` ``(s, r)``: every setting sees the same
flights (common random numbers).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pfcourse.checks import Array
from pfcourse.errors import DegenerateWeightsError, ParameterError
from pfcourse.filter import ParticleFilter
from pfcourse.seeding import data_rng, filter_rng
from pfcourse.terrain.map import TerrainMap
from pfcourse.terrain.scenario import AircraftScenario, extended_kalman_filter, position_error, simulate


#: A run whose final horizontal error exceeds this (m) is counted as diverged: about five
#: DEM cells, and thirty times the error of a converged particle filter in this scenario.
DIVERGED_ERROR = 500.0


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
) -> MonteCarloResult:
    """Run ``n_runs`` seeded flights of ``scenario`` and filter each one.

    Flight ``r`` is drawn with :func:`~pfcourse.seeding.data_rng` ``(seed, r)``: every setting of a study
    sees the same true flights and altimeter noise (common random numbers), so differences
    between settings are not differences between flights.  ``method`` is ``"pf"``
    (:class:`~pfcourse.filter.ParticleFilter`, seeded with :func:`~pfcourse.seeding.filter_rng`
    ``(seed, r)``) or ``"ekf"``.
    """
    if method not in ("pf", "ekf"):
        raise ParameterError(f"method must be 'pf' or 'ekf', got {method!r}")
    K = scenario.n_steps
    errors = np.full((n_runs, K), np.nan)
    sigma = np.full((n_runs, K), np.nan)
    lost = np.zeros(n_runs, dtype=bool)
    n_resamples = np.zeros(n_runs, dtype=int)
    model = scenario.model(terrain)
    pf = ParticleFilter(model, n_particles, threshold=threshold, resampler=resampler)
    for r in range(n_runs):
        flight = simulate(scenario, terrain, data_rng(seed, r))
        if method == "ekf":
            res = extended_kalman_filter(scenario, terrain, flight.measurements)
            lost[r] = res.lost_at is not None
            mean, cov = res.mean, res.cov
        else:
            try:
                res = pf.run(flight.measurements, rng=filter_rng(seed, r))
            except DegenerateWeightsError:
                lost[r] = True
                continue
            mean, cov = res.mean, res.cov
            n_resamples[r] = res.n_resamples
        errors[r] = position_error(flight.truth, mean)
        sigma[r] = np.sqrt(cov[:, 0, 0] + cov[:, 1, 1])
    return MonteCarloResult(errors=errors, sigma=sigma, lost=lost, n_resamples=n_resamples)
