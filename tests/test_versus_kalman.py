"""Scores against the Kalman posterior: zero for the Kalman filter itself, 95 % coverage of the truth."""

from __future__ import annotations

import numpy as np

from pfcourse.filter import ParticleFilter
from pfcourse.landmarks.kalman import kalman_filter
from pfcourse.landmarks.scenario import quadrant_scenario
from pfcourse.experiments.landmarks import kalman_scores


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
