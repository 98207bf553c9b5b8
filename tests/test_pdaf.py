"""The probabilistic data association filter (pfcourse.scenarios.robot.association.pda_update, run_pdaf):
its update is the moment match of the exact posterior mixture of a linear Gaussian prediction,
computed here by brute force on a grid; its gate; its run; its bad inputs."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse.errors import ModelError, ParameterError, ShapeError
from pfcourse.scenarios.robot import RobotModel, run_ekf, simulate_robot
from pfcourse.scenarios.robot.association import AssociationModel, ClutterSensor, pda_update, run_pdaf, simulate_readings

# A tiny linear case: a 2-D state, two look-alike "landmarks" h_j(x) = H_j x + b_j, two readings.
MEAN = np.array([1.0, -0.5])
COV = np.array([[0.8, 0.3], [0.3, 0.5]])
H = np.array([[[1.0, 0.2], [0.0, 1.0]], [[0.7, 0.0], [0.1, 1.2]]])
B = np.array([[0.0, 0.0], [1.5, -1.0]])
R = np.array([[0.3, 0.05], [0.05, 0.2]])
Z = np.array([[1.4, -0.2], [2.0, -1.3]])
SENSOR = ClutterSensor(p_detect=0.8, clutter_rate=1.5, max_range=2.0)


def brute_force_moments(sensor):
    """Mean and covariance of N(x; m, P) p(Z | x), p(Z | x) the clutter mixture, by quadrature on a grid."""
    sd = np.sqrt(np.diag(COV))
    axes = [np.linspace(m - 9 * s, m + 9 * s, 1201) for m, s in zip(MEAN, sd)]
    X = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 2)
    n, M, lam, c = len(Z), len(H), sensor.clutter_rate, np.exp(sensor.clutter_log_density)
    like = np.full(len(X), (1 - sensor.p_detect) * lam**n * c**n)
    for z in Z:
        for Hj, bj in zip(H, B):
            like += sensor.p_detect / M * stats.multivariate_normal(z, R).pdf(X @ Hj.T + bj) * lam ** (n - 1) * c ** (n - 1)
    w = stats.multivariate_normal(MEAN, COV).pdf(X) * like
    w /= w.sum()
    mean = w @ X
    d = X - mean
    return mean, (w[:, None] * d).T @ d


@pytest.mark.parametrize("sensor", [SENSOR, ClutterSensor(0.95, 0.3, 5.0), ClutterSensor(0.5, 4.0, 1.0)])
def test_the_update_is_the_moment_match_of_the_exact_mixture(sensor):
    """No gate: the PDA update of a linear Gaussian prediction is exact in its first two moments."""
    mean, cov, beta = pda_update(MEAN, COV, Z, H @ MEAN + B, H, R, sensor, gate_probability=None, angle_index=None)
    want_mean, want_cov = brute_force_moments(sensor)
    np.testing.assert_allclose(mean, want_mean, atol=1e-6)
    np.testing.assert_allclose(cov, want_cov, atol=1e-6)
    assert beta.shape == (1 + len(Z) * len(H),) and abs(beta.sum() - 1) < 1e-12 and np.all(beta > 0)


def test_the_gate_leaves_far_readings_out_and_scales_the_miss():
    """A reading far outside every gate gets no weight, and beta_0 uses 1 - P_D P_G."""
    far = np.vstack([Z[:1], [[60.0, 60.0]]])
    mean, cov, beta = pda_update(MEAN, COV, far, H @ MEAN + B, H, R, SENSOR, gate_probability=0.99, angle_index=None)
    assert np.all(beta[1 + 2:] == 0)  # reading 1 (the far one), both landmarks
    one_mean, one_cov, one_beta = pda_update(MEAN, COV, Z[:1], H @ MEAN + B, H, R, SENSOR, gate_probability=0.99,
                                             angle_index=None)
    # the same events as with the near reading alone, with the common factor lambda c of the far one cancelling
    np.testing.assert_allclose(beta[:3], one_beta, rtol=1e-12)
    np.testing.assert_allclose(mean, one_mean, rtol=1e-12)
    ungated = pda_update(MEAN, COV, Z[:1], H @ MEAN + B, H, R, SENSOR, gate_probability=None, angle_index=None)[2]
    odds = (1 - SENSOR.p_detect * 0.99) / (1 - SENSOR.p_detect)
    np.testing.assert_allclose(one_beta[0] / one_beta[1], odds * ungated[0] / ungated[1], rtol=1e-10)


def test_without_clutter_or_misses_the_pdaf_is_the_ekf():
    """P_D = 1, no clutter, the lab's landmarks far apart: every other landmark falls outside the gate,
    and the PDA filter is the known-association EKF."""
    sim = simulate_robot(rng=3, n_steps=200)
    sensor = ClutterSensor(1.0, 0.0)
    model = AssociationModel(RobotModel.for_simulation(sim), sensor)
    r = simulate_readings(sim, sensor, 1)
    res, none_true = run_pdaf(model, r.readings)
    ref = run_ekf(model.base, sim.measurements)
    np.testing.assert_allclose(res.mean, ref.mean, atol=1e-8)
    assert np.all(none_true == np.where(sim.has_measurement, 0.0, 1.0))


def test_clutter_makes_the_pdaf_doubt():
    """With clutter the filter gives "every reading is clutter" a positive probability at every step with
    readings (1 where every reading falls outside every gate), below 1 at most of them."""
    sim = simulate_robot(rng=3, n_steps=120)
    sensor = ClutterSensor(0.9, 3.0)
    model = AssociationModel(RobotModel.for_simulation(sim), sensor)
    readings = simulate_readings(sim, sensor, 2)
    res, none_true = run_pdaf(model, readings.readings)
    assert np.all(none_true[readings.counts == 0] == 1.0)
    seen = none_true[readings.counts > 0]
    assert np.all((seen > 0) & (seen <= 1)) and np.mean(seen < 1) > 0.8 and np.all(np.isfinite(res.mean))
    assert np.all(np.linalg.eigvalsh(res.cov)[:, 0] > 0)


_SIM = simulate_robot(None, 0, n_steps=6)
_MODEL = AssociationModel(RobotModel.for_simulation(_SIM), ClutterSensor())


@pytest.mark.parametrize("call, error, fragment", [
    (lambda: run_pdaf(_MODEL.base, np.zeros((6, 1, 2))), ModelError, "run_pdaf needs an AssociationModel"),
    (lambda: run_pdaf(_MODEL, np.zeros((6, 2))), ShapeError, "shape (K, C, 2)"),
    (lambda: run_pdaf(_MODEL, np.zeros((7, 1, 2))), ShapeError, "only 6 odometry rows"),
    (lambda: run_pdaf(_MODEL, np.zeros((6, 1, 2)), gate_probability=1.0), ParameterError, "strictly between"),
    (lambda: pda_update(MEAN, COV, Z, H @ MEAN + B, H, R, SENSOR, gate_probability=0.0), ParameterError,
     "strictly between"),
])
def test_bad_inputs_are_named(call, error, fragment):
    with pytest.raises(error) as info:
        call()
    assert fragment in str(info.value)
