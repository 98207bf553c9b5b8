"""The compiled terrain model against its NumPy / scipy definitions."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.terrain.scenario import AircraftScenario
from pfcourse.terrain.map import load_jacksboro
from pfcourse.terrain.compiled import bilinear


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
    ref = model.log_likelihood_numpy(x, z, 1)
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
    b = model.sample_transition_numpy(x, 1, np.random.default_rng(6))
    np.testing.assert_allclose(a[:, :3], b[:, :3], rtol=0, atol=1e-8)
    d = np.angle(np.exp(1j * (a[:, 3] - b[:, 3])))
    assert np.max(np.abs(d)) < 1e-12
    assert np.all((a[:, 3] > -np.pi) & (a[:, 3] <= np.pi))
