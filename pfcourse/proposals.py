"""Importance functions (proposals) for the particle filter, beyond the model's transition.

A proposal has ``propose(model, particles, z, k, rng) -> (new_particles, log_increment)``:
it draws ``x_k`` from ``q(x_k | x_{k-1}, z_k)`` and returns the log of the incremental weight
``p(z_k | x_k) f(x_k | x_{k-1}) / q(x_k | x_{k-1}, z_k)``.

* :class:`OptimalProposal` - the optimal importance function ``p(x_k | x_{k-1}, z_k)`` of a
  linear-Gaussian model (:class:`~pfcourse.linear_gaussian.LinearGaussianModel`).
"""

from __future__ import annotations

import numpy as np

from pfcourse.checks import covariance_factor
from pfcourse.gaussian import gaussian_logpdf
from pfcourse.linear_gaussian import LinearGaussianModel


class OptimalProposal:
    """The optimal importance function ``q = p(x_k | x_{k-1}, z_k)`` of a linear-Gaussian model.

    With ``m = F x_{k-1} + B``, ``S = H Q H^T + R`` and ``K = Q H^T S^{-1}``
    (observed rows only):

    .. math::

       p(x_k | x_{k-1}, z_k) = \\mathcal N(m + K (z_k - H m),\\ (I - K H) Q), \\qquad
       w_k \\propto w_{k-1}\\, p(z_k | x_{k-1}) = w_{k-1}\\, \\mathcal N(z_k; H m, S).

    The incremental weight does not depend on the sampled ``x_k``: this is the
    proposal that minimises the variance of the weights (Doucet, Godsill and
    Andrieu 2000).  The gain form stays accurate when ``Q`` is nearly singular.
    """

    def propose(self, model: LinearGaussianModel, particles, z, k, rng):
        mask, z_o, H_o, R_o = model.observed(z)
        predicted = model.predict_mean(particles)
        if not mask.any():
            return model.sample_transition(particles, k, rng), np.zeros(particles.shape[0])
        S = H_o @ model.Q @ H_o.T + R_o
        gain = np.linalg.solve(S, H_o @ model.Q).T
        cov = model.Q - gain @ S @ gain.T
        innovation = z_o - predicted @ H_o.T
        mean = predicted + innovation @ gain.T
        noise = rng.standard_normal(particles.shape) @ covariance_factor(0.5 * (cov + cov.T)).T
        return mean + noise, gaussian_logpdf(innovation, S)
