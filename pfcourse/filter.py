"""A generic, vectorized particle filter with log-domain weights.

The filter approximates the filtering distribution ``p(x_k | z_{0:k})`` by
particles ``x_k^i`` with normalised weights ``W_k^i``.  At every step ``k``:

1. **propose** ``x_k^i ~ q(x_k | x_{k-1}^i, z_k)`` (the transition ``p(x_k | x_{k-1})``
   by default: the *bootstrap* filter of Gordon, Salmond and Smith 1993);
2. **weight** in the log domain,
   ``log w_k^i = log W_{k-1}^i + log p(z_k | x_k^i) + log p(x_k^i | x_{k-1}^i) - log q(x_k^i | x_{k-1}^i, z_k)``
   (the last two cancel for the bootstrap proposal);
3. **normalise** ``W_k^i = exp(log w_k^i - logsumexp_j log w_k^j)``, with the effective
   sample size ``ESS = 1 / sum_i (W_k^i)^2`` and the log-likelihood increment
   ``log p^(z_k | z_{0:k-1}) = logsumexp_i(log W_{k-1}^i + log inc_k^i)`` (the weighted mean and
   covariance are the moments collector's, :mod:`pfcourse.collectors`);
4. **resample** (SIR) when ``ESS < threshold * N``, then reset the weights to ``1/N``.
   ``threshold = 0`` never resamples (SIS); ``threshold = 1`` resamples at every
   step whose weights are not exactly uniform.
   An optional ``jitter(particles, rng)`` is then applied to the resampled cloud
   (roughening, :mod:`pfcourse.jitter`); by default there is none.

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

**Stepping and collecting.** :meth:`ParticleFilter.steps` is that loop as a generator: it yields
a :class:`Step` (the weighted cloud, the ancestors drawn by its resampling, the ESS, the
log-likelihood increment) at the end of every step, so a reader can write
``for step in pf.steps(z, rng): ...`` and watch the cloud move.  :meth:`ParticleFilter.run` is
built on it: each step is shown to *collectors* (:mod:`pfcourse.collectors`), which keep what
they need and return their record at the end; the moments, the ESS, the resampling flags, the
log-likelihood increments and the sizes are always collected (the fields of
:class:`~pfcourse.results.FilterResult`), the clouds, the ancestors and the proposal's stages
on request (``collect=[Clouds(), Ancestors()]``).  Inside a step the named parts are
``_propose`` (step 1; with a variable ``N`` the policy's batches, :class:`_VariableSize`,
which share ``_move`` with it), ``_weight`` (steps 2 and 3) and ``_resample`` (step 4); the
choice between a fixed and a variable ``N`` is made once, when the filter is built
(:class:`_FixedSize` or :class:`_VariableSize`), not at each step.

Steps 3 and 4 run as compiled loops (:mod:`pfcourse.kernels`): one pass over the particles
for the weights, the ESS and the log-likelihood increment (the same floats as
:func:`~pfcourse.diagnostics.normalize_log_weights`), two for the moments, one merge pass
for the resampled indices.  The model's own methods are plain NumPy unless the model
compiles them too (:class:`pfcourse.scenarios.robot.scenario.RobotModel` does).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from pfcourse.checks import (
    Array,
    as_generator,
    check_count,
    check_fits,
    check_measurements,
    check_log_terms,
    check_particles,
    check_probability,
    is_missing,
)
from pfcourse import kernels
from pfcourse.errors import (
    DegenerateWeightsError,
    MeasurementError,
    ModelError,
    NumericalError,
    ParameterError,
    ShapeError,
)
from pfcourse.collectors import CollectorProtocol, start_collectors
from pfcourse.proposals import TransitionProposal
from pfcourse.resampling import get_resampler, multinomial
from pfcourse.results import FilterResult

Measurement = Array | None
#: The method a stateful proposal or jitter may have, called before step 0 of every run (the first found).
START_HOOKS = ("start", "reset")


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
    It is called only at steps that have a measurement.  A proposal that brings the likelihood
    in by stages (progressive correction) returns ``(x_k, log_inc, stages)``, the number of
    times it weighted the cloud: the step reports it (:attr:`Step.stages`).  A proposal that draws
    the ancestors itself (the auxiliary filter) sets ``draws_ancestors = True`` and has a method
    ``propose_with_ancestors(model, particles, z, k, rng, log_weights=log W_{k-1})`` (normalised
    weights) returning ``(x_k, log_inc, ancestors)``: ``x_k^i`` descends from ``particles[ancestors[i]]``,
    the children start from equal weights (unequal ``W_{k-1}`` are reset to ``1/N``) and the step
    records the ancestors (:attr:`Step.parents`); ``ancestors=None`` says that none were drawn at
    this step (the increments are then added to ``log W_{k-1}`` as those of ``propose``).
    A proposal (or a jitter) that keeps state from step to step has a method ``start()`` (or
    ``reset()``), which the filter calls before step 0 of every run: one filter run twice with one
    seed gives one result.
    """

    def propose(
        self, model: Model, particles: Array, z: Array, k: int, rng: np.random.Generator
    ) -> tuple[Array, Array]: ...


def _present(measurements: Sequence[Measurement] | Array):
    """``z_k`` as a float array, or ``None`` when the step's measurement is missing (:func:`is_missing`)."""
    if isinstance(measurements, np.ndarray) and measurements.dtype.kind == "f":
        missing = np.isnan(measurements.reshape(len(measurements), -1)).all(axis=1)  # is_missing, per row
    else:
        missing = [is_missing(z) for z in measurements]
    for k in range(len(measurements)):
        yield None if missing[k] else np.asarray(measurements[k], dtype=float)


class _Cloud:
    """The weighted cloud carried from step to step: ``x^i``, ``log W^i`` and ``W^i`` (``N`` of each).

    ``scratch`` is work space of the compiled weight update (:func:`pfcourse.kernels.normalize_step`).
    """

    def __init__(self, n: int) -> None:
        """``n`` particles still to be drawn (by ``sample_initial``), of weight ``1/n``."""
        self.particles: Array | None = None
        self._uniform_weights(n)

    @property
    def size(self) -> int:
        """The number of particles ``N``."""
        return len(self.log_weights)

    def restart(self, particles: Array) -> None:
        """Replace the particles by ``particles`` (resampled or newly drawn), each of weight ``W^i = 1/N``."""
        self.particles = particles
        self._uniform_weights(len(particles))

    def _uniform_weights(self, n: int) -> None:
        self.log_weights = np.full(n, -np.log(n))
        self.weights = np.full(n, 1.0 / n)
        self.scratch = np.empty(n)


@dataclass(frozen=True)
class Step:
    """The state of a particle filter at the end of step ``k`` (yielded by :meth:`ParticleFilter.steps`).

    ``particles`` ``(N_k, d)``, ``log_weights`` and ``weights`` ``(N_k,)``: the weighted cloud after
    the update of step ``k`` (before any resampling; ``weights = exp(log_weights)``, normalised).
    ``ess``: ``1 / sum_i (W_k^i)^2``.  ``log_likelihood_increment``: ``log p^(z_k | z_{0:k-1})``
    (0 without a measurement).  ``ancestors``: the indices the step's resampling drew, or ``None``
    when the step did not resample.  With a fixed ``N`` the resampling comes at the end of the
    step: particle ``i`` of step ``k + 1`` descends from ``particles[ancestors[i]]``.  With a
    ``sample_size`` policy it comes first: ``particles[i]`` descends from particle ``ancestors[i]``
    of step ``k - 1``.  ``stages``: how many times the proposal weighted the cloud at this step
    (the stages of progressive correction; 1 otherwise).  ``parents``: with a fixed ``N``, the
    ancestors a proposal drew before its move (the auxiliary filter's first stage), else ``None``:
    ``particles[i]`` descends from particle ``parents[i]`` of the cloud that ended step ``k - 1``
    (after its own resampling, if it had one).  That first stage resamples the cloud of step
    ``k - 1``: the ``resampled`` record and the :class:`~pfcourse.collectors.Ancestors` lines
    file it there.

    The filter never writes into a step's arrays after yielding it, so a collector may keep them.
    """

    k: int
    particles: Array
    log_weights: Array
    weights: Array
    ess: float
    log_likelihood_increment: float
    ancestors: Array | None = None
    stages: int = 1
    parents: Array | None = None

    @property
    def size(self) -> int:
        """The number of particles ``N_k``."""
        return len(self.weights)

    @property
    def resampled(self) -> bool:
        """Whether the step resampled (``ancestors`` is not ``None``; not the first stage of ``parents``)."""
        return self.ancestors is not None


class _FixedSize:
    """``N`` particles at every step: each particle moves (step 1), the cloud is resampled at the end of
    a step whose ``ESS < threshold * N`` (step 4)."""

    def __init__(self, pf: ParticleFilter) -> None:
        self.pf = pf

    def propose(self, cloud: _Cloud, z: Array | None, k: int,
                rng: np.random.Generator) -> tuple[Array | None, Array | None, int, Array | None]:
        """``(log inc_k, None, stages, parents)``: the ancestors a proposal drew before its move, if any."""
        log_inc, stages, parents = self.pf._propose(cloud, z, k, rng)
        return log_inc, None, stages, parents

    def select(self, cloud: _Cloud, ess: float, k: int, rng: np.random.Generator) -> Array | None:
        """Step 4: the ancestors drawn when ``ESS < threshold * N``, else ``None``."""
        if ess < self.pf.threshold * cloud.size * (1.0 - 1e-12):
            return self.pf._resample(cloud, k, rng)
        return None


class _VariableSize:
    """A ``sample_size`` policy (module docstring): at each measurement step after the first, the cloud
    is drawn in batches whose ancestors are drawn first (multinomial); there is no step 4."""

    def __init__(self, pf: ParticleFilter, policy) -> None:
        self.pf, self.policy = pf, policy

    def propose(self, cloud: _Cloud, z: Array | None, k: int,
                rng: np.random.Generator) -> tuple[Array | None, Array | None, int, None]:
        """Step 1, in place: ``(log inc_k, ancestors, stages, None)``; the batches at measurement steps ``k > 0``.

        Each batch of ``m`` particles: ancestors ``A_i`` by multinomial resampling of the previous
        weighted cloud, then ``x_k^i ~ q(. | x_{k-1}^{A_i}, z_k)`` (``_move``), until
        ``n >= min(max(needed, n_min), n_particles)``.  The new cloud starts from the uniform
        weights ``1/n`` (the ancestors carried the old ones).  ``stages``: the most of any batch.
        A proposal that draws ancestors within a batch composes with the batch's: ``ancestors``
        are always those of the step ``k - 1`` cloud.
        """
        if k == 0 or z is None:
            log_inc, stages, _ = self.pf._propose(cloud, z, k, rng)
            return log_inc, None, stages, None
        policy, n_max = self.policy, self.pf.n_particles
        policy.reset()
        new_x, new_log, drawn, stages = [], [], [], 1
        n, needed = 0, policy.n_min
        while n < min(max(needed, policy.n_min), n_max):
            m = int(min(n_max - n, max(policy.batch, min(needed, n_max) - n)))
            drawn.append(multinomial(cloud.weights, rng, m))
            x, log_inc, batch_stages, chosen = self.pf._move(kernels.gather_rows(cloud.particles, drawn[-1]), z, k, rng)
            if chosen is not None:
                drawn[-1] = drawn[-1][chosen]
            new_x.append(x)
            new_log.append(log_inc)
            stages = max(stages, batch_stages)
            n += m
            needed = policy.needed(x)
            if isinstance(needed, (bool, np.bool_)) or not isinstance(needed, (int, np.integer)) or needed < 0:
                raise ModelError(f"step {k}: sample_size.needed must return a count >= 0, got {needed!r}", step=k)
        cloud.restart(np.concatenate(new_x))
        return np.concatenate(new_log), np.concatenate(drawn), stages, None

    def select(self, cloud: _Cloud, ess: float, k: int, rng: np.random.Generator) -> None:
        """No resampling at the end of the step: the next one draws its ancestors itself."""
        return None


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
        right after each resampling (roughening, see :mod:`pfcourse.jitter`).
        ``None`` (default) leaves the resampled cloud, and the random stream, as is.
        A proposal or a jitter with a ``start()`` (or ``reset()``) method is started before step 0
        of every run (:class:`Proposal`).
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
        hook = getattr(proposal, "propose_with_ancestors", None)
        if getattr(proposal, "draws_ancestors", False) and not callable(hook):
            raise ModelError(f"a proposal that draws ancestors (draws_ancestors = True) must have a method "
                             f"propose_with_ancestors(model, particles, z, k, rng, log_weights), got {proposal!r}")
        if jitter is not None and not callable(jitter):
            raise ModelError(f"jitter must be a function (particles, rng) -> particles, got {jitter!r}")
        for role, component in (("proposal", proposal), ("jitter", jitter)):
            for hook_name in START_HOOKS:
                if getattr(component, hook_name, None) is not None and not callable(getattr(component, hook_name)):
                    raise ModelError(f"the {role}'s {hook_name} must be a method {hook_name}() (called at step 0 "
                                     f"of every run), got {getattr(component, hook_name)!r:.80}")
        angles = getattr(model, "angle_indices", ())
        try:
            angles = tuple(angles)
        except TypeError:
            raise ModelError(f"model.angle_indices must be a sequence of state indices, got {angles!r}") from None
        for a in angles:
            if isinstance(a, (bool, np.bool_)) or not isinstance(a, (int, np.integer)) or not 0 <= a < self.dim_x:
                raise ModelError(f"model.angle_indices must hold integers in [0, {self.dim_x}), got {angles!r}")
        self.proposal = proposal if proposal is not None else TransitionProposal()
        #: the FilterSettings record the filter was built from (set by FilterSettings.build), else None
        self.settings = None
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
        self._size = _FixedSize(self) if sample_size is None else _VariableSize(self, sample_size)

    def steps(self, measurements: Sequence[Measurement] | Array,
              rng: np.random.Generator | int | None = None) -> Iterator[Step]:
        """Filter ``z_0, ..., z_{K-1}`` one step at a time: a generator of one :class:`Step` per step.

        The measurements and ``rng`` are read as by :meth:`run` (and checked here, before the first
        step).  Each step is drawn when the loop asks for it, with the same random draws in the
        same order as :meth:`run`, which is this loop with collectors::

            for step in pf.steps(z, rng=1):
                print(step.k, step.ess, step.particles.mean(axis=0))
        """
        rng = as_generator(rng)
        measurements = check_measurements(measurements)
        return self._steps(measurements, rng)

    def run(
        self,
        measurements: Sequence[Measurement] | Array,
        rng: np.random.Generator | int | None = None,
        *,
        collect: Sequence[CollectorProtocol] = (),
    ) -> FilterResult:
        """Filter the measurements ``z_0, ..., z_{K-1}`` and return a :class:`FilterResult`.

        ``measurements[k]`` is the measurement at time ``k`` (``None`` or NaN when
        absent); ``x_0`` is drawn from the model's initial distribution and
        weighted by ``z_0`` if present.  ``rng`` is a ``numpy.random.Generator``
        or an integer seed: the same seed gives the same result; it must be given
        (:class:`~pfcourse.errors.ParameterError` if it is not).  A scalar measurement
        series may be 1-D (shape ``(K,)`` or a list of floats): it is read as ``(K, 1)``.

        **Collectors.** Every :class:`Step` of :meth:`steps` is shown to the collectors, and each
        returns its record at the end.  The moments, the ESS, the resampling flags, the
        log-likelihood increments and the sizes are always collected (the result's fields);
        ``collect`` adds others, whose records are ``result.collected[name]``
        (:mod:`pfcourse.collectors`: ``Clouds()``, which also fills ``result.particles`` and
        ``result.weights``, ``Ancestors()``, ``Stages()``).  A collector is any object with

        * ``name``, the key of its record (distinct, and none of the fields above);
        * ``collect(step)``, called at the end of every step with the :class:`Step`;
        * ``result()``, called once after the last step: the record;
        * optionally ``start(pf, n_steps)``, called when the run is built (this filter, the
          number of steps), to reset or allocate, or to refuse a filter it cannot serve.

        A collector of the largest weight at each step, in five lines::

            class LargestWeight(Collector):           # pfcourse.collectors.Collector
                name = "largest_weight"
                def fetch(self, step):                # one value per step ...
                    return step.weights.max()         # ... result(): their array

            pf.run(z, rng, collect=[LargestWeight()]).collected["largest_weight"]

        A malformed collector is refused, before the first step, with a
        :class:`~pfcourse.errors.ModelError` (a missing ``name`` or method) or a
        :class:`~pfcourse.errors.ParameterError` (a name twice, a collector that does not fit
        this filter, such as the clouds of a variable ``N``).
        """
        rng = as_generator(rng)
        measurements = check_measurements(measurements)
        collect = list(collect) if isinstance(collect, (list, tuple)) else collect
        collectors = start_collectors(self, len(measurements), collect)
        for step in self._steps(measurements, rng):
            for collector in collectors:
                collector.collect(step)
        records = {collector.name: collector.result() for collector in collectors}
        return self._result(records)

    # ------------------------------------------------------------------ the parts of a step
    def _steps(self, measurements: Sequence[Measurement] | Array, rng: np.random.Generator) -> Iterator[Step]:
        """The loop (checked inputs): the components started, then at each step steps 1 to 3, the step's
        state, step 4, then the :class:`Step`."""
        self._start_components()
        cloud = _Cloud(self.n_particles)
        for k, z in enumerate(_present(measurements)):
            log_inc, ancestors, stages, parents = self._size.propose(cloud, z, k, rng)
            ess, log_evidence = self._weight(cloud, log_inc, z, k)
            particles, log_weights, weights = cloud.particles, cloud.log_weights, cloud.weights
            if ancestors is None:
                ancestors = self._size.select(cloud, ess, k, rng)
            yield Step(k, particles, log_weights, weights, ess, log_evidence, ancestors, stages, parents)

    def _start_components(self) -> None:
        """Before step 0 of every run: ``start()`` (else ``reset()``) of the proposal and of the jitter that
        have one, once for an object that is both, so a stateful component (the stages of progressive
        correction, augmented MCL's averages) starts every run as it started the first one."""
        started: list = []
        for component in (self.proposal, self.jitter):
            if component is None or any(component is seen for seen in started):
                continue
            started.append(component)
            for hook_name in START_HOOKS:
                hook = getattr(component, hook_name, None)
                if hook is not None:
                    hook()
                    break

    def _propose(self, cloud: _Cloud, z: Array | None, k: int,
                 rng: np.random.Generator) -> tuple[Array | None, int, Array | None]:
        """Step 1, in place: ``x_0^i ~ p(x_0)`` at step 0, ``x_k^i ~ q(x_k | x_{k-1}^i, z_k)`` afterwards.

        Returns the checked log-increments ``log inc_k^i`` (``log p(z_0 | x_0^i)`` at step 0), or
        ``None`` when ``z_k`` is missing (the particles then move through the transition), the
        proposal's stages and the ancestors it drew (``None`` unless it draws them: the children
        then start from equal weights, ``W_{k-1}`` reset to ``1/N`` unless already equal).
        """
        if k > 0:
            cloud.particles, log_inc, stages, parents = self._move(cloud.particles, z, k, rng, cloud.log_weights)
            if parents is not None and not np.all(cloud.log_weights == cloud.log_weights[0]):
                cloud.restart(cloud.particles)
            return log_inc, stages, parents
        cloud.particles = self._check_particles(self.model.sample_initial(cloud.size, rng), k, "sample_initial")
        if z is None:
            return None, 1, None
        return self._check_log_increments(self.model.log_likelihood(cloud.particles, z, k), k, cloud.size), 1, None

    def _move(self, parents: Array, z: Array | None, k: int, rng: np.random.Generator,
              log_weights: Array | None = None) -> tuple[Array, Array | None, int, Array | None]:
        """Draw ``x_k^i ~ q(. | x_{k-1}^i, z_k)`` for each row ``x_{k-1}^i`` of ``parents`` (checked).

        Returns ``(x_k, log inc_k, stages, ancestors)`` with ``log inc_k^i = log p(z_k | x_k^i) + log p(x_k^i | x_{k-1}^i)
        - log q(x_k^i | x_{k-1}^i, z_k)`` (checked), or ``(x_k, None, 1)`` when ``z_k`` is missing: then
        ``q`` is the transition whatever the proposal.  ``stages`` is the third item of what the
        proposal returned, if it returned one (:class:`Proposal`), else 1.  ``ancestors``: those a
        proposal that draws them returned (checked), else ``None``.  Shared by the fixed and the
        variable ``N``.  ``log_weights`` (``log W_{k-1}``, equal if ``None``) go to a proposal that
        draws ancestors.
        """
        m, stages, ancestors = len(parents), 1, None
        if z is None or type(self.proposal) is TransitionProposal:
            new = self._check_particles(self.model.sample_transition(parents, k, rng), k, "sample_transition", m)
            if z is None:
                return new, None, 1, None
            log_inc = self.model.log_likelihood(new, z, k)
        else:
            if getattr(self.proposal, "draws_ancestors", False):
                proposed = self.proposal.propose_with_ancestors(self.model, parents, z, k, rng, log_weights=log_weights)
                if not isinstance(proposed, tuple) or len(proposed) != 3:
                    raise ModelError(f"step {k}: proposal.propose_with_ancestors must return "
                                     "(particles, log_increments, ancestors)", step=k)
                ancestors = None if proposed[2] is None else self._check_indices(proposed[2], k, m)
                proposed = proposed[:2]
            else:
                proposed = self.proposal.propose(self.model, parents, z, k, rng)
            if not isinstance(proposed, tuple) or len(proposed) not in (2, 3):
                raise ModelError(f"step {k}: proposal.propose must return (particles, log_increments) "
                                 "or (particles, log_increments, stages)", step=k)
            if len(proposed) == 3:
                stages = proposed[2]
                if isinstance(stages, (bool, np.bool_)) or not isinstance(stages, (int, np.integer)) or stages < 1:
                    raise ModelError(f"step {k}: the proposal's stages must be a count >= 1, got {stages!r}", step=k)
            new = self._check_particles(proposed[0], k, "proposal.propose", m)
            log_inc = proposed[1]
        return new, self._check_log_increments(log_inc, k, m), int(stages), ancestors

    def _weight(self, cloud: _Cloud, log_inc: Array | None, z: Array | None, k: int) -> tuple[float, float]:
        """Steps 2 and 3, in place: ``log W_k^i = log W_{k-1}^i + log inc_k^i - L_k``, ``W_k^i = exp(log W_k^i)``.

        ``L_k = logsumexp_i(log W_{k-1}^i + log inc_k^i) = log p^(z_k | z_{0:k-1})``; the increments
        are shifted by their largest value ``a`` when ``700 < |a| < inf`` (weights are invariant to
        a constant, ``exp`` is not) and ``L_k`` shifted back.  Returns ``(ESS, L_k)`` with
        ``ESS = 1 / sum_i (W_k^i)^2``; without a measurement the weights stay and ``L_k = 0``.
        Raises :class:`~pfcourse.errors.DegenerateWeightsError` when every weight is zero.
        """
        if log_inc is None:
            return 1.0 / kernels.sum_of_squares(cloud.weights), 0.0  # effective_sample_size(weights), same float
        cloud.weights = np.empty(cloud.size)
        cloud.log_weights = cloud.log_weights.copy()  # the last step's, yielded, stay as they were
        top = log_inc.max()
        shift = top if 700.0 < abs(top) < np.inf else 0.0
        if shift != 0.0:
            with np.errstate(over="ignore"):  # -1e308 - 1e308 = -inf: a zero weight, as it should
                log_inc = log_inc - shift
        log_evidence, ess = kernels.normalize_step(cloud.log_weights, log_inc, cloud.weights, cloud.scratch)
        log_evidence += shift
        if log_evidence == -np.inf or top == -np.inf:
            raise DegenerateWeightsError(
                f"step {k}: every particle has zero likelihood for the measurement "
                f"{np.array2string(z, precision=4)}; the filter has lost track "
                "(more particles, a wider process noise or a better proposal may help)",
                step=k,
            )
        return ess, log_evidence

    def _resample(self, cloud: _Cloud, k: int, rng: np.random.Generator) -> Array:
        """Step 4, in place: ``x^i <- x^{A_i}`` with ancestors ``A`` from the resampler, the optional
        jitter, and the weights reset to ``W^i = 1/N``.  Returns ``A``."""
        indices = self.resampler(cloud.weights, rng)
        if self._custom_resampler:
            indices = self._check_indices(indices, k)
        particles = kernels.gather_rows(cloud.particles, indices)
        if self.jitter is not None:
            particles = self._check_particles(self.jitter(particles, rng), k, "jitter")
        cloud.restart(particles)
        return indices

    def _result(self, records: dict) -> FilterResult:
        """The run's :class:`FilterResult` from the collectors' records, with the filter's settings: the
        record of the :class:`~pfcourse.filter_config.FilterSettings` it was built from
        (:meth:`~pfcourse.filter_config.FilterSettings.record`), or, for a filter built directly, the same
        fields read from the filter (``N``, the resampling rule, the components as data, ``proposal``
        ``None`` for the transition, ``model_change`` ``None``)."""
        from pfcourse.filter_config import describe  # (filter_config builds filters: imported here, not above)

        if self.settings is not None:
            settings = self.settings.record()
        else:
            default = type(self.proposal) is TransitionProposal
            settings = {"n_particles": self.n_particles, "threshold": self.threshold,
                        "resampler": getattr(self.resampler, "__name__", str(self.resampler)),
                        "proposal": None if default else describe(self.proposal), "jitter": describe(self.jitter),
                        "sample_size": describe(self.sample_size), "model_change": None}

        mean, cov = records.pop("moments")
        clouds = records.get("clouds")
        return FilterResult(
            mean=mean,
            cov=cov,
            ess=records.pop("ess"),
            resampled=records.pop("resampled"),
            log_likelihood_increments=records.pop("log_likelihood_increments"),
            n_particles=self.n_particles,
            particles=None if clouds is None else clouds[0],
            weights=None if clouds is None else clouds[1],
            settings=settings,
            sizes=records.pop("sizes"),
            collected=records,
        )

    def _check_indices(self, indices, k: int, n: int | None = None) -> np.ndarray:
        """A custom resampler's (or a proposal's) output must be ``n`` integer indices in [0, n), ``n = N``
        unless given (checked before the compiled gather)."""
        arr = np.asarray(indices)
        n = self.n_particles if n is None else n
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
