"""Measuring a particle filter against the exact Kalman posterior, over seeded runs.

For a linear-Gaussian model the Kalman filter gives the exact posterior
``N(m_k, P_k)``.  For one particle-filter run with means ``mu_k`` and covariances
``Sigma_k`` this module computes, per time step,

* the error against the exact mean, ``e_k = mu_k - m_k`` (summarised by its RMS over
  chosen components);
* the *posterior NEES* ``e_k^T P_k^{-1} e_k`` of the estimate against the exact
  posterior (about ``d / N_eff`` for a good filter, growing with bias);
* the log-ratio of generalised variances ``log det Sigma_k - log det P_k`` restricted
  to chosen components (negative: the cloud is overconfident);
* whether the truth ``x_k`` falls inside the filter's own 95 % ellipse, via the
  filter's NEES ``(x_k - mu_k)^T Sigma_k^{-1} (x_k - mu_k) <= chi2_{0.95}(d)``
  (a run whose covariance is exactly singular at some step, a fully collapsed
  cloud, counts as not covering at any step; a singular covariance gives a
  log-ratio of ``-inf``).

:func:`kalman_scores` repeats this over independent simulations and filter seeds.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import Executor

import numpy as np
from scipy import stats

from pfcourse.checks import check_count
from pfcourse.diagnostics import nees
from pfcourse.studies.executor import run_tasks
from pfcourse.studies.record import RunRecord, scores
from pfcourse.results import FilterResult
from pfcourse.kalman import kalman_filter
from pfcourse.results import KalmanResult
from pfcourse.scenarios.landmarks.scenario import LandmarkScenario, simulate
from pfcourse.seeding import study_filter_seed
from pfcourse import metrics


def score(
    result: FilterResult,
    kalman: KalmanResult,
    truth: np.ndarray,
    components: Sequence[int] | None = None,
) -> RunRecord:
    """``result`` scored against the Kalman posterior and the truth on ``components`` (all by default).

    The record's scores are per-step arrays of shape ``(K,)`` (see the module docstring):
    ``rmse``, ``log_var_ratio`` (per component), ``covered``, and the filter's ``ess`` and
    ``resampled``.
    """
    idx = np.arange(truth.shape[1]) if components is None else np.asarray(components)
    err = result.mean[:, idx] - kalman.mean[:, idx]
    rmse = metrics.rmse(err, axis=1)
    pf_cov = result.cov[:, idx][:, :, idx]
    kf_cov = kalman.cov[:, idx][:, :, idx]
    sign_pf, logdet_pf = np.linalg.slogdet(pf_cov + 1e-300 * np.eye(len(idx)))
    _, logdet_kf = np.linalg.slogdet(kf_cov)
    log_var_ratio = np.where(sign_pf > 0, logdet_pf, -np.inf) - logdet_kf
    dev = truth[:, idx] - result.mean[:, idx]
    limit = stats.chi2.ppf(0.95, len(idx))
    covered = nees(truth[:, idx], result.mean[:, idx], pf_cov) <= limit  # a collapsed step: inf
    return RunRecord({"rmse": rmse, "log_var_ratio": log_var_ratio / len(idx), "covered": covered,
                      "ess": result.ess, "resampled": result.resampled})


def kalman_scores(
    scenario: LandmarkScenario,
    run_filter: Callable[[np.ndarray, int], FilterResult],
    n_runs: int,
    components: Sequence[int] | None = None,
    first_seed: int = 0,
    kalman_model=None,
    executor: Executor | None = None,
) -> dict[str, np.ndarray]:
    """Score ``run_filter(measurements, seed)`` on ``n_runs`` simulations (seeds ``first_seed, ...``).

    Each run simulates ``scenario`` with seed ``s``, runs the Kalman filter of
    ``kalman_model`` (the scenario's own model by default) and the particle filter
    with seed ``s + 10**6``.  Returns arrays of shape ``(n_runs, K)`` keyed
    ``rmse``, ``log_var_ratio`` (per component), ``covered``, ``ess``, ``resampled``.
    The runs are shared out by :func:`~pfcourse.studies.executor.run_tasks` (``executor=None``:
    a process pool over the cores when ``run_filter`` can be sent to one, e.g. a bound
    ``ParticleFilter(...).run``; a lambda runs in this process); the result does not depend on it.
    """
    model = scenario.model() if kalman_model is None else kalman_model
    n_runs = check_count(n_runs, "n_runs")
    seeds = list(range(first_seed, first_seed + n_runs))
    chunks = [seeds[i:i + 10] for i in range(0, n_runs, 10)]
    runs = [s for chunk in run_tasks(_scored_runs, [(scenario, run_filter, chunk, components, model)
                                                   for chunk in chunks], executor=executor)
            for s in chunk]
    return {key: scores(runs, key) for key in ("rmse", "log_var_ratio", "covered", "ess", "resampled")}


def _scored_runs(scenario: LandmarkScenario, run_filter: Callable, seeds: list[int],
                 components: Sequence[int] | None, model) -> list[RunRecord]:
    """The runs ``seeds`` of :func:`kalman_scores`, scored."""
    out = []
    for seed in seeds:
        sim = simulate(scenario, rng=seed)
        kf = kalman_filter(model, sim.measurements)
        out.append(score(run_filter(sim.measurements, study_filter_seed(seed)), kf, sim.truth, components))
    return out
