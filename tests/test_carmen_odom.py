"""What the Intel log's ODOM lines are (book/data/intel/README.txt, chapter 16 "The log").

GMapping's converter ``gfs2log`` writes, between two scans, its best particle's poses after each odometry
update (``ODO_UPDATE``) and, right after each FLASER line, its scan-matched pose (``SM_UPDATE``), whose time
stamp is never set.  The increments between successive odometry updates are still the wheel encoders':
their heading steps sit on a lattice of one encoder quantum, which any Gaussian motion noise would break.
"""

import numpy as np
import pytest

from pfcourse.angles import wrap_angle
from pfcourse.errors import MeasurementError
from pfcourse.scenarios.maprobot.carmen import odom_records

#: The encoder's heading quantum (rad), measured on the log: 0.352 degrees.
ENCODER_STEP = 0.006146


@pytest.fixture(scope="module")
def records():
    return odom_records()


def heading_steps(records):
    poses, _, after_scan, scan = records
    i = np.flatnonzero(~after_scan)
    same = (scan[i[1:]] == scan[i[:-1]]) & (np.diff(i) == 1)
    return wrap_angle(poses[i[1:][same], 2] - poses[i[1:][same] - 1, 2])


def on_lattice(steps, q, tol=2e-5):
    """Share of the steps within ``tol`` rad of a whole multiple of ``q`` (the log prints 6 digits)."""
    return float(np.mean(np.abs(steps / q - np.round(steps / q)) * q < tol))


def test_one_scan_matched_pose_after_each_scan_and_the_rest_odometry_updates(records):
    poses, times, after_scan, scan = records
    assert len(poses) == 14541
    assert after_scan.sum() == 910 and (~after_scan).sum() == 13631
    # one scan-matched line after each of the 910 scans
    np.testing.assert_array_equal(np.sort(scan[after_scan]), np.arange(1, 911))
    # their time stamps were never set: most read 0, while every odometry update has a positive one
    assert (times[after_scan] == 0).sum() == 841
    assert np.all(times[~after_scan] > 0)


def test_the_heading_increments_are_whole_encoder_steps(records):
    steps = heading_steps(records)
    moving = np.abs(steps) > 1e-9
    assert len(steps) > 12000 and moving.sum() > 9000
    assert on_lattice(steps[moving], ENCODER_STEP) > 0.99
    # the check can fail: a quantum 1 % off, or Gaussian motion noise of 0.001 rad, leaves the lattice
    assert on_lattice(steps[moving], 1.01 * ENCODER_STEP) < 0.05
    noisy = steps[moving] + np.random.default_rng(0).normal(0, 1e-3, moving.sum())
    assert on_lattice(noisy, ENCODER_STEP) < 0.05


def test_a_malformed_odom_line_is_refused_by_name(tmp_path):
    bad = tmp_path / "bad.log"
    bad.write_text("ODOM 1 2 x 0 0 0 1 host 1\n")
    with pytest.raises(MeasurementError):
        odom_records(bad)
