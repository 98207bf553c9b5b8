"""Smoothers: RTS against the joint Gaussian posterior, FFBSm against RTS, the robot's
transition density against its sampler."""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest
from scipy import stats

from pfcourse.collectors import Clouds
from pfcourse import LinearGaussianModel, ParticleFilter
from pfcourse.errors import ParameterError, ShapeError
from pfcourse import kalman_filter
from pfcourse.scenarios.robot import RobotModel, RobotScenario, simulate_robot
from pfcourse.scenarios.robot.scenario import robot_transition_log_density
from pfcourse.smoothing import ffbsm, linear_gaussian_log_transition, pairwise, rts_smoother


@pytest.fixture(scope="module")
def scalar():
    """x_k = 0.9 x_{k-1} + w, Q = 1; z_k = x_k + v, R = 1; 20 steps, z_5..z_9 missing."""
    model = LinearGaussianModel(F=[[0.9]], H=[[1.0]], m0=[0.0], P0=[[2.0]], Q=[[1.0]], R=[[1.0]])
    rng = np.random.default_rng(5)
    x = np.empty(20)
    x[0] = rng.normal(0, np.sqrt(2))
    for k in range(1, 20):
        x[k] = 0.9 * x[k - 1] + rng.standard_normal()
    z = (x + rng.standard_normal(20))[:, None]
    z[5:10] = np.nan
    return model, z


def test_rts_is_the_joint_gaussian_posterior(scalar):
    model, z = scalar
    K = len(z)
    # prior covariance of (x_0..x_{K-1}): C[j, k] = 0.9^|j-k| Var(x_min(j,k))
    var = np.empty(K)
    var[0] = 2.0
    for k in range(1, K):
        var[k] = 0.81 * var[k - 1] + 1.0
    j, k = np.meshgrid(np.arange(K), np.arange(K), indexing="ij")
    C = 0.9 ** np.abs(j - k) * var[np.minimum(j, k)]
    obs = ~np.isnan(z[:, 0])
    S = C[np.ix_(obs, obs)] + np.eye(obs.sum())
    gain = C[:, obs] @ np.linalg.inv(S)
    mean = gain @ z[obs, 0]
    cov = C - gain @ C[obs, :]
    m_s, P_s = rts_smoother(model, kalman_filter(model, z))
    np.testing.assert_allclose(m_s[:, 0], mean, atol=1e-10)
    np.testing.assert_allclose(P_s[:, 0, 0], np.diag(cov), atol=1e-10)


def test_ffbsm_converges_to_rts(scalar):
    model, z = scalar
    m_s, P_s = rts_smoother(model, kalman_filter(model, z))
    sd = np.sqrt(P_s[:, 0, 0])
    errors = []
    for n in (100, 1600):
        r = ParticleFilter(model, n).run(z, 3, collect=[Clouds()])
        s = ffbsm(r.particles, r.weights, linear_gaussian_log_transition(model))
        np.testing.assert_allclose(s.weights.sum(axis=1), 1.0, atol=1e-12)
        np.testing.assert_array_equal(s.weights[-1], r.weights[-1])
        errors.append(np.sqrt(np.mean(((s.mean[:, 0] - m_s[:, 0]) / sd) ** 2)))
    # Monte Carlo error ~ 1/sqrt(ESS): well under 0.15 sd at N = 1600, and shrinking with N
    assert errors[1] < 0.15
    assert errors[1] < errors[0]


def test_cdist_transition_equals_the_row_by_row_density():
    rng = np.random.default_rng(1)
    A = rng.standard_normal((3, 3))
    model = LinearGaussianModel(F=0.5 * A, H=np.eye(3), m0=np.zeros(3), P0=np.eye(3),
                                Q=A @ A.T + np.eye(3), R=np.eye(3), B=[1.0, 0.0, -1.0])
    new, old = rng.standard_normal((7, 3)), rng.standard_normal((5, 3))
    np.testing.assert_allclose(linear_gaussian_log_transition(model)(new, old, 1),
                               pairwise(model.transition_log_density)(new, old, 1), rtol=1e-12)


@pytest.fixture(scope="module")
def robot():
    sim = simulate_robot(RobotScenario().with_(n_steps=20, dt=0.5), 4)
    return RobotModel.for_simulation(sim, q_scale=50.0), sim


def test_robot_transition_density_is_normalised(robot):
    """E_q[p(x)/q(x)] = 1 for a Gaussian q wider than p (importance sampling of the integral)."""
    model, sim = robot
    old = np.array([[3.0, -40.0, 0.7]])
    draws = model.sample_transition(np.repeat(old, 20000, axis=0), 5, np.random.default_rng(0))
    centre, cov = draws.mean(axis=0), 4 * np.cov(draws.T)
    q = stats.multivariate_normal(centre, cov)
    x = q.rvs(200_000, random_state=1)
    ratio = np.exp(robot_transition_log_density(model, x, np.repeat(old, len(x), axis=0), 5) - q.logpdf(x))
    assert ratio.mean() == pytest.approx(1.0, abs=4 * ratio.std() / np.sqrt(len(x)))


def test_robot_transition_density_inverts_the_motion(robot):
    model, sim = robot
    rng = np.random.default_rng(2)
    old = np.column_stack([rng.normal(0, 5, 50), rng.normal(-40, 5, 50), rng.uniform(-np.pi, np.pi, 50)])
    w = rng.multivariate_normal(np.zeros(3), model.q_est, 50)
    from pfcourse.scenarios.robot import motion
    new = motion(old, model.odometry[3] + w, model.dt)
    expected = stats.multivariate_normal(np.zeros(3), model.q_est).logpdf(w) - 3 * np.log(model.dt)
    np.testing.assert_allclose(robot_transition_log_density(model, new, old, 3), expected, rtol=1e-9)


def test_bad_input(scalar):
    model, z = scalar
    with pytest.raises(ShapeError, match="Clouds"):
        ffbsm(np.zeros((3, 4)), np.ones((3, 4)) / 4, linear_gaussian_log_transition(model))
    shifted = LinearGaussianModel(F=[[0.9]], H=[[1.0]], m0=[0.0], P0=[[2.0]], Q=[[1.0]], R=[[1.0]], B=[1.0])
    with pytest.raises(ParameterError, match="B = 0"):
        rts_smoother(shifted, kalman_filter(shifted, z))
    with pytest.raises(ShapeError, match="log_transition"):
        ffbsm(np.zeros((3, 4, 1)), np.ones((3, 4)) / 4, lambda new, old, k: np.zeros((4, 3)))


def test_ffbsi_draws_the_ffbsm_marginals(scalar):
    """Each FFBSi index b_k is distributed as the FFBSm weights W_{k|K} (Godsill, Doucet and West 2004):
    the mean of M trajectories is within 5 standard errors sqrt(Var_{k|K} / M) of the FFBSm mean."""
    from pfcourse.smoothing import ffbsi
    model, z = scalar
    r = ParticleFilter(model, 200).run(z, 4, collect=[Clouds()])
    s = ffbsm(r.particles, r.weights, linear_gaussian_log_transition(model))
    M = 4000
    paths = ffbsi(r.particles, r.weights, linear_gaussian_log_transition(model), M, np.random.default_rng(9))
    assert paths.shape == (len(z), M, 1)
    se = np.sqrt(s.cov[:, 0, 0] / M)
    assert np.max(np.abs(paths.mean(axis=1)[:, 0] - s.mean[:, 0]) / se) < 5


def test_ancestors_collected_and_fixed_lag_zero_is_the_filter(scalar):
    from pfcourse.collectors import Ancestors
    from pfcourse.smoothing import fixed_lag_means
    model, z = scalar
    r = ParticleFilter(model, 50, threshold=1.0).run(z, 6, collect=[Clouds(), Ancestors()])
    A = r.collected["ancestors"]
    np.testing.assert_array_equal(A[0], np.arange(50))
    steps = np.flatnonzero(r.resampled[:-1])  # resampled after these steps (ESS < N: not when nothing is seen)
    assert len(steps) > 5
    drawn = [s.ancestors for s in ParticleFilter(model, 50, threshold=1.0).steps(z, 6) if s.resampled]
    np.testing.assert_array_equal(A[steps + 1], np.array(drawn[:len(steps)]))
    kept = np.setdiff1d(np.arange(1, len(z)), steps + 1)
    np.testing.assert_array_equal(A[kept], np.tile(np.arange(50), (len(kept), 1)))
    np.testing.assert_allclose(fixed_lag_means(r.particles, r.weights, A, 0), r.mean, atol=1e-12)
    # a lag of one: the weights of step k+1 on the parents of its particles
    lag1 = fixed_lag_means(r.particles, r.weights, A, 1)
    np.testing.assert_allclose(lag1[3], r.weights[4] @ r.particles[3][A[4]], atol=1e-12)


def test_bad_smoother_input(scalar):
    from pfcourse.smoothing import fixed_lag_means, ffbsi
    model, _ = scalar
    p, w = np.zeros((3, 4, 1)), np.ones((3, 4)) / 4
    with pytest.raises(ParameterError, match="n_draws"):
        ffbsi(p, w, linear_gaussian_log_transition(model), 0, np.random.default_rng(0))
    with pytest.raises(ParameterError, match="lag"):
        fixed_lag_means(p, w, np.zeros((3, 4), int), -1)
    with pytest.raises(ShapeError, match="ancestors"):
        fixed_lag_means(p, w, np.zeros((2, 4), int), 1)
