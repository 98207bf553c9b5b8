"""The terrain map (orientation, units, bilinear heights, off-map handling) and scenario B."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse.scenarios.terrain.scenario import (
    AircraftScenario,
    dynamics_jacobian,
    extended_kalman_filter,
    measurement_jacobian,
    predicted_measurement,
    propagate,
    simulate,
)
from pfcourse.errors import DegenerateWeightsError, OffMapError, ShapeError
from pfcourse.filter import ParticleFilter
from pfcourse.metrics import position_error
from pfcourse.scenarios.terrain.map import EARTH_RADIUS, TerrainMap, load_jacksboro, metres_per_degree


@pytest.fixture(scope="module")
def jacksboro() -> TerrainMap:
    return load_jacksboro()


@pytest.fixture()
def tiny() -> TerrainMap:
    # 3 rows (south to north) x 4 columns, spacing 10 m east, 20 m north.
    h = np.array([[0.0, 10.0, 20.0, 30.0], [5.0, 15.0, 40.0, 0.0], [7.0, 1.0, 2.0, 3.0]])
    return TerrainMap(h, dx=10.0, dy=20.0)


# --- interpolation -----------------------------------------------------------------------


def test_exact_at_grid_nodes(tiny):
    ii, jj = np.meshgrid(range(3), range(4), indexing="ij")
    heights = tiny.height(jj * tiny.dx, ii * tiny.dy)
    np.testing.assert_array_equal(heights, tiny.heights)


def test_bilinear_between_nodes(tiny):
    # Cell (row 0, col 1): corners h00=10, h10=20, h01=15, h11=40 at s=0.25, t=0.5.
    s, t = 0.25, 0.5
    expected = (1 - s) * (1 - t) * 10 + s * (1 - t) * 20 + (1 - s) * t * 15 + s * t * 40
    assert tiny.height(10.0 + s * 10.0, t * 20.0) == pytest.approx(expected, abs=1e-12)
    # Along an edge the interpolant is linear.
    xs = np.linspace(0.0, 10.0, 11)
    np.testing.assert_allclose(tiny.height(xs, 0.0), xs, atol=1e-12)


def test_real_map_nodes_match_the_file(jacksboro):
    from matplotlib import cbook

    with cbook.get_sample_data("jacksboro_fault_dem.npz") as dem:
        raw = dem["elevation"]
    rng = np.random.default_rng(0)
    rows = rng.integers(0, raw.shape[0], 50)
    cols = rng.integers(0, raw.shape[1], 50)
    # File row 0 is the north edge, our row 0 the south edge.  Metres -> grid index
    # round-trips to within a few ulps, hence the 1e-12 relative tolerance.
    y = (raw.shape[0] - 1 - rows) * jacksboro.dy
    np.testing.assert_allclose(jacksboro.height(cols * jacksboro.dx, y), raw[rows, cols], rtol=1e-12)


# --- orientation and units ---------------------------------------------------------------


def test_highest_cell_is_cross_mountain(jacksboro):
    """The 1076 m maximum lies at the published summit of Cross Mountain (1077 m,
    36.19833 N, 84.23056 W): this fixes both the row orientation and the corner."""
    i, j = np.unravel_index(np.argmax(jacksboro.heights), jacksboro.shape)
    lon, lat = jacksboro.to_lonlat(j * jacksboro.dx, i * jacksboro.dy)
    east = (lon - (-84.23056)) * jacksboro.deg_lon
    north = (lat - 36.19833) * jacksboro.deg_lat
    assert np.hypot(east, north) < 0.5 * np.hypot(jacksboro.dx, jacksboro.dy)
    # Read with row 0 to the south it would be 251 rows (23 km) away.
    assert jacksboro.heights[i, j] == 1076


def test_units_consistent_with_degree_spacing(jacksboro):
    lat_centre = jacksboro.south + 0.5 * jacksboro.height_extent / jacksboro.deg_lat
    per_degree = EARTH_RADIUS * np.pi / 180.0
    assert jacksboro.dy == pytest.approx(per_degree / 1200.0, rel=1e-12)
    assert jacksboro.dx == pytest.approx(per_degree * np.cos(np.radians(lat_centre)) / 1200.0, rel=1e-12)
    # 403 x 344 cells of 3 arc-seconds at about 36.3 N: 30.1 km by 31.9 km of cells.
    left, right, bottom, top = jacksboro.extent
    assert right - left == pytest.approx(403 * jacksboro.dx)
    assert (right - left) / 1000 == pytest.approx(30.1, abs=0.05)
    assert (top - bottom) / 1000 == pytest.approx(31.9, abs=0.05)
    lon_m, lat_m = metres_per_degree(60.0)
    assert lon_m == pytest.approx(0.5 * lat_m)


# --- off the map -------------------------------------------------------------------------


def test_off_map_queries_give_nan_not_index_errors(tiny):
    x = np.array([-1e-9, 0.0, 30.0, 30.0 + 1e-9, 1e9, 5.0])
    y = np.array([5.0, 0.0, 40.0, 5.0, 5.0, -1e9])
    h = tiny.height(x, y)
    np.testing.assert_array_equal(np.isnan(h), [True, False, False, True, True, True])
    np.testing.assert_array_equal(tiny.contains(x, y), ~np.isnan(h))
    gx, gy = tiny.gradient(x, y)
    assert np.all(np.isnan(gx[np.isnan(h)])) and np.all(np.isfinite(gx[~np.isnan(h)]))
    with pytest.raises(OffMapError, match="4 point"):
        tiny.height_checked(x, y)


def test_bad_grid_is_a_named_error():
    with pytest.raises(ShapeError):
        TerrainMap(np.zeros(5), dx=1.0, dy=1.0)
    with pytest.raises(ShapeError):
        TerrainMap(np.zeros((3, 3)), dx=0.0, dy=1.0)


def test_off_map_particles_get_minus_infinite_log_likelihood(jacksboro):
    model = AircraftScenario().model(jacksboro)
    particles = np.array([[1000.0, 1000.0, 1500.0, 0.0], [-5.0, 1000.0, 1500.0, 0.0], [1e6, 0.0, 1500.0, 0.0]])
    loglik = model.log_likelihood(particles, np.array([800.0]), 1)
    assert np.isfinite(loglik[0])
    assert np.all(loglik[1:] == -np.inf)


def test_filter_raises_only_when_every_particle_leaves(jacksboro):
    scenario = AircraftScenario()
    flight = simulate(scenario, jacksboro, 3)
    # Half the prior off the map: the filter copes.
    half_off = scenario.with_(x0=np.array([0.0, 15000.0, 1500.0, 0.0]), P0=np.diag([300.0, 300.0, 10.0, 0.01]) ** 2)
    result = ParticleFilter(half_off.model(jacksboro), 200).run(flight.measurements[:5], rng=1)
    assert np.all(np.isfinite(result.mean))
    # The whole prior off the map: a named error at the first measurement.
    all_off = half_off.with_(x0=np.array([-5000.0, 15000.0, 1500.0, 0.0]))
    with pytest.raises(DegenerateWeightsError) as info:
        ParticleFilter(all_off.model(jacksboro), 200).run(flight.measurements[:5], rng=1)
    assert info.value.step == 1


# --- simulator ---------------------------------------------------------------------------


def test_flight_geometry_and_schedule(jacksboro):
    scenario = AircraftScenario().with_(gap=(50.0, 75.0))
    flight = simulate(scenario, jacksboro, 0)
    steps = np.diff(flight.truth[:, :2], axis=0)
    np.testing.assert_allclose(np.hypot(*steps.T), scenario.speed * scenario.dt)
    measured = ~np.isnan(flight.measurements[:, 0])
    assert not measured[0] and measured[1] and measured[49] and not measured[50]
    assert not measured[75] and measured[76] and measured.sum() == 80 - 26
    every10 = AircraftScenario().with_(measurement_period=10.0).measured()
    np.testing.assert_array_equal(np.flatnonzero(every10), np.arange(10, 81, 10))
    fast = AircraftScenario().with_(dt=0.1, measurement_period=0.1)
    assert fast.n_steps == 801 and fast.measured().sum() == 800


def test_measurement_noise_statistics(jacksboro):
    """Residuals y - (z - h) of 40 flights (3200 readings) are N(0, R): mean, variance, shape."""
    scenario = AircraftScenario().with_(R=15.0**2)
    residuals = []
    for seed in range(40):
        flight = simulate(scenario, jacksboro, seed)
        ok = ~np.isnan(flight.measurements[:, 0])
        residuals.append(flight.measurements[ok, 0] - (flight.truth[ok, 2] - flight.terrain_height[ok]))
    r = np.concatenate(residuals)
    n = r.size
    # 4-sigma bounds of the sample mean and variance of n Gaussian draws.
    assert abs(r.mean()) < 4 * 15.0 / np.sqrt(n)
    assert abs(r.var() / 15.0**2 - 1) < 4 * np.sqrt(2 / n)
    assert stats.kstest(r / 15.0, "norm").pvalue > 1e-3


def test_flight_must_stay_on_the_map(jacksboro):
    scenario = AircraftScenario().with_(speed=1000.0)
    with pytest.raises(OffMapError):
        simulate(scenario, jacksboro, 0, initial_state=[15000.0, 15000.0, 1500.0, 0.0])


# --- EKF -------------------------------------------------------------------------------


def test_measurement_jacobian_against_finite_differences(jacksboro):
    rng = np.random.default_rng(5)
    eps = 1e-3
    for _ in range(20):
        # Stay inside one cell: finite differences of a piecewise-bilinear map are exact
        # to round-off there (the interpolant is linear in x at fixed y).
        j, i = rng.integers(1, 300), rng.integers(1, 300)
        s, t = rng.uniform(0.1, 0.9, 2)
        state = np.array([(j + s) * jacksboro.dx, (i + t) * jacksboro.dy, 1500.0, 0.3])
        H = measurement_jacobian(state, jacksboro)
        numeric = np.empty(4)
        for c in range(4):
            step = np.zeros(4)
            step[c] = eps
            numeric[c] = (predicted_measurement(state + step, jacksboro) - predicted_measurement(state - step, jacksboro)) / (2 * eps)
        np.testing.assert_allclose(H[0], numeric, atol=1e-7)


def test_dynamics_jacobian_against_finite_differences():
    state = np.array([100.0, 200.0, 1500.0, 2.0])
    F = dynamics_jacobian(state, 100.0, 1.0)
    eps = 1e-6
    numeric = np.column_stack([
        (propagate(state + e, 100.0, -0.01, 1.0) - propagate(state - e, 100.0, -0.01, 1.0)) / (2 * eps)
        for e in np.eye(4) * eps
    ])
    np.testing.assert_allclose(F, numeric, atol=1e-5)


def test_ekf_converges_from_a_small_prior(jacksboro):
    """Started on the truth with a prior and process noise small against the terrain's
    correlation length, the linearisation holds and the EKF stays within about a cell."""
    scenario = AircraftScenario().with_(
        P0=np.diag([30.0, 30.0, 5.0, 0.01]) ** 2, Qf=np.diag([1.0, 1.0, 0.1, 0.001]) ** 2
    )
    for seed in range(3):
        flight = simulate(scenario, jacksboro, seed, initial_state=scenario.x0)
        result = extended_kalman_filter(scenario, jacksboro, flight.measurements)
        assert result.lost_at is None
        assert result.mean.shape == (81, 4) and result.cov.shape == (81, 4, 4)
        err = position_error(flight.truth, result.mean)
        assert np.max(err) < np.hypot(jacksboro.dx, jacksboro.dy)


# --- Monte Carlo helper ------------------------------------------------------------------


def test_monte_carlo_is_seeded_and_first_n_runs_are_a_smaller_study(jacksboro):
    from pfcourse.studies.record import scores
    from pfcourse.studies.terrain import flight_study

    scenario = AircraftScenario().with_(duration=10.0)
    a = flight_study(scenario, jacksboro, 6, method="ekf", seed=3)
    b = flight_study(scenario, jacksboro, 4, method="ekf", seed=3)
    np.testing.assert_array_equal(scores(a[:4], "errors"), scores(b, "errors"))
    pf = flight_study(scenario, jacksboro, 3, n_particles=200, seed=3)
    pf_again = flight_study(scenario, jacksboro, 3, n_particles=200, seed=3)
    np.testing.assert_array_equal(scores(pf, "errors"), scores(pf_again, "errors"))
    assert scores(pf, "errors").shape == (3, 11) and np.all(scores(pf, "n_resamples") >= 0)


def test_flight_study_does_not_depend_on_the_executor_or_the_batch_size(jacksboro):
    from concurrent.futures import ThreadPoolExecutor

    from pfcourse.studies.executor import SerialExecutor
    from pfcourse.studies.record import scores
    from pfcourse.studies.terrain import flight_study

    scenario = AircraftScenario().with_(duration=10.0)
    for method, n in (("pf", 20), ("ekf", None)):
        kwargs = {"method": method, "seed": 3} | ({"n_particles": n} if n else {})
        serial = flight_study(scenario, jacksboro, 5, executor=SerialExecutor(), batch_size=5, **kwargs)
        with ThreadPoolExecutor(2) as threads:
            others = [flight_study(scenario, jacksboro, 5, batch_size=2, **kwargs),  # the default pool
                      flight_study(scenario, jacksboro, 5, executor=threads, batch_size=1, **kwargs)]
        for other in others:
            assert [r.status for r in serial] == [r.status for r in other], method
            for field in ("errors", "sigma", "n_resamples"):
                a, b = scores(serial, field), scores(other, field)
                assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True), (method, field)


def test_summary_counts_lost_runs_as_infinite_without_nan():
    from pfcourse.studies.record import RunRecord
    from pfcourse.studies.terrain import flight_summary

    errors = np.array([[100.0, 10.0], [100.0, 20.0], [100.0, 30.0], [100.0, np.nan]])
    res = [RunRecord({"errors": e}, "ok" if k < 3 else "lost") for k, e in enumerate(errors)]
    s = flight_summary(res)
    assert s["final_median"] == 20.0 and s["final_q90"] == np.inf
    assert s["diverged"] == 0.25 and not any(np.isnan(v) for v in s.values())


def test_a_mismatched_map_has_the_stated_error_and_no_more():
    """mismatched_map: the error field's standard deviation is the stated one exactly; with no
    smoothing and no error the map is the truth; a negative size is refused by name."""
    from pfcourse.errors import ParameterError
    from pfcourse.seeding import map_error_rng
    from pfcourse.scenarios.terrain.map import TerrainMap, mismatched_map

    rng = np.random.default_rng(3)
    world = TerrainMap(rng.normal(500.0, 80.0, (40, 50)), 90.0, 75.0)
    same = mismatched_map(world, map_error_rng(0, 1), smoothing=0.0, error_sd=0.0)
    np.testing.assert_array_equal(same.heights, world.heights)
    noisy = mismatched_map(world, map_error_rng(0, 1), smoothing=0.0, error_sd=10.0)
    assert abs(np.std(noisy.heights - world.heights) - 10.0) < 1e-9
    again = mismatched_map(world, map_error_rng(0, 1), smoothing=0.0, error_sd=10.0)
    np.testing.assert_array_equal(noisy.heights, again.heights)  # seeded: one map per flight
    smooth = mismatched_map(world, map_error_rng(0, 1), smoothing=1.0, error_sd=0.0)
    assert np.std(smooth.heights) < np.std(world.heights)  # smoothing removes the cell-to-cell relief
    with pytest.raises(ParameterError, match="error_sd"):
        mismatched_map(world, map_error_rng(0, 1), error_sd=-1.0)


def test_a_flight_whose_filter_dies_is_recorded_failed_and_counts_as_diverged(jacksboro, monkeypatch):
    from pfcourse.errors import DegenerateWeightsError
    from pfcourse.studies.executor import SerialExecutor
    from pfcourse.studies.terrain import diverged, final_errors, flight_study
    from pfcourse.filter import ParticleFilter

    def dies(self, *args, **kwargs):
        raise DegenerateWeightsError("every particle is off the map", step=2)

    monkeypatch.setattr(ParticleFilter, "run", dies)
    flights = flight_study(AircraftScenario().with_(duration=10.0), jacksboro, 2, n_particles=50,
                           executor=SerialExecutor())
    assert [f.status for f in flights] == ["failed", "failed"] and flights[0].error.startswith("DegenerateWeightsError")
    assert np.all(np.isnan(flights[0].errors)) and flights[0].n_resamples == 0
    assert np.all(final_errors(flights) == np.inf) and diverged(flights).all()
