"""The baseline: bootstrap particle filters written particle by particle, in the lab-code style.

This is how the course's lab reports wrote their filters: a Python ``for`` loop over the
particles for the prediction, the weighting and the resampling, with small NumPy calls
inside (a 3-vector of noise, a 2x2 product), and weights kept in the linear domain.  It is
written here (not copied from any report) only to measure that style's speed: the same
bootstrap filter as :class:`pfcourse.filter.ParticleFilter` with the same settings
(systematic resampling when ``ESS < N / 2``, weighted mean as the estimate), on the same
data.  Use it for ``N <= 1e4`` only.
"""

from __future__ import annotations

import math

import numpy as np


def _systematic_loop(w: np.ndarray, u0: float) -> np.ndarray:
    """Systematic resampling with a while loop: ``u_j = (j + u0) / N`` against the running sum."""
    n = len(w)
    idx = np.empty(n, dtype=np.int64)
    i, c = 0, w[0]
    for j in range(n):
        u = (j + u0) / n
        while u > c and i < n - 1:
            i += 1
            c += w[i]
        idx[j] = i
    return idx


def robot_loop_filter(data: dict, n: int, seed: int) -> np.ndarray:
    """Bootstrap filter of the range-bearing robot, loop style; returns the ``(K, 3)`` weighted means."""
    rng = np.random.default_rng(seed)
    lq = np.linalg.cholesky(data["q_est"])
    r_inv = np.linalg.inv(data["r_est"])
    norm = 1.0 / (2.0 * math.pi * math.sqrt(np.linalg.det(data["r_est"])))
    odo, meas, lms, dt = data["odometry"], data["measurements"], data["landmarks"], float(data["dt"])
    K = len(meas)
    x = np.empty((n, 3))
    w = np.full(n, 1.0 / n)
    means = np.empty((K, 3))
    for k in range(K):
        if k == 0:
            for i in range(n):
                x[i] = data["start"] + data["initial_std"] * rng.standard_normal(3)
                x[i, 2] = (x[i, 2] + math.pi) % (2 * math.pi) - math.pi
        else:
            for i in range(n):
                u = odo[k] + lq @ rng.standard_normal(3)
                th = x[i, 2]
                x[i, 0] += (u[0] * math.cos(th) - u[1] * math.sin(th)) * dt
                x[i, 1] += (u[0] * math.sin(th) + u[1] * math.cos(th)) * dt
                x[i, 2] = (th + u[2] * dt + math.pi) % (2 * math.pi) - math.pi
        if not np.isnan(meas[k, 0]):
            lx, ly = lms[int(meas[k, 0])]
            for i in range(n):
                dx, dy = lx - x[i, 0], ly - x[i, 1]
                nu = np.array([meas[k, 1] - math.hypot(dx, dy),
                               meas[k, 2] - (math.atan2(dy, dx) - x[i, 2])])
                nu[1] = (nu[1] + math.pi) % (2 * math.pi) - math.pi
                w[i] *= norm * math.exp(-0.5 * nu @ r_inv @ nu)
            total = w.sum()
            if total == 0.0:
                raise RuntimeError(f"step {k}: every weight is zero")
            w /= total
        sx = sy = ss = sc = 0.0
        for i in range(n):
            sx += w[i] * x[i, 0]
            sy += w[i] * x[i, 1]
            ss += w[i] * math.sin(x[i, 2])
            sc += w[i] * math.cos(x[i, 2])
        means[k] = sx, sy, math.atan2(ss, sc)
        ess = 1.0 / sum(wi * wi for wi in w)
        if ess < 0.5 * n:
            x = x[_systematic_loop(w, rng.random())]
            w = np.full(n, 1.0 / n)
    return means


def landmark_loop_filter(data: dict, n: int, seed: int) -> np.ndarray:
    """Bootstrap filter of the linear landmark model, loop style; returns the ``(K, d)`` weighted means."""
    rng = np.random.default_rng(seed)
    F, B, H, Z = data["F"], data["B"], data["H"], data["Z"]
    l0 = np.linalg.cholesky(data["P0"])
    eigval, eigvec = np.linalg.eigh(data["Q"])
    lq = eigvec * np.sqrt(np.clip(eigval, 0.0, None))
    d = len(data["m0"])
    K = len(Z)
    x = np.empty((n, d))
    w = np.full(n, 1.0 / n)
    means = np.empty((K, d))
    for k in range(K):
        for i in range(n):
            if k == 0:
                x[i] = data["m0"] + l0 @ rng.standard_normal(d)
            else:
                x[i] = F @ x[i] + B + lq @ rng.standard_normal(d)
        seen = ~np.isnan(Z[k])
        if seen.any():
            h, z = H[seen], Z[k, seen]
            r = data["R"][np.ix_(seen, seen)]
            r_inv = np.linalg.inv(r)
            norm = 1.0 / math.sqrt((2.0 * math.pi) ** len(z) * np.linalg.det(r))
            for i in range(n):
                nu = z - h @ x[i]
                w[i] *= norm * math.exp(-0.5 * nu @ r_inv @ nu)
            total = w.sum()
            if total == 0.0:
                raise RuntimeError(f"step {k}: every weight is zero")
            w /= total
        m = np.zeros(d)
        for i in range(n):
            m += w[i] * x[i]
        means[k] = m
        ess = 1.0 / sum(wi * wi for wi in w)
        if ess < 0.5 * n:
            x = x[_systematic_loop(w, rng.random())]
            w = np.full(n, 1.0 / n)
    return means
