"""Importance functions (proposals) for the particle filter, all in this module.

A proposal has ``propose(model, particles, z, k, rng) -> (new_particles, log_increment)``:
it draws ``x_k`` from ``q(x_k | x_{k-1}, z_k)`` and returns the log of the incremental weight
``p(z_k | x_k) f(x_k | x_{k-1}) / q(x_k | x_{k-1}, z_k)`` (the protocol,
:class:`~pfcourse.filter.Proposal`, is the engine's, in :mod:`pfcourse.filter`).

**The transition** ``p(x_k | x_{k-1})`` (the bootstrap filter's, the engine's default):
:class:`TransitionProposal`.  **Any density** given by a sampler and its log-density:
:class:`DensityProposal` (the model must then provide ``transition_log_density``).

**The optimal importance function** ``p(x_k | x_{k-1}, z_k)`` of a linear-Gaussian model
(:class:`~pfcourse.linear_gaussian.LinearGaussianModel`): :class:`OptimalProposal`, and
:class:`LinearGaussianOptimal`, which also gives the predictive likelihood ``p(z_k | x_{k-1})``.

**The fully adapted auxiliary particle filter** (Pitt and Shephard 1999), :class:`FullyAdaptedAuxiliary`.
When the predictive likelihood ``p(z_k | x_{k-1})`` and the optimal importance function
``p(x_k | x_{k-1}, z_k)`` are both known in closed form (a linear-Gaussian model, or the
robot of a Rao-Blackwellised filter), the auxiliary filter *first* resamples the parents
with probabilities proportional to ``W_{k-1}^i p(z_k | x_{k-1}^i)`` and *then* moves each
chosen parent with the optimal importance function.  It is SIR on the extended target
``pi(a, x_k)``, proportional to ``W_{k-1}^a p(z_k | x_{k-1}^a) p(x_k | x_{k-1}^a, z_k)``, of the
ancestor and the new state (Johansen and Doucet 2008), whose marginal in ``x_k`` is the filtering density; drawn
from exactly that target, the new particles are equally weighted:

.. math::

   \\beta^i \\propto W_{k-1}^i\\, p(z_k \\mid x_{k-1}^i), \\qquad A^i \\sim \\mathrm{Cat}(\\beta),
   \\qquad x_k^i \\sim p(x_k \\mid x_{k-1}^{A^i}, z_k), \\qquad
   \\hat p(z_k \\mid z_{0:k-1}) = \\sum_i W_{k-1}^i\\, p(z_k \\mid x_{k-1}^i).

Compared with SIR and the same optimal importance function (whose weights are the same
``W_{k-1}^i p(z_k | x_{k-1}^i)``), only the order changes: resample, then move, so each copy
of a parent gets its own move instead of being a duplicate of one moved particle.  It runs in
the engine as a :class:`~pfcourse.filter.Proposal` that draws the ancestors itself
(``draws_ancestors = True``): the engine hands it the cloud's log-weights ``log W_{k-1}^i``, and
it returns the new particles, the increment ``log p^(z_k | z_{0:k-1})`` of every slot and the
ancestors ``A^i`` it drew; the engine gives the children equal weights whatever the resampling
threshold left in ``W_{k-1}``, and records the ancestors (the genealogy).

**Progressive correction** (Oudjane and Musso 2000), as an importance function
(:class:`ProgressiveCorrection`): at the first ``n_tempered`` readings the likelihood
is brought in by powers ``l(x)^{lambda_1}, ..., l(x)^{lambda_m}`` with
``lambda_1 + ... + lambda_m = 1``; each ``lambda_j`` is the largest that keeps the effective
sample size of the stage at ``ess_fraction N`` or more (bisection), and between stages the
cloud is resampled and regularised.  The final stage's weights ``l^{lambda_m}`` are returned,
so the target of the last stage is ``p(z | x) p(x | z_{0:k-1})``, the posterior.  Each stage
restarts from equal weights, so the engine must hand it an equally weighted cloud: use it
with ``threshold=1`` (resample whenever the weights are not uniform).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from pfcourse.checks import Array, check_log_terms, check_particles, covariance_factor
from pfcourse.errors import ModelError, ParameterError
from pfcourse.gaussian import gaussian_logpdf
from pfcourse.jitter import RegularisedJitter
from pfcourse.kernels import gather_rows
from pfcourse.linear_gaussian import LinearGaussianModel
from pfcourse.resampling import get_resampler


class TransitionProposal:
    """The prior as importance function: ``q = p(x_k | x_{k-1})``, so ``log_inc = log p(z_k | x_k)``."""

    def propose(self, model, particles, z, k, rng):
        new = model.sample_transition(particles, k, rng)
        return new, model.log_likelihood(new, z, k)


@dataclass(frozen=True)
class DensityProposal:
    """Any importance function given by a sampler and its log-density.

    ``sample(particles, z, k, rng)`` draws ``x_k^i ~ q(. | x_{k-1}^i, z_k)`` and
    ``log_density(new, particles, z, k)`` returns ``log q(x_k^i | x_{k-1}^i, z_k)``.
    The model must provide ``transition_log_density``.
    """

    sample: Callable[[Array, Array, int, np.random.Generator], Array]
    log_density: Callable[[Array, Array, Array, int], Array]

    def propose(self, model, particles, z, k, rng):
        transition_log_density = getattr(model, "transition_log_density", None)
        if transition_log_density is None:
            raise ModelError(
                f"step {k}: DensityProposal needs model.transition_log_density(new, old, k) to weight "
                "the particles"
            )
        new = check_particles(self.sample(particles, z, k, rng), particles.shape, k, "DensityProposal.sample")
        n = len(particles)
        terms = [
            (model.log_likelihood(new, z, k), "model.log_likelihood"),
            (transition_log_density(new, particles, k), "model.transition_log_density"),
            (self.log_density(new, particles, z, k), "DensityProposal.log_density"),
        ]
        log_lik, log_p, log_q = (check_log_terms(term, n, k, source) for term, source in terms)
        with np.errstate(invalid="ignore"):  # inf - inf: NaN, refused by the filter's check of the increments
            return new, log_lik + log_p - log_q


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
    :class:`LinearGaussianOptimal`, or :class:`~pfcourse.scenarios.landmarks.rao_blackwell.RaoBlackwellProposal`
    with ``optimal=True``.  ``stage_ess`` is ``1 / sum_i (beta^i)^2`` of the first-stage weights of
    the step in progress (NaN before the first; the engine's ESS is then always ``N``), which the
    collector :class:`FirstStageESS` records at every step (the proposal keeps no record of a run).

    It reads the weights of the cloud it moves (``draws_ancestors``), so it is right at any
    resampling threshold: with equal weights ``W_{k-1}^i = 1/N`` (``threshold=1``, or no
    measurement at step 0) the first stage is ``p(z_k | x_{k-1}^i)`` alone, and every slot
    gets the increment ``log (1/N) sum_i p(z_k | x_{k-1}^i)``.  In the engine
    (:meth:`propose_with_ancestors`) it reports the ancestors it drew, which the run records
    (:attr:`pfcourse.filter.Step.parents`; the ``resampled`` flag and the
    :class:`~pfcourse.collectors.Ancestors` lines of the step before), and all ``N`` children
    are kept, equally weighted, even when some ``W_{k-1}^i`` are zero.
    """

    draws_ancestors = True

    def __init__(self, inner, resampler: str | Callable = "systematic") -> None:
        self.inner = inner
        self.resampler = get_resampler(resampler)
        self._stage_ess = float("nan")  # private: the state of a run, not a setting (filter_config.describe)

    @property
    def stage_ess(self) -> float:
        """``1 / sum_i (beta^i)^2`` of the last first stage drawn in this run (NaN before the first)."""
        return self._stage_ess

    def start(self) -> None:
        """Called by the filter before step 0 of every run: no first stage drawn yet."""
        self._stage_ess = float("nan")

    def _select_and_move(self, model, particles: Array, z: Array, k: int, rng: np.random.Generator,
                         log_weights: Array | None):
        """The first stage and the move: ``(x_k, ancestors, log p^(z_k | z_{0:k-1}), equal)``."""
        n = particles.shape[0]
        a = np.asarray(self.inner.log_predictive(model, particles, z, k), dtype=float)
        equal = log_weights is None or bool(np.all(log_weights == log_weights[0]))
        if not equal:
            a = a + log_weights  # log W_{k-1}^i + log p(z_k | x_{k-1}^i)
        top = a.max()
        w = np.exp(a - top)
        total = w.sum()
        w /= total
        self._stage_ess = float(1.0 / np.sum(w**2))
        ancestors = np.asarray(self.resampler(w, rng))
        new, _ = self.inner.propose(model, particles[ancestors], z, k, rng)
        # log sum_i W_{k-1}^i p(z_k | x_{k-1}^i), with W_{k-1}^i = 1/N when the weights are equal
        log_evidence = top + np.log(total) - np.log(n) if equal else top + np.log(total)
        return new, ancestors, log_evidence, equal

    def propose_with_ancestors(self, model, particles: Array, z: Array, k: int, rng: np.random.Generator,
                               log_weights: Array | None = None):
        """The engine's hook: ``(x_k, log inc_k, ancestors)``, ``x_k^i`` moved from ``x_{k-1}^{ancestors[i]}``.

        Every one of the ``N`` children is kept, and every slot gets the same increment
        ``log p^(z_k | z_{0:k-1}) = log sum_i W_{k-1}^i p(z_k | x_{k-1}^i)``: the children are drawn
        from the extended target, so they are equally weighted, and the engine gives them the
        weights ``1/N`` (it resets unequal ``W_{k-1}``; equal ones it keeps as they are).
        """
        new, ancestors, log_evidence, _ = self._select_and_move(model, particles, z, k, rng, log_weights)
        return new, np.full(particles.shape[0], log_evidence), ancestors

    def propose(self, model, particles: Array, z: Array, k: int, rng: np.random.Generator,
                log_weights: Array | None = None):
        """``(x_k, log inc_k)`` for increments added to ``log W_{k-1}`` (equal if ``None``), used alone.

        The engine calls :meth:`propose_with_ancestors` instead.  Here slot ``i`` gets
        ``log p^(z_k | z_{0:k-1}) - log M - log W_{k-1}^i`` over the ``M`` slots of positive weight;
        a slot of weight zero cannot carry a child, so when ``M < N``, ``M`` of the ``N``
        children, chosen at random, fill the live slots (the others are lost).
        """
        n = particles.shape[0]
        new, _, log_evidence, equal = self._select_and_move(model, particles, z, k, rng, log_weights)
        if equal:  # log (1/N) sum_i p(z_k | x_{k-1}^i), the same for every slot
            return new, np.full(n, log_evidence)
        live = log_weights > -np.inf
        m = int(live.sum())
        log_inc = np.full(n, -np.inf)
        log_inc[live] = log_evidence - np.log(m) - log_weights[live]
        if m < n:
            new = new.copy()
            new[live] = new[rng.permutation(n)[:m]]
        return new, log_inc


class FirstStageESS:
    """Collector ``first_stage_ess`` ``(K,)``: the ESS ``1 / sum_i (beta^i)^2`` of the first-stage weights of a
    :class:`FullyAdaptedAuxiliary` proposal at each step that drew its ancestors (:attr:`pfcourse.filter.Step.parents`),
    NaN at the others (step 0, a missing measurement).  Reported by the step as it runs, not read from the
    proposal after the run.  Refuses a filter whose proposal is not fully adapted auxiliary, or whose ``N``
    varies (its batches each draw a first stage)."""

    name = "first_stage_ess"

    def start(self, pf, n_steps: int) -> None:
        if not isinstance(pf.proposal, FullyAdaptedAuxiliary):
            raise ParameterError(f"the collector {self.name!r} needs FullyAdaptedAuxiliary as the filter's proposal, "
                                 f"got {type(pf.proposal).__name__}")
        if pf.sample_size is not None:
            raise ParameterError(f"the collector {self.name!r} needs a fixed number of particles "
                                 "(this filter has a sample_size policy)")
        self.proposal, self.values = pf.proposal, np.full(n_steps, np.nan)

    def collect(self, step) -> None:
        if step.parents is not None:  # the proposal's first stage drew this step's parents
            self.values[step.k] = self.proposal.stage_ess

    def result(self) -> Array:
        return self.values


def tempering_exponent(loglik: Array, remaining: float, ess_fraction: float) -> float:
    """Largest ``lam`` in ``(0, remaining]`` with ESS of weights ``exp(lam * loglik)`` >= ``ess_fraction N``."""
    n = loglik.size
    finite = np.isfinite(loglik)
    if not finite.any():
        return remaining
    ll = np.where(finite, loglik, -np.inf)

    def ess(lam):
        a = lam * ll
        a = a - np.max(a)
        w = np.exp(a)
        return w.sum() ** 2 / np.sum(w * w)

    if ess(remaining) >= ess_fraction * n:
        return remaining
    lo, hi = 0.0, remaining
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if ess(mid) >= ess_fraction * n:
            lo = mid
        else:
            hi = mid
    return max(lo, 1e-12)


@dataclass
class ProgressiveCorrection:
    """Importance function doing progressive correction at the first ``n_tempered`` readings.

    Afterwards it is the transition (bootstrap).  ``propose`` returns ``(x_k, log_inc, stages)``:
    how many times it weighted the cloud (the price in particle-steps), which the filter's step
    reports (:attr:`pfcourse.filter.Step.stages`, collected by :class:`pfcourse.collectors.Stages`).
    """

    n_tempered: int = 5
    ess_fraction: float = 0.5
    kernel: RegularisedJitter = field(default_factory=lambda: RegularisedJitter(0.5, (3,)))
    max_stages: int = 50
    _seen: int = 0

    def start(self) -> None:
        """Called by the filter before step 0 of every run: the next reading is the first one tempered."""
        self._seen = 0

    def propose(self, model, particles, z, k, rng):
        new = model.sample_transition(particles, k, rng)
        loglik = model.log_likelihood(new, z, k)
        self._seen += 1
        if self._seen > self.n_tempered:
            return new, loglik, 1
        remaining, constant, n_stages = 1.0, 0.0, 1
        while True:
            lam = tempering_exponent(loglik, remaining, self.ess_fraction)
            if lam >= remaining or n_stages >= self.max_stages:
                return new, remaining * loglik + constant, n_stages
            a = lam * loglik
            top = np.max(a)
            w = np.exp(a - top)
            constant += top + np.log(np.mean(w))
            idx = rng.choice(len(w), size=len(w), p=w / w.sum())
            new = self.kernel(gather_rows(new, idx), rng)
            remaining -= lam
            loglik = model.log_likelihood(new, z, k)
            n_stages += 1
