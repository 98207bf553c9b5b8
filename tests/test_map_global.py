"""The chapter *Finding the robot on the map*: the lock-on rule, the twins, and the cure's parts
(pfcourse.scenarios.maprobot.lock_on, .twins, .global_mcl)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from scipy.special import logsumexp

from pfcourse.errors import ParameterError, ShapeError
from pfcourse.studies import map_global as mg
from pfcourse.studies import maprobot as study
from pfcourse.scenarios.maprobot import global_mcl as gm
from pfcourse.scenarios.maprobot import lock_on
from pfcourse.scenarios.maprobot.grid import rooms_and_corridor
from pfcourse.scenarios.maprobot.motion import OdometryModel
from pfcourse.scenarios.maprobot.twins import TWINS, path_log_likelihoods, twin_margin, twin_poses


def test_the_heading_tolerance_is_three_sd_of_one_straight_step():
    motion = OdometryModel((0.05, 0.05, 0.05, 0.05))
    sd = lock_on.step_heading_sd(motion, 0.25)
    assert sd == pytest.approx(np.sqrt(2 * 0.05) * 0.25, rel=1e-12)  # 0.079 rad, 4.5 degrees
    assert np.degrees(sd) == pytest.approx(4.53, abs=0.01)
    # Monte Carlo: the heading change of the odometry sampler for one straight step has that sd
    moved = motion.sample(np.zeros((200000, 3)), np.array([0.0, 0.25, 0.0]), np.random.default_rng(0))
    assert np.std(moved[:, 2]) == pytest.approx(sd, rel=0.01)
    assert lock_on.heading_tolerance(motion, 0.25) == pytest.approx(3 * sd, rel=1e-12)
    assert mg.HEADING_TOL == pytest.approx(3 * sd, rel=1e-12)


def test_locked_on_asks_for_most_of_the_window_not_every_step():
    dt, tol = 0.5, 0.2
    pos, head = np.full(100, 0.1), np.full(100, 0.01)
    assert lock_on.locked_on(pos, head, dt, tol)
    head[-40:-32] = 0.5  # 8 of the last 40 steps out: 80 % in, locked
    assert lock_on.locked_on(pos, head, dt, tol)
    head[-31] = 0.5  # 9 out: 77.5 % in, not locked
    assert not lock_on.locked_on(pos, head, dt, tol)
    pos2 = np.full(100, 0.1)
    pos2[-1] = 1.0  # exactly 1 m is not within 1 m
    assert lock_on.locked_steps(pos2, np.zeros(100), tol)[:-1].all() and not lock_on.locked_steps(pos2, np.zeros(100), tol)[-1]


def test_locked_from_is_the_step_from_which_every_window_is_locked():
    dt, tol = 0.5, 0.2
    pos = np.r_[np.full(60, 5.0), np.full(140, 0.1)]
    head = np.zeros(200)
    assert lock_on.locked_from(pos, head, dt, tol) == 60
    pos[150] = 5.0  # one bad step later: every window still at 80 % or more, so it stays 60
    assert lock_on.locked_from(pos, head, dt, tol) == 60
    assert lock_on.locked_from(np.full(50, 5.0), np.zeros(50), dt, tol) == 50  # never


def test_lock_on_refuses_bad_input():
    with pytest.raises(ShapeError):
        lock_on.locked_on(np.zeros(5), np.zeros(4), 0.5, 0.1)
    with pytest.raises(ParameterError):
        lock_on.locked_on(np.zeros(5), np.zeros(5), 0.5, -0.1)


def test_amcl_delta_is_read_from_the_quantile():
    assert gm.AMCL_DELTA == pytest.approx(1 - stats.norm.cdf(0.99), rel=1e-12)
    assert 0.16 < gm.AMCL_DELTA < 0.162
    assert stats.norm.ppf(1 - gm.AMCL_DELTA) == pytest.approx(0.99, abs=1e-9)


def test_twins_are_rigid_moves_that_keep_the_odometry():
    rng = np.random.default_rng(1)
    poses = rng.uniform([1, 1, -np.pi], [19, 10, np.pi], (50, 3))
    assert len(TWINS) == 13 and (False, 0.0) not in TWINS
    back = twin_poses(twin_poses(poses, True, 0.0), True, 0.0)
    assert np.allclose(back[:, :2], poses[:, :2], atol=1e-12)
    assert np.allclose(np.angle(np.exp(1j * (back[:, 2] - poses[:, 2]))), 0, atol=1e-12)
    # relative motion between consecutive poses, in the robot's frame, is the same for the twin
    def rel(p):
        d = p[1:, :2] - p[:-1, :2]
        c, s = np.cos(p[:-1, 2]), np.sin(p[:-1, 2])
        return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])
    for turn, shift in TWINS:
        assert np.allclose(rel(twin_poses(poses, turn, shift)), rel(poses), atol=1e-9)


def test_a_twin_without_the_box_sees_the_same_scans_and_a_wall_ends_a_path():
    grid, field = study.book_map(), study.field()
    run = study.simulate(3, 40)
    ll = path_log_likelihoods(grid, field, run.truth, run.scans)
    assert np.all(np.isfinite(ll))
    # far off the map: impossible from the first step
    assert np.all(np.isneginf(path_log_likelihoods(grid, field, twin_poses(run.truth, False, 40.0), run.scans)))
    margin, best = twin_margin(grid, field, run.truth, run.scans)
    assert margin.shape == best.shape == (40,)
    assert np.all(margin <= best + 1e-12)  # against all twins together is at most against the best one
    # on the map without its box (symmetric under the half-turn), the half-turn twin scores as the path itself
    from pfcourse.scenarios.maprobot.likelihood_field import LikelihoodField
    occ = grid.occupied
    sym = type(grid)(occ & occ[::-1, ::-1], grid.resolution)
    assert np.array_equal(sym.occupied, sym.occupied[::-1, ::-1]) and not np.array_equal(occ, occ[::-1, ::-1])
    sym_field = LikelihoodField(sym, field.angles, field.max_range, sigma=field.sigma)
    own = path_log_likelihoods(sym, sym_field, run.truth, run.scans)
    turned = path_log_likelihoods(sym, sym_field, twin_poses(run.truth, True, 0.0), run.scans)
    assert np.median(np.abs(own - turned)) < 1e-9  # equal but where an end point falls on a cell's edge


def test_the_proposal_density_is_the_mixture_it_draws_from():
    """log q of the drawn poses against a direct sum over the kept candidates' kernels."""
    grid, field = study.book_map(), study.field()
    run = study.simulate(0, 20)
    s = gm.with_settings(candidates=100, keep=20, refine_rounds=1)
    x, log_q = gm.scan_proposal(grid, field, run.scans[10], 400, np.random.default_rng(2), s)
    assert x.shape == (400, 3) and log_q.shape == (400,)
    h = np.array([s.kernel[0], s.kernel[0], s.kernel[1]])
    # a mixture density is at most its largest kernel's peak
    assert np.all(log_q <= -1.5 * np.log(2 * np.pi) - np.log(h).sum() + 1e-9)
    # kernel_log_density against scipy for one centre and equal weights
    c = np.array([[5.0, 5.0, 3.1]])
    pts = np.array([[5.1, 4.9, -3.1], [5.0, 5.0, 3.1]])
    want = stats.multivariate_normal(np.zeros(3), np.diag(h**2)).logpdf(
        np.column_stack([pts[:, :2] - c[0, :2], np.angle(np.exp(1j * (pts[:, 2] - c[0, 2])))]))
    assert np.allclose(gm.kernel_log_density(pts, c, np.zeros(1), h), want, atol=1e-12)
    # importance weights u / q integrate the uniform density to one (E_q[u / q] = 1): heavy-tailed, so loose
    x, log_q = gm.scan_proposal(grid, field, run.scans[10], 20000, np.random.default_rng(3),
                                gm.with_settings(kernel=(1.0, 1.0)))
    ratio = np.exp(gm.uniform_log_density(grid, x) - log_q)
    assert 0.7 < ratio.mean() < 1.3


def test_the_cure_draws_from_its_generator_and_is_deterministic():
    grid, field = study.book_map(), study.field()
    run = study.simulate(4, 30)
    s = gm.with_settings(n_start=2000, n_start_scan=200, history=8, inject_min=50, n_max=1000, poor_fit_only=False)
    state = np.random.get_state()
    a = gm.global_mcl(grid, field, study.MOTION, run.scans, run.drive.odometry, np.random.default_rng(1), s)
    b = gm.global_mcl(grid, field, study.MOTION, run.scans, run.drive.odometry, np.random.default_rng(1), s)
    c = gm.global_mcl(grid, field, study.MOTION, run.scans, run.drive.odometry, np.random.default_rng(2), s)
    assert np.array_equal(a.mean, b.mean) and not np.array_equal(a.mean, c.mean)
    assert np.array_equal(np.random.get_state()[1], state[1])
    assert a.sizes[0] == 2200 and np.all(a.sizes[1:] >= s.n_min)
    assert np.all((a.eps[1:] >= s.eps_min) & (a.eps[1:] <= 1))
    injected_steps = np.flatnonzero(a.injected_mass > 0)
    assert len(injected_steps) and np.all(injected_steps % s.inject_every == 0) and injected_steps.min() >= s.history


def test_the_injected_poses_carry_the_evidence_of_their_history():
    """With the cloud's evidence Z_j equal to the injected filter's own, the Bayes factor is one: the mean
    weight of the injected poses is then their last scan's mean likelihood times the first scan's u/q factor."""
    grid, field = study.book_map(), study.field()
    run = study.simulate(2, 40)
    s = gm.with_settings(history=5)
    x, lw = gm.injected(grid, field, study.MOTION, run.scans, run.drive.odometry, 30, 300, np.zeros(40),
                        np.random.default_rng(4), s)
    assert x.shape == (300, 3) and lw.shape == (300,)
    # subtracting a log-evidence of 1 nat per scan lowers every weight by exactly h nats
    _, lw2 = gm.injected(grid, field, study.MOTION, run.scans, run.drive.odometry, 30, 300, np.ones(40),
                         np.random.default_rng(4), s)
    assert np.allclose(lw - lw2, s.history, atol=1e-9)


def test_settings_are_checked():
    with pytest.raises(ParameterError):
        gm.GlobalSettings(n_min=600, n_max=500)
    with pytest.raises(ParameterError):
        gm.GlobalSettings(alpha_slow=0.2, alpha_fast=0.1)
    with pytest.raises(ShapeError):
        gm.global_mcl(study.book_map(), study.field(), study.MOTION, np.zeros((3, 24)), np.zeros((4, 3)),
                      np.random.default_rng(0))


def test_decided_uses_the_lock_on_share_of_the_window():
    window = int(lock_on.WINDOW_S / study.DT)
    m = np.full(200, 10.0)
    assert mg.decided(m)
    m[-window:-window + 8] = 0.0
    assert mg.decided(m)
    m[-window + 8] = 0.0
    assert not mg.decided(m)


def test_poor_fit_only_injects_only_while_the_scans_fit_worse_than_they_used_to():
    grid, field = study.book_map(), study.field()
    run = study.simulate(3, 40, kidnap_at=20)
    # a slow average that follows the last few seconds, so that the kidnapping shows within the run
    s = gm.with_settings(n_min=300, n_max=1000, history=6, inject_min=50, inject_every=2, alpha_slow=0.05, alpha_fast=0.5,
                         poor_fit_only=True)
    assert gm.POOR_FIT.poor_fit_only and not gm.SETTINGS.poor_fit_only
    a = gm.global_mcl(grid, field, study.MOTION, run.scans, run.drive.odometry, np.random.default_rng(1), s,
                      start=run.truth[0])
    b = gm.global_mcl(grid, field, study.MOTION, run.scans, run.drive.odometry, np.random.default_rng(1),
                      gm.replace(s, poor_fit_only=False), start=run.truth[0])
    inj_a, inj_b = np.flatnonzero(a.injected_mass > 0), np.flatnonzero(b.injected_mass > 0)
    # without the rule: every inject_every-th step from the history on; with it, only where eps is above its floor
    assert np.array_equal(inj_b, np.arange(s.history, 40, s.inject_every))
    assert np.all(a.eps[inj_a] > s.eps_min) and len(inj_a) < len(inj_b)
    # the kidnapping (robot carried away, odometry silent) is a poor fit: some injection follows it
    assert np.any(inj_a >= 20)
