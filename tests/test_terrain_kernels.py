"""The compiled terrain model against its NumPy / scipy definitions."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.angles import wrap_angle
from pfcourse.checks import covariance_factor
from pfcourse.scenarios.terrain.scenario import AircraftScenario, predicted_measurement, propagate
from pfcourse.scenarios.terrain.map import load_jacksboro
from pfcourse.scenarios.terrain.compiled import bilinear


def log_likelihood_definition(model, particles, z):
    """The NumPy / scipy definition of the model's ``log_likelihood``: ``log N(z - h(x); 0, Rf)``, -inf off the map."""
    rf = model.scenario.Rf
    innovation = float(np.ravel(z)[0]) - predicted_measurement(particles, model.terrain)
    loglik = -0.5 * (innovation**2 / rf + np.log(rf) + np.log(2.0 * np.pi))
    return np.where(np.isnan(loglik), -np.inf, loglik)


def sample_transition_definition(model, particles, rng):
    """The NumPy definition of the model's ``sample_transition`` (same draws)."""
    s = model.scenario
    x = propagate(particles, s.speed, s.omega, s.dt)
    x += rng.standard_normal(x.shape) @ covariance_factor(s.Qf * s.dt).T
    x[:, 3] = wrap_angle(x[:, 3])
    return x


@pytest.fixture(scope="module")
def setup():
    terrain = load_jacksboro()
    scenario = AircraftScenario()
    return terrain, scenario, scenario.model(terrain)


def test_bilinear_matches_map_coordinates(setup):
    terrain, _, _ = setup
    rng = np.random.default_rng(3)
    x = rng.uniform(-500.0, terrain.width + 500.0, 20000)
    y = rng.uniform(-500.0, terrain.height_extent + 500.0, 20000)
    x[:3] = [0.0, terrain.width, terrain.x_nodes[10]]  # edges and a node
    y[:3] = [terrain.height_extent, 0.0, terrain.y_nodes[7]]
    ours = bilinear(np.ascontiguousarray(terrain.heights), terrain.dx, terrain.dy, x, y)
    ref = terrain.height(x, y)
    np.testing.assert_array_equal(np.isnan(ours), np.isnan(ref))
    assert np.isnan(ref).sum() > 100  # the test does go off the map
    ok = ~np.isnan(ref)
    # heights up to ~1100 m: a few ulps of rounding difference at most
    np.testing.assert_allclose(ours[ok], ref[ok], rtol=0, atol=1e-9)


def test_likelihood_matches_numpy(setup):
    terrain, scenario, model = setup
    rng = np.random.default_rng(4)
    x = model.sample_initial(5000, rng)
    x[:50, 0] = -10.0  # off the map
    z = np.array([800.0])
    ours = model.log_likelihood(x, z, 1)
    ref = log_likelihood_definition(model, x, z)
    assert np.all(ours[:50] == -np.inf)
    np.testing.assert_array_equal(np.isinf(ours), np.isinf(ref))
    fin = np.isfinite(ref)
    np.testing.assert_allclose(ours[fin], ref[fin], rtol=1e-12, atol=1e-9)


def test_transition_matches_numpy_with_the_same_draws(setup):
    _, scenario, _ = setup
    sc = scenario.with_(Qf=np.array([[9.0, 1.0, 0, 0], [1.0, 9.0, 0, 0], [0, 0, 0.36, 0], [0, 0, 0, 0.003]]))
    model = sc.model(load_jacksboro())
    x = model.sample_initial(4000, np.random.default_rng(5))
    a = model.sample_transition(x, 1, np.random.default_rng(6))
    b = sample_transition_definition(model, x, np.random.default_rng(6))
    np.testing.assert_allclose(a[:, :3], b[:, :3], rtol=0, atol=1e-8)
    d = np.angle(np.exp(1j * (a[:, 3] - b[:, 3])))
    assert np.max(np.abs(d)) < 1e-12
    assert np.all((a[:, 3] > -np.pi) & (a[:, 3] <= np.pi))
