"""How far an estimate is from the truth, and how far the filter believes it is: the studies' metrics.

For a state whose first two components are the position ``(x, y)`` (the landmark robot, the
mobile robot, the aircraft) and an estimate ``x^`` with covariance ``P``:

* :func:`position_error` ``e_pos = sqrt((x^ - x)^2 + (y^ - y)^2)`` (m), the horizontal distance;
* :func:`heading_error` ``e_theta = |wrap(theta^ - theta)|`` (rad), wrapped to ``[0, pi]``;
* :func:`position_spread` ``sigma_pos = sqrt(P_xx + P_yy)`` (m), the filter's own horizontal
  standard deviation: the root of the expected squared position error, were the filter right;
* :func:`within_tolerances_from` and :func:`locked_on`, the book's one definition of *locked on* for a
  robot: within a position and a heading tolerance of the truth at a share of the steps of the
  last :data:`LOCK_WINDOW_S` seconds of the run (by default :data:`LOCK_POSITION_M` metres,
  :data:`LOCK_HEADING_RAD`, every step: the landmark robots; the map robot's tolerance and share,
  derived from its odometry, are in :mod:`pfcourse.scenarios.maprobot.lock_on`).

Errors are signed ``estimate - truth`` wherever the book keeps a sign.

Each takes arrays of any leading shape (a run ``(K, d)``, one step ``(d,)``, a cloud ``(N, d)``
against one true state ``(d,)``, by broadcasting) and returns one value per row.  The NEES and
the NIS, the consistency checks, are in :mod:`pfcourse.diagnostics`.

The floats are those of the package's earlier inline formulas: the distance is ``np.hypot``
(so ``truth - estimate`` and ``estimate - truth`` give the same float), the heading error wraps
``estimate - truth`` with :func:`pfcourse.angles.wrap_angle`.
"""

from __future__ import annotations

import numpy as np

from pfcourse.angles import wrap_angle
from pfcourse.checks import Array
from pfcourse.errors import ParameterError


def rmse(errors: Array, axis: int | None = None, *, components: int | tuple[int, ...] | None = None,
         points: int = 1):
    """Root mean square error ``sqrt(mean(e^2))`` of ``errors`` over ``axis`` (all of them by default):
    the one RMSE of the package (of a position error, a heading error, a state, ...).

    ``components`` names the axis (or axes) that hold the components of one error (``-1`` for
    ``(e_x, e_y)`` rows, ``(1, 2)`` for a run of matrices): their squares are summed first, the
    squared length ``e_x^2 + e_y^2`` (or the squared Frobenius norm), then averaged over ``axis``
    of the remaining axes: ``sqrt(mean(e_x^2 + e_y^2))``.  With ``points = L`` the components are those
    of ``L`` points (two landmarks' ``(x, y)``: four components) and their summed squares are divided by
    ``L``, the RMS over the points of each point's error: ``sqrt(mean((|e_1|^2 + ... + |e_L|^2) / L))``.
    """
    if not isinstance(points, (int, np.integer)) or isinstance(points, bool) or points < 1:
        raise ParameterError(f"rmse: points must be a positive whole number of points, got {points!r}")
    errors = np.asarray(errors)
    if components is None:
        return np.sqrt(np.mean(errors ** 2, axis=axis))
    squared = np.sum(errors ** 2, axis=components)
    return np.sqrt(np.mean(squared / points if points != 1 else squared, axis=axis))


def position_error(truth: Array, estimate: Array) -> Array:
    """Horizontal position error ``sqrt((x^ - x)^2 + (y^ - y)^2)`` (m), one per row.

    ``truth`` and ``estimate`` hold ``(x, y, ...)`` in their last axis and broadcast against
    each other.  Computed as ``np.hypot`` (no overflow or underflow of the squares).
    """
    truth = np.asarray(truth, dtype=float)
    estimate = np.asarray(estimate, dtype=float)
    return np.hypot(estimate[..., 0] - truth[..., 0], estimate[..., 1] - truth[..., 1])


def heading_error(truth: Array, estimate: Array, index: int = 2) -> Array:
    """Absolute heading error ``|wrap(theta^ - theta)|`` (rad, in ``[0, pi]``), one per row.

    ``theta`` is component ``index`` of the last axis (2 for the robots' ``(x, y, theta)``).
    """
    truth = np.asarray(truth, dtype=float)
    estimate = np.asarray(estimate, dtype=float)
    return np.abs(wrap_angle(estimate[..., index] - truth[..., index]))


def position_spread(cov: Array) -> Array:
    """The filter's horizontal standard deviation ``sqrt(P_xx + P_yy)`` (m), one per covariance.

    ``cov`` has shape ``(..., d, d)`` with the position in its first two rows; the same formula
    turns a Cramér-Rao bound ``B`` into the bound ``sqrt(B_xx + B_yy)`` on the RMS position error.
    """
    cov = np.asarray(cov, dtype=float)
    return np.sqrt(cov[..., 0, 0] + cov[..., 1, 1])


#: Locked on (one function, :func:`locked_on`, with parameters): the estimate is within this
#: distance of the true position (m) ...  The defaults below (every step, 5 degrees) are the landmark
#: robot's stricter convention (Chapters 11-13); the map robot (:mod:`pfcourse.scenarios.maprobot.lock_on`) calls
#: the same function with ``share = 0.8`` and a heading tolerance derived from its own odometry noise.
LOCK_POSITION_M = 1.0
#: ... and this angle of the true heading (rad, 5 degrees) ...
LOCK_HEADING_RAD = float(np.deg2rad(5.0))
#: ... at every step of the run's last ``LOCK_WINDOW_S`` seconds.
LOCK_WINDOW_S = 20.0


def within_tolerances_from(pos_err: Array, head_err: Array, position_tolerance: float = LOCK_POSITION_M,
                           heading_tolerance: float = LOCK_HEADING_RAD) -> int:
    """First step ``k0`` from which ``e_pos < position_tolerance`` and ``e_theta < heading_tolerance``
    hold at every step to the end (``K``, the number of steps, if they fail at the last one).

    Every step, not a share of the steps of a window: the map robot's
    :func:`pfcourse.scenarios.maprobot.lock_on.locked_from` is the step from which its windows are locked on."""
    ok = (np.asarray(pos_err) < position_tolerance) & (np.asarray(head_err) < heading_tolerance)
    bad = np.flatnonzero(~ok)
    return 0 if len(bad) == 0 else int(bad[-1] + 1)


def locked_on(pos_err: Array, head_err: Array, dt: float, window_s: float = LOCK_WINDOW_S, *, share: float = 1.0,
              position_tolerance: float = LOCK_POSITION_M, heading_tolerance: float = LOCK_HEADING_RAD) -> bool:
    """Locked on: within the tolerances at ``share`` or more of the last ``ceil(window_s / dt)`` steps
    (every one of them with ``share = 1``, the default).

    ``pos_err`` and ``head_err`` are the per-step errors of one run (:func:`position_error`,
    :func:`heading_error`), ``dt`` its step (s).  A run shorter than the window is judged on all its steps.
    """
    n_steps = len(pos_err)
    window = min(n_steps, int(np.ceil(window_s / dt - 1e-9)))
    if share >= 1.0:
        start = within_tolerances_from(pos_err, head_err, position_tolerance, heading_tolerance)
        return start <= n_steps - window
    ok = ((np.asarray(pos_err)[n_steps - window:] < position_tolerance)
          & (np.asarray(head_err)[n_steps - window:] < heading_tolerance))
    return bool(ok.mean() >= share)
