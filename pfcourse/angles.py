"""Angles: wrapping to (-pi, pi] and the weighted circular mean.

A heading of 179 deg and one of -179 deg are 2 deg apart, but their arithmetic
mean is 0 deg: every angle in the package goes through these functions.
"""

from __future__ import annotations

import math

import numpy as np

from pfcourse.compiled import jit

TWO_PI = 2.0 * np.pi


def wrap_angle(angle):
    """Map angles (radians, any shape) to the interval (-pi, pi].

    ``wrap(a) = a - 2 pi * ceil((a - pi) / (2 pi))``, so ``wrap(pi) = pi`` and
    ``wrap(-pi) = pi``.
    """
    angle = np.asarray(angle, dtype=float)
    return angle - 2.0 * np.pi * np.ceil((angle - np.pi) / (2.0 * np.pi))


@jit
def wrap(angle: float) -> float:
    """:func:`wrap_angle` of one float, compiled (for loops over particles and the Kalman filters' steps).

    The same formula, so the same float: ``wrap(a) = a - 2 pi ceil((a - pi) / (2 pi))``.
    """
    return angle - TWO_PI * math.ceil((angle - np.pi) / TWO_PI)


def sigma_point_mean(points: np.ndarray, weights: np.ndarray, angle_indices=()) -> np.ndarray:
    """Weighted mean ``sum_i w_i p_i`` of the rows of ``points`` ``(n, d)``, with the circular mean
    ``atan2(sum_i w_i sin a_i, sum_i w_i cos a_i)`` for the components in ``angle_indices``.

    The weights may be negative (unscented-transform weights), so no resultant check is made:
    the mean function of every UKF in the package.
    """
    m = weights @ points
    for j in angle_indices:
        m[j] = resultant_direction(points[:, j], weights)
    return m


def resultant_direction(angles: np.ndarray, weights: np.ndarray) -> float:
    """``atan2(sum_i w_i sin a_i, sum_i w_i cos a_i)`` as two dot products, with no resultant check
    (the weights may be negative): the circular mean of the sigma points and of a grid filter's layers."""
    return np.arctan2(weights @ np.sin(angles), weights @ np.cos(angles))


def circular_mean(angles: np.ndarray, weights: np.ndarray | None = None, axis: int = 0):
    """Weighted circular mean ``atan2(sum w_i sin a_i, sum w_i cos a_i)``.

    The direction of the weighted resultant of unit vectors; it equals the
    ordinary mean for tightly clustered angles away from the +/-pi cut and is
    correct across it.  With a zero resultant (angles spread evenly around the
    circle) the mean is undefined and NaN is returned.
    """
    angles = np.asarray(angles, dtype=float)
    if weights is None:  # equal weights: the mean of the unit vectors
        s, c, total = np.mean(np.sin(angles), axis=axis), np.mean(np.cos(angles), axis=axis), 1.0
    else:
        weights = np.asarray(weights, dtype=float)
        shape = [1] * angles.ndim
        shape[axis] = -1
        w = weights.reshape(shape)
        s = np.sum(w * np.sin(angles), axis=axis)
        c = np.sum(w * np.cos(angles), axis=axis)
        total = np.sum(np.abs(weights))
    resultant = np.hypot(s, c)
    mean = np.arctan2(s, c)
    return np.where(resultant > 1e-12 * total, mean, np.nan)
