"""The marginalised particle filter (altitude Kalman in each particle) and the point-mass filter of
the terrain scenario: each against an exact answer."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage
from scipy.stats import norm

from pfcourse.errors import ParameterError
from pfcourse.terrain.map import TerrainMap
from pfcourse.terrain.marginalised import MarginalisedTerrainModel, altitude_kalman_update, marginalised_filter
from pfcourse.terrain.point_mass import PointMassFilter, bilinear_shift
from pfcourse.terrain.scenario import AircraftScenario


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
    res = marginalised_filter(FLAT, SHORT, 50, threshold=0.5).run(readings[:, None], rng=4, store_particles=True)
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


@pytest.mark.parametrize("shift", [(0.3, -1.7), (2.5, 0.0), (-0.2, 0.9)])
def test_bilinear_shift_is_scipys_order_one_shift(shift):
    a = np.random.default_rng(1).random((3, 20, 30))
    expected = ndimage.shift(a, (0, *shift), order=1, mode="grid-constant", cval=0.0, prefilter=False)
    assert np.allclose(bilinear_shift(a, *shift), expected, rtol=0, atol=1e-13)


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
    # the moved prior is shifted by bilinear interpolation: within a tenth of a cell of the exact mean
    assert np.allclose(res.mean[1, :2], exact, atol=2.5)
    moved_prior = np.array([np.sum(prior * x1), np.sum(prior * y1)]) / prior.sum()
    assert np.linalg.norm(exact - moved_prior) > 20.0  # the reading moved the mean: the test can fail
