"""The Intel log's experiments (pfcourse.studies.intel): the held-out split, the lock-on rule, the
scan proposal's density, and a global run's determinism."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import logsumexp
from scipy.stats import norm

from pfcourse.angles import wrap_angle
from pfcourse.errors import ParameterError
from pfcourse.studies import intel
from pfcourse.scenarios.maprobot.carmen import relative_pose


def test_the_map_is_built_from_the_other_half_and_holds_the_held_out_path():
    sp = intel.split()
    assert intel.MAP_PART.start == intel.HELD_OUT.stop == 455
    assert len(sp.poses) == len(sp.ranges) == len(sp.odometry) == 455
    assert np.all(sp.odometry[0] == 0.0)
    # the held-out poses lie on the map, off its walls, and most in cells the other half saw free (94 %:
    # the rest were never crossed by a beam of the second half, or are a wall cell there)
    assert sp.grid.is_free(sp.poses).mean() > 0.97
    assert sp.free.is_free(sp.poses).mean() > 0.9
    # the held-out poses are the log's corrected poses moved by the map's origin, nothing else
    np.testing.assert_allclose(sp.poses[:, :2] + sp.map.origin, sp.log.poses[intel.HELD_OUT, :2], atol=1e-12)


def test_the_heading_tolerance_is_three_times_the_odometrys_rms_heading_error_of_a_step():
    log = intel.split().log
    true = relative_pose(log.poses[:-1], log.poses[1:])[:, 2]
    rms = np.sqrt(np.mean(wrap_angle(log.relative_motion()[1:, 2] - true) ** 2))
    assert intel.heading_tolerance(log) == pytest.approx(3 * rms, rel=1e-12)
    assert np.deg2rad(5) < intel.heading_tolerance(log) < np.deg2rad(20)


def test_locked_on_means_most_of_the_last_window():
    tol = 0.2
    window = intel.LOCK_WINDOW
    good = int(np.ceil(intel.LOCK_SHARE * window))
    pos, head = np.zeros(50), np.zeros(50)
    pos[-window:][:window - good] = 5.0  # the first steps of the window off by 5 m
    assert intel.locked_on_share(pos, head, tol)
    pos[-good] = 5.0  # one more step off: below the share
    assert not intel.locked_on_share(pos, head, tol)
    assert not intel.locked_on_share(np.zeros(50), np.full(50, 0.3), tol)  # heading beyond the tolerance
    assert intel.locked_on_share(np.r_[np.full(35, 9.0), np.zeros(15)], np.zeros(50), tol)  # earlier steps do not count


def test_the_scan_proposal_returns_the_exact_log_density_of_its_draws():
    """Rebuild the proposal's candidates from the same seed and evaluate the kernel mixture with scipy."""
    sp = intel.split()
    field = sp.field()
    z = sp.ranges[100, ::intel.BEAM_STEP]
    x, log_q = intel.scan_proposal(sp.free, field, z, 50, np.random.default_rng(4), positions=200, headings=12,
                                   keep=40)
    rng = np.random.default_rng(4)
    xy = sp.free.sample_free(200, rng)[:, :2]
    theta = wrap_angle(rng.random() * 2 * np.pi / 12 + np.arange(12) * 2 * np.pi / 12)
    c = np.column_stack([np.repeat(xy, 12, axis=0), np.tile(theta, 200)])
    coarse = type(field)(field.grid, field.angles[::3], max_range=field.max_range, z_hit=field.z_hit,
                         z_rand=field.z_rand, sigma=field.sigma)
    s = 0.5 * coarse.log_likelihood(c, z[::3])
    kept = np.argsort(-s)[:40]
    log_v = s[kept] - logsumexp(s[kept])
    dth = wrap_angle(x[:, None, 2] - c[kept][None, :, 2])
    log_k = (norm.logpdf(x[:, None, 0], c[kept][None, :, 0], 0.25) + norm.logpdf(x[:, None, 1], c[kept][None, :, 1], 0.25)
             + norm.logpdf(dth, 0.0, 0.1))
    np.testing.assert_allclose(log_q, logsumexp(log_k + log_v, axis=1), rtol=1e-10)
    # the draws sit where the scan fits: far better than uniform poses
    uniform = sp.free.sample_free(50, np.random.default_rng(5))
    assert np.median(field.log_likelihood(x, z)) > np.median(field.log_likelihood(uniform, z)) + 20


def test_the_uniform_density_is_one_over_the_free_volume_and_zero_elsewhere():
    free = intel.split().free
    inside = free.sample_free(5, np.random.default_rng(0))
    np.testing.assert_allclose(intel.uniform_log_density(free, inside), -np.log(free.free_area * 2 * np.pi))
    assert np.all(np.isneginf(intel.uniform_log_density(free, np.array([[-5.0, -5.0, 0.0]]))))


def test_a_global_run_depends_on_its_seed_only():
    a, b = intel.global_row(3, method="uniform"), intel.global_row(3, method="uniform")
    assert a == b
    assert intel.global_row(4, method="uniform")["start_scan"] != a["start_scan"]
    state = np.random.get_state()[1].copy()
    intel.global_row(3, method="uniform")
    assert np.array_equal(np.random.get_state()[1], state)
    with pytest.raises(ParameterError, match="method"):
        intel.global_row(3, method="bootstrap")
