"""The map robot's lock-on rule: when is a localization filter *locked on*?

A filter is locked on when its estimate stays with the robot.  The rule must fit the robot: a
heading tolerance tighter than the heading noise the odometry itself adds between two scans counts
a filter that tracks well as lost (the old rule, 5 degrees at every step, did so in 13 of 100
tracking runs, each on one step).  So the tolerance is derived from the odometry model:

On a straight step of length ``d`` (``delta_rot1 = delta_rot2 = 0``, ``delta_trans = d``) the
odometry model (Thrun, Burgard and Fox 2005, table 5.6) perturbs the heading by
``-(eta_1 + eta_3)``, with ``eta_1`` and ``eta_3`` independent and of variance ``a_2 d^2`` each, so
one step adds heading noise of standard deviation

    sigma_theta = sqrt(2 a_2) d.

A cloud that is locked on spreads by that much in heading at each move before the scan pulls it
back; an estimate more than three of those from the true heading is farther off than one step of
the odometry explains.  With the map robot's ``a_2 = 0.05`` and ``d = 0.5 m/s x 0.5 s = 0.25 m``,
``sigma_theta = 0.079 rad`` (4.5 degrees) and the tolerance is ``3 sigma_theta = 0.24 rad`` (13.6
degrees).  The position tolerance is 1 m (a room's door is wider; a twin room is 5 m away).

**Most of the window, not every step.**  A filter is locked on at the end of a run when both
tolerances hold at ``SHARE`` (four in five) or more of the steps of the last ``WINDOW_S`` seconds:
one step of a tight turn does not make a tracking filter lost, a filter in a twin room fails at
every step.  The same rule (:func:`pfcourse.metrics.locked_on` with ``share < 1``) scores the Intel
log's runs (:mod:`pfcourse.experiments.intel`), with the heading noise of that robot's odometry.
"""

from __future__ import annotations

import numpy as np

from pfcourse import metrics
from pfcourse.checks import Array

#: The map robot's odometry noise a_1..a_4 (pfcourse.experiments.maprobot.MOTION) ...
ALPHAS = (0.05, 0.05, 0.05, 0.05)
#: ... and the length of a straight step (m): 0.5 m/s for 0.5 s between scans.
STEP_M = 0.25
POSITION_TOLERANCE_M = metrics.LOCK_POSITION_M
WINDOW_S = metrics.LOCK_WINDOW_S
SHARE = 0.8


def step_heading_sd(alphas=ALPHAS, step_m: float = STEP_M) -> float:
    """``sigma_theta = sqrt(2 a_2) d`` (rad): the heading noise the odometry adds on a straight step ``d``."""
    return float(np.sqrt(2.0 * alphas[1]) * step_m)


#: The heading tolerance (rad): three times one straight step's heading noise.
HEADING_TOLERANCE = 3.0 * step_heading_sd()


def locked_on(pos_err: Array, head_err: Array, dt: float, *, window_s: float = WINDOW_S, share: float = SHARE,
              position_tolerance: float = POSITION_TOLERANCE_M, heading_tolerance: float = HEADING_TOLERANCE) -> bool:
    """Locked on at the end of a run: position error below ``position_tolerance`` (m) and heading error
    below ``heading_tolerance`` (rad) at ``share`` or more of the steps of the last ``window_s`` seconds.

    ``pos_err`` and ``head_err`` are the run's per-step errors (:func:`pfcourse.metrics.position_error`,
    :func:`pfcourse.metrics.heading_error`), ``dt`` its step (s).
    """
    return metrics.locked_on(pos_err, head_err, dt, window_s, share=share, position_tolerance=position_tolerance,
                             heading_tolerance=heading_tolerance)
