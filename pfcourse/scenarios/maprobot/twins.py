"""The look-alike twins of a drive on the book's map, and how far the scans set the truth apart from them.

The map (:func:`pfcourse.scenarios.maprobot.grid.rooms_and_corridor`) looks the same under a half-turn about its
centre and under shifts by a room's width along the corridor.  A rigid motion ``T`` of the plane
maps the true path ``x_0, ..., x_k`` to a *twin* path ``T x_0, ..., T x_k`` that has exactly the same
odometry increments (they are measured in the robot's frame) and, while it stays in free space, the
same prior density under the uniform start.  The posterior odds of the true path against its twin
are therefore the likelihood ratio of the scans alone:

    log p(x_{0:k} | z_{0:k}, u) - log p(T x_{0:k} | z_{0:k}, u) = sum_{j<=k} [log p(z_j | x_j) - log p(z_j | T x_j)],

and a twin path that enters a wall (or leaves the map) has posterior zero from that step on.
:func:`twin_margin` returns, per step, the log-odds of the true path against all its twins together
(``log p(z | truth) - logsumexp_T log p(z | T path)``, cumulative): where it is large, the evidence
has decided and an exact filter would have its mass on the truth; where it is near zero or
negative, no filter can know.  :data:`TWINS` lists the transforms: the half-turn, the shifts by
5, 10 and 15 m either way, and each shift after the half-turn.
"""

from __future__ import annotations

import numpy as np
from scipy.special import logsumexp

from pfcourse.angles import wrap_angle
from pfcourse.checks import Array
from pfcourse.errors import ShapeError
from pfcourse.scenarios.maprobot.grid import MAP_HEIGHT, MAP_WIDTH, ROOM_WIDTH, OccupancyGrid
from pfcourse.scenarios.maprobot.likelihood_field import LikelihoodField

#: The twins: (half-turn about the map's centre first?, shift along x in metres), the identity left out.
TWINS = tuple((turn, shift) for turn in (False, True) for shift in ROOM_WIDTH * np.arange(-3, 4)
              if turn or shift != 0.0)


def twin_poses(poses: Array, turn: bool, shift: float) -> Array:
    """The poses ``(..., 3)`` moved by the twin transform: the half-turn about the map's centre
    ``(x, y, theta) -> (W - x, H - y, theta + pi)`` if ``turn``, then the shift ``x -> x + shift``."""
    p = np.array(poses, dtype=float)
    if p.shape[-1] != 3:
        raise ShapeError(f"poses must have 3 components (x, y, theta), got shape {p.shape}")
    if turn:
        p[..., 0], p[..., 1], p[..., 2] = MAP_WIDTH - p[..., 0], MAP_HEIGHT - p[..., 1], wrap_angle(p[..., 2] + np.pi)
    p[..., 0] += shift
    return p


def path_log_likelihoods(grid: OccupancyGrid, field: LikelihoodField, path: Array, scans: Array) -> Array:
    """``log p(z_k | x_k)`` of each step of ``path`` ``(K, 3)``, ``-inf`` from the first pose not in free space."""
    ll = np.array([field.log_likelihood(x[None], z)[0] for x, z in zip(path, scans)])
    outside = np.cumsum(~grid.is_free(path)) > 0
    return np.where(outside, -np.inf, ll)


def exact_twin_estimate(grid: OccupancyGrid, field: LikelihoodField, truth: Array, scans: Array) -> Array:
    """The estimate ``(K, 3)`` of an exact filter whose only hypotheses are the true path and its twins:
    masses proportional to each path's ``exp`` cumulative log-likelihood, the weighted mean position and
    the circular mean heading (what a particle filter reports, with the twins' ambiguity and nothing else)."""
    truth, scans = np.asarray(truth, dtype=float), np.asarray(scans, dtype=float)
    if truth.ndim != 2 or truth.shape[1] != 3 or len(scans) != len(truth):
        raise ShapeError(f"truth must be (K, 3) and scans (K, B), got {truth.shape} and {scans.shape}")
    paths = np.array([truth] + [twin_poses(truth, t, s) for t, s in TWINS])
    cum = np.array([np.cumsum(path_log_likelihoods(grid, field, p, scans)) for p in paths])
    w = np.exp(cum - logsumexp(cum, axis=0))
    xy = np.einsum("tk,tkd->kd", w, paths[..., :2])
    heading = np.arctan2((w * np.sin(paths[..., 2])).sum(0), (w * np.cos(paths[..., 2])).sum(0))
    return np.column_stack([xy, heading])


def twin_margin(grid: OccupancyGrid, field: LikelihoodField, truth: Array, scans: Array) -> tuple[Array, Array]:
    """Per step ``k``: the cumulative log-odds of the true path against all its twins together
    (module docstring), and against the best twin alone (``(K,)`` each)."""
    truth, scans = np.asarray(truth, dtype=float), np.asarray(scans, dtype=float)
    if truth.ndim != 2 or truth.shape[1] != 3 or len(scans) != len(truth):
        raise ShapeError(f"truth must be (K, 3) and scans (K, B), got {truth.shape} and {scans.shape}")
    own = np.cumsum(path_log_likelihoods(grid, field, truth, scans))
    twins = np.array([np.cumsum(path_log_likelihoods(grid, field, twin_poses(truth, t, s), scans))
                      for t, s in TWINS])
    return own - logsumexp(twins, axis=0), own - twins.max(axis=0)
