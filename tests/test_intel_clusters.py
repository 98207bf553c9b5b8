"""intel/cluster_estimate: the guarded cure's global runs judged by AMCL's kind of estimate."""

import numpy as np

from pfcourse.scenarios.maprobot import global_mcl
from pfcourse.studies import intel
from pfcourse.studies.intel_clusters import CLUSTER_RADIUS, heaviest_cluster_mean
from pfcourse.studies.registry import STUDIES


def test_the_heaviest_cluster_sits_on_the_heavier_mode_where_the_mean_falls_between():
    rng = np.random.default_rng(0)
    robot = rng.normal([2.0, 3.0, 0.5], [0.1, 0.1, 0.05], (600, 3))
    twin = rng.normal([12.0, 3.0, -2.0], [0.1, 0.1, 0.05], (400, 3))
    x, W = np.vstack([robot, twin]), np.full(1000, 1e-3)
    est = heaviest_cluster_mean(x, W)
    np.testing.assert_allclose(est, robot.mean(axis=0), atol=0.02)
    assert np.hypot(*(W @ x[:, :2] - est[:2])) > 3.0  # the cloud's mean is metres away, between the modes
    # the lighter mode wins once it carries more weight
    W2 = np.r_[np.full(600, 0.3 / 600), np.full(400, 0.7 / 400)]
    np.testing.assert_allclose(heaviest_cluster_mean(x, W2)[:2], twin[:, :2].mean(axis=0), atol=0.02)
    # a unimodal cloud: the cluster's mean is the cloud's mean
    W3 = np.full(600, 1 / 600)
    np.testing.assert_allclose(heaviest_cluster_mean(robot, W3)[:2], W3 @ robot[:, :2], atol=1e-9)
    assert CLUSTER_RADIUS == 1.0


def test_observe_sees_every_cloud_whose_mean_the_filter_reports():
    sp = intel.split()
    first = intel.global_start(0)
    run = slice(first, first + intel.GLOBAL_STEPS)
    odometry = sp.odometry[run].copy()
    odometry[0] = 0.0
    scans = sp.ranges[run, ::intel.BEAM_STEP]
    seen = []
    res = global_mcl.global_mcl(sp.free, sp.field(), intel.MOTION, scans, odometry, np.random.default_rng([41, 0, 1]),
                                intel.GUARDED_SETTINGS, observe=lambda k, x, W: seen.append((k, x.copy(), W.copy())))
    assert [k for k, *_ in seen] == list(range(intel.GLOBAL_STEPS))
    for k, x, W in seen:
        assert abs(W.sum() - 1) < 1e-12
        np.testing.assert_array_equal(res.mean[k, :2], [W @ x[:, 0], W @ x[:, 1]])


def test_the_stored_runs_are_the_cures_runs_of_intel_injection():
    table = STUDIES["intel/cluster_estimate"].load().sort_values("seed").reset_index(drop=True)
    cure = STUDIES["intel/injection"].load().query("method == 'guarded'").sort_values("seed").reset_index(drop=True)
    assert len(table) == intel.N_GLOBAL
    assert (table["start_scan"].to_numpy() == cure["start_scan"].to_numpy()).all()
    assert (table["locked_on"].to_numpy() == cure["locked_on"].to_numpy()).all()
    np.testing.assert_allclose(table["final_position_error"], cure["final_position_error"], rtol=0, atol=1e-9)
    assert ((table["final_mass_near_reference"] >= 0) & (table["final_mass_near_reference"] <= 1 + 1e-9)).all()
