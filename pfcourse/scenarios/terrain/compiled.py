"""Compiled (numba) passes of the terrain model: the aircraft's transition and the altimeter likelihood.

They compute, one particle at a time, exactly the equations of :mod:`pfcourse.scenarios.terrain.scenario`
(the NumPy definitions :func:`~pfcourse.scenarios.terrain.scenario.propagate`,
:func:`~pfcourse.scenarios.terrain.scenario.predicted_measurement` with the bilinear
:meth:`~pfcourse.scenarios.terrain.map.TerrainMap.height`), without the NumPy temporaries:

- transition: ``x' = f(x) + L e`` with ``e`` the standard normal draws (drawn by NumPy, so the
  random stream is the NumPy model's), ``L`` the Cholesky factor of ``Qf dt``, heading wrapped;
- likelihood: ``log N(y; z - h(x, y), Rf)`` with the bilinear height
  ``h = (1-s)(1-t) h00 + s(1-t) h10 + (1-s) t h01 + s t h11`` of the cell containing the point,
  ``-inf`` outside ``[0, width] x [0, height]``.

tests/test_terrain_kernels.py checks them against the NumPy / scipy definitions.
"""

from __future__ import annotations

import math

import numpy as np

from pfcourse.angles import wrap
from pfcourse.compiled import jit


@jit
def on_map(heights, dx, dy, xi, yi):
    """Is ``(xi, yi)`` inside the node hull ``[0, (nx-1) dx] x [0, (ny-1) dy]``?"""
    ny, nx = heights.shape
    return xi >= 0.0 and xi <= (nx - 1) * dx and yi >= 0.0 and yi <= (ny - 1) * dy


@jit
def cell_height(heights, dx, dy, xi, yi):
    """Bilinear height at one point ``(xi, yi)``; NaN outside the node hull."""
    if not on_map(heights, dx, dy, xi, yi):
        return np.nan
    ny, nx = heights.shape
    c = xi / dx
    r = yi / dy
    j = min(int(math.floor(c)), nx - 2)
    k = min(int(math.floor(r)), ny - 2)
    s = c - j
    t = r - k
    return ((1.0 - s) * (1.0 - t) * heights[k, j] + s * (1.0 - t) * heights[k, j + 1]
            + (1.0 - s) * t * heights[k + 1, j] + s * t * heights[k + 1, j + 1])


@jit
def bilinear(heights, dx, dy, x, y):
    """Bilinear height at each ``(x[i], y[i])``; NaN outside the node hull."""
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        out[i] = cell_height(heights, dx, dy, x[i], y[i])
    return out


@jit
def altimeter_log_likelihood(particles, heights, dx, dy, z, rf, log_norm):
    """``log_norm - (z - (alt - h(x, y)))^2 / (2 rf)`` per particle; ``-inf`` off the map."""
    n = particles.shape[0]
    out = np.empty(n)
    for i in range(n):
        if not on_map(heights, dx, dy, particles[i, 0], particles[i, 1]):
            out[i] = -np.inf
            continue
        h = cell_height(heights, dx, dy, particles[i, 0], particles[i, 1])
        nu = z - (particles[i, 2] - h)
        out[i] = log_norm - 0.5 * nu * nu / rf
    return out


@jit
def aircraft_transition(particles, noise, factor, speed, omega, dt):
    """``f(x) + factor @ e`` for every row (``noise`` holds ``e``), heading wrapped to (-pi, pi]."""
    n = particles.shape[0]
    out = np.empty((n, 4))
    for i in range(n):
        psi = particles[i, 3]
        f0 = particles[i, 0] + speed * dt * math.cos(psi)
        f1 = particles[i, 1] + speed * dt * math.sin(psi)
        f2 = particles[i, 2]
        f3 = wrap(psi + omega * dt)
        e0 = noise[i, 0]
        e1 = noise[i, 1]
        e2 = noise[i, 2]
        e3 = noise[i, 3]
        out[i, 0] = f0 + factor[0, 0] * e0 + factor[0, 1] * e1 + factor[0, 2] * e2 + factor[0, 3] * e3
        out[i, 1] = f1 + factor[1, 0] * e0 + factor[1, 1] * e1 + factor[1, 2] * e2 + factor[1, 3] * e3
        out[i, 2] = f2 + factor[2, 0] * e0 + factor[2, 1] * e1 + factor[2, 2] * e2 + factor[2, 3] * e3
        out[i, 3] = wrap(f3 + factor[3, 0] * e0 + factor[3, 1] * e1 + factor[3, 2] * e2 + factor[3, 3] * e3)
    return out
