"""The map robot's package code: the odometry sampler against its model, ray casting against hand-computed
distances, the likelihood field at a wall and far from it, the book's map, the engine on it."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.errors import MeasurementError, OffMapError, ParameterError, ShapeError
from pfcourse.filter import ParticleFilter
from pfcourse.scenarios.maprobot import (LikelihoodField, MapRobotModel, OccupancyGrid, OdometryModel, Scanner, cast_rays,
                               odometry_increments, rooms_and_corridor, simulate_drive)
from pfcourse.scenarios.maprobot.grid import ROUTE


def box_grid(n: int = 10, resolution: float = 0.1) -> OccupancyGrid:
    """An ``n x n`` grid whose border cells are walls: free space ``[r, (n - 1) r]^2``."""
    occ = np.zeros((n, n), dtype=bool)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = True
    return OccupancyGrid(occ, resolution)


def test_sampler_moments_match_the_model():
    """The increments recovered from sampled poses have mean u and covariance diag(std(u)^2)
    (table 5.6): means within 5 standard errors, variances within 5 relative standard errors sqrt(2/n)."""
    motion = OdometryModel((0.01, 0.02, 0.01, 0.02))
    u = np.array([0.4, 0.5, -0.2])
    n = 200_000
    start = np.array([1.0, 2.0, 0.3])
    new = motion.sample(np.tile(start, (n, 1)), u, np.random.default_rng(5))
    inc = odometry_increments(np.tile(start, (n, 1)), new)
    std = motion.std(u)
    np.testing.assert_array_less(np.abs(inc.mean(axis=0) - u), 5 * std / np.sqrt(n))
    cov = np.cov(inc.T)
    np.testing.assert_array_less(np.abs(np.diag(cov) / std**2 - 1), 5 * np.sqrt(2 / n))
    corr = cov / np.outer(std, std)
    off = corr[~np.eye(3, dtype=bool)]
    np.testing.assert_array_less(np.abs(off), 5 / np.sqrt(n))


def test_sampler_without_noise_is_the_geometry():
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, np.pi / 2]])
    new = OdometryModel((0, 0, 0, 0)).sample(poses, np.array([np.pi / 2, 1.0, -np.pi / 2]), np.random.default_rng(0))
    np.testing.assert_allclose(new, [[0.0, 1.0, 0.0], [0.0, 1.0, np.pi / 2]], atol=1e-12)
    np.testing.assert_allclose(odometry_increments(poses[0], new[0]), [np.pi / 2, 1.0, -np.pi / 2], atol=1e-12)
    np.testing.assert_allclose(odometry_increments(poses[0], [0.0, 0.0, 0.5]), [0.0, 0.0, 0.5])  # turn on the spot


def test_ray_casting_hand_computed():
    """From (0.55, 0.55) in a 1 m box with 0.1 m walls: the walls' faces are 0.35 m east and north,
    0.45 m west and south, 0.35 sqrt(2) m along the diagonal; error at most step / 2."""
    grid = box_grid()
    angles = np.array([0.0, np.pi / 2, np.pi, -np.pi / 2, np.pi / 4])
    z = cast_rays(grid, np.array([[0.55, 0.55, 0.0]]), angles, 5.0)[0]
    step = grid.resolution / 4
    np.testing.assert_allclose(z, [0.35, 0.35, 0.45, 0.45, 0.35 * np.sqrt(2)], atol=step / 2 + 1e-12)
    # turned by 90 degrees: the beams turn with the robot
    z90 = cast_rays(grid, np.array([[0.55, 0.55, np.pi / 2]]), angles[:4], 5.0)[0]
    np.testing.assert_allclose(z90, [0.35, 0.45, 0.45, 0.35], atol=step / 2 + 1e-12)
    # nothing within range: the maximum range
    assert cast_rays(grid, np.array([[0.55, 0.55, 0.0]]), np.array([0.0]), 0.2)[0, 0] == 0.2


def test_likelihood_field_at_a_wall_and_far_away():
    grid = box_grid(60)  # 6 m box
    assert grid.distance[30, 3] == pytest.approx(0.3)  # three cells from the west wall
    lf = LikelihoodField(grid, np.array([0.0]), max_range=8.0, z_hit=0.9, z_rand=0.1, sigma=0.2)
    at_wall = np.log(0.9 / (np.sqrt(2 * np.pi) * 0.2) + 0.1 / 8.0)
    # from (3.05, 3.05) heading east, a range of 2.9 m ends at x = 5.95, in the east wall's cell
    assert lf.log_likelihood(np.array([[3.05, 3.05, 0.0]]), np.array([2.9]))[0] == pytest.approx(at_wall)
    # a range of 1 m ends at (4.05, 3.05), 1.9 m (19 cells) from the nearest wall: the Gaussian term is ~e^-45
    far = lf.log_likelihood(np.array([[3.05, 3.05, 0.0]]), np.array([1.0]))[0]
    assert far == pytest.approx(np.log(0.1 / 8.0), abs=1e-12)
    # a beam at the maximum range is left out; a beam off the map scores the random term
    assert lf.log_likelihood(np.array([[3.05, 3.05, 0.0]]), np.array([8.0]))[0] == 0.0
    assert lf.log_likelihood(np.array([[3.05, 3.05, 0.0]]), np.array([7.0]))[0] == pytest.approx(np.log(0.1 / 8.0))


def test_scanner_noise_parts():
    grid = box_grid()
    rng = np.random.default_rng(1)
    z_star = np.full(20_000, 0.35)
    hits = Scanner(z_hit=1.0, z_short=0.0, z_max=0.0, z_rand=0.0, sigma_hit=0.02).sample(z_star, rng)
    assert abs(hits.mean() - 0.35) < 5 * 0.02 / np.sqrt(len(z_star))
    assert abs(hits.std() / 0.02 - 1) < 5 * np.sqrt(0.5 / len(z_star))
    short = Scanner(z_hit=0.0, z_short=1.0, z_max=0.0, z_rand=0.0).sample(z_star, rng)
    assert short.min() >= 0.0 and short.max() <= 0.35
    assert np.all(Scanner(z_hit=0.0, z_short=0.0, z_max=1.0, z_rand=0.0).sample(z_star, rng) == 8.0)
    rand = Scanner(z_hit=0.0, z_short=0.0, z_max=0.0, z_rand=1.0).sample(z_star, rng)
    assert abs(rand.mean() - 4.0) < 5 * 8.0 / np.sqrt(12 * len(z_star))
    assert len(Scanner(n_beams=24).true_ranges(grid, [0.55, 0.55, 0.0])) == 24


def test_book_map_and_drive():
    grid = rooms_and_corridor(0.1)
    assert grid.occupied.shape == (110, 200)
    assert grid.is_free(ROUTE).all()
    poses = grid.sample_free(1000, np.random.default_rng(0))
    assert grid.is_free(poses).all() and np.all(np.abs(poses[:, 2]) <= np.pi)
    drive = simulate_drive(ROUTE, 200, np.random.default_rng(0))
    assert grid.is_free(drive.truth).all()  # the robot stays off the walls
    speeds = drive.odometry[1:, 1] / 0.5
    assert speeds.max() == pytest.approx(0.5)


def test_engine_tracks_on_the_map():
    """The bootstrap MCL filter from the known start stays within half a metre on a seeded drive."""
    grid = rooms_and_corridor(0.1)
    rng = np.random.default_rng(3)
    drive = simulate_drive(ROUTE, 60, rng)
    scanner = Scanner()
    scans = np.array([scanner.sample(scanner.true_ranges(grid, x), rng) for x in drive.truth])
    model = MapRobotModel(grid, LikelihoodField(grid, scanner.angles), drive.odometry, start=drive.truth[0])
    res = ParticleFilter(model, 300, threshold=1.0).run(scans, rng=4)
    assert np.hypot(*(res.mean[:, :2] - drive.truth[:, :2]).T).max() < 0.5


@pytest.mark.parametrize("call, error, fragment", [
    (lambda: OccupancyGrid(np.zeros((5, 5)), 0.1), ShapeError, "boolean"),
    (lambda: OccupancyGrid(np.ones((5, 5), dtype=bool), 0.1), ParameterError, "no free cell"),
    (lambda: OccupancyGrid(np.zeros((5, 5), dtype=bool), 0.0), ParameterError, "resolution"),
    (lambda: rooms_and_corridor(2.0), ParameterError, "resolution"),
    (lambda: OdometryModel((0.1, -0.1, 0.1, 0.1)), ParameterError, "alpha_2"),
    (lambda: OdometryModel((0.1, 0.1)), ShapeError, "four numbers"),
    (lambda: OdometryModel().sample(np.zeros((3, 2)), np.zeros(3), np.random.default_rng(0)), ShapeError, "(N, 3)"),
    (lambda: Scanner(z_hit=0.5), ParameterError, "must be 1"),
    (lambda: Scanner(n_beams=0), ParameterError, "n_beams"),
    (lambda: cast_rays(box_grid(), np.array([[0.05, 0.05, 0.0]]), np.zeros(1), 1.0), OffMapError, "in a wall"),
    (lambda: LikelihoodField(box_grid(), np.array([0.0]), sigma=0.0), ParameterError, "sigma"),
    (lambda: LikelihoodField(box_grid(), np.array([0.0])).log_likelihood(np.zeros((2, 3)), np.ones(2)),
     MeasurementError, "1 ranges"),
    (lambda: MapRobotModel(box_grid(), LikelihoodField(box_grid(), np.zeros(1)), np.zeros((5, 2))), ShapeError, "odometry"),
    (lambda: MapRobotModel(box_grid(), LikelihoodField(box_grid(), np.zeros(1)), np.zeros((5, 3)), inject=2.0),
     ParameterError, "inject"),
    (lambda: simulate_drive(ROUTE, 10, np.random.default_rng(0), start=99), ParameterError, "start"),
])
def test_bad_inputs_named(call, error, fragment):
    with pytest.raises(error, match=None) as info:
        call()
    assert fragment in str(info.value)
