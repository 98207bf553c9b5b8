"""Conditional SMC with ancestor sampling, and particle Gibbs, on the engine's own filter.

**Conditional SMC** (Andrieu, Doucet and Holenstein 2010) is a particle filter in which one
particle, here particle ``0``, is not drawn but set to a given *reference path*
``x*_{0:K-1}``; the other ``N - 1`` particles are drawn as usual.  At the end one path is drawn
from the final weights and traced back through the ancestors: that path is the next reference.
The map ``x* -> new path`` leaves the smoothing distribution ``p(x_{0:K-1} | z)`` invariant for
every ``N >= 2``.

**Ancestor sampling** (Lindsten, Jordan and Schön 2014): at each resampling, the reference
particle's ancestor is not kept but drawn,

.. math::

   P(A_k^0 = j) \\propto W_{k-1}^j\\, p(x^*_k \\mid x_{k-1}^j),

so the reference's past is renewed and the chain mixes even when the filter's ancestral
lines degenerate.

Both are the engine (:class:`pfcourse.filter.ParticleFilter`) with two pieces added, no second
loop: :class:`ReferenceModel` pins particle ``0`` to the reference (at step 0 and at steps without
a measurement, where nothing is resampled) and :class:`AncestorSamplingProposal`, a proposal
that draws the ancestors itself (the engine's ``draws_ancestors`` hook, as the auxiliary filter):
multinomial ancestors for particles ``1..N-1``, the ancestor-sampling draw for particle ``0``,
then the transition.  The filter runs with ``threshold = 0`` (the proposal resamples at every
measured step).  :func:`conditional_smc` returns the new path; :func:`particle_gibbs`
alternates it with a draw of a parameter given the path.

:func:`noise_scale_draw` is that draw for a scale ``theta`` of the measurement noise
``R = theta R_0`` of a linear-Gaussian model under a prior flat in ``log theta`` on
``[a, b]``: ``theta | x, z`` is inverse-gamma, ``IG(m / 2, S / 2)`` truncated to ``[a, b]``,
with ``m`` the number of measured coordinates and ``S = sum_k r_k^T R_{0,oo}^{-1} r_k`` over the
residuals ``r_k = z_{k,o} - H_o x_k``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import stats
from scipy.special import logsumexp

from pfcourse.checks import as_generator, check_count, check_measurements
from pfcourse.collectors import Ancestors, Clouds
from pfcourse.errors import ModelError, ParameterError, ShapeError
from pfcourse.filter import ParticleFilter
from pfcourse.resampling import multinomial


class ReferenceModel:
    """``model`` with particle ``0`` set to ``reference[k]`` after every draw (``reference=None``: unchanged).

    The log-likelihood and transition density are the model's own.
    """

    def __init__(self, model, reference: np.ndarray | None) -> None:
        self.model = model
        self.dim_x = model.dim_x
        self.angle_indices = tuple(getattr(model, "angle_indices", ()))
        self.reference = reference

    def _pin(self, particles: np.ndarray, k: int) -> np.ndarray:
        if self.reference is None:
            return particles
        particles = np.array(particles, dtype=float, copy=True)
        particles[0] = self.reference[k]
        return particles

    def sample_initial(self, n: int, rng: np.random.Generator) -> np.ndarray:
        return self._pin(self.model.sample_initial(n, rng), 0)

    def sample_transition(self, particles: np.ndarray, k: int, rng: np.random.Generator) -> np.ndarray:
        return self._pin(self.model.sample_transition(particles, k, rng), k)

    def log_likelihood(self, particles: np.ndarray, z: np.ndarray, k: int) -> np.ndarray:
        return self.model.log_likelihood(particles, z, k)

    def transition_log_density(self, new: np.ndarray, old: np.ndarray, k: int) -> np.ndarray:
        return self.model.transition_log_density(new, old, k)


class AncestorSamplingProposal:
    """The conditional resample-and-move of one measured step (module docstring).

    ``propose_with_ancestors`` draws ``A^i ~ W_{k-1}`` (multinomial) for every particle, replaces
    ``A^0`` by the ancestor-sampling draw (``ancestor_sampling=True``) or by ``0`` (plain
    conditional SMC: the reference keeps its own past), moves every particle by the model's
    transition (the :class:`ReferenceModel` pins particle ``0``) and returns the bootstrap
    increments ``log p(z_k | x_k^i)``.  Without a reference it is the bootstrap filter with
    multinomial resampling at every measured step.
    """

    draws_ancestors = True

    def __init__(self, reference: np.ndarray | None, ancestor_sampling: bool = True) -> None:
        self.reference = reference
        self.ancestor_sampling = bool(ancestor_sampling)

    def ancestor_log_weights(self, model, particles: np.ndarray, log_weights: np.ndarray, k: int) -> np.ndarray:
        """``log W_{k-1}^j + log p(x*_k | x_{k-1}^j)``, unnormalised, for every ``j``."""
        target = np.broadcast_to(self.reference[k], particles.shape)
        return log_weights + model.transition_log_density(target, particles, k)

    def propose_with_ancestors(self, model, particles, z, k, rng, log_weights=None):
        n = len(particles)
        log_weights = np.full(n, -np.log(n)) if log_weights is None else np.asarray(log_weights, dtype=float)
        ancestors = multinomial(np.exp(log_weights - logsumexp(log_weights)), rng, n)
        if self.reference is not None:
            if self.ancestor_sampling:
                a = self.ancestor_log_weights(model, particles, log_weights, k)
                if not np.isfinite(a.max()):
                    raise ModelError(f"step {k}: the reference path has zero transition density from every "
                                     "particle (ancestor sampling needs p(x*_k | x_(k-1)^j) > 0 for some j)", step=k)
                p = np.exp(a - logsumexp(a))
                ancestors[0] = min(int(np.searchsorted(np.cumsum(p), rng.random(), side="right")), n - 1)
            else:
                ancestors[0] = 0
        new = model.sample_transition(particles[ancestors], k, rng)
        return new, model.log_likelihood(new, z, k), ancestors

    def propose(self, model, particles, z, k, rng):  # the protocol's method; the engine calls the one above
        new, log_inc, _ = self.propose_with_ancestors(model, particles, z, k, rng)
        return new, log_inc


def trace_path(particles: np.ndarray, ancestors: np.ndarray, index: int) -> np.ndarray:
    """The ancestral line ending at particle ``index`` of the last step: ``(K, d)``.

    ``particles`` ``(K, N, d)`` and ``ancestors`` ``(K, N)`` as the Clouds and Ancestors
    collectors record them (particle ``i`` of step ``k`` descends from ``ancestors[k, i]``).
    """
    K = particles.shape[0]
    path = np.empty((K, particles.shape[2]))
    b = int(index)
    for k in range(K - 1, -1, -1):
        path[k] = particles[k, b]
        b = int(ancestors[k, b])
    return path


@dataclass
class CSMCResult:
    """One conditional SMC sweep: the drawn ``path`` ``(K, d)``, the index it ended at, and the run's
    ``log_likelihood`` (log of the conditional filter's estimate; not an unbiased estimate)."""

    path: np.ndarray
    index: int
    log_likelihood: float


def conditional_smc(model, measurements, n_particles: int, reference: np.ndarray | None,
                    rng: np.random.Generator | int, ancestor_sampling: bool = True) -> CSMCResult:
    """One sweep of conditional SMC (with ancestor sampling by default) given ``reference`` ``(K, d)``.

    ``reference=None`` runs the unconditional filter (a first path).  The model needs
    ``transition_log_density`` for ancestor sampling.
    """
    rng = as_generator(rng)
    n_particles = check_count(n_particles, "n_particles")
    z = check_measurements(measurements)
    if n_particles < 2:
        raise ParameterError(f"conditional SMC needs n_particles >= 2 (one is the reference), got {n_particles}")
    if reference is not None:
        reference = np.asarray(reference, dtype=float)
        if reference.shape != (len(z), model.dim_x):
            raise ShapeError(f"the reference path must have shape ({len(z)}, {model.dim_x}), got {reference.shape}")
        if not np.all(np.isfinite(reference)):
            raise ParameterError("the reference path must be finite")
        if ancestor_sampling and not callable(getattr(model, "transition_log_density", None)):
            raise ModelError("ancestor sampling needs the model's transition_log_density(new, old, k)")
    pinned = ReferenceModel(model, reference)
    pf = ParticleFilter(pinned, n_particles, threshold=0.0, proposal=AncestorSamplingProposal(reference, ancestor_sampling))
    result = pf.run(z, rng, collect=[Clouds(), Ancestors()])
    w = result.weights[-1]
    index = min(int(np.searchsorted(np.cumsum(w), rng.random() * w.sum(), side="right")), n_particles - 1)
    path = trace_path(result.particles, result.collected["ancestors"], index)
    return CSMCResult(path=path, index=index, log_likelihood=result.log_likelihood)


@dataclass
class GibbsChain:
    """Output of :func:`particle_gibbs`: ``theta`` per sweep and the last reference ``path``."""

    theta: np.ndarray
    path: np.ndarray


def particle_gibbs(model_of: Callable, draw_theta: Callable, measurements, theta0: float, n_particles: int,
                   n_iterations: int, rng: np.random.Generator | int, ancestor_sampling: bool = True) -> GibbsChain:
    """Particle Gibbs: ``x_{0:K-1} ~`` CSMC(-AS) given ``theta``, then ``theta ~ draw_theta(path, rng)``.

    ``model_of(theta)`` builds the model; the first path comes from an unconditional run at
    ``theta0``.  Every draw uses ``rng``.
    """
    rng = as_generator(rng)
    n_iterations = check_count(n_iterations, "n_iterations")
    theta = float(theta0)
    path = conditional_smc(model_of(theta), measurements, n_particles, None, rng).path
    thetas = np.empty(n_iterations)
    for t in range(n_iterations):
        path = conditional_smc(model_of(theta), measurements, n_particles, path, rng, ancestor_sampling).path
        theta = float(draw_theta(path, rng))
        thetas[t] = theta
    return GibbsChain(theta=thetas, path=path)


def noise_scale_draw(H: np.ndarray, R0: np.ndarray, measurements, path: np.ndarray, bounds: tuple[float, float],
                     rng: np.random.Generator) -> float:
    """``theta ~ p(theta | x, z)`` for ``R = theta R_0``, prior flat in ``log theta`` on ``bounds`` (module docstring)."""
    lo, hi = bounds
    if not 0 < lo < hi:
        raise ParameterError(f"bounds must satisfy 0 < low < high, got {bounds}")
    Z = np.asarray(measurements, dtype=float)
    m, S = 0, 0.0
    for k, z in enumerate(Z):
        mask = ~np.isnan(z)
        if not mask.any():
            continue
        r = z[mask] - H[mask] @ path[k]
        S += float(r @ np.linalg.solve(R0[np.ix_(mask, mask)], r))
        m += int(mask.sum())
    if m == 0:
        raise ParameterError("no measured coordinate: the noise scale's conditional is its prior")
    law = stats.invgamma(m / 2.0, scale=S / 2.0)
    a, b = law.cdf(lo), law.cdf(hi)
    return float(law.ppf(a + (b - a) * rng.random()))
