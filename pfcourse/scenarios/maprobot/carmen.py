"""A real robot's laser log in the CARMEN text format: scans, corrected poses and odometry.

A CARMEN log (the format of the Radish data sets, among them the Intel Research Lab log of
``book/data/intel``) is one message a line, its type first.  Two types are read here:

* ``FLASER n r_1 ... r_n x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp``:
  a front laser scan of ``n`` ranges (m; the Intel log's scanner: ``n = 180`` beams one degree
  apart over 180 degrees, from the robot's right to its left, a beam with no echo coded
  :data:`NO_RETURN` = 81.83 m), taken at the pose ``(x, y, theta)``.  In a *corrected* log
  these poses are a SLAM estimate (GMapping), not the odometry.
* ``ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp``: an odometry pose.

Other lines (``#`` comments, ``PARAM``, ``SYNC``, GMapping's ``NEFF``, ...) are skipped.

**The odometry between two scans.**  In the corrected log the ODOM lines restart from the
corrected pose after each scan: the first ODOM line after scan ``k`` repeats its pose, and the
following ones add what the wheels measured.  The motion the odometer reports between scans
``k`` and ``k + 1`` is therefore the pose of the last ODOM line before scan ``k + 1``, seen from
the corrected pose of scan ``k``:

    u_{k+1} = (corrected pose k)^{-1} (+) (last ODOM pose before scan k + 1),

with ``(+)`` the composition of planar poses (:func:`relative_pose`).  Dead reckoning chains
these increments from the first corrected pose (:meth:`CarmenLog.dead_reckoning`).

Malformed input raises :class:`CarmenFormatError` (a :class:`pfcourse.errors.MeasurementError`)
naming the line.
"""

from __future__ import annotations

import gzip
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pfcourse.angles import wrap_angle
from pfcourse.checks import Array
from pfcourse.errors import MeasurementError
from pfcourse.scenarios.maprobot.motion import odometry_increments

#: The range (m) the Intel log's scanner reports for a beam with no echo.
NO_RETURN = 81.83
#: The book's copy of the Intel Research Lab log (GMapping-corrected), gzipped.
INTEL_LOG = Path(__file__).resolve().parents[3] / "book" / "data" / "intel" / "intel-corrected.log.gz"
#: Its SHA-256 checksum (book/data/intel/SHA256SUMS).
INTEL_SHA256 = "71bef16e9926506cf7417995ef35ace09dbd5de067fd042a3aab85188b5480dc"


class CarmenFormatError(MeasurementError):
    """A line of a CARMEN log is malformed (wrong number of fields, a field that is not a finite
    number, a negative range, scans of different sizes, no scan at all)."""


def relative_pose(base: Array, pose: Array) -> Array:
    """``base^{-1} (+) pose``: ``pose`` ``(..., 3)`` expressed in the frame of ``base`` ``(..., 3)``."""
    base, pose = np.asarray(base, dtype=float), np.asarray(pose, dtype=float)
    dx, dy = pose[..., 0] - base[..., 0], pose[..., 1] - base[..., 1]
    c, s = np.cos(base[..., 2]), np.sin(base[..., 2])
    return np.stack([c * dx + s * dy, -s * dx + c * dy, wrap_angle(pose[..., 2] - base[..., 2])], axis=-1)


def compose(base: Array, delta: Array) -> Array:
    """``base (+) delta``: the pose reached from ``base`` by the motion ``delta`` given in base's frame."""
    base, delta = np.asarray(base, dtype=float), np.asarray(delta, dtype=float)
    c, s = np.cos(base[..., 2]), np.sin(base[..., 2])
    return np.stack([base[..., 0] + c * delta[..., 0] - s * delta[..., 1],
                     base[..., 1] + s * delta[..., 0] + c * delta[..., 1],
                     wrap_angle(base[..., 2] + delta[..., 2])], axis=-1)


@dataclass(frozen=True, eq=False)
class CarmenLog:
    """The scans of a log and what goes with them, one row per scan ``k = 0, ..., K - 1``.

    ``ranges`` ``(K, B)`` (m), ``poses`` ``(K, 3)`` the corrected poses, ``times`` ``(K,)`` the
    logger's time stamps (s), ``odometry_poses`` ``(K, 3)`` the pose of the last ODOM line between
    the previous scan and each scan (none: the previous scan's pose, no motion; row 0: the last
    ODOM line before the first scan, or the first scan's pose),
    ``n_odometry`` the number of ODOM lines read.
    """

    ranges: Array
    poses: Array
    times: Array
    odometry_poses: Array
    n_odometry: int
    fov: float = np.pi

    @property
    def n_scans(self) -> int:
        return len(self.ranges)

    @property
    def angles(self) -> Array:
        """Beam angles relative to the heading (rad): ``B`` beams evenly over ``fov``, right to left,
        ``-fov/2 + (b + 1/2) fov / B`` (the beams' centres; one degree apart for 180 beams).

        A FLASER line carries no angles.  For 180 beams CARMEN's reader (``readlog.c``) puts beam ``b`` at
        ``-90 + b`` degrees, and the reader of GMapping's programs (``carmenconfiguration.cpp``; GMapping made
        the Intel log's corrected poses) at ``-90 .. -1`` and ``+1 .. +90``; the centres, ``-89.5 + b``, lie
        within half a degree of both and are symmetric about the heading, as GMapping's are
        (book/data/intel/README.txt)."""
        n = self.ranges.shape[1]
        return -self.fov / 2 + (np.arange(n) + 0.5) * self.fov / n

    @property
    def returned(self) -> Array:
        """Whether each beam has an echo (its range below :data:`NO_RETURN`), ``(K, B)``."""
        return self.ranges < NO_RETURN

    def relative_motion(self) -> Array:
        """``(K, 3)``: row ``k >= 1`` is ``u_k = poses[k-1]^{-1} (+) odometry_poses[k]`` (dx, dy, dtheta in
        the frame of scan ``k - 1``); row 0 is zero."""
        out = np.zeros((self.n_scans, 3))
        out[1:] = relative_pose(self.poses[:-1], self.odometry_poses[1:])
        return out

    def odometry(self, still: float = 0.01) -> Array:
        """The increments ``(rot1, trans, rot2)`` of the odometry motion model, ``(K, 3)``, row 0 zero.

        A robot that backs up has ``|rot1| > pi / 2``: it is written as a negative ``trans`` with
        ``rot1`` turned by ``pi`` (the same motion), so that the model's noise, which grows with
        ``rot1^2``, is not that of a half-turn; below ``still`` metres ``rot1 = 0`` (a turn on the spot)."""
        delta = self.relative_motion()
        u = odometry_increments(np.zeros_like(delta), delta, still=still)
        back = np.abs(u[:, 0]) > np.pi / 2
        u[back, 0] = wrap_angle(u[back, 0] - np.pi)
        u[back, 1] = -u[back, 1]
        u[:, 2] = wrap_angle(delta[:, 2] - u[:, 0])
        return u

    def dead_reckoning(self, start: Array | None = None) -> Array:
        """Poses ``(K, 3)`` from ``start`` (default: the first corrected pose) by the odometry alone."""
        pose = self.poses[0] if start is None else np.asarray(start, dtype=float)
        delta = self.relative_motion()
        out = np.empty((self.n_scans, 3))
        out[0] = pose
        for k in range(1, self.n_scans):
            out[k] = pose = compose(pose, delta[k])
        return out


def _numbers(fields: list[str], line_no: int, kind: str) -> Array:
    try:
        values = np.array([float(f) for f in fields])
    except ValueError:
        raise CarmenFormatError(f"line {line_no}: a {kind} field is not a number") from None
    if not np.all(np.isfinite(values)):
        raise CarmenFormatError(f"line {line_no}: a {kind} field is not finite")
    return values


def parse_carmen(lines) -> CarmenLog:
    """Read FLASER and ODOM messages from an iterable of text lines (see the module's docstring)."""
    ranges, poses, times, odo_before = [], [], [], []
    last_odom, n_odom = None, 0
    for line_no, line in enumerate(lines, 1):
        fields = line.split()
        if not fields or fields[0] not in ("FLASER", "ODOM"):
            continue
        if fields[0] == "ODOM":
            if len(fields) != 10:
                raise CarmenFormatError(f"line {line_no}: an ODOM line has 10 fields "
                                        f"(ODOM x y theta tv rv accel ipc_time host log_time), got {len(fields)}")
            last_odom = _numbers(fields[1:4], line_no, "ODOM")
            n_odom += 1
            continue
        try:
            n = int(fields[1]) if len(fields) > 1 else -1
        except ValueError:
            raise CarmenFormatError(f"line {line_no}: a FLASER line's second field is its number of beams, "
                                    f"got {fields[1]!r}") from None
        if n < 1 or len(fields) != n + 11:
            raise CarmenFormatError(f"line {line_no}: a FLASER line of n beams has n + 11 fields "
                                    f"(FLASER n ranges x y theta odom_x odom_y odom_theta ipc_time host log_time); "
                                    f"n = {n}, got {len(fields)} fields")
        if ranges and n != len(ranges[0]):
            raise CarmenFormatError(f"line {line_no}: a scan of {n} beams after scans of {len(ranges[0])}")
        z = _numbers(fields[2:2 + n], line_no, "FLASER range")
        if np.any(z < 0):
            raise CarmenFormatError(f"line {line_no}: a range is negative")
        pose = _numbers(fields[2 + n:5 + n], line_no, "FLASER pose")
        ranges.append(z)
        poses.append(pose)
        times.append(_numbers(fields[-1:], line_no, "FLASER time stamp")[0])
        # the odometry since the previous scan; none read: no motion measured since that scan
        if last_odom is None:
            last_odom = poses[-2] if len(poses) > 1 else pose
        odo_before.append(last_odom)
        last_odom = None
    if not ranges:
        raise CarmenFormatError("the log holds no FLASER line: there is no scan to read")
    return CarmenLog(ranges=np.array(ranges), poses=np.array(poses), times=np.array(times),
                     odometry_poses=np.array(odo_before),
                     n_odometry=n_odom)


def read_carmen(path: str | Path = INTEL_LOG) -> CarmenLog:
    """Read a CARMEN log file (gzipped if its name ends in ``.gz``); by default the Intel log."""
    path = Path(path)
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt", encoding="ascii") as f:
        return parse_carmen(f)


def odom_records(path: str | Path = INTEL_LOG) -> tuple[Array, Array, Array, Array]:
    """Every ``ODOM`` line of a log: ``(poses (M, 3), times (M,), after_scan (M,), scan (M,))``, with
    ``after_scan`` true for a line that comes right after a ``FLASER`` line (in GMapping's output, written
    back by ``gfs2log``, its scan-matched pose, ``SM_UPDATE``, whose time stamp is never set; the other lines
    are its best particle's poses after odometry updates, ``ODO_UPDATE``) and ``scan`` the number of
    ``FLASER`` lines before the line."""
    path = Path(path)
    opener = gzip.open if path.suffix == ".gz" else open
    poses, times, after, scan = [], [], [], []
    n_scans, previous = 0, None
    with opener(path, "rt") as f:
        for line_no, line in enumerate(f, 1):
            fields = line.split()
            if not fields:
                continue
            if fields[0] == "ODOM":
                poses.append(_numbers(fields[1:4], line_no, "ODOM"))
                times.append(_numbers(fields[-1:], line_no, "ODOM time stamp")[0])
                after.append(previous == "FLASER")
                scan.append(n_scans)
            elif fields[0] == "FLASER":
                n_scans += 1
            previous = fields[0]
    return np.array(poses).reshape(-1, 3), np.array(times), np.array(after, dtype=bool), np.array(scan)
