"""Posterior Cramér-Rao bound (PCRB) of terrain navigation.

Tichavsky, Muravchik and Nehorai (1998) give the Bayesian information matrix ``J_k`` of the
state ``x_k`` of ``x_{k+1} = f(x_k) + w_k``, ``w_k ~ N(0, Q)``, ``y_k = g(x_k) + v_k``,
``v_k ~ N(0, R)`` by the recursion

    J_{k+1} = D22_k - D21_k (J_k + D11_k)^{-1} D12_k,
    D11_k = E[F_k^T Q^{-1} F_k],  D12_k = D21_k^T = -E[F_k^T] Q^{-1},
    D22_k = Q^{-1} + E[H_{k+1}^T R^{-1} H_{k+1}]   (no second term without a reading),

with ``F_k = df/dx(x_k)``, ``H_k = dg/dx(x_k)``, ``J_0 = P_0^{-1}``; any unbiased-in-the-Bayesian-
sense estimator has ``E[(x^_k - x_k)(x^_k - x_k)^T] >= J_k^{-1}``.  For terrain navigation
(Bergman 1999) ``H_k = [-dh/dx, -dh/dy, 1, 0]`` is the DEM's gradient along the flight: the
expectations are averages over flights (:func:`terrain_pcrb` with several flights), or one
flight's trajectory (the bound conditioned on that flight, as Bergman plots it).
In the linear-Gaussian case the recursion gives exactly the Kalman filter's covariance
(tests/test_terrain_pcrb.py).
"""

from __future__ import annotations

import numpy as np

from pfcourse.checks import Array
from pfcourse.errors import ShapeError
from pfcourse.metrics import position_spread
from pfcourse.scenarios.terrain.scenario import AircraftScenario, dynamics_jacobian, measurement_jacobian


def pcrb_recursion(J0: Array, F: Array, Q: Array, H: Array, R: Array, measured: Array) -> Array:
    """Bounds ``J_k^{-1}`` ``(K, d, d)`` from the recursion above.

    ``F`` ``(M, K, d, d)``: Jacobian of ``f`` at ``x_k`` of each of ``M`` trajectories (row ``k``
    maps ``k`` to ``k + 1``; the last is unused); ``H`` ``(M, K, m, d)``; ``measured`` ``(K,)``.
    Expectations are averages over the ``M`` trajectories.
    """
    F = np.asarray(F, dtype=float)
    H = np.asarray(H, dtype=float)
    if F.ndim != 4 or H.ndim != 4 or F.shape[:2] != H.shape[:2]:
        raise ShapeError(f"F must be (M, K, d, d) and H (M, K, m, d), got {F.shape} and {H.shape}")
    M, K, d, _ = F.shape
    Qi = np.linalg.inv(Q)
    Ri = np.linalg.inv(np.atleast_2d(R))
    J = np.asarray(J0, dtype=float)
    out = np.empty((K, d, d))
    info = lambda k: np.mean(np.einsum("mij,jk,mkl->mil", H[:, k].transpose(0, 2, 1), Ri, H[:, k]), axis=0)
    if measured[0]:
        J = J + info(0)
    out[0] = np.linalg.inv(J)
    for k in range(K - 1):
        Fk = F[:, k]
        D11 = np.mean(np.einsum("mji,jk,mkl->mil", Fk, Qi, Fk), axis=0)
        D12 = -np.mean(Fk, axis=0).T @ Qi
        D22 = Qi + (info(k + 1) if measured[k + 1] else 0.0)
        J = D22 - D12.T @ np.linalg.solve(J + D11, D12)
        J = 0.5 * (J + J.T)
        out[k + 1] = np.linalg.inv(J)
    return out


def terrain_pcrb(scenario: AircraftScenario, terrain, trajectories: Array) -> Array:
    """PCRB ``(K, 4, 4)`` of scenario B along true trajectories ``(M, K, 4)`` (or one ``(K, 4)``).

    Uses the filter's model: ``Q = Qf dt``, ``R = Rf``, ``J_0 = P0^{-1}``.
    """
    X = np.asarray(trajectories, dtype=float)
    if X.ndim == 2:
        X = X[None]
    M, K, _ = X.shape
    F = np.array([[dynamics_jacobian(x, scenario.speed, scenario.dt) for x in traj] for traj in X])
    H = np.array([[measurement_jacobian(x, terrain) for x in traj] for traj in X])
    return pcrb_recursion(np.linalg.inv(scenario.P0), F, scenario.Qf * scenario.dt, H,
                          np.array([[scenario.Rf]]), scenario.measured())


def horizontal_bound(bound: Array) -> Array:
    """``sqrt(B_xx + B_yy)``: the bound on the horizontal RMS error (m) per step."""
    return position_spread(bound)


def deterministic_bound(J0: Array, F: Array, H: Array, R: Array, measured: Array) -> Array:
    """The bound ``J_k^{-1}`` ``(K, d, d)`` of one trajectory of noise-free dynamics (``Q = 0``).

    The limit ``Q -> 0`` of the recursion, for invertible ``F_k``:
    ``J_{k+1} = F_k^{-T} J_k F_k^{-1} + H_{k+1}^T R^{-1} H_{k+1}``.  ``F`` ``(K, d, d)``, ``H`` ``(K, m, d)``.
    This is the bound for the flights as simulated (the true aircraft has no process noise).
    """
    Ri = np.linalg.inv(np.atleast_2d(R))
    K, d, _ = F.shape
    J = np.asarray(J0, dtype=float) + (H[0].T @ Ri @ H[0] if measured[0] else 0.0)
    out = np.empty((K, d, d))
    out[0] = np.linalg.inv(J)
    for k in range(K - 1):
        Fi = np.linalg.inv(F[k])
        J = Fi.T @ J @ Fi + (H[k + 1].T @ Ri @ H[k + 1] if measured[k + 1] else 0.0)
        J = 0.5 * (J + J.T)
        out[k + 1] = np.linalg.inv(J)
    return out


def terrain_bound_noise_free(scenario: AircraftScenario, terrain, trajectory: Array) -> Array:
    """:func:`deterministic_bound` of scenario B along one true trajectory ``(K, 4)`` (``R = Rf``)."""
    X = np.asarray(trajectory, dtype=float)
    F = np.array([dynamics_jacobian(x, scenario.speed, scenario.dt) for x in X])
    H = np.array([measurement_jacobian(x, terrain) for x in X])
    return deterministic_bound(np.linalg.inv(scenario.P0), F, H, np.array([[scenario.Rf]]), scenario.measured())


def weighted_pcrb_recursion(J0: Array, F: Array, Q: Array, H: Array, R: Array, measured: Array,
                            weights: Array) -> Array:
    """:func:`pcrb_recursion` with the expectations weighted, for many weightings at once.

    ``weights`` ``(B, M)``: row ``b`` weighs the ``M`` trajectories (e.g. the counts of a bootstrap
    resample; each row is normalised to sum to one).  Returns the bounds ``(B, K, d, d)``; a row of
    equal weights gives :func:`pcrb_recursion`.  Used for the bootstrap interval of a bound whose
    expectation is estimated from the same flights as the error it is compared with.
    """
    F = np.asarray(F, dtype=float)
    H = np.asarray(H, dtype=float)
    W = np.atleast_2d(np.asarray(weights, dtype=float))
    if F.ndim != 4 or H.ndim != 4 or F.shape[:2] != H.shape[:2] or W.shape[1] != F.shape[0]:
        raise ShapeError(f"F must be (M, K, d, d), H (M, K, m, d) and weights (B, M), got {F.shape}, {H.shape} "
                         f"and {W.shape}")
    if np.any(W < 0) or np.any(W.sum(axis=1) <= 0):
        raise ShapeError("weights must be non-negative with a positive sum in every row")
    W = W / W.sum(axis=1, keepdims=True)
    M, K, d, _ = F.shape
    Qi = np.linalg.inv(Q)
    Ri = np.linalg.inv(np.atleast_2d(R))
    info = np.einsum("mkji,jl,mkln->mkin", H, Ri, H)  # H^T R^-1 H per trajectory and step
    FQF = np.einsum("mkji,jl,mkln->mkin", F, Qi, F)
    avg = lambda A: np.einsum("bm,mij->bij", W, A)  # weighted mean over the trajectories, per weighting
    J = np.broadcast_to(np.asarray(J0, dtype=float), (len(W), d, d)).copy()
    out = np.empty((len(W), K, d, d))
    if measured[0]:
        J = J + avg(info[:, 0])
    out[:, 0] = np.linalg.inv(J)
    for k in range(K - 1):
        D11 = avg(FQF[:, k])
        D12 = -np.swapaxes(avg(F[:, k]), 1, 2) @ Qi
        D22 = Qi + (avg(info[:, k + 1]) if measured[k + 1] else 0.0)
        J = D22 - np.swapaxes(D12, 1, 2) @ np.linalg.solve(J + D11, D12)
        J = 0.5 * (J + np.swapaxes(J, 1, 2))
        out[:, k + 1] = np.linalg.inv(J)
    return out
