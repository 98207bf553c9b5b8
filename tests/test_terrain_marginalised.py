"""The marginalised particle filter (altitude Kalman in each particle) and the point-mass filter of
the terrain scenario: each against an exact answer."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import norm

from pfcourse.collectors import Clouds
from pfcourse.errors import ParameterError
from pfcourse.scenarios.terrain.map import TerrainMap
from pfcourse.scenarios.terrain.marginalised import MarginalisedTerrainModel, altitude_kalman_update, marginalised_filter
from pfcourse.scenarios.terrain.point_mass import PointMassFilter, ground_on_lattice
from pfcourse.scenarios.terrain.scenario import AircraftScenario


def _scalar_kalman(readings, ground, m0, p0, q, r):
    """The textbook scalar Kalman filter of z_k = z_(k-1) + w, y_k = z_k - ground + v (NaN: no reading)."""
    m, p, means, variances = m0, p0, [m0], [p0]
    for y in readings[1:]:
        p = p + q
        if not np.isnan(y):
            gain = p / (p + r)
            m, p = m + gain * (y + ground - m), (1 - gain) * p
        means.append(m)
        variances.append(p)
    return np.array(means), np.array(variances)


FLAT = TerrainMap(np.full((60, 60), 250.0), dx=1000.0, dy=1000.0)
SHORT = AircraftScenario(duration=20.0, x0=np.array([30000.0, 30000.0, 1500.0, 0.3]),
                         P0=np.diag([300.0, 300.0, 100.0, 0.1]) ** 2, gap=(8.0, 11.0))


def test_on_a_flat_map_every_particle_is_the_scalar_kalman_filter():
    rng = np.random.default_rng(3)
    readings = 1500.0 - 250.0 + 20.0 * rng.standard_normal(SHORT.n_steps)
    readings[~SHORT.measured()] = np.nan
    res = marginalised_filter(FLAT, SHORT, 50, threshold=0.5).run(readings[:, None], rng=4, collect=[Clouds()])
    m, p = _scalar_kalman(readings, 250.0, 1500.0, 100.0**2, SHORT.Qf[2, 2] * SHORT.dt, SHORT.Rf)
    assert np.allclose(res.particles[:, :, 2], m[:, None], rtol=1e-13, atol=0)
    assert np.allclose(res.particles[:, :, 4], p[:, None], rtol=1e-13, atol=0)
    assert np.allclose(res.mean[:, 2], m, rtol=1e-13)


def test_the_weight_is_the_predictive_density_and_zero_off_the_map():
    mean, var = np.array([1500.0, 1480.0, 1510.0]), 900.0
    ground = np.array([240.0, 260.0, np.nan])
    m, p, log_lik = altitude_kalman_update(mean, var, ground, 1230.0, 400.0)
    expected = norm.logpdf(1230.0, mean[:2] - ground[:2], np.sqrt(900.0 + 400.0))
    assert np.allclose(log_lik[:2], expected, rtol=1e-13) and log_lik[2] == -np.inf
    assert np.allclose(p, 900.0 * 400.0 / 1300.0, rtol=1e-13) and m[2] == mean[2]


def test_the_model_alone_refuses_to_weight():
    from pfcourse.filter import ParticleFilter

    readings = np.full((SHORT.n_steps, 1), 1250.0)
    with pytest.raises(ParameterError, match="AltitudeKalmanProposal"):
        ParticleFilter(MarginalisedTerrainModel(FLAT, SHORT), 10).run(readings, rng=0)


def test_a_prior_that_couples_altitude_is_refused():
    P0 = np.diag([300.0, 300.0, 100.0, 0.1]) ** 2
    P0[0, 2] = P0[2, 0] = 10.0
    with pytest.raises(ParameterError, match="couples the altitude"):
        MarginalisedTerrainModel(FLAT, SHORT.with_(P0=P0))


WIDE = TerrainMap(np.full((40, 40), 250.0), dx=1000.0, dy=1000.0)
STRAIGHT = AircraftScenario(duration=30.0, x0=np.array([20000.0, 20000.0, 1500.0, 0.4]),
                            P0=np.diag([300.0, 300.0, 100.0, 0.1]) ** 2, Qf=np.diag([0.0, 0.0, 0.6, 0.0]) ** 2)


def _layer_moments(w, x, y):
    """Per heading layer: mass, mean (x, y) and variance (x, y) of w (layers, rows, columns)."""
    mass = w.sum(axis=(1, 2))
    mx, my = w.sum(axis=1) @ x / mass, w.sum(axis=2) @ y / mass
    vx = w.sum(axis=1) @ x**2 / mass - mx**2
    vy = w.sum(axis=2) @ y**2 / mass - my**2
    return mass, np.column_stack([mx, my]), np.column_stack([vx, vy])


def test_without_heading_noise_each_layer_moves_by_whole_cells_and_keeps_its_shape():
    # No heading noise, no readings: each heading layer is the prior moved along its dead-reckoned path.
    # The exact shift keeps every layer's spread (a bilinear shift would add f(1 - f) cell^2 a step) and
    # moves its mean by the exact displacement: by whole cells on the lattice (within half a cell), and the
    # layer's points lie at the lattice plus the layer's residual, at the last step as at the first.
    grid = PointMassFilter(WIDE, STRAIGHT, cell=50.0, heading_step=0.02, tail=0.0)
    w0 = grid.initial()[0]
    m0, mean0, var0 = _layer_moments(w0, grid.x, grid.y)
    K = STRAIGHT.n_steps
    grid.run(np.full(K, np.nan), keep=K - 1)
    j0 = grid.box[0]
    mass, mean, var = _layer_moments(grid.kept, grid.kept_x, grid.kept_y)
    layers = slice(j0, j0 + len(mass))
    assert np.allclose(mass, m0[layers], rtol=1e-9)  # no mass changes heading
    assert np.allclose(var, var0[layers], rtol=1e-9)  # no numerical diffusion
    exact = mean0[layers] + grid.displacement[:, layers, -1].T
    assert np.all(np.abs(mean - exact) <= grid.cell / 2 + 1e-9)
    assert np.allclose(mean + grid.residual.T, exact, rtol=0, atol=1e-6)
    assert np.abs(grid.displacement[:, layers, -1].T / grid.cell % 1 - 0.5).min() < 0.45  # not whole cells by luck


def test_the_ground_on_the_lattice_is_the_map_s_bilinear_height():
    rng = np.random.default_rng(5)
    x, y = np.sort(rng.uniform(-500.0, 40500.0, 60)), np.sort(rng.uniform(-500.0, 40500.0, 50))
    xs = np.arange(40) * 1000.0
    terrain = TerrainMap(300.0 + 80.0 * np.sin(xs[None, :] / 9000.0) * np.cos(xs[:, None] / 7000.0), dx=1000.0, dy=1000.0)
    expected = terrain.height(*np.meshgrid(x, y))
    got = ground_on_lattice(terrain, x, y)
    assert np.array_equal(np.isnan(got), np.isnan(expected)) and np.isnan(got).any()
    assert np.allclose(got, expected, rtol=0, atol=1e-9, equal_nan=True)


def test_the_spread_of_the_prior_is_the_model_s():
    # Heading noise, no readings: the grid's position mean and covariance after K steps against a Monte
    # Carlo of the filter's model (heading random walk, no horizontal noise).  Each step's whole-cell
    # rounding is within a cell, so the grid's variance may differ by up to K cell^2 / 4 per axis, plus the
    # Monte Carlo's sampling error (4 standard errors).
    sc = STRAIGHT.with_(duration=20.0, Qf=np.diag([0.0, 0.0, 0.6, 0.04]) ** 2)
    grid = PointMassFilter(WIDE, sc, cell=25.0, heading_step=np.radians(1.0), tail=1e-12)
    K = sc.n_steps
    res = grid.run(np.full(K, np.nan))
    rng = np.random.default_rng(11)
    n = 400_000
    x = sc.x0[[0, 1, 3]] + rng.standard_normal((n, 3)) * np.sqrt(np.diag(sc.P0)[[0, 1, 3]])
    for _ in range(K - 1):
        x[:, 0] += sc.speed * sc.dt * np.cos(x[:, 2])
        x[:, 1] += sc.speed * sc.dt * np.sin(x[:, 2])
        x[:, 2] += sc.omega * sc.dt + np.sqrt(sc.Qf[3, 3] * sc.dt) * rng.standard_normal(n)
    mc_mean, mc_var = x[:, :2].mean(axis=0), x[:, :2].var(axis=0)
    assert np.all(np.abs(res.mean[-1, :2] - mc_mean) <= grid.cell / 2 + 4 * np.sqrt(mc_var / n))
    assert np.all(np.abs(res.sd[-1] ** 2 - mc_var) <= K * grid.cell**2 / 4 + 4 * mc_var * np.sqrt(2 / n))
    assert mc_var.sum() > 1.3 * np.trace(sc.P0[:2, :2])  # the heading noise spread it: the test can fail


def test_the_grid_and_a_large_marginalised_particle_filter_agree_on_a_short_flight():
    # Over the book's map, 15 readings: the grid (50 m, 1 degree) and the marginalised filter with 2 x 10^5
    # particles approximate the same posterior; their final means must agree within half a cell on each
    # axis (the grid's mass is within a cell of where it belongs; the particles' Monte Carlo error is a
    # few metres), while the readings moved the mean far more than that from the dead-reckoned prior's.
    from pfcourse.scenarios.terrain.map import load_jacksboro
    from pfcourse.scenarios.terrain.scenario import simulate

    terrain = load_jacksboro()
    sc = AircraftScenario(duration=15.0, P0=np.diag([300.0, 300.0, 100.0, 0.05]) ** 2)
    flight = simulate(sc, terrain, np.random.default_rng(7))
    grid = PointMassFilter(terrain, sc, cell=50.0, heading_step=np.radians(1.0))
    res = grid.run(flight.measurements)
    pf = marginalised_filter(terrain, sc, 200_000, threshold=0.5).run(flight.measurements, rng=1)
    assert np.all(np.abs(res.mean[-1, :2] - pf.mean[-1, :2]) <= grid.cell / 2)
    prior = grid.run(np.full(sc.n_steps, np.nan)).mean[-1, :2]
    assert np.hypot(*(res.mean[-1, :2] - prior)) > 2 * grid.cell


def test_the_grid_posterior_mean_matches_a_brute_force_posterior():
    # One step, one reading, over a smooth synthetic map: the exact posterior of the position at t = 1,
    # altitude integrated out in closed form, summed over a fine grid of the prior (x0, y0, psi0).
    xs = np.arange(80) * 100.0
    X, Y = np.meshgrid(xs, xs)
    terrain = TerrainMap(300.0 + 80.0 * np.sin(X / 900.0) * np.cos(Y / 700.0), dx=100.0, dy=100.0)
    sc = AircraftScenario(duration=1.0, x0=np.array([4000.0, 4000.0, 1500.0, 0.5]),
                          P0=np.diag([400.0, 400.0, 50.0, 0.05]) ** 2,
                          Qf=np.diag([1e-3, 1e-3, 0.6, 1e-4]) ** 2)
    reading = 1500.0 - 300.0 - 50.0
    g = np.linspace(-4.5, 4.5, 181)
    x0, y0, psi0 = np.meshgrid(4000.0 + 400.0 * g, 4000.0 + 400.0 * g, 0.5 + 0.05 * np.linspace(-4.5, 4.5, 41),
                               indexing="ij")
    prior = np.exp(-0.5 * (((x0 - 4000.0) / 400.0) ** 2 + ((y0 - 4000.0) / 400.0) ** 2 + ((psi0 - 0.5) / 0.05) ** 2))
    x1, y1 = x0 + 100.0 * np.cos(psi0), y0 + 100.0 * np.sin(psi0)
    s = 50.0**2 + sc.Qf[2, 2] + sc.Rf
    post = prior * norm.pdf(reading, 1500.0 - terrain.height(x1, y1), np.sqrt(s))
    exact = np.array([np.sum(post * x1), np.sum(post * y1)]) / post.sum()
    res = PointMassFilter(terrain, sc, cell=25.0, heading_step=0.01).run(np.array([np.nan, reading]))
    # each heading layer moves by whole cells (each within half a cell): the mean within a tenth of a cell
    assert np.allclose(res.mean[1, :2], exact, atol=2.5)
    moved_prior = np.array([np.sum(prior * x1), np.sum(prior * y1)]) / prior.sum()
    assert np.linalg.norm(exact - moved_prior) > 20.0  # the reading moved the mean: the test can fail
