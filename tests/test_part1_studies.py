"""The row functions of Part I's stored studies (pfcourse.studies.part1_studies) measure what they say.

tests/test_stored_studies.py re-computes a sample of the stored rows; these tests check properties
the theory gives for single runs, and that a bad setting is refused.
"""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.studies import part1_studies as ps


def test_a_setting_or_method_that_does_not_exist_is_refused():
    with pytest.raises(ValueError):
        ps.proposals_row(0, "sharpest", "optimal")
    with pytest.raises(ValueError):
        ps.five_landmarks_row(0, "EKF")


def test_with_sharp_measurements_the_optimal_proposal_keeps_far_more_effective_particles():
    # one-point theory, one axis, r/q = 0.2: the bootstrap keeps r sqrt(r^2 + 2 q^2) / (r^2 + q^2) ~ 0.28 of
    # the optimal ESS, and several coordinates are measured at once: a factor 2 is a loose bound
    boot, opt = (ps.proposals_row(3, "sharp", p) for p in ("bootstrap", "optimal"))
    assert boot["n_measured"] == opt["n_measured"] > 0
    assert opt["ess"] > 2 * boot["ess"]
    assert np.isclose(opt["ess"], opt["ess_sum"] / opt["n_measured"])
    assert 0 < boot["ess"] <= 1 and 0 < opt["ess"] <= 1


def test_sis_collapses_on_the_five_landmark_model_and_the_rao_blackwellised_filter_keeps_the_map_spread():
    sis, rbpf = ps.five_landmarks_row(0, "SIS"), ps.five_landmarks_row(0, "RBPF")
    assert sis["collapse"] <= 5 and sis["lm_sd"] < 1e-3  # one particle left: no spread
    assert 0.1 < rbpf["lm_sd"] < 10  # the map covariances are Kalman covariances: the exact spread's order
    assert 0 <= rbpf["robot_cover"] <= 1
