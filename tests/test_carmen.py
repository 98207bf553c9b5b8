"""The CARMEN loader (pfcourse.scenarios.maprobot.carmen) on small logs written here and on the Intel log; the
occupancy grid mapping (pfcourse.scenarios.maprobot.mapping) on a scan of a known wall."""

from __future__ import annotations

import gzip
import hashlib

import numpy as np
import pytest

from pfcourse.errors import MeasurementError
from pfcourse.scenarios.maprobot.carmen import (INTEL_LOG, INTEL_SHA256, NO_RETURN, CarmenFormatError, compose, parse_carmen,
                                      read_carmen, relative_pose)
from pfcourse.scenarios.maprobot.mapping import L_FREE, L_OCC, build_map


def flaser(ranges, pose, t=0.0):
    r = " ".join(f"{v:g}" for v in ranges)
    p = " ".join(f"{v:g}" for v in pose)
    return f"FLASER {len(ranges)} {r} {p} {p} {t:g} host {t:g}"


def odom(pose, t=0.0):
    return "ODOM " + " ".join(f"{v:g}" for v in pose) + f" 0 0 0 {t:g} host {t:g}"


def small_log(turn=0.3):
    """Two scans; between them the ODOM lines restart at scan 0's corrected pose, then the odometry moves
    1 m ahead of it and turns by ``turn``; scan 1's corrected pose differs from that."""
    p0 = (1.0, 2.0, np.pi / 2)
    odo_end = compose(np.array(p0), np.array([1.0, 0.0, turn]))
    return ["# a comment", "PARAM robot_frontlaser_offset 0.0 nohost 0", odom((0, 0, 0)),
            flaser([1.0, 2.0, NO_RETURN], p0, 1.0), odom(p0), "NEFF 15", odom(odo_end),
            flaser([1.5, 2.5, 3.0], (1.1, 3.1, np.pi / 2 + 0.25), 2.0)]


def test_a_small_log_gives_its_scans_poses_times_and_odometry():
    log = parse_carmen(small_log())
    assert log.n_scans == 2 and log.n_odometry == 3
    np.testing.assert_allclose(log.ranges, [[1.0, 2.0, NO_RETURN], [1.5, 2.5, 3.0]])
    np.testing.assert_allclose(log.times, [1.0, 2.0])
    assert log.returned.tolist() == [[True, True, False], [True, True, True]]
    # the increment is scan 0's corrected pose to the last ODOM pose, in scan 0's frame: 1 m ahead, 0.3 rad
    np.testing.assert_allclose(log.relative_motion()[1], [1.0, 0.0, 0.3], atol=1e-5)
    np.testing.assert_allclose(log.odometry()[1], [0.0, 1.0, 0.3], atol=1e-5)
    np.testing.assert_allclose(log.dead_reckoning()[1], [1.0, 3.0, np.pi / 2 + 0.3], atol=1e-5)
    # beams one degree apart for 180 over pi; three beams: -pi/3, 0, pi/3
    np.testing.assert_allclose(log.angles, [-np.pi / 3, 0.0, np.pi / 3])


def test_no_odometry_between_two_scans_is_no_motion():
    lines = [flaser([1.0], (0, 0, 0)), flaser([1.0], (0.2, 0.0, 0.1))]
    np.testing.assert_allclose(parse_carmen(lines).relative_motion(), 0.0)


def test_a_robot_that_backs_up_has_a_negative_translation_not_a_half_turn():
    p0 = (0.0, 0.0, 0.0)
    lines = [flaser([1.0], p0), odom(p0), odom((-0.5, 0.0, 0.05)), flaser([1.0], (-0.5, 0.0, 0.05))]
    u = parse_carmen(lines).odometry()[1]
    np.testing.assert_allclose(u, [0.0, -0.5, 0.05], atol=1e-9)


def test_relative_pose_undoes_compose():
    rng = np.random.default_rng(3)
    base, delta = rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    delta[:, 2] = np.angle(np.exp(1j * delta[:, 2]))
    np.testing.assert_allclose(relative_pose(base, compose(base, delta)), delta, atol=1e-12)


@pytest.mark.parametrize("line, message", [
    (flaser([1.0, 2.0], (0, 0, 0)).replace("FLASER 2", "FLASER 3"), r"n \+ 11 fields"),
    ("FLASER two 1 2", "number of beams"),
    (flaser([1.0, -2.0], (0, 0, 0)), "negative"),
    (flaser([1.0, 2.0], (0, 0, 0)).replace(" 2 0", " nan 0", 1), "not finite"),
    (flaser([1.0, 2.0], (0, 0, 0)).replace(" 2 0", " x 0", 1), "not a number"),
    ("ODOM 1 2 3", "10 fields"),
    (odom((0, 0, 0)).replace("ODOM 0", "ODOM zero"), "not a number"),
])
def test_malformed_lines_raise_a_named_error_with_the_line(line, message):
    with pytest.raises(CarmenFormatError, match=message) as info:
        parse_carmen([flaser([1.0, 2.0], (0, 0, 0)), line])
    assert "line 2" in str(info.value)
    assert isinstance(info.value, MeasurementError)


def test_scans_of_different_sizes_and_a_log_without_scans_are_refused():
    with pytest.raises(CarmenFormatError, match="a scan of 3 beams after scans of 2"):
        parse_carmen([flaser([1.0, 2.0], (0, 0, 0)), flaser([1.0, 2.0, 3.0], (0, 0, 0))])
    with pytest.raises(CarmenFormatError, match="no FLASER"):
        parse_carmen([odom((0, 0, 0))])


def test_a_gzipped_file_reads_like_its_lines(tmp_path):
    path = tmp_path / "small.log.gz"
    with gzip.open(path, "wt", encoding="ascii") as f:
        f.write("\n".join(small_log()) + "\n")
    a, b = read_carmen(path), parse_carmen(small_log())
    np.testing.assert_array_equal(a.ranges, b.ranges)
    np.testing.assert_array_equal(a.odometry(), b.odometry())


def test_the_intel_log_is_the_committed_file_with_its_counts():
    assert hashlib.sha256(INTEL_LOG.read_bytes()).hexdigest() == INTEL_SHA256
    sums = (INTEL_LOG.parent / "SHA256SUMS").read_text().split()
    assert sums == [INTEL_SHA256, INTEL_LOG.name]
    log = read_carmen()
    assert log.n_scans == 910 and log.n_odometry == 14541 and log.ranges.shape == (910, 180)
    np.testing.assert_allclose(np.diff(log.angles), np.pi / 180)
    # real echoes stop short of the no-return code
    assert log.ranges[log.returned].max() < 26.0 and np.all(log.ranges[~log.returned] == NO_RETURN)
    # the odometry is close to the corrected motion step by step (a few cm), yet drifts far in the end
    true = relative_pose(log.poses[:-1], log.poses[1:])
    step = log.relative_motion()[1:]
    assert np.median(np.hypot(*(true[:, :2] - step[:, :2]).T)) < 0.1
    final = np.hypot(*(log.dead_reckoning()[-1, :2] - log.poses[-1, :2]))
    assert final > 10.0


def test_mapping_a_wall_marks_its_cells_occupied_and_the_way_to_it_free():
    """A robot at the origin facing +x sees a wall 2 m ahead with three beams: the end cells get L_OCC
    per scan, the cells before them L_FREE, the cells behind the wall stay unknown."""
    angles = np.array([-0.05, 0.0, 0.05])
    poses = np.zeros((2, 3))
    ranges = np.tile(2.0 / np.cos(angles), (2, 1))
    m = build_map(poses, ranges, angles, max_range=10.0, resolution=0.1, margin=0.5)
    grid = m.log_odds

    def cell(x, y):
        return grid[int(np.floor((y - m.origin[1]) / 0.1)), int(np.floor((x - m.origin[0]) / 0.1))]

    assert cell(2.02, 0.01) == pytest.approx(2 * L_OCC)
    assert cell(1.0, 0.01) == pytest.approx(2 * L_FREE)
    assert cell(0.05, 0.01) == pytest.approx(2 * L_FREE)
    assert cell(2.3, 0.01) == 0.0 and cell(1.0, 0.4) == 0.0
    assert m.grid().occupied.sum() == (grid > 0).sum() > 0
    # beams at max range are left out
    empty = build_map(poses, np.full((2, 3), 10.0), angles, max_range=10.0, resolution=0.1)
    assert not np.any(empty.log_odds)
