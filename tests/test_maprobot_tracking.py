"""The map robot's tracking chapter: the lock-on rule and its derivation, AMCL's sum-of-cubes weighting,
the beam model's log-likelihood, KLD-sampling's delta from amcl's kld_z, and the chapter's data helper."""

import numpy as np
import pytest
from scipy import stats

from pfcourse.scenarios.maprobot import drive as scenario
from pfcourse.scenarios.maprobot import OdometryModel, lock_on
from pfcourse.scenarios.maprobot.amcl import CubesLikelihoodField, beam_log_likelihood
from pfcourse.metrics import locked_on as metrics_locked_on


def test_the_heading_tolerance_is_three_straight_steps_of_the_odometrys_heading_noise():
    # the constants are the map robot's: its odometry alphas and 0.5 m/s for one scan interval
    assert lock_on.ALPHAS == scenario.MOTION.alphas
    assert lock_on.STEP_M == pytest.approx(0.5 * scenario.DT)
    n = 200_000
    moved = OdometryModel(lock_on.ALPHAS).sample(np.zeros((n, 3)), np.array([0.0, lock_on.STEP_M, 0.0]),
                                                 np.random.default_rng(3))
    sd = moved[:, 2].std()
    # the sample sd of n normals is within 4 standard errors (sd / sqrt(2n)) of the derived one
    assert abs(sd - lock_on.step_heading_sd()) < 4 * lock_on.step_heading_sd() / np.sqrt(2 * n)
    assert lock_on.HEADING_TOLERANCE == pytest.approx(3 * np.sqrt(2 * 0.05) * 0.25)


def test_locked_on_holds_at_most_of_the_last_window_not_every_step():
    dt, window = 0.5, 40  # 20 s of 0.5 s steps
    pos, head = np.full(100, 0.1), np.full(100, 0.01)
    assert lock_on.locked_on(pos, head, dt)
    bad = head.copy()
    bad[-window:][:8] = lock_on.HEADING_TOLERANCE * 1.01  # 8 of 40 steps off: 80 % within
    assert lock_on.locked_on(pos, bad, dt)
    bad[-window:][:9] = lock_on.HEADING_TOLERANCE * 1.01  # 9 of 40 off
    assert not lock_on.locked_on(pos, bad, dt)
    far = pos.copy()
    far[-window:][:9] = 1.0  # the position tolerance is strict: 1 m is not within 1 m
    assert not lock_on.locked_on(far, head, dt)
    early = head.copy()
    early[:-window] = np.pi  # lost before the window: does not count
    assert lock_on.locked_on(pos, early, dt)
    # the old rule (every step, 5 degrees) is the metrics default, unchanged
    assert not metrics_locked_on(pos, bad, dt)


def test_amcls_weight_is_one_plus_the_sum_of_cubed_unnormalised_beam_probabilities():
    grid = scenario.book_map()
    cubes = CubesLikelihoodField(grid, scenario.SCANNER.angles, scenario.SCANNER.max_range, sigma=scenario.FIELD_SIGMA)
    run = scenario.simulate(1, 5)
    z = run.scans[3].copy()
    z[0] = scenario.SCANNER.max_range  # a beam without an echo is left out
    poses = run.truth[3] + np.random.default_rng(0).normal(0, 0.3, (50, 3))
    got = cubes.log_likelihood(poses, z)
    use = z < scenario.SCANNER.max_range
    for i in (0, 17, 49):
        heading = poses[i, 2] + scenario.SCANNER.angles[use]
        ends = np.column_stack([poses[i, 0] + z[use] * np.cos(heading), poses[i, 1] + z[use] * np.sin(heading)])
        d = grid.distance_at(ends)
        p = 0.9 * np.exp(-d**2 / (2 * 0.2**2)) + 0.1 / 8.0
        assert got[i] == pytest.approx(np.log(1 + np.sum(p**3)), rel=1e-12)
    # every p_b lies in [z_rand / z_max, z_hit + z_rand / z_max]: the weight ratio is bounded by the beams' number
    top = np.log(1 + use.sum() * (0.9 + 0.1 / 8) ** 3)
    assert np.all(got <= top + 1e-12) and np.all(got >= 0)
    assert got.max() - got.min() < np.log(1 + use.sum())


def test_the_beam_model_scores_a_reading_by_its_four_parts_and_refuses_walls():
    grid, scanner = scenario.book_map(), scenario.SCANNER
    run = scenario.simulate(2, 5)
    truth, z = run.truth[4], run.scans[4]
    z_star = scanner.true_ranges(grid, truth)
    lam, s = scanner.lambda_short, scanner.sigma_hit
    hit = stats.norm.pdf(z, z_star, s)
    short = np.where(z < z_star, lam * np.exp(-lam * z) / (1 - np.exp(-lam * z_star)), 0.0)
    p = scanner.z_hit * hit + scanner.z_short * short + scanner.z_max * (z >= scanner.max_range) + scanner.z_rand / 8
    assert beam_log_likelihood(grid, scanner, truth[None], z)[0] == pytest.approx(np.log(p).sum(), rel=1e-10)
    off = truth + np.array([0.3, 0.0, 0.0])
    wall = np.array([0.05, 0.05, 0.0])  # the map's border is a wall
    ll = beam_log_likelihood(grid, scanner, np.vstack([truth, off, wall]), z)
    assert ll[0] > ll[1] and ll[2] == -np.inf


def test_kld_delta_is_the_tail_beyond_amcls_kld_z_quantile():
    # amcl's pf_resample_limit puts kld_z where the bound has z_{1-delta}: delta = 1 - Phi(0.99)
    assert scenario.AMCL_KLD["delta"] == pytest.approx(1 - stats.norm.cdf(0.99))
    assert 0.16 < scenario.AMCL_KLD["delta"] < 0.162


def test_the_chapters_drive_is_the_studies_drive_as_plain_arrays():
    drive, run = scenario.book_drive(0, 20), scenario.simulate(0, 20)
    assert np.array_equal(drive.scans, run.scans) and np.array_equal(drive.truth, run.truth)
    assert np.array_equal(drive.odometry, run.drive.odometry)
    grid = scenario.book_map()
    assert np.array_equal(drive.distance, grid.distance) and drive.resolution == grid.resolution
    assert np.array_equal(drive.angles, scenario.SCANNER.angles) and drive.alphas == scenario.MOTION.alphas
