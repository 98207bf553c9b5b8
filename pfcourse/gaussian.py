"""The multivariate normal log-density, vectorized over many points.

Used by every Gaussian measurement model: for residuals ``r_i`` (rows of an
``(n, d)`` array) and a covariance ``S``,

.. math::

   \\log \\mathcal N(r; 0, S) = -\\tfrac12 \\left( r^T S^{-1} r + \\log\\det S + d \\log 2\\pi \\right),

computed through the Cholesky factor ``S = L L^T`` so that
``r^T S^{-1} r = \\|L^{-1} r\\|^2`` and ``\\log\\det S = 2 \\sum_j \\log L_{jj}``.
It agrees with :func:`scipy.stats.multivariate_normal.logpdf` (tested) and is
several times faster for the small ``d`` and large ``n`` of particle filters.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_triangular

from pfcourse.errors import CovarianceError

LOG_2PI = float(np.log(2.0 * np.pi))


def gaussian_logpdf(residuals: np.ndarray, cov: np.ndarray, name: str = "measurement covariance") -> np.ndarray:
    """Log-density of ``N(0, cov)`` at each row of ``residuals`` (shape ``(n, d)``); ``name``
    names ``cov`` in the error raised when it is not positive definite."""
    residuals = np.atleast_2d(residuals)
    d = residuals.shape[-1]
    try:
        chol = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError as exc:
        raise CovarianceError(
            f"{name} is not positive definite, the Gaussian density is undefined"
        ) from exc
    whitened = solve_triangular(chol, residuals.T, lower=True, check_finite=False)
    mahalanobis = np.einsum("ij,ij->j", whitened, whitened)
    log_det = 2.0 * float(np.sum(np.log(np.diag(chol))))
    return -0.5 * (mahalanobis + log_det + d * LOG_2PI)
