"""Locked on: the map robot's rule, with its heading tolerance set by the odometry's own noise.

A filter is *locked on* at the end of a run when its estimate is within ``position_tolerance``
(1 m) of the true position and within ``heading_tolerance`` of the true heading at ``share``
(80 %) or more of the steps of the run's last ``window_s`` seconds (20 s): *most* of the window,
not every step, so that one step where the estimate lags a turn does not count a filter that
follows the robot as lost.

**The heading tolerance.**  Between two scans the odometry alone moves a locked-on filter's
heading, and the scan then pulls it back; the heading error a filter that follows the robot may
carry at a step is of the order of the heading noise of one odometry step.  In the odometry model
(:class:`pfcourse.scenarios.maprobot.motion.OdometryModel`) the heading changes by ``rot1^ + rot2^`` with the
independent errors ``e1`` and ``e3``, so for one straight step (``rot1 = rot2 = 0``, translation
``d``) its standard deviation is

    sigma_theta = sqrt(var e1 + var e3) = sqrt(2 alpha_2) d,

(with the map robot's ``alpha_2 = 0.05`` and ``d = 0.5 m/s x 0.5 s = 0.25 m``: 0.079 rad, 4.5
degrees).  The tolerance is ``k`` such standard deviations, ``k = 3`` by default: a heading error
the odometry of a single step leaves with probability below 0.3 % if it is Gaussian
(:func:`heading_tolerance`; 13.6 degrees for the map robot).  The Intel log's rule
(:func:`pfcourse.studies.intel.heading_tolerance`) is the same with the RMS of the log's
measured one-step heading errors in place of ``sigma_theta``.

The rule is :func:`pfcourse.metrics.locked_on` with ``share < 1`` (the package's one definition); this
module sets its tolerances for the map robot and validates the arguments.
"""

from __future__ import annotations

import numpy as np

from pfcourse import metrics
from pfcourse.checks import Array, check_probability, check_real
from pfcourse.errors import ParameterError, ShapeError
from pfcourse.scenarios.maprobot.drive import MOTION, STEP_M
from pfcourse.scenarios.maprobot.motion import OdometryModel

#: The rule's defaults: 1 m, three standard deviations of one step's heading noise, 80 % of the last 20 s.
POSITION_TOLERANCE_M = metrics.LOCK_POSITION_M
HEADING_SIGMAS = 3.0
WINDOW_S = metrics.LOCK_WINDOW_S
SHARE = 0.8
#: The map robot's odometry noise a_1..a_4 (:data:`pfcourse.scenarios.maprobot.drive.MOTION`) ...
ALPHAS = MOTION.alphas
#: ... and the length of a straight step (m): :data:`~pfcourse.scenarios.maprobot.drive.STEP_M`, 0.5 m/s for
#: 0.5 s between scans (imported above).


def step_heading_sd(motion: OdometryModel | None = None, step_m: float = STEP_M) -> float:
    """Standard deviation (rad) of the heading noise of one straight odometry step of ``step_m`` metres:
    ``sqrt(var e1 + var e3) = sqrt(2 alpha_2) step_m`` (``rot1 = rot2 = 0``); the map robot's by default."""
    motion = motion if motion is not None else OdometryModel(ALPHAS)
    step_m = check_real(step_m, "step_m", low=0.0, low_open=True)
    sd = motion.std(np.array([0.0, step_m, 0.0]))
    return float(np.hypot(sd[0], sd[2]))


def heading_tolerance(motion: OdometryModel | None = None, step_m: float = STEP_M,
                      sigmas: float = HEADING_SIGMAS) -> float:
    """The lock-on heading tolerance (rad): ``sigmas`` times :func:`step_heading_sd`."""
    sigmas = check_real(sigmas, "sigmas", low=0.0, low_open=True)
    return sigmas * step_heading_sd(motion, step_m)


#: The map robot's heading tolerance (rad): three times one straight step's heading noise (13.6 degrees).
HEADING_TOLERANCE = heading_tolerance()


def locked_steps(pos_err: Array, head_err: Array, heading_tol: float,
                 position_tol: float = POSITION_TOLERANCE_M) -> Array:
    """Per step: within ``position_tol`` (m) and ``heading_tol`` (rad)."""
    pos_err, head_err = np.asarray(pos_err, dtype=float), np.asarray(head_err, dtype=float)
    if pos_err.ndim != 1 or pos_err.shape != head_err.shape:
        raise ShapeError(f"pos_err and head_err must be 1-D arrays of one run's steps, of the same length, "
                         f"got shapes {pos_err.shape} and {head_err.shape}")
    return (pos_err < position_tol) & (head_err < heading_tol)


def locked_on(pos_err: Array, head_err: Array, dt: float, heading_tol: float = HEADING_TOLERANCE, *,
              position_tol: float = POSITION_TOLERANCE_M, window_s: float = WINDOW_S, share: float = SHARE) -> bool:
    """Locked on at the end of a run: within the tolerances at ``share`` or more of the last
    ``ceil(window_s / dt)`` steps (all of them if the run is shorter), by :func:`pfcourse.metrics.locked_on`.
    Errors per step: position (m), absolute heading (rad); ``dt`` the step (s)."""
    locked_steps(pos_err, head_err, heading_tol, position_tol)  # validates the shapes
    dt = check_real(dt, "dt", low=0.0, low_open=True)
    share = check_probability(share, "share")
    if heading_tol <= 0 or position_tol <= 0:
        raise ParameterError(f"the tolerances must be positive, got {position_tol} m and {heading_tol} rad")
    return bool(metrics.locked_on(np.asarray(pos_err, dtype=float), np.asarray(head_err, dtype=float), dt, window_s,
                                  share=share, position_tolerance=position_tol, heading_tolerance=heading_tol))


def locked_from(pos_err: Array, head_err: Array, dt: float, heading_tol: float, *,
                position_tol: float = POSITION_TOLERANCE_M, window_s: float = WINDOW_S, share: float = SHARE) -> int:
    """First step ``k0`` from which every window of ``ceil(window_s / dt)`` steps starting at or after it
    (and ending by the run's end) is locked on at ``share`` or more, and step ``k0`` itself is within the
    tolerances: the step from which the filter stays locked on.  ``len(pos_err)`` if it never does."""
    ok = locked_steps(pos_err, head_err, heading_tol, position_tol).astype(float)
    n = len(ok)
    window = min(n, int(np.ceil(window_s / dt - 1e-9)))
    if window == 0:
        return n
    c = np.concatenate([[0.0], np.cumsum(ok)])
    starts = np.arange(n - window + 1)
    good = (c[starts + window] - c[starts]) / window >= share
    if not good[-1]:
        return n
    bad = np.flatnonzero(~good)
    k0 = 0 if len(bad) == 0 else int(bad[-1] + 1)
    # the first step of the good run of windows that is itself within the tolerances
    inside = np.flatnonzero(ok[k0:] > 0)
    return int(k0 + inside[0]) if len(inside) else n
