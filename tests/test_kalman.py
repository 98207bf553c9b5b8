"""The Kalman family's one loop (pfcourse.kalman): the stored outputs of the four entry points,
the Kalman filter against batch Gaussian conditioning, and the EKF and UKF on a linear model."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from scipy.stats import multivariate_normal

from kalman_cases import REFERENCE, arrays, cases
from pfcourse.kalman import GaussianModel, Linearised, Measurement, Transition, Unscented, gaussian_filter, kalman_filter
from pfcourse.linear_gaussian import LinearGaussianModel

CASES = cases()


@pytest.fixture(scope="module")
def reference():
    return np.load(REFERENCE)


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_entry_points_give_the_stored_floats(name, reference):
    """Each of kalman_filter, run_ekf, run_ukf and the terrain EKF and UKF gives, float for float,
    what it gave before it became a wrapper over gaussian_filter (tests/kalman_cases.py)."""
    for key, value in arrays(name, CASES[name]()).items():
        np.testing.assert_array_equal(value, reference[key], err_msg=key)


def _model(seed: int = 0) -> LinearGaussianModel:
    """A 3-state, 2-reading linear-Gaussian model with an input ``B`` and correlated noises."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(3, 3))
    return LinearGaussianModel(F=0.9 * np.eye(3) + 0.1 * A, H=rng.normal(size=(2, 3)), m0=[1.0, -2.0, 0.5],
                               P0=np.diag([2.0, 1.0, 0.5]), Q=0.1 * np.eye(3) + 0.02 * np.ones((3, 3)),
                               R=[[0.3, 0.1], [0.1, 0.2]], B=[0.1, 0.0, -0.2])


def _readings(K: int = 6, seed: int = 1) -> np.ndarray:
    z = np.random.default_rng(seed).normal(size=(K, 2))
    z[2] = np.nan  # a step without a reading
    z[4, 1] = np.nan  # a reading with one component missing
    return z


def test_the_kalman_filter_is_batch_gaussian_conditioning():
    """``x_{0:K}`` and the observed readings are jointly Gaussian; conditioning the stacked vector on
    ``z_{0:k}`` gives ``N(m_k, P_k)``, and the readings' joint density is ``exp(sum of increments)``."""
    model, z = _model(), _readings()
    K, d = len(z), 3
    # x_k = F^k m0 + sum F^(k-j) B + noise: the joint mean and covariance of x_{0:K-1}.
    mean, T = np.zeros(K * d), np.zeros((K * d, K * d))  # x = mean + T [x0 - m0, w_1, ..., w_{K-1}]
    noise = scipy.linalg.block_diag(model.P0, *[model.Q] * (K - 1))
    x, blocks = model.m0.copy(), [np.eye(d)]
    for k in range(K):
        if k:
            x = model.F @ x + model.B
            blocks = [model.F @ b for b in blocks] + [np.eye(d)]
        mean[k * d:(k + 1) * d] = x
        for j, b in enumerate(blocks):
            T[k * d:(k + 1) * d, j * d:(j + 1) * d] = b
    Sx = T @ noise @ T.T
    result = kalman_filter(model, z)
    for k in range(K):
        rows = [(j, i) for j in range(k + 1) for i in range(2) if not np.isnan(z[j, i])]
        Hs = np.array([np.concatenate([np.zeros(j * d), model.H[i], np.zeros((K - j - 1) * d)]) for j, i in rows])
        Rs = np.array([[model.R[i, i2] if j == j2 else 0.0 for j2, i2 in rows] for j, i in rows])
        zs = np.array([z[j, i] for j, i in rows])
        S = Hs @ Sx @ Hs.T + Rs
        gain = Sx @ Hs.T @ np.linalg.inv(S)
        post_mean = mean + gain @ (zs - Hs @ mean)
        post_cov = Sx - gain @ Hs @ Sx
        block = slice(k * d, (k + 1) * d)
        np.testing.assert_allclose(result.mean[k], post_mean[block], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(result.cov[k], post_cov[block, block], rtol=1e-12, atol=1e-12)
        joint = multivariate_normal(Hs @ mean, S).logpdf(zs)
        assert result.log_likelihood_increments[: k + 1].sum() == pytest.approx(joint, rel=1e-12)


def _as_functions(model: LinearGaussianModel, **residuals) -> GaussianModel:
    """``model`` as :class:`GaussianModel` functions, without kalman_filter's matrices: ``f``, ``h``
    and their Jacobians (for the EKF), every reading complete."""
    moved = Transition(lambda x: model.F @ x + model.B, model.Q, model.F)
    return GaussianModel(model.m0, model.P0, model.dim_z, lambda k, m: moved,
                         lambda k, z: None if np.isnan(z).all() else
                         Measurement(z, lambda x: model.H @ x, model.R, lambda x: model.H), **residuals)


def _compare(a, b, rtol):
    for field in ("mean", "cov", "innovation", "innovation_cov", "predicted", "gain", "log_likelihood_increments"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), rtol=rtol, atol=rtol, err_msg=field)


@pytest.mark.parametrize("seed", range(3))
def test_the_ekf_of_a_linear_model_is_the_kalman_filter(seed):
    """With ``f`` and ``h`` linear the linearisation is exact: every recorded quantity is the KF's,
    to round-off (only the inverse of ``S``, SciPy's here and NumPy's there, differs)."""
    model, z = _model(seed), _readings(8, seed + 10)
    z[4] = np.nan
    _compare(gaussian_filter(_as_functions(model), Linearised(), z, "EKF"), kalman_filter(model, z), 1e-12)


@pytest.mark.parametrize("alpha, beta, kappa", [(1.0, 2.0, 0.0), (0.5, 2.0, 1.0), (1e-2, 2.0, 0.0)])
def test_the_ukf_of_a_linear_model_is_the_kalman_filter(alpha, beta, kappa):
    """The unscented transform of a Gaussian through a linear map is exact for any sigma-point
    spread; the UKF's ``P - G S G^T`` and the KF's Joseph form agree to round-off (scaled by the
    spread's conditioning, ``1 / alpha^2``)."""
    model, z = _model(3), _readings(8, 4)
    z[4] = np.nan
    gaussian = _as_functions(model)
    ukf = gaussian_filter(gaussian, Unscented(gaussian, alpha, beta, kappa), z, "UKF")
    _compare(ukf, kalman_filter(model, z), 1e-12 / alpha**2)


def test_the_log_likelihood_can_be_left_out():
    model, z = _model(), _readings()
    gaussian = _as_functions(model)
    z[4] = np.nan
    full = gaussian_filter(gaussian, Linearised(), z, "EKF")
    bare = gaussian_filter(gaussian, Linearised(), z, "EKF", log_likelihood=False)
    np.testing.assert_array_equal(bare.mean, full.mean)
    assert np.all(bare.log_likelihood_increments == 0.0) and np.all(full.log_likelihood_increments[[0, 1, 3]] < 0)


def test_a_filter_off_the_domain_of_h_is_lost_there():
    """A random walk on ``x >= 0`` read directly: the run stops at the first step whose predicted
    mean, sigma point or updated mean leaves the domain, and every row from there on is NaN."""
    walk = LinearGaussianModel(F=[[1.0]], H=[[1.0]], m0=[3.0], P0=[[0.25]], Q=[[0.01]], R=[[0.01]], B=[-1.0])
    z = np.array([[3.0], [2.0], [np.nan], [0.5], [-0.5], [-1.5]])
    on_domain = {"on_domain": lambda points: bool(np.all(points[:, 0] >= 0.0))}
    gaussian = _as_functions(walk, **on_domain)
    ekf = gaussian_filter(gaussian, Linearised(), z, "EKF")
    assert ekf.lost_at == 4  # predicted mean ~ -0.5
    assert np.all(np.isnan(ekf.mean[4:])) and np.all(np.isfinite(ekf.mean[:4]))
    assert np.all(np.isnan(ekf.innovation[4:]))
    # the sigma points of N(m, P) reach sqrt(n P) ~ 0.1 below a mean of 0.05: the UKF stops at step 3
    ukf = gaussian_filter(gaussian, Unscented(gaussian), np.array([[3.0], [2.0], [1.0], [0.05]]), "UKF")
    assert ukf.lost_at == 3 and np.isfinite(ukf.mean[2, 0])


def test_the_steps_are_filterpys_float_for_float():
    """The linearised step with NumPy's inverse is filterpy's ``KalmanFilter``, the unscented step its
    ``UnscentedKalmanFilter`` (same sigma points, same order of operations): equal floats."""
    from filterpy.kalman import KalmanFilter, MerweScaledSigmaPoints, UnscentedKalmanFilter

    model, z = _model(5), _readings(8, 6)
    z[[2, 4]] = np.nan
    gaussian = _as_functions(model)
    ours = {"KF": gaussian_filter(gaussian, Linearised(np.linalg.inv), z, "KF"),
            "UKF": gaussian_filter(gaussian, Unscented(gaussian, 0.5, 2.0, 1.0), z, "UKF")}
    kf = KalmanFilter(dim_x=3, dim_z=2)
    kf.x, kf.P, kf.F, kf.Q, kf.H, kf.R = model.m0.copy(), model.P0.copy(), model.F, model.Q, model.H, model.R
    ukf = UnscentedKalmanFilter(dim_x=3, dim_z=2, dt=1.0, hx=lambda x: model.H @ x,
                                fx=lambda x, dt: model.F @ x + model.B,
                                points=MerweScaledSigmaPoints(3, alpha=0.5, beta=2.0, kappa=1.0))
    ukf.x, ukf.P, ukf.Q, ukf.R = model.m0.copy(), model.P0.copy(), model.Q, model.R
    ukf.sigmas_f = ukf.points_fn.sigma_points(ukf.x, ukf.P)  # filterpy's sigma points before a first predict
    for k, zk in enumerate(z):
        if k:
            kf.predict(u=np.ones(1), B=model.B[:, None])
            ukf.predict()
        if not np.isnan(zk).all():
            kf.update(zk)
            ukf.update(zk)
        for name, theirs in (("KF", kf), ("UKF", ukf)):
            np.testing.assert_array_equal(ours[name].mean[k], np.ravel(theirs.x), err_msg=f"{name} {k}")
            np.testing.assert_array_equal(ours[name].cov[k], theirs.P, err_msg=f"{name} {k}")
