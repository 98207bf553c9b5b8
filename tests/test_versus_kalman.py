"""Scores against the Kalman posterior: zero for the Kalman filter itself, 95 % coverage of the truth."""

from __future__ import annotations

import numpy as np

from pfcourse.filter import ParticleFilter
from pfcourse.kalman import kalman_filter
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario
from pfcourse.studies.landmarks import kalman_scores


class KalmanAsFilter:
    def __init__(self, model):
        self.model = model

    def __call__(self, Z, seed):
        r = kalman_filter(self.model, Z)
        r.ess = np.ones(len(Z))
        r.resampled = np.zeros(len(Z), dtype=bool)
        return r


def test_the_exact_filter_scores_zero_error_and_covers_the_truth_95_percent_of_the_time():
    scenario = quadrant_scenario()
    n_runs = 200
    out = kalman_scores(scenario, KalmanAsFilter(scenario.model()), n_runs)
    assert np.all(out["rmse"] == 0.0)
    np.testing.assert_allclose(out["log_var_ratio"], 0.0, atol=1e-9)
    # Final-step coverage over independent runs: Binomial(200, 0.95), sd ~ 0.015; allow 4 sd.
    assert abs(out["covered"][:, -1].mean() - 0.95) < 4 * np.sqrt(0.95 * 0.05 / n_runs)


def test_a_collapsed_particle_cloud_is_scored_overconfident():
    scenario = quadrant_scenario()
    pf = ParticleFilter(scenario.model(), 50, threshold=0.0)
    out = kalman_scores(scenario, lambda Z, s: pf.run(Z, s), 5, components=[2, 3, 4, 5])
    # SIS degenerates to one particle: its landmark variance is orders of magnitude too small.
    assert np.median(out["log_var_ratio"][:, -1]) < np.log(1e-4)
    assert out["rmse"].shape == (5, scenario.n_samples)


def test_scores_do_not_depend_on_the_executor():
    from concurrent.futures import ThreadPoolExecutor

    from pfcourse.studies.executor import SerialExecutor

    scenario = quadrant_scenario()
    pf = ParticleFilter(scenario.model(), 100, threshold=0.5)
    serial = kalman_scores(scenario, pf.run, 12, components=[2, 3], executor=SerialExecutor())
    with ThreadPoolExecutor(3) as threads:
        others = [kalman_scores(scenario, pf.run, 12, components=[2, 3]),  # the default pool
                  kalman_scores(scenario, pf.run, 12, components=[2, 3], executor=threads),
                  kalman_scores(scenario, lambda z, s: pf.run(z, s), 12, components=[2, 3])]  # in this process
    for other in others:
        assert other.keys() == serial.keys()
        for key in serial:
            assert np.array_equal(other[key], serial[key], equal_nan=True), key


def test_linear_convergence_does_not_depend_on_the_executor():
    from pfcourse.studies.comparison import linear_convergence
    from pfcourse.studies.executor import SerialExecutor
    from pfcourse.scenarios.landmarks.scenario import simulate

    scenario = quadrant_scenario()
    model = scenario.model()
    data = simulate(scenario, rng=1)
    exact = kalman_filter(model, data.measurements)
    serial = linear_convergence(model, data.measurements, exact, [30, 100], 4, executor=SerialExecutor())
    pooled = linear_convergence(model, data.measurements, exact, [30, 100], 4)
    for field in ("mean_error", "cov_error", "loglik_error"):
        assert np.array_equal(serial[field], pooled[field]), field
    assert serial["mean_error"].shape == (2, 4)
