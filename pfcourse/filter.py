"""A generic, vectorized particle filter with log-domain weights.

The filter approximates the filtering distribution ``p(x_k | z_{0:k})`` by
particles ``x_k^i`` with normalised weights ``W_k^i``.  At every step ``k``:

1. **propose** ``x_k^i ~ q(x_k | x_{k-1}^i, z_k)`` (the transition ``p(x_k | x_{k-1})``
   by default: the *bootstrap* filter of Gordon, Salmond and Smith 1993);
2. **weight** in the log domain,
   ``log w_k^i = log W_{k-1}^i + log p(z_k | x_k^i) + log p(x_k^i | x_{k-1}^i) - log q(x_k^i | x_{k-1}^i, z_k)``
   (the last two cancel for the bootstrap proposal);
3. **normalise** ``W_k^i = exp(log w_k^i - logsumexp_j log w_k^j)`` and record the
   weighted mean, covariance, the effective sample size ``ESS = 1 / sum_i (W_k^i)^2``
   and the log-likelihood increment ``log p^(z_k | z_{0:k-1}) = logsumexp_i(log W_{k-1}^i + log inc_k^i)``;
4. **resample** (SIR) when ``ESS < threshold * N``, then reset the weights to ``1/N``.
   ``threshold = 0`` never resamples (SIS); ``threshold = 1`` resamples at every
   step whose weights are not exactly uniform.
   An optional ``jitter(particles, rng)`` is then applied to the resampled cloud
   (roughening, :mod:`pfcourse.roughening`); by default there is none.

**A variable number of particles** (``sample_size``, e.g. KLD-sampling,
:mod:`pfcourse.sample_size`): ``N = n_particles`` particles are drawn at step 0 and ``N`` is
the ceiling afterwards. At each later measurement step the new cloud is drawn in batches,
``x_k^i ~ q(. | x_{k-1}^{A_i}, z_k)`` with ancestors ``A_i`` drawn by multinomial resampling of
the previous weighted cloud, until the policy has enough; the weights are then the
log-increments alone (the ancestors carried the old weights), so step 4 does not apply.
Steps without a measurement move the cloud and keep its size and weights.

A measurement that is missing (``None``, or an array of NaN) leaves the weights
unchanged: the particles move through the transition only.  A measurement with
*some* NaN entries is passed to the model, whose likelihood treats NaN entries
as "not observed".  Any NaN produced by the model, and a step at which every
particle has zero likelihood, raise a named error that gives the step.

Steps 3 and 4 run as compiled loops (:mod:`pfcourse.kernels`): one pass over the particles
for the weights, the ESS and the log-likelihood increment (the same floats as
:func:`~pfcourse.diagnostics.normalize_log_weights`), two for the moments, one merge pass
for the resampled indices.  The model's own methods are plain NumPy unless the model
compiles them too (:class:`pfcourse.robot.scenario.RobotModel` does).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from pfcourse.checks import (
    Array,
    as_generator,
    check_count,
    check_fits,
    check_measurements,
    check_moments,
    check_probability,
    is_missing,
)
from . import kernels
from pfcourse.errors import (
    DegenerateWeightsError,
    MeasurementError,
    ModelError,
    NumericalError,
    ParameterError,
    ShapeError,
)
from pfcourse.resampling import get_resampler, multinomial
from pfcourse.results import FilterResult

Measurement = Array | None


class Model(Protocol):
    """What the particle filter needs from a state-space model.

    ``dim_x`` is the state dimension; arrays of particles have shape ``(N, dim_x)``.
    ``k`` is the time index of the state being produced or weighted.
    """

    dim_x: int

    def sample_initial(self, n: int, rng: np.random.Generator) -> Array:
        """Draw ``n`` particles from ``p(x_0)``."""

    def sample_transition(self, particles: Array, k: int, rng: np.random.Generator) -> Array:
        """Draw ``x_k ~ p(x_k | x_{k-1})`` for every row of ``particles``."""

    def log_likelihood(self, particles: Array, z: Array, k: int) -> Array:
        """Return ``log p(z_k | x_k^i)`` for every particle (shape ``(N,)``)."""


@dataclass(frozen=True)
class StateSpaceModel:
    """A model made of plain functions, for defining one in a few lines.

    Example: a scalar random walk seen in Gaussian noise::

        model = StateSpaceModel(
            dim_x=1,
            sample_initial=lambda n, rng: rng.normal(0.0, 1.0, (n, 1)),
            sample_transition=lambda x, k, rng: x + rng.normal(0.0, 0.1, x.shape),
            log_likelihood=lambda x, z, k: norm.logpdf(z[0], x[:, 0], 0.5),
        )

    ``transition_log_density(new, old, k)`` is needed only by proposals other
    than the transition; ``angle_indices`` lists state components that are
    angles (circular mean, wrapped covariance).
    """

    dim_x: int
    sample_initial: Callable[[int, np.random.Generator], Array]
    sample_transition: Callable[[Array, int, np.random.Generator], Array]
    log_likelihood: Callable[[Array, Array, int], Array]
    transition_log_density: Callable[[Array, Array, int], Array] | None = None
    angle_indices: tuple[int, ...] = ()


class Proposal(Protocol):
    """An importance function: draws new particles and returns their log incremental weights.

    ``propose`` returns ``(x_k, log_inc)`` with
    ``log_inc^i = log p(z_k | x_k^i) + log p(x_k^i | x_{k-1}^i) - log q(x_k^i | x_{k-1}^i, z_k)``.
    It is called only at steps that have a measurement.
    """

    def propose(
        self, model: Model, particles: Array, z: Array, k: int, rng: np.random.Generator
    ) -> tuple[Array, Array]: ...


class TransitionProposal:
    """The prior as importance function: ``q = p(x_k | x_{k-1})``, so ``log_inc = log p(z_k | x_k)``."""

    def propose(self, model, particles, z, k, rng):
        new = model.sample_transition(particles, k, rng)
        return new, model.log_likelihood(new, z, k)


def check_particles(particles: Array, expected: tuple[int, int], k: int, source: str) -> Array:
    """Check a cloud that ``source`` returned at step ``k`` before anything else sees it: a real
    array (``ModelError`` otherwise) of shape ``expected`` (``ShapeError``) with finite states
    (``NumericalError``); returns it as floats."""
    raw = np.asarray(particles) if particles is not None else None
    if raw is None or raw.dtype.kind not in "fiu" or raw.dtype == bool:
        kind = "None" if raw is None else f"dtype {raw.dtype}"
        raise ModelError(f"step {k}: {source} returned {kind}, expected a real array of particles", step=k)
    particles = raw.astype(float, copy=False)
    if particles.shape != expected:
        raise ShapeError(
            f"step {k}: {source} returned particles of shape {particles.shape}, "
            f"expected {expected}"
        )
    if not kernels.finite_minimum(particles.ravel())[0]:
        raise NumericalError(
            f"step {k}: {source} produced NaN or infinite particle states", step=k
        )
    return particles


def check_log_terms(values: Array, n: int, k: int, source: str = "the log-likelihood") -> Array:
    """Check log-densities that ``source`` returned at step ``k`` (one per particle) before they are
    combined: a real array (``ModelError``) of shape ``(n,)`` (``ShapeError``); returns it as floats."""
    raw = np.asarray(values) if values is not None else None
    if raw is None or raw.dtype.kind not in "fiu" or raw.dtype == bool:
        kind = "None" if raw is None else f"dtype {raw.dtype}"
        raise ModelError(
            f"step {k}: {source} (or a proposal's log-increment) is {kind}, "
            "expected a real array (return -inf for impossible particles; a missing "
            "measurement is None or NaN in the measurements, not in the likelihood)",
            step=k,
        )
    values = raw.astype(float, copy=False)
    if values.shape != (n,):
        raise ShapeError(f"step {k}: {source} has shape {values.shape}, expected ({n},)")
    return values


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


class ParticleFilter:
    """Sequential importance sampling with optional resampling (SIS / SIR).

    Parameters
    ----------
    model:
        Any object with ``dim_x``, ``sample_initial``, ``sample_transition`` and
        ``log_likelihood`` (see :class:`Model`).
    n_particles:
        Number of particles ``N >= 1``: an integer (or an integral float such as ``5.0``); a number
        whose particles would not fit in the machine's memory is refused when the filter is built.
    threshold:
        Resample when ``ESS < threshold * N``; in ``[0, 1]``.  0 gives SIS.
    resampler:
        ``"multinomial"``, ``"stratified"``, ``"systematic"`` (default), ``"residual"``
        or a function ``(weights, rng) -> indices``.
    proposal:
        Importance function (:class:`Proposal`); the transition by default.
    jitter:
        Optional function ``(particles, rng) -> particles`` applied to the cloud
        right after each resampling (roughening, see :mod:`pfcourse.roughening`).
        ``None`` (default) leaves the resampled cloud, and the random stream, as is.
    sample_size:
        Optional policy for a variable number of particles (:class:`pfcourse.sample_size.KLDSampling`):
        ``n_particles`` is then the initial number and the ceiling (module docstring).
        ``threshold``, ``resampler`` and ``jitter`` do not apply then: the ancestors of each
        measurement step are drawn by multinomial resampling.
    """

    def __init__(
        self,
        model: Model,
        n_particles: int,
        *,
        threshold: float = 0.5,
        resampler: str | Callable = "systematic",
        proposal: Proposal | None = None,
        jitter: Callable[[Array, np.random.Generator], Array] | None = None,
        sample_size=None,
    ) -> None:
        for attribute in ("sample_initial", "sample_transition", "log_likelihood"):
            if not callable(getattr(model, attribute, None)):
                raise ModelError(f"the model has no callable {attribute} (see pfcourse.Model)")
        self.dim_x = check_count(getattr(model, "dim_x", None), "model.dim_x")
        self.model = model
        n = check_count(n_particles, "n_particles")
        self.n_particles = check_fits(n, "n_particles", 8 * n * (2 * self.dim_x + 4),
                                      f"the particles (dim_x={self.dim_x}, two clouds and four weight arrays)")
        self.threshold = check_probability(threshold, "threshold")
        self.resampler = get_resampler(resampler)
        self._custom_resampler = not isinstance(resampler, str)
        if proposal is not None and not callable(getattr(proposal, "propose", None)):
            raise ModelError(f"proposal must have a propose(model, particles, z, k, rng) method, got {proposal!r}")
        if jitter is not None and not callable(jitter):
            raise ModelError(f"jitter must be a function (particles, rng) -> particles, got {jitter!r}")
        angles = getattr(model, "angle_indices", ())
        try:
            angles = tuple(angles)
        except TypeError:
            raise ModelError(f"model.angle_indices must be a sequence of state indices, got {angles!r}") from None
        for a in angles:
            if isinstance(a, (bool, np.bool_)) or not isinstance(a, (int, np.integer)) or not 0 <= a < self.dim_x:
                raise ModelError(f"model.angle_indices must hold integers in [0, {self.dim_x}), got {angles!r}")
        self.proposal = proposal if proposal is not None else TransitionProposal()
        self.angle_indices = tuple(getattr(model, "angle_indices", ()))
        self.jitter = jitter
        if sample_size is not None:
            for attribute in ("reset", "needed"):
                if not callable(getattr(sample_size, attribute, None)):
                    raise ModelError(f"sample_size has no callable {attribute} (see pfcourse.sample_size)")
            check_count(getattr(sample_size, "n_min", None), "sample_size.n_min")
            check_count(getattr(sample_size, "batch", None), "sample_size.batch")
            if jitter is not None:
                raise ParameterError("jitter and sample_size cannot be combined: with a variable N the "
                                     "ancestors are drawn inside the step, there is no resampled cloud to jitter")
        self.sample_size = sample_size

    def run(
        self,
        measurements: Sequence[Measurement] | Array,
        rng: np.random.Generator | int | None = None,
        *,
        store_particles: bool = False,
    ) -> FilterResult:
        """Filter the measurements ``z_0, ..., z_{K-1}`` and return a :class:`FilterResult`.

        ``measurements[k]`` is the measurement at time ``k`` (``None`` or NaN when
        absent); ``x_0`` is drawn from the model's initial distribution and
        weighted by ``z_0`` if present.  ``rng`` is a ``numpy.random.Generator``
        or an integer seed: the same seed gives the same result; it must be given
        (:class:`~pfcourse.errors.ParameterError` if it is not).  A scalar measurement
        series may be 1-D (shape ``(K,)`` or a list of floats): it is read as ``(K, 1)``.
        """
        rng = as_generator(rng)
        n, d = self.n_particles, self.dim_x
        measurements = check_measurements(measurements)
        n_steps = len(measurements)
        if store_particles and self.sample_size is not None:
            raise ParameterError("store_particles needs a fixed number of particles (this filter has a sample_size policy)")
        try:
            mean = np.empty((n_steps, d))
            cov = np.empty((n_steps, d, d))
            ess = np.empty(n_steps)
            resampled = np.zeros(n_steps, dtype=bool)
            log_inc_total = np.zeros(n_steps)
            sizes = np.empty(n_steps, dtype=np.int64)
            stored_x = np.empty((n_steps, n, d)) if store_particles else None
            stored_w = np.empty((n_steps, n)) if store_particles else None
            np.empty((n, d))  # the cloud itself
        except (MemoryError, ValueError):
            raise ParameterError(
                f"before step 0: n_particles={n}, dim_x={d} and {n_steps} steps need more memory "
                "than this machine has"
            ) from None

        particles = None
        log_weights = np.full(n, -np.log(n))
        weights = np.full(n, 1.0 / n)
        scratch = np.empty(n)
        is_angle = np.zeros(d, dtype=bool)
        is_angle[list(self.angle_indices)] = True
        linear = ~is_angle if is_angle.any() else None  # the variances that must stay finite
        if isinstance(measurements, np.ndarray) and measurements.dtype.kind == "f":
            missing_steps = np.isnan(measurements.reshape(n_steps, -1)).all(axis=1)  # is_missing, per row
        else:
            missing_steps = [is_missing(z) for z in measurements]
        default_proposal = type(self.proposal) is TransitionProposal
        adaptive = self.sample_size is not None
        for k in range(n_steps):
            z = measurements[k]
            missing = missing_steps[k]
            if not missing:
                z = np.asarray(z, dtype=float)
            # particles are checked before the model's likelihood sees them
            if adaptive and k > 0 and not missing:
                particles, log_inc = self._adaptive_step(particles, weights, z, k, rng)
                n = len(particles)
                log_weights = np.full(n, -np.log(n))
                scratch = np.empty(n)
                resampled[k] = True
            elif k == 0:
                particles = self._check_particles(self.model.sample_initial(n, rng), k, "sample_initial")
                log_inc = None if missing else self.model.log_likelihood(particles, z, k)
            elif missing or default_proposal:
                particles = self._check_particles(
                    self.model.sample_transition(particles, k, rng), k, "sample_transition", n
                )
                log_inc = None if missing else self.model.log_likelihood(particles, z, k)
            else:
                proposed = self.proposal.propose(self.model, particles, z, k, rng)
                if not isinstance(proposed, tuple) or len(proposed) != 2:
                    raise ModelError(f"step {k}: proposal.propose must return (particles, log_increments)", step=k)
                particles = self._check_particles(proposed[0], k, "proposal.propose")
                log_inc = proposed[1]

            sizes[k] = n
            if not missing:
                log_inc = self._check_log_increments(log_inc, k, n)
                weights = np.empty(n)
                top = log_inc.max()
                shift = top if 700.0 < abs(top) < np.inf else 0.0  # weights are invariant to a constant
                if shift != 0.0:
                    with np.errstate(over="ignore"):  # -1e308 - 1e308 = -inf: a zero weight, as it should
                        log_inc = log_inc - shift
                log_inc_total[k], ess[k] = kernels.normalize_step(log_weights, log_inc, weights, scratch)
                log_inc_total[k] += shift
                if log_inc_total[k] == -np.inf or top == -np.inf:
                    raise DegenerateWeightsError(
                        f"step {k}: every particle has zero likelihood for the measurement "
                        f"{np.array2string(z, precision=4)}; the filter has lost track "
                        "(more particles, a wider process noise or a better proposal may help)",
                        step=k,
                    )
            else:
                ess[k] = 1.0 / kernels.sum_of_squares(weights)  # effective_sample_size(weights), same float

            mean[k], cov[k] = kernels.weighted_moments(particles, weights, is_angle)
            check_moments(particles, cov[k], linear, k)
            if store_particles:
                stored_x[k] = particles
                stored_w[k] = weights
            if not adaptive and ess[k] < self.threshold * n * (1.0 - 1e-12):
                indices = self.resampler(weights, rng)
                if self._custom_resampler:
                    indices = self._check_indices(indices, k)
                particles = kernels.gather_rows(particles, indices)
                if self.jitter is not None:
                    particles = self._check_particles(self.jitter(particles, rng), k, "jitter")
                log_weights = np.full(n, -np.log(n))
                weights = np.full(n, 1.0 / n)
                resampled[k] = True

        return FilterResult(
            mean=mean,
            cov=cov,
            ess=ess,
            resampled=resampled,
            log_likelihood_increments=log_inc_total,
            n_particles=self.n_particles,
            particles=stored_x,
            weights=stored_w,
            settings={
                "threshold": self.threshold,
                "resampler": getattr(self.resampler, "__name__", str(self.resampler)),
                "proposal": type(self.proposal).__name__,
                "sample_size": None if self.sample_size is None else type(self.sample_size).__name__,
            },
            sizes=sizes,
        )

    def _adaptive_step(self, particles: Array, weights: Array, z: Array, k: int,
                       rng: np.random.Generator) -> tuple[Array, Array]:
        """Draw the cloud of measurement step ``k`` in batches until the ``sample_size`` policy has enough.

        Each batch of ``m`` particles: ancestors by multinomial resampling of the previous
        weighted cloud, then the proposal; returns the new cloud and its log-increments.
        """
        policy, n_max = self.sample_size, self.n_particles
        policy.reset()
        new_x, new_log = [], []
        n, needed = 0, policy.n_min
        while n < min(max(needed, policy.n_min), n_max):
            m = int(min(n_max - n, max(policy.batch, min(needed, n_max) - n)))
            parents = kernels.gather_rows(particles, multinomial(weights, rng, m))
            if type(self.proposal) is TransitionProposal:
                x = self._check_particles(self.model.sample_transition(parents, k, rng), k, "sample_transition", m)
                log_inc = self.model.log_likelihood(x, z, k)
            else:
                proposed = self.proposal.propose(self.model, parents, z, k, rng)
                if not isinstance(proposed, tuple) or len(proposed) != 2:
                    raise ModelError(f"step {k}: proposal.propose must return (particles, log_increments)", step=k)
                x = self._check_particles(proposed[0], k, "proposal.propose", m)
                log_inc = proposed[1]
            new_x.append(x)
            new_log.append(self._check_log_increments(log_inc, k, m))
            n += m
            needed = policy.needed(x)
            if isinstance(needed, (bool, np.bool_)) or not isinstance(needed, (int, np.integer)) or needed < 0:
                raise ModelError(f"step {k}: sample_size.needed must return a count >= 0, got {needed!r}", step=k)
        return np.concatenate(new_x), np.concatenate(new_log)

    def _check_indices(self, indices, k: int) -> np.ndarray:
        """A custom resampler's output must be N integer indices in [0, N) (checked before the compiled gather)."""
        arr = np.asarray(indices)
        n = self.n_particles
        if arr.dtype.kind not in "iu" or arr.dtype == bool:
            raise ModelError(f"step {k}: the resampler returned dtype {arr.dtype}, expected integer indices", step=k)
        if arr.shape != (n,):
            raise ShapeError(f"step {k}: the resampler returned indices of shape {arr.shape}, expected ({n},)")
        if n and (arr.min() < 0 or arr.max() >= n):
            raise ShapeError(
                f"step {k}: the resampler returned indices outside [0, {n}) (min {arr.min()}, max {arr.max()})"
            )
        return arr.astype(np.int64, copy=False)

    def _check_particles(self, particles: Array, k: int, source: str = "the model", n: int | None = None) -> Array:
        return check_particles(particles, (self.n_particles if n is None else n, self.dim_x), k, source)

    def _check_log_increments(self, log_inc: Array, k: int, n: int | None = None) -> Array:
        log_inc = check_log_terms(log_inc, self.n_particles if n is None else n, k)
        top = log_inc.max()  # NaN if any entry is NaN
        if np.isnan(top) or top == np.inf:
            bad = int(np.sum(np.isnan(log_inc) | (log_inc == np.inf)))
            raise NumericalError(
                f"step {k}: the log-likelihood is NaN or +inf for {bad} particle(s)", step=k
            )
        return log_inc
