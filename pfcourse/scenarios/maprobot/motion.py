"""The odometry motion model (Thrun, Burgard and Fox 2005, tables 5.5 and 5.6) and the simulated drive.

Between two steps the odometer reports the relative motion ``u_k = (rot1, trans, rot2)``: turn by
``rot1`` towards the direction of travel, move ``trans`` straight, turn by ``rot2``.  From two odometry
poses ``(x, y, theta)`` and ``(x', y', theta')`` (:func:`odometry_increments`):

    rot1 = atan2(y' - y, x' - x) - theta,   trans = sqrt((x' - x)^2 + (y' - y)^2),   rot2 = theta' - theta - rot1

(``rot1 = 0`` for a turn on the spot).  The true motion differs from it by independent zero-mean
Gaussian errors whose variances grow with the motion, with four parameters ``alpha_1 ... alpha_4``:

    rot1^ = rot1 - e1,    e1 ~ N(0, alpha_1 rot1^2 + alpha_2 trans^2)
    trans^ = trans - e2,  e2 ~ N(0, alpha_3 trans^2 + alpha_4 (rot1^2 + rot2^2))
    rot2^ = rot2 - e3,    e3 ~ N(0, alpha_1 rot2^2 + alpha_2 trans^2)

and the pose moves by the perturbed increments (:meth:`OdometryModel.sample`, table 5.6):

    x' = x + trans^ cos(theta + rot1^),   y' = y + trans^ sin(theta + rot1^),   theta' = theta + rot1^ + rot2^.

``alpha_1`` is rotation error per rotation, ``alpha_2`` rotation error per translation (rad^2/m^2),
``alpha_3`` translation error per translation, ``alpha_4`` translation error per rotation (m^2/rad^2).

:func:`simulate_drive` drives a robot along a loop of waypoints at a forward speed, commanding the
increments ``u_k`` from its true pose, executing them through :meth:`OdometryModel.sample` and
recording ``u_k`` as the odometry.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pfcourse.angles import wrap_angle
from pfcourse.checks import Array, check_count, check_real
from pfcourse.errors import ParameterError, ShapeError


def odometry_increments(old: Array, new: Array, still: float = 1e-9) -> Array:
    """``(rot1, trans, rot2)`` that take pose ``old`` to pose ``new`` (table 5.6, lines 2-4), each row;
    ``rot1 = 0`` when ``trans < still`` (a turn on the spot)."""
    old, new = np.asarray(old, dtype=float), np.asarray(new, dtype=float)
    dx, dy = new[..., 0] - old[..., 0], new[..., 1] - old[..., 1]
    trans = np.hypot(dx, dy)
    rot1 = np.where(trans < still, 0.0, wrap_angle(np.arctan2(dy, dx) - old[..., 2]))
    rot2 = wrap_angle(new[..., 2] - old[..., 2] - rot1)
    return np.stack([rot1, trans, rot2], axis=-1)


@dataclass(frozen=True)
class OdometryModel:
    """The rot1-trans-rot2 model with its four error parameters ``alphas = (alpha_1, ..., alpha_4)``."""

    alphas: tuple[float, float, float, float] = (0.05, 0.05, 0.05, 0.05)

    def __post_init__(self) -> None:
        a = np.asarray(self.alphas, dtype=float) if np.ndim(self.alphas) == 1 else None
        if a is None or a.shape != (4,):
            raise ShapeError(f"alphas must be four numbers (alpha_1, ..., alpha_4), got {self.alphas!r}")
        for n, value in enumerate(self.alphas, 1):
            check_real(value, f"alpha_{n}", low=0.0)
        object.__setattr__(self, "alphas", tuple(float(v) for v in self.alphas))

    def std(self, u: Array) -> Array:
        """Standard deviations of ``(e1, e2, e3)`` for the increments ``u = (rot1, trans, rot2)``."""
        a1, a2, a3, a4 = self.alphas
        rot1, trans, rot2 = np.asarray(u, dtype=float)
        return np.sqrt([a1 * rot1**2 + a2 * trans**2,
                        a3 * trans**2 + a4 * (rot1**2 + rot2**2),
                        a1 * rot2**2 + a2 * trans**2])

    def sample(self, poses: Array, u: Array, rng: np.random.Generator) -> Array:
        """Move every pose (rows of ``poses``, shape ``(N, 3)``) by the odometry ``u`` with sampled errors
        (table 5.6); one ``rng.standard_normal((N, 3))`` draw."""
        poses = np.asarray(poses, dtype=float)
        if poses.ndim != 2 or poses.shape[1] != 3:
            raise ShapeError(f"poses must have shape (N, 3), got {poses.shape}")
        u = np.asarray(u, dtype=float)
        if u.shape != (3,) or not np.all(np.isfinite(u)):
            raise ShapeError(f"the odometry u must be three finite numbers (rot1, trans, rot2), got {u!r}")
        e = rng.standard_normal((len(poses), 3)) * self.std(u)
        rot1, trans, rot2 = u[0] - e[:, 0], u[1] - e[:, 1], u[2] - e[:, 2]
        heading = poses[:, 2] + rot1
        return np.column_stack([poses[:, 0] + trans * np.cos(heading), poses[:, 1] + trans * np.sin(heading),
                                wrap_angle(heading + rot2)])


@dataclass(frozen=True)
class Drive:
    """A simulated drive: true poses ``truth`` ``(K, 3)`` and odometry ``odometry`` ``(K, 3)`` (row ``k``:
    the increments from step ``k - 1`` to ``k``; row 0 is zero), ``dt`` seconds apart."""

    truth: Array
    odometry: Array
    dt: float


def simulate_drive(route: Array, n_steps: int, rng: np.random.Generator, *, motion: OdometryModel = OdometryModel(),
                   dt: float = 0.5, speed: float = 0.5, turn_rate: float = 1.0, start: int = 0,
                   tolerance: float = 0.15) -> Drive:
    """Drive the loop of waypoints ``route`` (``(M, 2)``, m) from waypoint ``start``, heading to the next.

    At each step the robot turns towards its waypoint: on the spot by at most ``turn_rate dt`` when it
    faces more than that away from it, else it turns and moves ``min(speed dt, distance)``; a waypoint
    closer than ``tolerance`` passes to the next.  The commanded increments are the odometry ``u_k``;
    the true pose follows :meth:`OdometryModel.sample` from the true pose.
    """
    route = np.asarray(route, dtype=float)
    if route.ndim != 2 or route.shape[1] != 2 or len(route) < 2:
        raise ShapeError(f"route must have shape (M, 2) with M >= 2 waypoints, got {route.shape}")
    n_steps = check_count(n_steps, "n_steps")
    dt = check_real(dt, "dt", low=0.0, low_open=True)
    speed = check_real(speed, "speed", low=0.0, low_open=True)
    max_turn = check_real(turn_rate, "turn_rate", low=0.0, low_open=True) * dt
    if not 0 <= start < len(route):
        raise ParameterError(f"start must be a waypoint index in [0, {len(route)}), got {start}")
    target = (start + 1) % len(route)
    a, b = route[start], route[target]
    pose = np.array([a[0], a[1], np.arctan2(b[1] - a[1], b[0] - a[0])])
    truth, odometry = np.empty((n_steps, 3)), np.zeros((n_steps, 3))
    truth[0] = pose
    for k in range(1, n_steps):
        while np.hypot(*(route[target] - pose[:2])) < tolerance:
            target = (target + 1) % len(route)
        d = route[target] - pose[:2]
        turn = float(wrap_angle(np.arctan2(d[1], d[0]) - pose[2]))
        if abs(turn) > max_turn:
            u = np.array([np.clip(turn, -max_turn, max_turn), 0.0, 0.0])
        else:
            u = np.array([turn, min(speed * dt, float(np.hypot(*d))), 0.0])
        pose = motion.sample(pose[None], u, rng)[0]
        truth[k], odometry[k] = pose, u
    return Drive(truth=truth, odometry=odometry, dt=dt)
