"""Angles: wrapping to (-pi, pi] and the weighted circular mean (the one resultant, :func:`resultant`).

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


def resultant(angles: np.ndarray, weights: np.ndarray) -> complex:
    """The weighted resultant ``r = sum_i w_i exp(i a_i)`` of 1-D ``angles`` (radians), one dot product
    ``weights @ np.exp(1j * angles)``: the sum behind :func:`circular_mean`, so the global-localization
    cure's mean heading, the smoother's and the predictive moments give the same float for the same cloud
    (:func:`resultant_direction` sums it as two real dot products, for the reason given there)."""
    return weights @ np.exp(1j * angles)


def resultant_direction(angles: np.ndarray, weights: np.ndarray) -> float:
    """``atan2(sum_i w_i sin a_i, sum_i w_i cos a_i)`` as two dot products, with no resultant check
    (the weights may be negative): the circular mean of the sigma points and of a grid filter's layers.

    The direction of :func:`resultant`, summed as two real dot products instead of one complex one: the
    two agree to rounding, not bit for bit (8 of 400 terrain-UKF means and 28 of 162 point-mass means
    differ, by up to 4.4e-16 rad), and the terrain UKF is chaotic on the flights it loses, so the complex
    sum would move the stored outputs of its runs (the terrain UKF of pf_vs_kalman: 17 of 28 flights, by up
    to 1.7 cm)."""
    return np.arctan2(weights @ np.sin(angles), weights @ np.cos(angles))


def circular_mean(angles: np.ndarray, weights: np.ndarray | None = None, axis: int = 0):
    """Weighted circular mean ``arg(sum_i w_i exp(i a_i)) = atan2(sum_i w_i sin a_i, sum_i w_i cos a_i)``.

    The direction of the weighted resultant of unit vectors; it equals the
    ordinary mean for tightly clustered angles away from the +/-pi cut and is
    correct across it.  With a zero resultant (angles spread evenly around the
    circle, ``|r| <= 1e-12 sum_i |w_i|``) the mean is undefined and NaN is returned.

    With weights the resultant is :func:`resultant` (one complex dot product per 1-D slice along
    ``axis``), so ``circular_mean(x[:, 2], W)`` is, float for float, ``np.angle(W @ np.exp(1j * x[:, 2]))``
    wherever that is defined; without weights it is the mean of the sines and of the cosines.
    """
    angles = np.asarray(angles, dtype=float)
    if weights is None:  # equal weights: the mean of the unit vectors
        s, c, total = np.mean(np.sin(angles), axis=axis), np.mean(np.cos(angles), axis=axis), 1.0
    else:
        weights = np.asarray(weights, dtype=float)
        if angles.ndim == 1:
            r = resultant(angles, weights)
        else:  # each 1-D slice as above, so a slice's mean is the same float as the slice's own
            r = np.apply_along_axis(resultant, axis, angles, weights)
        s, c = r.imag, r.real
        total = np.sum(np.abs(weights))
    resultant_length = np.hypot(s, c)
    mean = np.arctan2(s, c)
    return np.where(resultant_length > 1e-12 * total, mean, np.nan)
