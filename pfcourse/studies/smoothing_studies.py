"""The smoothing chapter's stored study (``book/data/smoothing/``): particle smoothers against RTS.

``landmarks``: on the linear landmark model with process noise ``0.05^2`` on every component
(the likelihood chapter's scenario A, :data:`SCENARIO`), run ``r`` simulates its data from
``data_rng(SEED, r)`` and runs a bootstrap filter with ``N`` particles from ``filter_rng(SEED, r)``
(the same data for every ``N``); the same generator then draws the ``N`` FFBSi trajectories.
Each smoother's distance to the exact RTS mean is the root mean square, over the steps and
the six components, of ``(estimate - m_{k|K}) / sqrt(P_{k|K})`` (exact standard deviations):
FFBSm, FFBSi (the mean of its ``N`` trajectories), the ancestral fixed-lag smoother for each
lag of :data:`LAGS` (lag ``0`` is the filter, lag ``K - 1`` the naive smoother), and the filter
against the Kalman filter.  The densities each backward pass evaluates are counted.
"""

from __future__ import annotations

import numpy as np

from pfcourse.collectors import Ancestors, Clouds
from pfcourse.filter_config import FilterSettings
from pfcourse.kalman import kalman_filter
from pfcourse.scenarios.landmarks import quadrant_scenario, simulate
from pfcourse.seeding import data_rng, filter_rng
from pfcourse.smoothing import (ffbsi, ffbsm, fixed_lag_means, linear_gaussian_log_transition,
                                rts_smoother)
from pfcourse import metrics

SCENARIO = quadrant_scenario().with_(Qw=0.05**2 * np.eye(6), Rv=0.5**2 * np.eye(4))
SEED = 23
N_VALUES = [50, 100, 200, 400]
N_RUNS = 100
LAGS = [0, 1, 2, 4, 8, 16, 49]
#: The filter: bootstrap, systematic resampling at ESS < N/2 (``N`` from the grid; 100 nominal).
FILTER = FilterSettings(100)


def landmarks_row(seed: int, n_particles: int) -> dict:
    """One run (``seed`` is the run's number): the smoothers' distances to RTS (module docstring)."""
    sim = simulate(SCENARIO, data_rng(SEED, seed))
    model = SCENARIO.model()
    kf = kalman_filter(model, sim.measurements)
    m_s, P_s = rts_smoother(model, kf)
    sd_s = np.sqrt(np.diagonal(P_s, axis1=1, axis2=2))
    sd_f = np.sqrt(np.diagonal(kf.cov, axis1=1, axis2=2))

    def distance(mean, exact=m_s, sd=sd_s) -> float:
        return float(metrics.rmse((mean - exact) / sd))

    calls = []
    base = linear_gaussian_log_transition(model)

    def log_f(new, old, k):
        calls.append(len(new) * len(old))
        return base(new, old, k)

    rng = filter_rng(SEED, seed)
    r = FILTER.with_(n_particles=n_particles).build(model).run(sim.measurements, rng, collect=[Clouds(), Ancestors()])
    ancestors = r.collected["ancestors"]
    out = {"filter_vs_kalman": distance(r.mean, kf.mean, sd_f)}
    out["ffbsm_rts"] = distance(ffbsm(r.particles, r.weights, log_f).mean)
    out["ffbsm_densities"] = int(sum(calls))
    calls.clear()
    out["ffbsi_rts"] = distance(ffbsi(r.particles, r.weights, log_f, n_particles, rng).mean(axis=1))
    out["ffbsi_densities"] = int(sum(calls))
    for lag in LAGS:
        out[f"lag_{lag}_rts"] = distance(fixed_lag_means(r.particles, r.weights, ancestors, lag))
    idx = np.arange(n_particles)
    for k in range(len(ancestors) - 1, 0, -1):
        idx = ancestors[k][idx]
    out["ancestors_at_0"] = int(len(np.unique(idx)))
    out["rts_truth_error"] = float(metrics.rmse(m_s - sim.truth))
    out["kalman_truth_error"] = float(metrics.rmse(kf.mean - sim.truth))
    return out


def landmark_smoothing_run(data_seed: int = 7, n_particles: int = 100, filter_seed: int = 21):
    """The smoothing chapter's run (``book/part5/smoothing.py``), loaded by one call: the landmark model
    :data:`SCENARIO`, its data (``data_seed``), a bootstrap filter of ``n_particles`` that stores every
    step's cloud, weights and ancestor indices, the Kalman filter and the exact RTS smoother.

    Returns a namespace: ``particles`` ``(T+1, N, 6)``, ``weights`` ``(T+1, N)``, ``ancestors`` ``(T+1, N)``
    (``ancestors[k, i]``: the index at step ``k-1`` of particle ``i``'s parent), ``log_f(new, old, k)`` (the
    matrix ``[log p(new_j | old_i)]``), ``times``, ``truth``, ``Z``, ``kf_mean``, ``rts_mean``, ``rts_cov``,
    and ``model``, ``sim``, ``pf`` themselves."""
    from types import SimpleNamespace

    model = SCENARIO.model()
    sim = simulate(SCENARIO, data_seed)
    pf = FILTER.with_(n_particles=n_particles).build(model).run(sim.measurements, filter_seed,
                                                                collect=[Clouds(), Ancestors()])
    kf = kalman_filter(model, sim.measurements)
    rts_mean, rts_cov = rts_smoother(model, kf)
    return SimpleNamespace(model=model, sim=sim, pf=pf, particles=pf.particles, weights=pf.weights,
                           ancestors=pf.collected["ancestors"], log_f=linear_gaussian_log_transition(model),
                           times=sim.T, truth=sim.truth, Z=sim.measurements, kf_mean=kf.mean,
                           rts_mean=rts_mean, rts_cov=rts_cov)
