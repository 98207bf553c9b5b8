"""Scenario A (landmark model and simulator), the linear-Gaussian model and the Kalman reference."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse import CovarianceError, LinearGaussianModel, ShapeError, kalman_filter
from pfcourse.scenarios.landmarks.scenario import circle_scenario, quadrant_scenario, rotation, simulate


def test_report_defaults_of_the_quadrant_scenario():
    s = quadrant_scenario()
    assert (s.n_landmarks, s.n_samples, s.dt) == (2, 50, 1.0)
    np.testing.assert_array_equal(s.mX0, [2, 0, -1, 4, 4, -1])
    np.testing.assert_allclose(np.diag(s.Qw), [0.0025, 0.0025, 1e-20, 1e-20, 1e-20, 1e-20])
    np.testing.assert_allclose(s.Rv, 0.01 * np.eye(4))
    np.testing.assert_allclose(s.F[:2, :2], rotation(np.pi / 4))
    np.testing.assert_array_equal(s.B, np.zeros(6))
    np.testing.assert_array_equal(s.H[:2], [[-1, 0, 1, 0, 0, 0], [0, -1, 0, 1, 0, 0]])


def test_simulation_shapes_and_visibility_pattern():
    for scenario in (quadrant_scenario(), circle_scenario()):
        sim = simulate(scenario, 4)
        k, d, m = scenario.n_samples, scenario.dim_x, scenario.n_landmarks
        assert sim.T.shape == (k,) and sim.truth.shape == (k, d) and sim.measurements.shape == (k, 2 * m)
        np.testing.assert_array_equal(np.isnan(sim.measurements), ~np.repeat(sim.seen, 2, axis=1))
        assert not sim.seen[0].any()
        np.testing.assert_array_equal(sim.seen[1:], scenario.visible(sim.truth[1:]))
        assert sim.seen.any(axis=0).all(), "every landmark is seen at least once"
        assert not sim.seen.all(), "some landmark is out of view at some step"


def test_quadrant_visibility_rule():
    s = quadrant_scenario()
    x = np.array([0.0, 0.0, 1.0, 1.0, -1.0, 1.0])
    np.testing.assert_array_equal(s.visible(x), [True, False])


def test_triangle_field_of_view_looks_along_the_direction_of_travel():
    s = circle_scenario(n_landmarks=2)
    robot = s.centre + np.array([3.0, 0.0])  # anticlockwise: heading north
    assert s.heading(robot) == pytest.approx(np.pi / 2)
    ahead, behind = robot + [0.0, 2.0], robot + [0.0, -2.0]
    far, wide = robot + [0.0, 7.0], robot + [2.5, 2.0]
    for landmark, seen in ((ahead, True), (behind, False), (far, False), (wide, False)):
        x = np.concatenate([robot, landmark, behind])
        assert s.visible(x)[0] == seen, landmark


def test_noiseless_robot_stays_on_its_circle():
    s = circle_scenario()
    assert np.linalg.norm(s.B) > 0
    quiet = s.with_(Qw=np.zeros((s.dim_x, s.dim_x)), PX0=np.zeros((s.dim_x, s.dim_x)))
    sim = simulate(quiet, 0)
    radius = np.linalg.norm(sim.truth[:, :2] - s.centre, axis=1)
    np.testing.assert_allclose(radius, 3.0)
    np.testing.assert_allclose(sim.truth[:, 2:], np.broadcast_to(s.mX0[2:], sim.truth[:, 2:].shape))


def test_simulated_measurements_have_the_model_noise():
    s = quadrant_scenario()
    residuals = []
    for seed in range(200):
        sim = simulate(s, seed)
        r = sim.measurements - sim.truth @ s.H.T
        residuals.append(r[~np.isnan(r)])
    residuals = np.concatenate(residuals)
    assert stats.kstest(residuals / 0.1, "norm").pvalue > 1e-3


def test_scenario_checks_its_matrices():
    with pytest.raises(CovarianceError, match="Qw is not symmetric"):
        quadrant_scenario().with_(Qw=np.triu(np.ones((6, 6))))
    with pytest.raises(ShapeError, match="mX0 must have length 6"):
        quadrant_scenario().with_(mX0=np.zeros(5))


def test_linear_gaussian_likelihood_uses_only_observed_rows():
    s = quadrant_scenario()
    model = s.model()
    rng = np.random.default_rng(0)
    particles = rng.normal(size=(7, 6))
    z = np.array([1.0, 2.0, np.nan, np.nan])
    expected = stats.multivariate_normal(np.zeros(2), s.Rv[:2, :2]).logpdf(z[:2] - particles @ s.H[:2].T)
    np.testing.assert_allclose(model.log_likelihood(particles, z, 1), expected)
    np.testing.assert_array_equal(model.log_likelihood(particles, np.full(4, np.nan), 1), np.zeros(7))


def test_linear_gaussian_model_rejects_bad_input():
    good = dict(F=np.eye(2), H=np.eye(2), m0=np.zeros(2), P0=np.eye(2), Q=np.eye(2), R=np.eye(2))
    with pytest.raises(ShapeError, match=r"F must have shape \(2, 2\)"):
        LinearGaussianModel(**{**good, "F": np.eye(3)})
    with pytest.raises(ShapeError, match="H must have 2 columns"):
        LinearGaussianModel(**{**good, "H": np.ones((1, 3))})
    with pytest.raises(CovarianceError, match="Q is not positive semi-definite"):
        LinearGaussianModel(**{**good, "Q": -np.eye(2)})
    with pytest.raises(CovarianceError, match="R is not positive definite"):
        LinearGaussianModel(**{**good, "R": np.zeros((2, 2))})
    with pytest.raises(ShapeError, match="m0 must be a 1-D vector"):
        LinearGaussianModel(**{**good, "m0": np.zeros((2, 1))})


def batch_log_likelihood(model: LinearGaussianModel, Z: np.ndarray) -> float:
    """log p(z_{0:K}) from the joint Gaussian of all observed entries, built without any filter.

    x_k = F^k x_0 + sum_j F^(k-j) (B + w_j): means and covariances of the stacked
    states follow, and the observed z's are a linear map of them plus noise.
    """
    K, d = len(Z), model.dim_x
    mean_x = [model.m0]
    for _ in range(1, K):
        mean_x.append(model.F @ mean_x[-1] + model.B)
    # Cov(x_a, x_b) for a <= b: F^(b-a) Cov(x_a, x_a)
    cov_xx = [model.P0]
    for _ in range(1, K):
        cov_xx.append(model.F @ cov_xx[-1] @ model.F.T + model.Q)
    rows, means, blocks = [], [], []
    for k in range(K):
        mask = ~np.isnan(Z[k])
        rows.append((k, mask))
        means.append(model.H[mask] @ mean_x[k])
    z = np.concatenate([Z[k][m] for k, m in rows])
    mu = np.concatenate(means)
    sizes = [int(m.sum()) for _, m in rows]
    S = np.zeros((len(z), len(z)))
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    for a, (ka, ma) in enumerate(rows):
        for b, (kb, mb) in enumerate(rows):
            lo, hi = min(ka, kb), max(ka, kb)
            cross = np.linalg.matrix_power(model.F, hi - lo) @ cov_xx[lo]
            c = cross.T if ka <= kb else cross
            block = model.H[ma] @ c @ model.H[mb].T
            if ka == kb:
                block = block + model.R[np.ix_(ma, ma)]
            S[offsets[a] : offsets[a + 1], offsets[b] : offsets[b + 1]] = block
    return float(stats.multivariate_normal(mu, S).logpdf(z))


def test_kalman_log_likelihood_equals_the_batch_gaussian_one():
    scenario = circle_scenario(n_landmarks=3).with_(n_samples=8, Qw=0.05**2 * np.eye(8))
    sim = simulate(scenario, 2)
    model = scenario.model()
    kf = kalman_filter(model, sim.measurements)
    assert kf.log_likelihood == pytest.approx(batch_log_likelihood(model, sim.measurements), rel=1e-9)


def test_kalman_on_missing_rows_equals_kalman_on_the_reduced_model():
    s = quadrant_scenario()
    sim = simulate(s, 3)
    only_first = sim.measurements.copy()
    only_first[:, 2:] = np.nan
    full = kalman_filter(s.model(), only_first)
    reduced_model = LinearGaussianModel(F=s.F, H=s.H[:2], m0=s.mX0, P0=s.PX0, Q=s.Qw, R=s.Rv[:2, :2])
    reduced = kalman_filter(reduced_model, only_first[:, :2])
    np.testing.assert_allclose(full.mean, reduced.mean)
    np.testing.assert_allclose(full.cov, reduced.cov)
    np.testing.assert_allclose(full.log_likelihood, reduced.log_likelihood)


def test_unseen_landmark_keeps_its_uncertainty_and_seen_one_shrinks():
    s = quadrant_scenario()
    sim = simulate(s, 3)
    kf = kalman_filter(s.model(), sim.measurements)
    first_seen = int(np.argmax(sim.seen[:, 0]))
    assert np.trace(kf.cov[first_seen - 1, 2:4, 2:4]) == pytest.approx(np.trace(s.PX0[2:4, 2:4]), rel=1e-6)
    assert np.trace(kf.cov[-1, 2:4, 2:4]) < 0.1 * np.trace(s.PX0[2:4, 2:4])
