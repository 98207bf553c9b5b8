"""The particle filter against the Kalman family: accuracy, consistency and cost on the same runs.

Three measurements, for every filter on every seeded run:

* **accuracy**: the position error ``||p_k - p^_k||`` per step (m);
* **consistency**: the normalised estimation error squared
  ``NEES_k = e_k^T P_k^{-1} e_k`` (chi-square with ``d = dim x`` degrees of freedom for a
  consistent filter) and the normalised innovation squared ``NIS_k = y_k^T S_k^{-1} y_k``
  (chi-square with ``m = dim z``), see :func:`pfcourse.diagnostics.nees` and
  :func:`pfcourse.diagnostics.nis`;
* **cost**: wall-clock seconds of the filter's run, and the number of model evaluations
  per step (``N`` particles, ``2 d + 1`` sigma points, one linearisation point).

Each filter on each run is one :class:`~pfcourse.studies.record.RunRecord`: its setting
``filter`` (``"pf"``, ``"ekf"``, ``"ukf"``) and ``n_particles`` (0 for a Kalman filter), its
scores ``position_error`` (m), ``nees`` and ``nis`` (per step), ``seconds`` and ``status``.

**Where the innovations come from.**  Every Kalman-family filter returns its own
(:class:`pfcourse.results.KalmanResult`: ``innovation`` ``y_k`` and ``innovation_cov`` ``S_k``
as the filter computed them, ``H P^- H^T + R`` for the EKF and the unscented transform plus
``R`` for the UKF), so nothing is recomputed here.

For the particle filter, the predictive distribution of ``z_k`` is the mixture
``sum_i W_{k-1}^i N(z; h(x_k^i), R)`` over the *predicted* particles (after the move,
before the weighting by ``z_k``); ``S_k`` is its covariance,
:func:`pfcourse.diagnostics.predictive_moments`.  The bootstrap filter stores exactly
these particles (``collect=[Clouds()]``), with weights ``W_{k-1}`` (uniform after a
resampling).
"""

from __future__ import annotations

from collections.abc import Sequence
from concurrent.futures import Executor

import numpy as np
import pandas as pd

from pfcourse.angles import wrap_angle
from pfcourse.checks import Array, check_count
from pfcourse.collectors import Clouds
from pfcourse.diagnostics import chi2_band, fraction_in_band, nees, nis, predictive_moments
from pfcourse.studies.executor import run_tasks
from pfcourse.studies.record import RunRecord, record_run
from pfcourse.filter_config import FilterConfig, FilterSettings, configurations
from pfcourse import metrics
from pfcourse.metrics import position_error, rmse
from pfcourse.results import FilterResult, KalmanResult
from pfcourse.scenarios.robot.scenario import ANGLE_INDICES, RobotModel, range_bearing, simulate_robot
from pfcourse.seeding import data_rng, filter_rng, sized_filter_rng
from pfcourse.scenarios.terrain.kalman import unscented_kalman_filter
from pfcourse.scenarios.terrain.map import TerrainMap
from pfcourse.scenarios.terrain.scenario import (
    AircraftScenario,
    extended_kalman_filter,
    predicted_measurement,
    simulate as simulate_flight,
)


def particle_innovations(result: FilterResult, measurements: Array, predict, noise_cov: Array,
                         angle_indices: Sequence[int] = ()) -> tuple[Array, Array]:
    """Innovations ``y_k = z_k - z-bar_k`` and covariances ``S_k`` of a bootstrap particle filter.

    ``result`` must come from ``run(..., collect=[Clouds()])`` with the transition as
    proposal, so that ``result.particles[k]`` are the predicted particles of step ``k``.
    ``predict(particles, z, k)`` returns ``h(x^i)`` ``(N, m)`` for the measurement ``z``
    (NaN rows for particles where ``h`` is undefined: they are left out, since their
    likelihood is zero); see :func:`~pfcourse.diagnostics.predictive_moments`.
    Returns ``(y, S)`` of shapes ``(K, m)`` and ``(K, m, m)``, NaN without a measurement.
    """
    if result.particles is None:
        raise ValueError("particle_innovations needs a run with its clouds collected (collect=[Clouds()])")
    noise_cov = np.atleast_2d(np.asarray(noise_cov, dtype=float))
    m = noise_cov.shape[0]
    K, n = result.weights.shape
    y = np.full((K, m), np.nan)
    S = np.full((K, m, m), np.nan)
    for k in range(1, K):
        zk = np.asarray(measurements[k], dtype=float).ravel()
        if np.all(np.isnan(zk)):
            continue
        w = np.full(n, 1.0 / n) if result.resampled[k - 1] else result.weights[k - 1]
        h = np.asarray(predict(result.particles[k], zk, k), dtype=float).reshape(n, m)
        ok = ~np.any(np.isnan(h), axis=1)
        mean, S[k] = predictive_moments(h[ok], w[ok] / w[ok].sum(), noise_cov, angle_indices)
        diff = zk[-m:] - mean
        for j in angle_indices:
            diff[j] = wrap_angle(diff[j])
        y[k] = diff
    return y, S


def _safe_nees(truth, mean, cov, angle_indices) -> Array:
    """NEES with ``inf`` where the filter has no estimate or a singular covariance."""
    out = np.full(len(truth), np.inf)
    ok = np.all(np.isfinite(mean), axis=1) & np.all(np.isfinite(cov), axis=(1, 2))
    ok &= np.linalg.eigvalsh(np.where(ok[:, None, None], cov, np.eye(cov.shape[-1])))[:, 0] > 0
    if np.any(ok):
        out[ok] = nees(truth[ok], mean[ok], cov[ok], angle_indices)
    return out


def _innovations(result, particle_innovations_of) -> tuple[Array, Array]:
    """A Kalman-family result's own innovations, or a particle filter's from its predicted clouds."""
    if isinstance(result, KalmanResult):
        return result.innovation, result.innovation_cov
    return particle_innovations_of(result)


def _tracks(filters: Sequence[tuple[str, int]], run, score, shape: tuple[int, int, int]) -> list[RunRecord]:
    """One record per ``(filter, N)``: ``run(filter, N)`` scored by ``score`` (:func:`record_run`)."""
    return [record_run(lambda: run(name, n), score, setting={"filter": name, "n_particles": n}, shape=shape)
            for name, n in filters]


def robot_tracks(seed: int, n_values: Sequence[int], *, n_steps: int = 100, q_scale: float = 1.0,
                 r_scale: float = 1.0, kalman: Sequence[str] = ("ekf", "ukf"), **scenario) -> list[RunRecord]:
    """The robot scenario: simulate run ``seed``, filter it with a PF per ``N`` and the EKF/UKF.

    Defaults differ from :func:`pfcourse.studies.robot.compare_filters` in one respect:
    the filters assume the *true* noise levels (``q_scale = r_scale = 1``), so that a
    consistent filter has NEES ~ chi2_3 and NIS ~ chi2_2.  The particle filter's random
    stream is :func:`~pfcourse.seeding.sized_filter_rng` ``(seed, N)``, that is ``[seed, N]``.  Errors are Euclidean position errors (m).
    """
    from pfcourse.scenarios.robot.kalman import run_ekf, run_ukf

    sim = simulate_robot(None, seed, n_steps=n_steps, **scenario)
    model = RobotModel.for_simulation(sim, q_scale=q_scale, r_scale=r_scale)
    z = sim.measurements

    def predict(particles, zk, k):
        return range_bearing(particles, model.landmarks[int(zk[0])])

    def run(name, n):
        if name == "pf":
            return FilterSettings(n).build(model).run(z, sized_filter_rng(seed, n), collect=[Clouds()])
        return (run_ekf if name == "ekf" else run_ukf)(model, z)

    def score(res) -> dict:
        y, S = _innovations(res, lambda r: particle_innovations(r, z, predict, model.r_est, angle_indices=(1,)))
        return {"position_error": position_error(sim.truth, res.mean),
                "nees": _safe_nees(sim.truth, res.mean, res.cov, ANGLE_INDICES), "nis": nis(y, S)}

    filters = [("pf", int(n)) for n in n_values] + [(name, 0) for name in kalman]
    return _tracks(filters, run, score, (len(z), 3, 2))


#: What might fix the robot particle filter's over-confidence (the "what is fixable" study):
#: setting -> (particles N, process-noise scale of the filter's Q, roughening constant K or None).
CONSISTENCY_FIXES = {
    "PF N=1000": (1000, 1.0, None),
    "PF N=3000": (3000, 1.0, None),
    "PF N=1000, roughening K=0.2": (1000, 1.0, 0.2),
    "PF N=1000, filter's Q x2": (1000, 2.0, None),
    "PF N=1000, filter's Q x4": (1000, 4.0, None),
}
CONSISTENCY_STEPS, CONSISTENCY_BURN_IN = 100, 20


def _consistency_filters() -> dict[str, FilterConfig]:
    from pfcourse.jitter import Roughening

    return configurations(*(FilterConfig.of(name, FilterSettings(n, jitter=None if K is None else Roughening(K)))
                            for name, (n, _, K) in CONSISTENCY_FIXES.items()))


#: The particle filter of each setting as a settings record (systematic resampling at ESS < N/2; the
#: scale of the filter's Q is the model's, ``RobotModel.for_simulation(sim, q_scale=...)``).
CONSISTENCY_FILTERS = _consistency_filters()


def consistency_fix_row(seed: int, setting: str) -> dict:
    """Run ``seed`` of the robot of :func:`robot_tracks` (true noise levels in the data) through the
    particle filter of ``setting`` (:data:`CONSISTENCY_FIXES`): the position RMSE (m) and the mean NEES
    after :data:`CONSISTENCY_BURN_IN` steps, and the NEES of every step (``nees``, an array).

    The filter's stream is ``filter_rng(0, seed)`` whatever the setting, and the data the same
    (``simulate_robot(None, seed)``): the settings are paired run by run.
    """
    _, q_scale, _ = CONSISTENCY_FIXES[setting]
    sim = simulate_robot(None, seed, n_steps=CONSISTENCY_STEPS)
    model = RobotModel.for_simulation(sim, q_scale=q_scale, r_scale=1.0)
    res = CONSISTENCY_FILTERS[setting].build(model).run(sim.measurements, filter_rng(0, seed))
    nees_k = _safe_nees(sim.truth, res.mean, res.cov, ANGLE_INDICES)
    err = position_error(sim.truth, res.mean)[CONSISTENCY_BURN_IN:]
    return {"rmse_m": float(rmse(err)), "nees_mean": float(np.mean(nees_k[CONSISTENCY_BURN_IN:])),
            "nees": nees_k}


def terrain_tracks(seed: int, run: int, scenario: AircraftScenario, terrain: TerrainMap,
                   n_values: Sequence[int], *, kalman: Sequence[str] = ("ekf", "ukf"),
                   resampler: str = "multinomial") -> list[RunRecord]:
    """Terrain navigation: flight ``run`` of a study with seed ``seed`` (as
    :func:`pfcourse.studies.terrain.flight_study`: flight :func:`~pfcourse.seeding.data_rng`,
    particle filter :func:`~pfcourse.seeding.filter_rng`), filtered by a PF per ``N`` and the EKF/UKF.

    Errors are horizontal position errors (m); a lost filter (every particle off the map: status
    ``"failed"``; a Kalman estimate or sigma point off the map: ``"lost"``) has ``inf`` error,
    NEES and NIS from the step it was lost (from the start for a particle filter).
    """
    flight = simulate_flight(scenario, terrain, data_rng(seed, run))
    z = flight.measurements
    measured = ~np.isnan(z[:, 0])
    model = scenario.model(terrain)

    def predict(particles, zk, k):
        return predicted_measurement(particles, terrain)[:, None]

    def run_filter(name, n):
        if name == "pf":
            return FilterSettings(n, resampler=resampler).build(model).run(
                z, filter_rng(seed, run), collect=[Clouds()])
        return (extended_kalman_filter if name == "ekf" else unscented_kalman_filter)(scenario, terrain, z)

    def score(res) -> dict:
        y, S = _innovations(res, lambda r: particle_innovations(r, z, predict, np.array([[scenario.Rf]])))
        q = nis(y, S)
        q[measured & np.isnan(q)] = np.inf
        return {"position_error": np.where(np.isnan(res.mean[:, 0]), np.inf, position_error(flight.truth, res.mean)),
                "nees": _safe_nees(flight.truth, res.mean, res.cov, (3,)), "nis": q}

    filters = [("pf", int(n)) for n in n_values] + [(name, 0) for name in kalman]
    return _tracks(filters, run_filter, score, (len(z), 4, 1))


def label(track: RunRecord) -> str:
    """``"PF N=300"``, ``"EKF"`` or ``"UKF"``."""
    return f"PF N={track.n_particles}" if track.filter == "pf" else track.filter.upper()


def evaluations_per_step(track: RunRecord, dim_x: int) -> int:
    """Model evaluations per step: ``N`` (particles), ``2 d + 1`` (sigma points) or 1 (EKF)."""
    return {"pf": track.n_particles, "ukf": 2 * dim_x + 1, "ekf": 1}[track.filter]


def summarize_tracks(runs: Sequence[Sequence[RunRecord]], *, dim_x: int, dim_z: int, burn_in: int = 0,
              diverged_error: float | None = None) -> pd.DataFrame:
    """One row per filter over ``R`` runs (``runs[r]`` holds the same filters in the same order).

    Columns: ``rmse_q10``, ``rmse_q50``, ``rmse_q90`` (quantiles over runs of the per-run RMS
    position error over steps ``k >= burn_in``, m); ``diverged`` (share of runs lost or with
    a final error above ``diverged_error``, if given); ``nees_median`` / ``nis_median``
    (median over runs and steps); ``nees_in_band`` / ``nis_in_band`` (fraction of steps
    whose run-averaged NEES / NIS lies in the 95 % band of the average of ``R`` chi-square
    variables, :func:`~pfcourse.diagnostics.chi2_band`: 0.95 expected of a consistent
    filter, a lost run's ``inf`` puts the step outside), and ``nees_below`` / ``nis_below``
    the fraction of steps below the band (a conservative filter); ``ms_per_step`` (median run time
    over runs / steps); ``evaluations`` (:func:`evaluations_per_step`).
    """
    R = len(runs)
    nees_band = chi2_band(dim_x, R)
    nis_band = chi2_band(dim_z, R)
    rows = []
    for j, first in enumerate(runs[0]):
        tracks = [r[j] for r in runs]
        err = np.array([t.position_error[burn_in:] for t in tracks])
        with np.errstate(invalid="ignore", over="ignore"):
            rmse = metrics.rmse(err, axis=1)
            nees_all = np.array([t.nees[burn_in:] for t in tracks])
            nis_all = np.array([t.nis[burn_in:] for t in tracks])
            nis_steps = ~np.all(np.isnan(nis_all), axis=0)
            nees_avg = np.mean(nees_all, axis=0)
            nis_avg = np.mean(nis_all[:, nis_steps], axis=0)
        q10, q50, q90 = np.quantile(rmse, [0.1, 0.5, 0.9], method="inverted_cdf")
        row = {
            "filter": label(first),
            "N": first.n_particles,
            "rmse_q10": q10, "rmse_q50": q50, "rmse_q90": q90,
            "nees_median": float(np.median(nees_all)),
            "nis_median": float(np.nanmedian(nis_all)),
            "nees_in_band": fraction_in_band(nees_avg, nees_band),
            "nis_in_band": fraction_in_band(nis_avg, nis_band),
            "nees_below": fraction_in_band(nees_avg, (-np.inf, np.nextafter(nees_band[0], -np.inf))),
            "nis_below": fraction_in_band(nis_avg, (-np.inf, np.nextafter(nis_band[0], -np.inf))),
            "ms_per_step": 1000 * float(np.median([t.seconds for t in tracks])) / len(first.position_error),
            "evaluations": evaluations_per_step(first, dim_x),
        }
        if diverged_error is not None:
            final = np.array([t.position_error[-1] for t in tracks])
            row["diverged"] = float(np.mean(~(final <= diverged_error)))
        rows.append(row)
    return pd.DataFrame(rows).set_index("filter")


def linear_convergence(model, measurements: Array, kalman, n_values: Sequence[int], n_runs: int, *,
                       seed: int = 0, threshold: float = 0.5, executor: Executor | None = None) -> dict[str, Array]:
    """Run a bootstrap particle filter ``n_runs`` times per ``N`` on one data set and compare it
    with the Kalman result ``kalman`` (:func:`pfcourse.kalman.kalman_filter`).

    Returns the table of errors per ``N`` (rows) and run (columns), arrays keyed:
    ``mean_error``, the RMS over steps and components of ``m^PF_k - m^KF_k`` (m);
    ``cov_error``, the RMS over steps of the Frobenius norm ``||P^PF_k - P^KF_k||_F`` (m^2);
    ``loglik_error``, ``log p^(z_{0:K}) - log p(z_{0:K})`` (nats, signed); and ``n_values``.
    A run that fails raises (these runs are on a linear-Gaussian model, where none should).

    Run ``r`` at ``N`` uses the random stream :func:`~pfcourse.seeding.sized_filter_rng`
    ``(seed, N, run=r)``, that is ``[seed, r, N]``.  The values of ``N`` are shared out by
    :func:`~pfcourse.studies.executor.run_tasks` (``executor=None``: a process pool over the
    cores); the result does not depend on it.
    """
    n_values = np.asarray(n_values, dtype=int)
    n_runs = check_count(n_runs, "n_runs")
    errors = run_tasks(_convergence_runs, [(model, measurements, kalman, int(n), n_runs, seed, threshold)
                                           for n in n_values], executor=executor)
    mean_err, cov_err, ll_err = (np.array(column) for column in zip(*errors))
    return {"n_values": n_values, "mean_error": mean_err, "cov_error": cov_err, "loglik_error": ll_err}


def _convergence_runs(model, measurements: Array, kalman, n: int, n_runs: int, seed: int,
                      threshold: float) -> tuple[Array, Array, Array]:
    """The ``n_runs`` runs of :func:`linear_convergence` at ``N = n``: errors of the mean, covariance, log-likelihood."""
    pf = FilterSettings(n, threshold=threshold).build(model)
    mean_err, cov_err, ll_err = np.empty(n_runs), np.empty(n_runs), np.empty(n_runs)
    for r in range(n_runs):
        res = pf.run(measurements, sized_filter_rng(seed, n, run=r))
        mean_err[r] = metrics.rmse(res.mean - kalman.mean)
        cov_err[r] = metrics.rmse(res.cov - kalman.cov, components=(1, 2))
        ll_err[r] = res.log_likelihood - kalman.log_likelihood
    return mean_err, cov_err, ll_err


__all__ = [
    "evaluations_per_step", "label", "linear_convergence", "particle_innovations",
    "robot_tracks", "summarize_tracks", "terrain_tracks",
]
