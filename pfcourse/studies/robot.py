"""One seeded run of the robot scenario through several filters, summarised by a few numbers.

This is the unit a Monte Carlo study repeats: :func:`compare_filters` simulates
run ``seed`` with the scenario settings given as keyword arguments, runs the
particle filter, the EKF and/or the UKF on *the same* data, and records, per
filter, the position and heading RMSE, the time-averaged NEES and the run time
(a :class:`~pfcourse.studies.record.RunRecord`).
:func:`global_localization_run` records one particle filter started
from a cloud uniform over the map and whether it locked on, and :func:`pf_run` returns
the fuller row of a Part III study.  The three take the filter settings
(:class:`RobotRunOptions`: the defaults and their meaning, written once) and the scenario
changes as keyword arguments.

The metrics (``e_k = estimate_k - truth_k``, heading wrapped, steps ``k >= burn_in``)::

    RMSE_pos   = sqrt(mean_k (e_x^2 + e_y^2))            (m)
    RMSE_theta = sqrt(mean_k e_theta^2)                  (rad)
    NEES       = mean_k e_k^T P_k^{-1} e_k               (chi2 with 3 dof per step if consistent)
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from pfcourse.diagnostics import nees
from pfcourse.checks import check_count, check_real
from pfcourse.errors import ParameterError
from pfcourse.studies.record import RunRecord, record_run
from pfcourse.filter_config import FilterSettings
from pfcourse.metrics import rmse as metrics_rmse
from pfcourse.metrics import LOCK_HEADING_RAD, LOCK_POSITION_M, heading_error, locked_on, position_error, position_spread
from pfcourse.results import FilterResult
from pfcourse.scenarios.robot.scenario import (
    ANGLE_INDICES,
    INITIAL_STD,
    RobotModel,
    RobotScenario,
    RobotSimulation,
    simulate_robot,
    tracking_errors,
    tracking_rmse,
)
from pfcourse.scenarios.robot.kalman import run_ekf, run_ukf

FILTERS = ("pf", "ekf", "ukf")


def _metrics(sim, mean, cov, burn_in) -> dict:
    """The scores of one robot run: ``position_rmse``, ``heading_rmse``, ``mean_nees`` and the
    per-step ``nees`` of the steps ``k >= burn_in`` (NaN where the filter has no estimate)."""
    pos, head = tracking_rmse(sim.truth, mean, burn_in)
    per_step = nees(sim.truth[burn_in:], mean[burn_in:], cov[burn_in:], ANGLE_INDICES)
    return {"position_rmse": pos, "heading_rmse": head, "mean_nees": float(np.mean(per_step)), "nees": per_step}


@dataclass(frozen=True)
class RobotRunOptions:
    """How the filters of one robot run are set up (the particle filter's own settings record is
    :meth:`filter_settings`): the keyword arguments shared by
    :func:`compare_filters`, :func:`pf_run` and :func:`global_localization_run`.

    ``n_particles``
        Number of particles ``N`` of the particle filter.
    ``q_scale``, ``r_scale``
        The filters use ``QEst = q_scale QTrue`` and ``REst = r_scale RTrue``.
    ``threshold``, ``scheme``
        The particle filter resamples with ``scheme`` when ``ESS < threshold N``.
    ``initial``
        The particle filter's start, ``"tracking"`` or ``"uniform"`` (the Kalman filters
        always start from the tracking prior).
    ``initial_std``
        Standard deviations of the tracking prior around the true start.
    ``burn_in``
        The metrics are taken over the steps ``k >= burn_in``.

    The particle filter's random stream is seeded with the run's seed.  The run functions
    take these as keyword arguments beside the
    :class:`~pfcourse.scenarios.robot.scenario.RobotScenario` fields (:meth:`split` tells them apart):
    ``pf_run(seed, n_particles=100, n_steps=50)``.
    """

    n_particles: int = 300
    q_scale: float = 2.0
    r_scale: float = 2.0
    threshold: float = 0.5
    scheme: str = "systematic"
    initial: str = "tracking"
    initial_std: tuple[float, float, float] = INITIAL_STD
    burn_in: int = 0

    @classmethod
    def split(cls, options: dict) -> tuple[RobotRunOptions, dict]:
        """``(settings, scenario_changes)``: the keyword arguments that are fields of this class
        and the others (:class:`~pfcourse.scenarios.robot.scenario.RobotScenario` fields)."""
        names = {f.name for f in fields(cls)}
        mine = {key: value for key, value in options.items() if key in names}
        return cls(**mine), {key: value for key, value in options.items() if key not in names}

    def simulate(self, seed: int, scenario: RobotScenario | None, changes: dict) -> RobotSimulation:
        """Simulate run ``seed`` of ``scenario`` updated by ``changes``; refuse a ``burn_in``
        that leaves no step."""
        check_count(self.burn_in + 1, "burn_in + 1")
        sim = simulate_robot(scenario, seed, **changes)
        if self.burn_in >= sim.scenario.n_steps:
            raise ParameterError(f"burn_in = {self.burn_in} leaves no step of the {sim.scenario.n_steps}")
        return sim

    def model(self, sim: RobotSimulation, initial: str | None = None) -> RobotModel:
        """The filters' model of ``sim`` (``initial`` overrides :attr:`initial`)."""
        return RobotModel.for_simulation(sim, q_scale=self.q_scale, r_scale=self.r_scale,
                                         initial=initial or self.initial, initial_std=self.initial_std)

    def filter_settings(self) -> FilterSettings:
        """The particle filter's settings record (:class:`pfcourse.filter_config.FilterSettings`): ``N``, the
        threshold and the resampler; ``q_scale``, ``r_scale``, ``initial`` and ``initial_std`` set its model."""
        return FilterSettings(self.n_particles, threshold=self.threshold, resampler=self.scheme)

    def run_particle_filter(self, model: RobotModel, sim: RobotSimulation, seed: int) -> FilterResult:
        """The particle filter on ``sim``'s measurements, its random stream seeded with ``seed``."""
        return self.filter_settings().build(model).run(sim.measurements, seed)


def compare_filters(
    seed: int,
    *,
    filters: tuple[str, ...] = FILTERS,
    scenario: RobotScenario | None = None,
    **options,
) -> dict[str, RunRecord]:
    """Simulate run ``seed`` and filter it with each of ``filters`` (``"pf"``, ``"ekf"``, ``"ukf"``).

    ``options`` are :class:`RobotRunOptions` fields (``n_particles``, ``q_scale``, ``r_scale``,
    ``threshold``, ``scheme``, ``initial``, ``initial_std``, ``burn_in``; defaults and meaning
    there) and :class:`~pfcourse.scenarios.robot.scenario.RobotScenario` fields changing ``scenario``
    (``n_steps``, ``dt_meas``, ``gap``, ``n_landmarks``, ``q_true``, ...).  Each filter's
    record (:func:`~pfcourse.studies.record.record_run`) has the scores ``position_rmse``,
    ``heading_rmse``, ``mean_nees`` and the per-step ``nees`` (steps ``k >= burn_in``), and
    ``seconds``; a filter that fails (a :class:`~pfcourse.errors.StepError`) is recorded
    ``"failed"``, its scores NaN (no estimate).
    """
    unknown = set(filters) - set(FILTERS)
    if unknown:
        raise ParameterError(f"unknown filter(s) {sorted(unknown)}; choose among {FILTERS}")
    settings, scenario_changes = RobotRunOptions.split(options)
    sim = settings.simulate(seed, scenario, scenario_changes)
    runners = {"pf": lambda model: settings.run_particle_filter(model, sim, seed),
               "ekf": lambda model: run_ekf(model, sim.measurements),
               "ukf": lambda model: run_ukf(model, sim.measurements)}
    out: dict[str, RunRecord] = {}
    for name in filters:
        model = settings.model(sim, None if name == "pf" else "tracking")
        out[name] = record_run(lambda: runners[name](model),
                               lambda res: _metrics(sim, res.mean, res.cov, settings.burn_in),
                               shape=(sim.scenario.n_steps, 3, 2))
    return out


def global_localization_run(
    seed: int,
    n_particles: int,
    *,
    n_steps: int = 60,
    position_tolerance: float = LOCK_POSITION_M,
    heading_tolerance: float = LOCK_HEADING_RAD,
    scenario: RobotScenario | None = None,
    **options,
) -> RunRecord:
    """Run the particle filter from a uniform cloud over the map and record whether it locked on.

    ``options`` are :class:`RobotRunOptions` fields (``q_scale``, ``r_scale``, ``threshold``,
    ``scheme``; the start is ``"uniform"``) and :class:`~pfcourse.scenarios.robot.scenario.RobotScenario`
    fields.  Locked on is the book's one definition, :func:`pfcourse.metrics.locked_on`: the
    posterior mean within ``position_tolerance`` metres and ``heading_tolerance`` radians of the
    truth at every step of the last ``LOCK_WINDOW_S`` seconds (the whole run if it is shorter);
    other tolerances than the book's (1 m, 5 degrees) scale the errors before the test.
    The record's scores: ``locked_on``, the final position error ``position_error`` (m) and the
    filter's own final position standard deviation ``position_sd`` ``sqrt(P_xx + P_yy)`` (m).
    A filter that fails (every particle impossible) is recorded ``"failed"``: not locked on, its
    error and standard deviation NaN (no estimate).
    """
    if "initial" in options:
        raise ParameterError("global_localization_run always starts from the uniform cloud: do not pass initial")
    position_tolerance = check_real(position_tolerance, "position_tolerance", low=0.0, low_open=True)
    heading_tolerance = check_real(heading_tolerance, "heading_tolerance", low=0.0, low_open=True)
    settings, scenario_changes = RobotRunOptions.split({**options, "n_particles": n_particles, "initial": "uniform"})
    sim = settings.simulate(seed, scenario, {"n_steps": n_steps, **scenario_changes})

    def score(res) -> dict:
        dist = position_error(sim.truth, res.mean)
        turn = heading_error(sim.truth, res.mean)
        ok = locked_on(dist * (LOCK_POSITION_M / position_tolerance),
                       turn * (LOCK_HEADING_RAD / heading_tolerance), sim.scenario.dt)
        return {"locked_on": bool(ok), "position_error": float(dist[-1]),
                "position_sd": float(position_spread(res.cov[-1]))}

    return record_run(lambda: settings.run_particle_filter(settings.model(sim), sim, seed), score,
                      shape=(sim.scenario.n_steps, 3, 2))


def pf_run(
    seed: int,
    *,
    keep_errors: bool = False,
    scenario: RobotScenario | None = None,
    **options,
) -> dict:
    """Simulate run ``seed`` and filter it with the particle filter: the metrics of a Part III study row.

    ``options`` as in :func:`compare_filters` (:class:`RobotRunOptions` and
    :class:`~pfcourse.scenarios.robot.scenario.RobotScenario` fields: the same simulation, model, filter
    and seed, so ``position_rmse``, ``heading_rmse`` and ``mean_nees`` are those of
    ``compare_filters(seed, filters=("pf",), ...)``).  Metrics (steps ``k >= burn_in``):
    ``position_rmse`` (m), ``heading_rmse`` (rad), ``mean_nees`` (``inf`` if all the weight
    sat on one particle at some step), the final position and heading errors, the mean
    ``ESS / N`` over measurement steps, the number of resamplings, the filter's own position
    standard deviation ``sd_k = sqrt(P_xx + P_yy)`` averaged over the steps
    (``mean_position_sd``), and the jitter of the estimated path,
    ``sqrt(mean_k ||(p^_k - p^_{k-1}) - (p_k - p_{k-1})||^2)`` (m per step).  With
    ``keep_errors=True`` also the per-step arrays ``position_error`` ``||p^_k - p_k||``,
    ``position_sd`` and ``heading_error`` ``|wrap(theta^_k - theta_k)|``.  A collapse raises
    its :class:`~pfcourse.errors.StepError` (the study runner records a failed run).
    """
    settings, scenario_changes = RobotRunOptions.split(options)
    sim = settings.simulate(seed, scenario, scenario_changes)
    res = settings.run_particle_filter(settings.model(sim), sim, seed)
    burn_in = settings.burn_in
    metrics = _metrics(sim, res.mean, res.cov, burn_in)
    err = tracking_errors(sim.truth, res.mean)
    distance = position_error(sim.truth, res.mean)
    sd = position_spread(res.cov)
    jitter = np.diff(res.mean[burn_in:, :2], axis=0) - np.diff(sim.truth[burn_in:, :2], axis=0)
    measured = sim.has_measurement
    row = {
        "position_rmse": metrics["position_rmse"],
        "heading_rmse": metrics["heading_rmse"],
        "mean_nees": metrics["mean_nees"],
        "final_position_error": float(distance[-1]),
        "final_heading_error": float(abs(err[-1, 2])),
        "mean_ess_fraction": float(np.mean(res.ess[measured]) / res.n_particles) if measured.any() else 1.0,
        "resamples": res.n_resamples,
        "mean_position_sd": float(np.mean(sd[burn_in:])),
        "estimate_jitter": float(metrics_rmse(jitter, components=-1)) if len(jitter) else 0.0,
    }
    if keep_errors:
        row["position_error"] = distance
        row["position_sd"] = sd
        row["heading_error"] = np.abs(err[:, 2])
    return row


#: The filter of :func:`dead_reckoning_row`: the bootstrap filter, N = 300, systematic at ESS < N/2.
DEAD_RECKONING_FILTER = FilterSettings(300, threshold=0.5, resampler="systematic")


def dead_reckoning_row(seed: int, n_particles: int = 300, threshold: float = 0.5) -> dict:
    """Run ``seed`` of the landmark robot's default scenario (chapter *A robot among landmarks*): the
    final position error (m) of dead reckoning (the odometry integrated from the true start) and of the
    bootstrap filter (``n_particles``, resampling below ``threshold``, systematic, filter seed
    :func:`pfcourse.seeding.run_filter_seed`), and the filter's largest position error over the run."""
    from pfcourse.seeding import run_filter_seed

    sim = simulate_robot(rng=seed)
    settings = DEAD_RECKONING_FILTER.with_(n_particles=n_particles, threshold=threshold)
    res = settings.build(RobotModel.for_simulation(sim)).run(sim.measurements, rng=run_filter_seed(seed))
    pf_error = position_error(sim.truth, res.mean)
    return {"dr_final_m": float(position_error(sim.truth[-1], sim.odometry_path[-1])),
            "pf_final_m": float(pf_error[-1]), "pf_max_m": float(pf_error.max())}
