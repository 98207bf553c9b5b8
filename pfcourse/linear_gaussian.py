"""The linear-Gaussian state-space model, as a particle-filter model.

.. math::

   x_0 \\sim \\mathcal N(m_0, P_0), \\qquad
   x_k = F x_{k-1} + B + w_k,\\ w_k \\sim \\mathcal N(0, Q), \\qquad
   z_k = H x_k + v_k,\\ v_k \\sim \\mathcal N(0, R).

NaN entries of ``z_k`` mean "not observed": the likelihood then uses only the
observed rows, ``p(z_k | x_k) = N(z_{k,o}; H_o x_k, R_{oo})`` with ``H_o`` the rows
of ``H`` and ``R_{oo}`` the block of ``R`` of the observed entries.  For this model
the Kalman filter is exact (:mod:`pfcourse.kalman`), and so is the optimal
importance function ``p(x_k | x_{k-1}, z_k)`` (:class:`pfcourse.proposals.OptimalProposal`).
"""

from __future__ import annotations

import numpy as np

from pfcourse.checks import as_matrix, as_vector, check_covariance, covariance_factor
from pfcourse.errors import ShapeError
from pfcourse.gaussian import gaussian_logpdf


class LinearGaussianModel:
    """Linear dynamics and measurements with additive Gaussian noise (see module docstring).

    All arrays are checked when the model is built, each error naming its parameter: real
    and finite entries; shapes that agree with ``dim_x = len(m0) >= 1``; ``P0``, ``Q``, ``R``
    symmetric positive semi-definite (``R`` definite).
    """

    def __init__(self, F, H, m0, P0, Q, R, B=None) -> None:
        self.m0 = as_vector(m0, "m0", finite=True)
        d = self.m0.shape[0]
        if d == 0:
            raise ShapeError("m0 must have one entry per state (dim_x >= 1), got an empty vector")
        self.dim_x = d
        self.F = as_matrix(F, "F", (d, d), finite=True)
        self.B = np.zeros(d) if B is None else as_vector(B, "B", d, finite=True)
        self.H = as_matrix(H, "H", finite=True)
        if self.H.shape[1] != d or self.H.shape[0] == 0:
            raise ShapeError(f"H must have {d} columns (one per state) and at least one row, got shape {self.H.shape}")
        self.dim_z = self.H.shape[0]
        self.P0 = check_covariance(P0, "P0", d)
        self.Q = check_covariance(Q, "Q", d)
        self.R = check_covariance(R, "R", self.dim_z, definite=True)
        self._P0_factor = covariance_factor(self.P0)
        self._Q_factor = covariance_factor(self.Q)

    def sample_initial(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``x_0^i = m_0 + L_0 e_i`` with ``L_0 L_0^T = P_0``, ``e_i ~ N(0, I)``."""
        return self.m0 + rng.standard_normal((n, self.dim_x)) @ self._P0_factor.T

    def predict_mean(self, particles: np.ndarray) -> np.ndarray:
        """``F x + B`` for every row of ``particles``."""
        return particles @ self.F.T + self.B

    def sample_transition(self, particles: np.ndarray, k: int, rng: np.random.Generator):
        """``x_k^i = F x_{k-1}^i + B + L_Q e_i``."""
        noise = rng.standard_normal(particles.shape) @ self._Q_factor.T
        return self.predict_mean(particles) + noise

    def transition_log_density(self, new: np.ndarray, old: np.ndarray, k: int) -> np.ndarray:
        """``log N(x_k; F x_{k-1} + B, Q)`` (``Q`` must then be positive definite)."""
        return gaussian_logpdf(new - self.predict_mean(old), self.Q, "transition_log_density: process noise covariance Q")

    def observed(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Split ``z`` into its observed part: ``(mask, z_o, H_o, R_oo)``."""
        z = as_vector(z, "z", self.dim_z)
        mask = ~np.isnan(z)
        return mask, z[mask], self.H[mask], self.R[np.ix_(mask, mask)]

    def log_likelihood(self, particles: np.ndarray, z: np.ndarray, k: int) -> np.ndarray:
        """``log N(z_o; H_o x, R_oo)`` per particle; 0 when nothing is observed."""
        mask, z_o, H_o, R_o = self.observed(z)
        if not mask.any():
            return np.zeros(particles.shape[0])
        return gaussian_logpdf(z_o - particles @ H_o.T, R_o)
