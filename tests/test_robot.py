"""The robot scenario (scenario C): model, simulator, EKF/UKF and the particle filter on it."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse.angles import wrap_angle
from pfcourse.errors import CovarianceError, ParameterError, ShapeError
from pfcourse.filter import ParticleFilter
from pfcourse.scenarios.robot.scenario import (
    Q_TRUE,
    R_TRUE,
    RobotModel,
    RobotScenario,
    motion,
    range_bearing,
    tracking_rmse,
    simulate_robot,
    tracking_errors,
)
from pfcourse.studies.robot import compare_filters, global_localization_run
from pfcourse.scenarios.robot.kalman import (
    measurement_jacobian,
    measurement_residual,
    motion_jacobians,
    range_bearing_one,
    run_ekf,
    run_ukf,
    state_mean,
)


@pytest.fixture(scope="module")
def default_sim():
    return simulate_robot(rng=11)


# --- angles near +/- pi ---------------------------------------------------------------


def test_motion_wraps_the_heading_across_pi():
    x = np.array([[0.0, 0.0, np.pi - 0.01], [0.0, 0.0, -np.pi + 0.01]])
    u = np.array([[0.0, 0.0, 0.02], [0.0, 0.0, -0.02]])
    out = motion(x, u, 1.0)
    np.testing.assert_allclose(out[:, 2], [-np.pi + 0.01, np.pi - 0.01], atol=1e-12)
    assert np.all((out[:, 2] > -np.pi) & (out[:, 2] <= np.pi))


def test_bearing_innovation_is_wrapped_for_a_landmark_behind_the_robot():
    # landmark almost straight behind: predicted bearing close to +pi, measured one close to -pi
    model = RobotModel(np.array([[-10.0, 0.01]]), np.zeros((2, 3)), Q_TRUE, R_TRUE)
    x = np.array([[0.0, 0.0, 0.0]])
    pred = range_bearing(x, model.landmarks[0])[0]
    assert pred[1] > np.pi - 0.01
    z = np.array([0.0, pred[0], wrap_angle(pred[1] + 0.002)])  # crosses the cut
    assert z[2] < 0
    expected = stats.multivariate_normal(np.zeros(2), R_TRUE).logpdf([0.0, 0.002])
    np.testing.assert_allclose(model.log_likelihood(x, z, 1), [expected], rtol=1e-10)


def test_filter_heading_estimate_straddling_pi_is_circular():
    """Start facing -x (heading pi): the posterior heading must stay near +/-pi, not near 0."""
    sim = simulate_robot(rng=2, n_steps=150, start=(1.0, -50.0, np.pi))
    model = RobotModel.for_simulation(sim)
    result = ParticleFilter(model, 300).run(sim.measurements, 2)
    assert np.all(np.abs(result.mean[:, 2]) > np.pi / 2)
    _, heading = tracking_rmse(sim.truth, result.mean)
    assert heading < np.deg2rad(3.0)
    for run in (run_ekf(model, sim.measurements), run_ukf(model, sim.measurements)):
        assert np.all(np.abs(run.mean[:, 2]) <= np.pi)
        assert tracking_rmse(sim.truth, run.mean)[1] < np.deg2rad(3.0)


def test_state_mean_of_sigma_points_across_pi():
    sigmas = np.array([[0.0, 0.0, np.pi - 0.1], [0.0, 0.0, -np.pi + 0.1]])
    m = state_mean(sigmas, np.array([0.5, 0.5]))
    assert abs(abs(m[2]) - np.pi) < 1e-12


def test_tracking_errors_wrap_heading():
    truth = np.array([[0.0, 0.0, np.pi - 0.01]])
    est = np.array([[0.0, 0.0, -np.pi + 0.01]])
    np.testing.assert_allclose(tracking_errors(truth, est)[0, 2], 0.02, atol=1e-12)
    np.testing.assert_allclose(measurement_residual(np.array([1.0, -np.pi + 0.01]), np.array([1.0, np.pi - 0.01])), [0.0, 0.02], atol=1e-12)


# --- simulator --------------------------------------------------------------------------


def test_odometry_errors_have_covariance_q_true(default_sim):
    e = default_sim.odometry[1:] - default_sim.controls[1:]
    n = len(e)
    # each sample variance has relative standard deviation sqrt(2 / n) ~ 4.5 %: allow 5 of them
    np.testing.assert_allclose(np.var(e, axis=0), np.diag(Q_TRUE), rtol=5 * np.sqrt(2 / n))
    assert np.all(np.abs(e.mean(axis=0)) < 5 * np.sqrt(np.diag(Q_TRUE) / n))


def test_measurement_errors_have_covariance_r_true(default_sim):
    sim = default_sim
    k = np.flatnonzero(sim.has_measurement)
    pred = np.array([range_bearing(sim.truth[i], sim.landmarks[sim.landmark_index[i]]) for i in k])
    err = sim.measurements[k, 1:] - pred
    err[:, 1] = wrap_angle(err[:, 1])
    n = len(k)
    np.testing.assert_allclose(np.var(err, axis=0), np.diag(R_TRUE), rtol=5 * np.sqrt(2 / n))
    assert np.all(np.abs(sim.measurements[k, 2]) <= np.pi)


def test_landmark_indices_are_valid_and_uniform(default_sim):
    j = default_sim.landmark_index[default_sim.has_measurement]
    m = len(default_sim.landmarks)
    assert j.min() >= 0 and j.max() == m - 1  # every landmark, including the last, is used
    counts = np.bincount(j, minlength=m)
    assert stats.chisquare(counts).pvalue > 1e-3
    assert np.all(np.abs(default_sim.landmarks) <= 60.0)


def test_dt_meas_and_gap_are_respected():
    sim = simulate_robot(rng=0, n_steps=600, dt_meas=5.0, gap=(250.0, 350.0))
    k = np.flatnonzero(sim.has_measurement)
    assert np.all(k % 5 == 0) and k[0] == 5
    assert not np.any((k >= 250) & (k < 350))
    assert np.all(np.isnan(sim.measurements[~sim.has_measurement]))
    # the other draws of the seeded run do not depend on dt_meas or the gap
    ref = simulate_robot(rng=0, n_steps=600)
    np.testing.assert_array_equal(sim.odometry, ref.odometry)
    np.testing.assert_array_equal(sim.measurements[k], ref.measurements[k])


def test_truth_follows_true_controls_and_start():
    sim = simulate_robot(rng=4, n_steps=50)
    np.testing.assert_array_equal(sim.truth[0], [1.0, -50.0, 0.0])
    np.testing.assert_allclose(sim.truth[1:], motion(sim.truth[:-1], sim.controls[1:], 1.0))
    np.testing.assert_allclose(sim.odometry_path[1:], motion(sim.odometry_path[:-1], sim.odometry[1:], 1.0))


# --- the particle-filter model -----------------------------------------------------------


def test_transition_noise_has_covariance_q_est():
    odometry = np.array([[0.0, 0.0, 0.0], [0.3, 0.1, 0.05]])
    model = RobotModel(np.zeros((1, 2)), odometry, Q_TRUE, R_TRUE)
    n = 200_000
    x = np.zeros((n, 3))  # heading 0: rotation is the identity, so x_1 = u~ + w exactly
    out = model.sample_transition(x, 1, np.random.default_rng(0))
    assert np.all(np.abs(out.mean(axis=0) - odometry[1]) < 5 * np.sqrt(np.diag(Q_TRUE) / n))
    np.testing.assert_allclose(np.var(out, axis=0), np.diag(Q_TRUE), rtol=5 * np.sqrt(2 / n))


def test_log_likelihood_matches_scipy_for_a_full_covariance():
    r = np.array([[0.3, 0.01], [0.01, 0.002]])
    model = RobotModel(np.array([[5.0, 3.0], [-2.0, 8.0]]), np.zeros((2, 3)), Q_TRUE, r)
    x = np.random.default_rng(1).normal(size=(20, 3))
    z = np.array([1.0, 9.0, 0.4])
    pred = range_bearing(x, model.landmarks[1])
    nu = np.column_stack([z[1] - pred[:, 0], wrap_angle(z[2] - pred[:, 1])])
    expected = stats.multivariate_normal(np.zeros(2), r).logpdf(nu)
    np.testing.assert_allclose(model.log_likelihood(x, z, 1), expected, rtol=1e-10)


def test_uniform_initial_cloud_covers_the_map():
    model = RobotModel(np.zeros((1, 2)), np.zeros((2, 3)), Q_TRUE, R_TRUE, initial="uniform")
    x = model.sample_initial(20_000, np.random.default_rng(0))
    assert np.all(np.abs(x[:, :2]) <= 60.0) and np.all(np.abs(x[:, 2]) <= np.pi)
    assert stats.kstest(x[:, 0], stats.uniform(-60, 120).cdf).pvalue > 1e-3
    assert stats.kstest(x[:, 2], stats.uniform(-np.pi, 2 * np.pi).cdf).pvalue > 1e-3


def test_scalar_range_bearing_matches_the_vectorized_model():
    """The Kalman filters' one-state range and bearing: the bearing is the same float, the range
    (math.hypot against np.hypot) within an ulp."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        x, lm = rng.normal(size=3) * 30, rng.normal(size=2) * 40
        one, vectorised = range_bearing_one(x, lm), range_bearing(x, lm)
        assert one[1] == vectorised[1]
        assert abs(one[0] - vectorised[0]) <= np.spacing(vectorised[0])


def test_jacobians_match_finite_differences():
    x, u, lm, h = np.array([2.0, -3.0, 0.7]), np.array([0.3, 0.1, 0.02]), np.array([10.0, 5.0]), 1e-6
    F, G = motion_jacobians(x, u, 1.0)
    H = measurement_jacobian(x, lm)
    for i in range(3):
        d = np.zeros(3)
        d[i] = h
        df = (motion(x + d, u, 1.0) - motion(x - d, u, 1.0)) / (2 * h)
        dg = (motion(x, u + d, 1.0) - motion(x, u - d, 1.0)) / (2 * h)
        dh = measurement_residual(range_bearing(x + d, lm), range_bearing(x - d, lm)) / (2 * h)
        np.testing.assert_allclose(F[:, i], df, atol=1e-7)
        np.testing.assert_allclose(G[:, i], dg, atol=1e-7)
        np.testing.assert_allclose(H[:, i], dh, atol=1e-7)


# --- EKF / UKF ----------------------------------------------------------------------------


def test_ekf_and_ukf_run_without_nan_on_the_default_scenario(default_sim):
    model = RobotModel.for_simulation(default_sim)
    for run in (run_ekf(model, default_sim.measurements), run_ukf(model, default_sim.measurements)):
        assert np.all(np.isfinite(run.mean)) and np.all(np.isfinite(run.cov))
        assert run.mean.shape == (1000, 3) and run.cov.shape == (1000, 3, 3)
        pos, head = tracking_rmse(default_sim.truth, run.mean)
        assert pos < 0.5 and head < np.deg2rad(2.0)


def test_ekf_and_ukf_agree_when_noise_is_small():
    """With 100 times smaller noise variances the posterior is a few mm wide and both filters
    linearize over a region where h is linear to ~1e-5 m: their means must agree to far less
    than the posterior standard deviation."""
    sim = simulate_robot(rng=5, n_steps=300, q_true=Q_TRUE / 100, r_true=R_TRUE / 100)
    model = RobotModel.for_simulation(sim, initial_std=(0.1, 0.1, 0.01))
    ekf, ukf = run_ekf(model, sim.measurements), run_ukf(model, sim.measurements)
    sd = np.sqrt(ekf.cov[-1, 0, 0])
    diff = tracking_errors(ukf.mean, ekf.mean)
    assert np.max(np.abs(diff[20:, :2])) < 0.05 * sd
    d = np.sqrt(np.diagonal(ekf.cov[20:], axis1=1, axis2=2))
    scale = d[:, :, None] * d[:, None, :]  # |P_ij| <= sqrt(P_ii P_jj): compare on that scale
    assert np.max(np.abs(ekf.cov[20:] - ukf.cov[20:]) / scale) < 0.05


# --- the numbers the chapter reports ------------------------------------------------------


def test_particle_filter_rmse_lies_in_the_range_the_chapter_reports():
    """book/part2/robot_vs_kalman.py reports, over 50 runs (seeds 0-49, 150 steps, burn-in 20),
    a position RMSE with 10-90 % quantiles [0.151, 0.289] m (median 0.197) and a heading RMSE
    with quantiles [0.741, 0.924] deg.  If the filter behaves as in the chapter, the median of
    7 fresh seeded runs falls outside the 10-90 % range with probability below 0.5 %
    (it needs 4 of 7 draws beyond one quantile: P <= 2 * P(Bin(7, 0.1) >= 4) = 0.0055)."""
    runs = [compare_filters(s, filters=("pf",), n_steps=150, burn_in=20)["pf"] for s in range(100, 107)]
    pos = np.median([r.position_rmse for r in runs])
    head = np.degrees(np.median([r.heading_rmse for r in runs]))
    assert 0.151 <= pos <= 0.289
    assert 0.741 <= head <= 0.924


def test_global_localization_with_many_particles_locks_on():
    out = global_localization_run(2, 30000, n_steps=30)
    assert out.locked_on and out.position_error < 1.0


# --- errors ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "changes, error",
    [
        ({"q_true": np.diag([1.0, -1.0, 1.0])}, CovarianceError),
        ({"r_true": np.array([[1.0, 0.5], [0.0, 1.0]])}, CovarianceError),
        ({"r_true": np.eye(3)}, ShapeError),
        ({"dt_meas": 0.5}, ParameterError),
        ({"gap": (300.0, 200.0)}, ParameterError),
        ({"n_landmarks": 0}, ParameterError),
        ({"landmarks": np.zeros((3, 3))}, ShapeError),
        ({"start": (0.0, 1.0)}, ShapeError),
    ],
)
def test_bad_scenarios_raise_named_errors(changes, error):
    with pytest.raises(error):
        simulate_robot(rng=0, **changes)


def test_bad_model_inputs_raise_named_errors(default_sim):
    sim = default_sim
    with pytest.raises(ShapeError):
        RobotModel(np.zeros((3, 3)), sim.odometry, Q_TRUE, R_TRUE)
    with pytest.raises(ShapeError):
        RobotModel(sim.landmarks, sim.odometry[:, :2], Q_TRUE, R_TRUE)
    with pytest.raises(CovarianceError):
        RobotModel(sim.landmarks, sim.odometry, Q_TRUE, np.zeros((2, 2)))
    with pytest.raises(CovarianceError):
        RobotModel(sim.landmarks, sim.odometry, -Q_TRUE, R_TRUE)
    with pytest.raises(ParameterError):
        RobotModel(sim.landmarks, sim.odometry, Q_TRUE, R_TRUE, initial="gps")
    with pytest.raises(ParameterError):
        RobotModel.for_simulation(sim, q_scale=0.0)
    model = RobotModel.for_simulation(sim)
    x = np.zeros((4, 3))
    with pytest.raises(ShapeError):
        model.log_likelihood(x, np.array([1.0, 2.0]), 1)
    with pytest.raises(ParameterError):
        model.log_likelihood(x, np.array([7.0, 2.0, 0.1]), 1)
    with pytest.raises(ParameterError):
        model.sample_transition(x, 5000, np.random.default_rng(0))
    with pytest.raises(ShapeError):
        run_ekf(model, sim.measurements[:, :2])
    with pytest.raises(ParameterError):
        compare_filters(0, filters=("pf", "kf"))


def test_scenario_with_is_checked():
    with pytest.raises(ParameterError):
        RobotScenario().with_(n_steps=1)
