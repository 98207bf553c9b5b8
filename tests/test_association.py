"""Unknown data association (pfcourse.scenarios.robot.association): the simulator of anonymous readings,
the mixture likelihood over associations, the nearest-neighbour EKF and their bad inputs."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from scipy.special import logsumexp

from pfcourse.errors import MeasurementError, ModelError, ParameterError, ShapeError
from pfcourse.studies import association as study
from pfcourse.scenarios.robot import RobotModel, simulate_robot
from pfcourse.scenarios.robot.association import (
    AssociationModel,
    ClutterSensor,
    mixture_log_likelihood,
    run_nn_ekf,
    simulate_readings,
)


@pytest.fixture(scope="module")
def sim():
    return simulate_robot(rng=3, n_steps=400)


def cloud(sim, n=200, seed=0):
    return RobotModel.for_simulation(sim).sample_initial(n, np.random.default_rng(seed))


def test_mixture_reduces_to_the_known_association_likelihood(sim):
    """P_D = 1, no clutter, one landmark, one reading: the mixture is RobotModel's Gaussian."""
    one = RobotModel.for_simulation(sim)
    one = RobotModel(sim.landmarks[2:3], sim.odometry, one.q_est, one.r_est)
    x = cloud(sim)
    z = np.array([[40.0, 0.3]])
    got = mixture_log_likelihood(one, ClutterSensor(1.0, 0.0), x, z)
    np.testing.assert_allclose(got, one.log_likelihood(x, np.array([0.0, 40.0, 0.3]), 0), rtol=0, atol=1e-12)


def test_mixture_is_the_sum_over_associations(sim):
    """Two readings: the set density written term by term (module docstring), in plain floats."""
    base = RobotModel.for_simulation(sim)
    sensor = ClutterSensor(0.7, 1.5, 150.0)
    x = cloud(sim, 50)
    z = np.array([[30.0, 1.0], [np.nan, np.nan], [55.0, -2.0]])
    c = 1.0 / (2 * np.pi * 150.0)
    lam, M = 1.5, len(sim.landmarks)
    g = [np.mean([np.exp(base.log_likelihood(x, np.array([j, *zi]), 0)) for j in range(M)], axis=0)
         for zi in z[[0, 2]]]
    expected = np.exp(-lam) * ((1 - 0.7) * lam**2 * c * c + 0.7 * lam * c * (g[0] + g[1]))
    np.testing.assert_allclose(mixture_log_likelihood(base, sensor, x, z), np.log(expected), rtol=1e-10)


def test_no_reading_is_uninformative(sim):
    base = RobotModel.for_simulation(sim)
    got = mixture_log_likelihood(base, ClutterSensor(0.8, 2.0), cloud(sim), np.full((2, 2), np.nan))
    np.testing.assert_allclose(got, np.log(0.2) - 2.0)


def test_clutter_rate_and_detections(sim):
    """Clutter per measurement step is Poisson(lambda): its mean within 4 standard errors; every
    detection is the lab's reading; padding only after the readings of a step."""
    lam = 2.5
    sensor = ClutterSensor(0.8, lam, 100.0)
    r = simulate_readings(sim, sensor, 7)
    measured = sim.has_measurement
    counts = r.clutter_counts[measured]
    assert abs(counts.mean() - lam) < 4 * np.sqrt(lam / len(counts))
    assert r.clutter_counts[~measured].sum() == 0
    clutter = r.readings[r.origin == -1]
    assert clutter[:, 0].min() >= 0 and clutter[:, 0].max() <= 100.0
    assert stats.kstest(clutter[:, 0] / 100.0, "uniform").pvalue > 1e-3
    k, i = np.nonzero(r.origin >= 0)
    np.testing.assert_array_equal(r.readings[k, i], sim.measurements[k, 1:])
    np.testing.assert_array_equal(r.origin[k, i], sim.landmark_index[k])
    detected = np.isin(np.arange(len(sim.truth)), k)
    n = measured.sum()
    assert abs(detected.sum() / n - 0.8) < 4 * np.sqrt(0.16 / n)
    assert np.all(np.isnan(r.readings[r.origin == -2]))


def test_same_detections_whatever_the_clutter(sim):
    a = simulate_readings(sim, ClutterSensor(0.9, 0.0), 5)
    b = simulate_readings(sim, ClutterSensor(0.9, 3.0), 5)
    assert np.array_equal(np.sort(a.origin[a.origin >= 0]), np.sort(b.origin[b.origin >= 0]))
    assert np.array_equal(np.any(a.origin >= 0, axis=1), np.any(b.origin >= 0, axis=1))


def test_nn_ekf_without_clutter_is_the_ekf(sim):
    """P_D = 1, no clutter, landmarks far apart: every reading goes to its own landmark and the
    estimates are those of the known-association EKF."""
    from pfcourse.scenarios.robot import run_ekf

    sensor = ClutterSensor(1.0, 0.0)
    r = simulate_readings(sim, sensor, 1)
    model = AssociationModel(RobotModel.for_simulation(sim), sensor)
    res, chosen = run_nn_ekf(model, r.readings)
    np.testing.assert_array_equal(chosen, r.origin)
    ref = run_ekf(model.base, sim.measurements)
    np.testing.assert_allclose(res.mean, ref.mean, atol=1e-8)


def test_nn_ekf_gates_out_far_clutter(sim):
    sensor = ClutterSensor(1.0, 0.0)
    r = simulate_readings(sim, sensor, 1)
    readings = np.concatenate([r.readings, np.full((len(sim.truth), 1, 2), np.nan)], axis=1)
    readings[5, 1] = (1.0, 3.0)  # one metre away, behind: outside every gate
    _, chosen = run_nn_ekf(AssociationModel(RobotModel.for_simulation(sim), sensor), readings)
    assert chosen[5, 1] == -1


def _pairs_d2(model, x, P, z):
    """d^2 of every (reading, landmark) pair of one step, (n, M), from the prediction (x, P)."""
    from pfcourse.scenarios.robot.kalman import measurement_jacobian, measurement_residual, range_bearing_one

    out = np.empty((len(z), len(model.base.landmarks)))
    for i, zi in enumerate(z):
        for j, landmark in enumerate(model.base.landmarks):
            H = measurement_jacobian(x, landmark)
            nu = measurement_residual(zi, range_bearing_one(x, landmark))
            out[i, j] = nu @ np.linalg.solve(H @ P @ H.T + model.base.r_est, nu)
    return out


def test_nn_standard_filter_updates_once_with_the_nearest_gated_pair(sim):
    """rule="nearest" (Bar-Shalom, Daum and Huang 2009): at most one reading a step is used, and it is the
    pair of smallest d^2 over every reading and landmark, recomputed here from the filter's own prediction;
    with several readings in a step, the sequential variant may use more than one."""
    sensor = ClutterSensor(0.9, 4.0)
    r = simulate_readings(sim, sensor, 2)
    model = AssociationModel(RobotModel.for_simulation(sim), sensor)
    res, chosen = run_nn_ekf(model, r.readings)
    used = np.sum(chosen >= 0, axis=1)
    assert used.max() == 1 and used.sum() > 50
    gamma = stats.chi2.ppf(0.99, 2)
    checked = 0
    for k in np.flatnonzero(used[1:] == 1)[:40] + 1:
        z = r.readings[k][~np.isnan(r.readings[k]).all(axis=1)]
        x, P = res.predicted[k], _predicted_cov(model, res, k)
        d2 = _pairs_d2(model, x, P, z)
        i, j = np.unravel_index(np.argmin(d2), d2.shape)
        present = np.flatnonzero(~np.isnan(r.readings[k]).all(axis=1))
        assert d2[i, j] <= gamma and chosen[k, present[i]] == j
        checked += 1
    assert checked == 40
    _, sequential = run_nn_ekf(model, r.readings, rule="sequential")
    assert np.sum(sequential >= 0, axis=1).max() > 1


def _predicted_cov(model, res, k):
    """The covariance the filter predicted at step k, from its covariance at k - 1."""
    from pfcourse.scenarios.robot.kalman import motion_jacobians

    u = model.base.odometry[k]
    F, G = motion_jacobians(res.mean[k - 1], u, model.base.dt)
    return F @ res.cov[k - 1] @ F.T + G @ model.base.q_est @ G.T


def test_study_row_is_seeded():
    a = study.row(seed=0, clutter_rate=1.0)
    b = study.row(seed=0, clutter_rate=1.0)
    assert {k: v for k, v in a.items() if "seconds" not in k} == {k: v for k, v in b.items() if "seconds" not in k}
    assert a["pf_rmse_m"] > 0 and a["ekf_rmse_m"] > 0


_SIM = simulate_robot(None, 0, n_steps=6)
_MODEL = AssociationModel(RobotModel.for_simulation(_SIM), ClutterSensor())


@pytest.mark.parametrize("call, error, fragment", [
    (lambda: ClutterSensor(p_detect=1.5), ParameterError, "p_detect"),
    (lambda: ClutterSensor(clutter_rate=-1.0), ParameterError, "clutter_rate must lie in"),
    (lambda: ClutterSensor(clutter_rate=np.nan), ParameterError, "clutter_rate must be finite"),
    (lambda: ClutterSensor(max_range=0.0), ParameterError, "max_range must lie in (0.0"),
    (lambda: ClutterSensor(max_range="far"), ParameterError, "max_range must be a real number"),
    (lambda: simulate_readings(_SIM.measurements, ClutterSensor(), 0), ParameterError, "sim must be a RobotSimulation"),
    (lambda: simulate_readings(_SIM, 0.5, 0), ParameterError, "sensor must be a ClutterSensor"),
    (lambda: simulate_readings(_SIM, ClutterSensor(), 1.5), ParameterError, "rng must be"),
    (lambda: AssociationModel("map", ClutterSensor()), ModelError, "base must be a RobotModel"),
    (lambda: AssociationModel(_MODEL.base, None), ParameterError, "sensor must be a ClutterSensor"),
    (lambda: _MODEL.log_likelihood(np.zeros((3, 3)), np.array([1.0, 2.0]), 4), ShapeError, "step 4: anonymous"),
    (lambda: _MODEL.log_likelihood(np.zeros((3, 3)), np.array([[1.0, np.nan]]), 4), MeasurementError,
     "step 4: a reading must have a finite"),
    (lambda: run_nn_ekf(_MODEL.base, np.zeros((6, 1, 2))), ModelError, "needs an AssociationModel"),
    (lambda: run_nn_ekf(_MODEL, np.zeros((6, 2))), ShapeError, "shape (K, C, 2)"),
    (lambda: run_nn_ekf(_MODEL, np.zeros((7, 1, 2))), ShapeError, "only 6 odometry rows"),
    (lambda: run_nn_ekf(_MODEL, np.zeros((6, 1, 2)), gate_probability=1.0), ParameterError, "strictly between"),
    (lambda: run_nn_ekf(_MODEL, np.full((6, 1, 2), np.inf)), MeasurementError, "step 0: a reading must have"),
    (lambda: run_nn_ekf(_MODEL, np.zeros((6, 1, 2)), rule="nearest-two"), ParameterError, "rule must be one of"),
])
def test_bad_inputs_are_named(call, error, fragment):
    with pytest.raises(error) as info:
        call()
    assert fragment in str(info.value)


def test_logsumexp_form_matches_plain_mixture_for_one_reading(sim):
    """The book's one-reading formula, e^{-lambda}[(1 - P_D) lambda c + sum_j P_D/M N_j]."""
    base = RobotModel.for_simulation(sim)
    x = cloud(sim, 30)
    z = np.array([[25.0, -0.4]])
    ell = np.array([base.log_likelihood(x, np.array([j, 25.0, -0.4]), 0) for j in range(len(sim.landmarks))])
    c = 1 / (2 * np.pi * 200.0)
    plain = -1.2 + logsumexp(np.vstack([np.full(30, np.log(0.1 * 1.2 * c)), np.log(0.9 / 5) + ell]), axis=0)
    np.testing.assert_allclose(mixture_log_likelihood(base, ClutterSensor(0.9, 1.2), x, z), plain, rtol=1e-12)
