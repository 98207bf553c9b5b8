"""The fully adapted auxiliary particle filter (Pitt and Shephard 1999), as a proposal.

When the predictive likelihood ``p(z_k | x_{k-1})`` and the optimal importance function
``p(x_k | x_{k-1}, z_k)`` are both known in closed form (a linear-Gaussian model, or the
robot of a Rao-Blackwellised filter), the auxiliary filter *first* resamples the parents
with probabilities proportional to ``W_{k-1}^i p(z_k | x_{k-1}^i)`` and *then* moves each
chosen parent with the optimal importance function.  The new weights are all equal:

.. math::

   a^i = \\log p(z_k \\mid x_{k-1}^i), \\qquad A^i \\sim \\mathrm{Cat}\\big(e^{a^i} / \\textstyle\\sum_j e^{a^j}\\big),
   \\qquad x_k^i \\sim p(x_k \\mid x_{k-1}^{A^i}, z_k), \\qquad
   \\hat p(z_k \\mid z_{0:k-1}) = \\frac1N \\sum_i e^{a^i}.

Compared with SIR and the same optimal importance function, the cloud is resampled
*before* the move, so no two children of a duplicated parent coincide.  It runs in the
engine as a :class:`~pfcourse.filter.Proposal` that returns the constant incremental
weight ``log (1/N) sum_i e^{a^i}`` for every particle; the engine must hand it uniform
weights, so use it with ``threshold=1`` (resample whenever the weights are not uniform,
which then never happens after the first measured step).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pfcourse.checks import Array
from pfcourse.gaussian import gaussian_logpdf
from pfcourse.linear_gaussian import LinearGaussianModel
from pfcourse.proposals import OptimalProposal
from pfcourse.resampling import get_resampler


class LinearGaussianOptimal(OptimalProposal):
    """:class:`~pfcourse.proposals.OptimalProposal` with its predictive likelihood exposed."""

    def log_predictive(self, model: LinearGaussianModel, particles: Array, z: Array, k: int) -> Array:
        """``log N(z_k; H (F x_{k-1} + B), H Q H^T + R)`` per particle (observed rows only)."""
        mask, z_o, H_o, R_o = model.observed(z)
        if not mask.any():
            return np.zeros(particles.shape[0])
        innovation = z_o - model.predict_mean(particles) @ H_o.T
        return gaussian_logpdf(innovation, H_o @ model.Q @ H_o.T + R_o)


class FullyAdaptedAuxiliary:
    """Auxiliary resampling then the optimal move (see the module docstring).

    ``inner`` provides ``log_predictive(model, particles, z, k)`` and a fully adapted
    ``propose`` (its incremental weight is that predictive likelihood, whatever is drawn):
    :class:`LinearGaussianOptimal`, or :class:`~pfcourse.landmarks.rao_blackwell.RaoBlackwellProposal`
    with ``optimal=True``.  ``first_stage_ess`` records ``1 / sum_i (W^i)^2`` of the
    first-stage weights at each measured step (the engine's ESS is then always ``N``).
    """

    def __init__(self, inner, resampler: str | Callable = "systematic") -> None:
        self.inner = inner
        self.resampler = get_resampler(resampler)
        self.first_stage_ess: list[float] = []

    def propose(self, model, particles: Array, z: Array, k: int, rng: np.random.Generator):
        n = particles.shape[0]
        a = np.asarray(self.inner.log_predictive(model, particles, z, k), dtype=float)
        top = a.max()
        w = np.exp(a - top)
        total = w.sum()
        w /= total
        self.first_stage_ess.append(float(1.0 / np.sum(w**2)))
        parents = particles[self.resampler(w, rng)]
        new, _ = self.inner.propose(model, parents, z, k, rng)
        return new, np.full(n, top + np.log(total) - np.log(n))
